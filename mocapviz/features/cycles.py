"""Gait-cycle segmentation by dynamic time warping (multi-frame 4D motion paper, §4.1).

A clip is described by its hip rotation curves: the flexion angle of each thigh in the
pelvis frame (sagittal plane, degrees; 0 = thigh along the rest pose's down direction,
positive = forward). Each curve set is centred and scaled before comparison. Two reference cycles, one starting with the left foot and its mirror
image starting with the right, are compared with every sub-segment of a clip by DTW
(``dtaidistance``, C implementation, dependent multi-dimensional DTW); segments below a
distance threshold are cycles, chosen greedily without overlap, and segments under 0.3 s or
over 3 s are pruned. References come from real clips (a named clip and hand-chosen frames;
see ``data_prep.body4d_dataset``), never from invented curves.

Also: uniform resampling of a cycle to a fixed number of time-stamped frames.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from dtaidistance import dtw_ndim

from mocapviz.heading import across_vector, facing_direction
from mocapviz.ik import LEGS
from mocapviz.motion import Motion

MIN_CYCLE_S = 0.3
MAX_CYCLE_S = 3.0
DTW_FPS = 30.0  # curves are compared at 30 fps (cycles of 0.3 s still have 9 samples)


def _forward_axis(motion: Motion) -> np.ndarray:
    """The rest pose's facing direction (unit, horizontal): (left hip - right hip) x up."""
    sk = motion.skeleton
    fwd = facing_direction(across_vector(sk.rest_positions(), sk, [("LeftUpLeg", "RightUpLeg")]))
    return fwd / np.linalg.norm(fwd)


def hip_flexion(motion: Motion) -> np.ndarray:
    """Left and right thigh flexion (F, 2) in degrees, in the pelvis (Hips) frame."""
    sk = motion.skeleton
    pos, glob = motion.global_pose()
    pelvis = glob[:, 0]
    fwd = _forward_axis(motion)
    out = []
    for hip, knee, _ in LEGS:
        d = pos[:, sk.index(knee)] - pos[:, sk.index(hip)]
        d = np.einsum("fji,fj->fi", pelvis, d)  # into the pelvis frame (R^T d)
        out.append(np.degrees(np.arctan2(d @ fwd, -d[:, 1])))
    return np.stack(out, axis=1)


def mirror_curves(curves: np.ndarray) -> np.ndarray:
    """Left/right mirror of hip curves: flexion is mirror-invariant, so swap the legs."""
    return np.ascontiguousarray(curves[:, ::-1])


@dataclass(frozen=True)
class References:
    """Left-start and right-start reference cycles (at the motion's fps) and their source."""

    left: np.ndarray
    right: np.ndarray
    fps: float
    source: str = ""


def make_references(motion: Motion, start: int, end: int) -> References:
    """References from frames [start, end] of a real clip: a cycle that starts with the left
    foot, and its mirror image (starting with the right)."""
    curves = hip_flexion(motion)[start:end + 1]
    return References(curves, mirror_curves(curves), motion.fps, f"{motion.name}[{start}:{end}]")


def _resample_curves(curves: np.ndarray, fps: float, new_fps: float) -> np.ndarray:
    n = int(np.floor((len(curves) - 1) * new_fps / fps)) + 1
    t = np.arange(n) * fps / new_fps
    return np.stack([np.interp(t, np.arange(len(curves)), c) for c in curves.T], axis=1)


@dataclass(frozen=True)
class Cycle:
    """One detected cycle: frames [start, end] (inclusive) of its clip, which reference
    matched ('L' or 'R'), and the length-normalised DTW distance (degrees)."""

    start: int
    end: int
    side: str
    distance: float

    def duration(self, fps: float) -> float:
        return (self.end - self.start) / fps


def _normalise(c: np.ndarray) -> np.ndarray:
    """Centre each curve on its mean and scale both to a pooled std of 20 degrees, so that
    pelvis-frame offsets and the larger hip swing of running do not count as distance."""
    c = c - c.mean(0)
    return c / max(float(c.std()), 1e-6) * 20.0


def dtw_distance(a: np.ndarray, b: np.ndarray, independent: bool = False) -> float:
    """DTW distance between two curve sets (each normalised by :func:`_normalise`), divided
    by the square root of the summed lengths (so in degrees, comparable across lengths).
    ``independent`` warps each curve on its own (DTW_I) instead of both together (DTW_D)."""
    a, b = _normalise(a), _normalise(b)
    if independent:
        d = np.sqrt(sum(dtw_ndim.distance_fast(np.ascontiguousarray(a[:, [k]], dtype=np.double),
                                               np.ascontiguousarray(b[:, [k]], dtype=np.double)) ** 2
                        for k in range(a.shape[1])))
    else:
        d = dtw_ndim.distance_fast(np.ascontiguousarray(a, dtype=np.double),
                                   np.ascontiguousarray(b, dtype=np.double))
    return float(d / np.sqrt(len(a) + len(b)))


def segment_cycles(motion: Motion, refs: References, threshold: float = 10.0, step_s: float = 1 / 30,
                   min_s: float = MIN_CYCLE_S, max_s: float = MAX_CYCLE_S) -> list[Cycle]:
    """Single cycles of a clip, as non-overlapping segments matching a reference by DTW.

    Every segment of the clip (starts and ends on a 1/30 s grid, lengths 0.5-2x the
    reference's) is compared to both references at 30 fps; the best segment under
    ``threshold`` is kept, segments overlapping it by more than a frame are discarded, and
    so on. Kept segments shorter than ``min_s`` or longer than ``max_s`` are pruned.
    Boundaries are returned in the clip's frames.
    """
    curves = _resample_curves(hip_flexion(motion), motion.fps, DTW_FPS)
    ref = {side: _resample_curves(r, refs.fps, DTW_FPS) for side, r in (("L", refs.left), ("R", refs.right))}
    n_ref = len(ref["L"])
    step = max(1, int(round(step_s * DTW_FPS)))
    lo, hi = max(2, int(0.5 * n_ref)), int(2 * n_ref)
    cands = []
    for s in range(0, len(curves) - lo + 1, step):
        for e in range(s + lo - 1, min(len(curves), s + hi), step):
            seg = curves[s:e + 1]
            for side, r in ref.items():
                cands.append((dtw_distance(seg, r), s, e, side))
    cands.sort()
    chosen: list[tuple] = []
    for d, s, e, side in cands:
        if d > threshold:
            break
        if all(e <= cs or s >= ce for _, cs, ce, _ in chosen):
            chosen.append((d, s, e, side))
    scale = motion.fps / DTW_FPS
    cycles = [Cycle(int(round(s * scale)), min(motion.n_frames - 1, int(round(e * scale))), side, d)
              for d, s, e, side in sorted(chosen, key=lambda c: c[1])]
    return [c for c in cycles if min_s <= c.duration(motion.fps) <= max_s]


def resample_uniform(motion: Motion, start: int, end: int, n: int = 100):
    """Frames [start, end] resampled to ``n`` uniformly spaced times (:meth:`Motion.sample`:
    slerp / linear).

    Returns (rotations (n, J, 3, 3), root_positions (n, 3), times (n,) in seconds from
    the segment's start).
    """
    t = np.linspace(start, end, n)
    part = motion.sample(t)
    return part.rotations, part.root_positions, (t - start) / motion.fps
