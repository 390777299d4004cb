"""Gait-cycle segmentation by dynamic time warping (multi-frame 4D motion paper, §4.1).

The paper finds cycles "by considering the rotation of the hips joints". A clip is described
here by four hip curves (degrees, in the pelvis frame, from the thigh's direction): the
flexion of each thigh (sagittal plane; 0 = along the rest pose's down direction, positive =
forward) and its abduction (frontal plane, positive = away from the body's midline), so that
a sideways swing is seen as well as a forward one. The thigh's twist is left out: it is the
component least alike between rigs (HDM05, CMU and Bandai place the knee axis differently).

References are real cycles (a named clip and frames: see ``data_prep.body4d_dataset``), each
kind (forward walk, backward walk, ...) as a left-start cycle and its mirror image.

Search. A cycle of a reference starts and ends at the same event: a minimum of the leading
thigh's flexion (its maximal extension, at toe-off; the left thigh for a left-start cycle).
Candidates are the pairs of such minima (prominence :data:`EVENT_PROMINENCE`, so near-flat
curves give no candidates) that lie 0.3-3 s apart (:data:`MIN_CYCLE_S`, :data:`MAX_CYCLE_S`),
every one compared by DTW (``dtaidistance``, dependent multi-dimensional DTW, at 30 fps) to the
references of its side. Anchoring on events rather than trying every start and length keeps
the whole 0.3-3 s window affordable: Bandai's ~90 minutes of locomotion would need some 10^8
DTW comparisons exhaustively, a few 10^4 this way. The best candidate under the threshold is
kept, candidates overlapping it are discarded, and so on.

Rejection (the rule; rejected cycles are returned with their reason, not dropped silently):

- ``edge``: the cycle starts or ends within :data:`EDGE_S` of the clip's first or last frame
  (a cut-off clip: its first or last minimum may be where the cut fell, not a toe-off; a
  cycle cut mid-way by the clip has no extension event at the cut and is never a candidate);
- ``shape``: the Pearson correlation between the cycle's curves (uniformly resampled to the
  reference's length) and the matched reference's is below :data:`MIN_CORRELATION`: DTW's
  warping can fold a different movement onto the reference at a small cost, a correlation
  without warping cannot;
- ``duration``: outside 0.3-3 s in the clip's frames (cannot happen with the candidate window;
  kept as the paper's pruning rule);
- half cycles (travel below half of the clip group's typical stride) need the other cycles of
  a subject and type: :func:`half_cycles` marks them at the dataset level.

Also: uniform resampling of a cycle to a fixed number of time-stamped frames.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from dtaidistance import dtw_ndim
from scipy.signal import find_peaks

from mocapviz.heading import across_vector, facing_direction
from mocapviz.ik import LEGS
from mocapviz.motion import Motion

MIN_CYCLE_S = 0.3
MAX_CYCLE_S = 3.0
DTW_FPS = 30.0  # curves are compared at 30 fps (cycles of 0.3 s still have 9 samples)
CURVES = ("flexion L", "flexion R", "abduction L", "abduction R")
EVENT_PROMINENCE = 10.0  # degrees: a thigh's extension minimum must stand out by this much
EDGE_S = 1 / 30  # one frame at 30 fps
MIN_CORRELATION = 0.6
HALF_CYCLE_TRAVEL = 0.5  # a cycle travelling less than this share of its group's median is half a cycle


def _pelvis_axes(motion: Motion) -> tuple[np.ndarray, np.ndarray]:
    """The rest pose's forward and left directions (unit, horizontal): left = left hip - right hip."""
    sk = motion.skeleton
    across = across_vector(sk.rest_positions(), sk, [("LeftUpLeg", "RightUpLeg")])
    fwd = facing_direction(across)
    across = across - across[1] * np.array([0.0, 1.0, 0.0])
    return fwd / np.linalg.norm(fwd), across / np.linalg.norm(across)


def hip_angles(motion: Motion) -> np.ndarray:
    """Hip curves (F, 4) in degrees, in the pelvis (Hips) frame, ordered as :data:`CURVES`:
    flexion of the left and right thigh, then their abduction (outward positive)."""
    sk = motion.skeleton
    pos, glob = motion.global_pose()
    fwd, left = _pelvis_axes(motion)
    flex, abd = [], []
    for (hip, knee, _), out in zip(LEGS, (left, -left)):
        d = np.einsum("fji,fj->fi", glob[:, 0], pos[:, sk.index(knee)] - pos[:, sk.index(hip)])  # R^T d
        flex.append(np.degrees(np.arctan2(d @ fwd, -d[:, 1])))
        abd.append(np.degrees(np.arctan2(d @ out, -d[:, 1])))
    return np.stack(flex + abd, axis=1)


def hip_flexion(motion: Motion) -> np.ndarray:
    """Left and right thigh flexion (F, 2) in degrees, in the pelvis (Hips) frame."""
    return hip_angles(motion)[:, :2]


def mirror_curves(curves: np.ndarray) -> np.ndarray:
    """Left/right mirror of hip curves (F, 2k) ordered (L, R) pairs: flexion and outward
    abduction are mirror-invariant, so the mirror swaps the legs."""
    f = curves.shape[0]
    return np.ascontiguousarray(curves.reshape(f, -1, 2)[:, :, ::-1].reshape(f, -1))


@dataclass(frozen=True)
class References:
    """Left-start and right-start reference curves (F, 4) of one kind of cycle (at ``fps``)."""

    left: np.ndarray
    right: np.ndarray
    fps: float
    source: str = ""
    kind: str = "walk"

    def by_side(self) -> dict:
        return {"L": self.left, "R": self.right}


def make_references(motion: Motion, start: int, end: int, kind: str = "walk") -> References:
    """References from frames [start, end] of a real clip: a cycle that starts with the left
    thigh at its maximal extension, and its mirror image (starting with the right)."""
    curves = hip_angles(motion)[start:end + 1]
    return References(curves, mirror_curves(curves), motion.fps, f"{motion.name}[{start}:{end}]", kind)


def _resample_curves(curves: np.ndarray, fps: float, new_fps: float) -> np.ndarray:
    n = int(np.floor((len(curves) - 1) * new_fps / fps)) + 1
    t = np.arange(n) * fps / new_fps
    return np.stack([np.interp(t, np.arange(len(curves)), c) for c in curves.T], axis=1)


def _resample_to(curves: np.ndarray, n: int) -> np.ndarray:
    t = np.linspace(0, len(curves) - 1, n)
    return np.stack([np.interp(t, np.arange(len(curves)), c) for c in curves.T], axis=1)


@dataclass(frozen=True)
class Cycle:
    """One cycle: frames [start, end] (inclusive) of its clip, which reference matched (its
    ``kind`` and ``side``, 'L' or 'R'), the length-normalised DTW distance and the curve
    correlation with that reference."""

    start: int
    end: int
    side: str
    distance: float
    kind: str = "walk"
    correlation: float = float("nan")

    def duration(self, fps: float) -> float:
        return (self.end - self.start) / fps


def _normalise(c: np.ndarray) -> np.ndarray:
    """Centre each curve on its mean and scale all of them by one number, the flexion curves'
    pooled std, to 20 degrees: pelvis-frame offsets and the larger swing of running do not
    count as distance, while abduction keeps its size relative to flexion."""
    c = c - c.mean(0)
    return c / max(float(c[:, :2].std()), 1e-6) * 20.0


def dtw_distance(a: np.ndarray, b: np.ndarray, independent: bool = False) -> float:
    """DTW distance between two curve sets (each normalised by :func:`_normalise`), divided
    by the square root of the summed lengths (so in degrees, comparable across lengths).
    ``independent`` warps each curve on its own (DTW_I) instead of all together (DTW_D)."""
    a, b = _normalise(a), _normalise(b)
    if independent:
        d = np.sqrt(sum(dtw_ndim.distance_fast(np.ascontiguousarray(a[:, [k]], dtype=np.double),
                                               np.ascontiguousarray(b[:, [k]], dtype=np.double)) ** 2
                        for k in range(a.shape[1])))
    else:
        d = dtw_ndim.distance_fast(np.ascontiguousarray(a, dtype=np.double),
                                   np.ascontiguousarray(b, dtype=np.double))
    return float(d / np.sqrt(len(a) + len(b)))


def curve_correlation(segment: np.ndarray, reference: np.ndarray) -> float:
    """Pearson correlation of a segment's curves, uniformly resampled to the reference's
    length, with the reference's (each curve centred, all curves pooled)."""
    a = _resample_to(segment, len(reference))
    a, b = (a - a.mean(0)).ravel(), (reference - reference.mean(0)).ravel()
    return float(a @ b / max(np.linalg.norm(a) * np.linalg.norm(b), 1e-12))


def extension_events(curve: np.ndarray, fps: float, prominence: float = EVENT_PROMINENCE) -> np.ndarray:
    """Frames of a thigh's maximal extension: minima of its flexion curve (F,) standing out by
    ``prominence`` degrees, at least 0.15 s apart. A side that runs into the clip's first or
    last frame does not need the rise (the clip may end just after a toe-off); whether such a
    cycle is cut off is the edge rule's call."""
    pad = np.full(1, curve.max() + 2 * prominence)
    return find_peaks(-np.concatenate([pad, curve, pad]), prominence=prominence,
                      distance=max(1, int(0.15 * fps)))[0] - 1


def _as_list(refs) -> list[References]:
    return [refs] if isinstance(refs, References) else list(refs)


def find_cycles(motion: Motion, refs, threshold: float = 10.0, min_s: float = MIN_CYCLE_S,
                max_s: float = MAX_CYCLE_S, edge_s: float = EDGE_S,
                min_correlation: float = MIN_CORRELATION) -> tuple[list[Cycle], list[tuple[Cycle, str]]]:
    """Cycles of a clip matched to ``refs`` (one :class:`References` or several kinds), and the
    matched segments rejected by the rule of the module docstring as (cycle, reason) pairs.
    Boundaries are in the clip's frames."""
    curves = hip_angles(motion)
    fps = motion.fps
    by_side = {side: [(r.kind, _resample_curves(c, r.fps, DTW_FPS)) for r in _as_list(refs)
                      for s, c in r.by_side().items() if s == side] for side in ("L", "R")}
    cands = []
    for k, side in enumerate(("L", "R")):
        events = extension_events(curves[:, k], fps)
        for i, s in enumerate(events):
            for e in events[i + 1:]:
                if (e - s) / fps > max_s:
                    break
                if (e - s) / fps < min_s:
                    continue
                seg = _resample_curves(curves[s:e + 1], fps, DTW_FPS)
                d, kind, ref = min((dtw_distance(seg, ref), kind, ref) for kind, ref in by_side[side])
                cands.append((d, int(s), int(e), side, kind, ref))
    cands.sort(key=lambda c: c[:3])
    chosen = []
    for d, s, e, side, kind, ref in cands:
        if d > threshold:
            break
        if all(e <= c.start or s >= c.end for c in chosen):
            r = curve_correlation(_resample_curves(curves[s:e + 1], fps, DTW_FPS), ref)
            chosen.append(Cycle(s, e, side, d, kind, r))
    kept, rejected = [], []
    edge = edge_s * fps
    for c in sorted(chosen, key=lambda c: c.start):
        if c.start < edge or c.end > motion.n_frames - 1 - edge:
            rejected.append((c, "edge"))
        elif c.correlation < min_correlation:
            rejected.append((c, "shape"))
        elif not min_s <= c.duration(fps) <= max_s:
            rejected.append((c, "duration"))
        else:
            kept.append(c)
    return kept, rejected


def segment_cycles(motion: Motion, refs, threshold: float = 10.0, **kw) -> list[Cycle]:
    """The accepted cycles of :func:`find_cycles`."""
    return find_cycles(motion, refs, threshold, **kw)[0]


def travel(motion: Motion, cycle: Cycle) -> float:
    """Ground-plane distance (m) the root covers from a cycle's first to its last frame."""
    d = motion.root_positions[cycle.end] - motion.root_positions[cycle.start]
    return float(np.hypot(d[0], d[2]))


def half_cycles(travel_m, groups, share: float = HALF_CYCLE_TRAVEL) -> np.ndarray:
    """Boolean mask (N,): cycles whose travel (m) is below ``share`` of the median travel of
    their group (e.g. subject and motion type): a step taken for a stride."""
    travel_m = np.asarray(travel_m, dtype=float)
    groups = np.asarray(groups)
    out = np.zeros(len(travel_m), dtype=bool)
    for g in np.unique(groups):
        idx = groups == g
        out[idx] = travel_m[idx] < share * np.median(travel_m[idx])
    return out


def resample_uniform(motion: Motion, start: int, end: int, n: int = 100):
    """Frames [start, end] resampled to ``n`` uniformly spaced times (:meth:`Motion.sample`:
    slerp / linear).

    Returns (rotations (n, J, 3, 3), root_positions (n, 3), times (n,) in seconds from
    the segment's start).
    """
    t = np.linspace(start, end, n)
    part = motion.sample(t)
    return part.rotations, part.root_positions, (t - start) / motion.fps
