"""Following user-specified trajectories (CCNet paper §4.3.2, Figs. 5-7).

A target path (one of the six in ``trajectories/``: points in the character's start frame,
metres) is split into segments whose motion types are a seeded draw; the character walks it at
the mean speed of its segment's type in the training data, which turns the path into one ground
point per frame. Each test seed (the first 120 frames of a locomotion test clip) gets the path
placed at the root and heading where its seed ends; the generator recomputes c^d every frame from
the character's integrated root and heading (:class:`mocapviz.tasks.controls.PathControls`), and
c^t follows the segments (a 20-frame linear blend at each change, as the keyboard control's).

Trajectory distance (§4.3.2): per generated frame, the closest distance of the root's ground
projection to the target polyline, averaged over the frames of one generation; the table gives
mean ± std of that average over every (seed, path) in cm. A character that stays at the start
is close to the curve too (the path starts where the seed ends), so the table adds two measures
that standing still cannot pass: ``timed_cm``, the distance to the target point of the same
frame (where the character should be by now, at its segment's speed), and ``covered``, the
share of the target's points that the root passed within 0.5 m of; and a ``stand_still`` row
(the root kept where the seed ends) that shows what doing nothing scores on each.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from mocapviz.features.ccnet import FPS, FeatureLayout, integrate_root
from mocapviz.features.motion_types import MOTION_TYPES, one_hot
from mocapviz.heading import from_heading_frame_xz
from mocapviz.tasks.controls import PathControls
from mocapviz.tasks.generate import Generated, Generator

TRAJECTORY_DIR = Path(__file__).resolve().parent / "trajectories"
TRAJECTORIES = ("straight", "s_curve", "circle", "figure_eight", "zig_zag", "tight_turns")
# the types a segment may take: forward locomotion that every model trained on (Bandai + HDM05)
FOLLOW_TYPES = ("walk", "jog")
# test clips whose first 120 frames seed a generation: the locomotion types
LOCOMOTION_TYPES = ("walk", "jog", "sneak", "hop", "dash", "walk_back", "side_step")
N_SEED = 120
BLEND = 20
COVER_RADIUS = 0.5    # m: a target point counts as covered when the root passed this close


@dataclass
class Trajectory:
    name: str
    points: np.ndarray        # (P, 2) X/Z in the start frame, m
    segments: np.ndarray      # arc-length fractions, 0 .. 1
    type_seed: int

    @property
    def arc(self) -> np.ndarray:
        """(P,) arc length at each point, m."""
        return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(self.points, axis=0), axis=1))])


def load_trajectory(name: str, folder: Path = TRAJECTORY_DIR) -> Trajectory:
    path = Path(folder) / f"{name}.json"
    if not path.is_file():
        known = sorted(p.stem for p in Path(folder).glob("*.json"))
        raise KeyError(f"unknown trajectory {name!r}; known: {known}")
    d = json.loads(path.read_text())
    return Trajectory(d["name"], np.asarray(d["points"], dtype=np.float64), np.asarray(d["segments"], float),
                      int(d["type_seed"]))


def segment_types(traj: Trajectory, types=FOLLOW_TYPES) -> list[str]:
    """One type per segment, drawn with the trajectory's seed."""
    rng = np.random.default_rng(traj.type_seed)
    return [str(types[i]) for i in rng.integers(len(types), size=len(traj.segments) - 1)]


def type_speeds(ds, types=FOLLOW_TYPES) -> dict[str, float]:
    """Mean root ground speed (m/s) of the training clips of each type."""
    root = FeatureLayout(len(ds.joint_names), len(ds.motion_types)).x_blocks["root"]
    out = {}
    for t in types:
        rows = [np.arange(r.start, r.stop) for r in ds.clips.itertuples() if r.split == "train" and r.type == t]
        if not rows:
            raise ValueError(f"no training clip of type {t!r}")
        v = ds.x[np.concatenate(rows), root.start:root.start + 2]
        out[t] = float(np.linalg.norm(v, axis=1).mean())
    return out


def frame_path(traj: Trajectory, types: list[str], speeds: dict[str, float], fps: float = FPS):
    """The path as one point per frame, walked at the speed of each segment's type: (N, 2)
    points (the first is the start) and (N,) type names."""
    arc, total = traj.arc, traj.arc[-1]
    bounds = traj.segments * total
    s, out_s, out_t = 0.0, [0.0], [types[0]]
    while s < total:
        k = min(int(np.searchsorted(bounds, s, side="right")) - 1, len(types) - 1)
        s = min(total, s + speeds[types[k]] / fps)
        out_s.append(s)
        out_t.append(types[k])
    s = np.asarray(out_s)
    pts = np.stack([np.interp(s, arc, traj.points[:, 0]), np.interp(s, arc, traj.points[:, 1])], 1)
    return pts, np.asarray(out_t)


def blended_types(names, start_type: str, n_types: int, blend: int = BLEND, vocabulary=MOTION_TYPES) -> np.ndarray:
    """(N, n_types) labels of per-frame type names, each change blended linearly over ``blend``
    frames; frame 0 blends from ``start_type`` (the seed's)."""
    target = one_hot([vocabulary.index(t) for t in names], n_types)
    out = np.empty_like(target)
    cur = one_hot([vocabulary.index(start_type)], n_types)[0]
    start, k = cur.copy(), blend
    for i in range(len(target)):
        if i == 0 or not np.array_equal(target[i], target[i - 1]):
            start, k = cur.copy(), 0
        k = min(k + 1, blend)
        cur = start + (target[i] - start) * (k / blend)
        out[i] = cur
    return out


def place(points: np.ndarray, origin_xz, heading: float) -> np.ndarray:
    """Start-frame points (N, 2) in the world: at ``origin_xz``, +Z turned onto ``heading``."""
    return np.asarray(origin_xz, dtype=np.float64) + from_heading_frame_xz(np.asarray(points), np.float64(heading))


def polyline_distance(p: np.ndarray, line: np.ndarray) -> np.ndarray:
    """(N,) closest distance of points (N, 2) to the polyline (P, 2)."""
    a, b = line[:-1], line[1:]
    ab = b - a
    t = np.clip(np.einsum("nsk,sk->ns", p[:, None] - a[None], ab) / np.maximum((ab * ab).sum(1), 1e-12), 0, 1)
    closest = a[None] + t[..., None] * ab[None]
    return np.linalg.norm(p[:, None] - closest, axis=-1).min(axis=1)


def coverage(target: np.ndarray, achieved: np.ndarray, radius: float = COVER_RADIUS) -> float:
    """Share of the target polyline's points (P, 2) within ``radius`` m of the achieved path (N, 2)."""
    return float((polyline_distance(target, achieved) <= radius).mean())


def seed_rows(ds, types=LOCOMOTION_TYPES, n_seed: int = N_SEED) -> list[int]:
    """Test-split clip rows of locomotion types with more than ``n_seed`` frames."""
    c = ds.clips
    ok = (c.split == "test") & c.type.isin(types) & ((c.stop - c.start) > n_seed)
    return [int(i) for i in np.flatnonzero(ok.values)]


@dataclass
class Following:
    model: str
    trajectory: str
    rows: list[int]
    target: np.ndarray        # (B, P, 2) world target polyline per character
    achieved: np.ndarray      # (B, N, 2) root ground path of the generated frames
    distance_cm: np.ndarray   # (B,) mean over frames of the closest distance, cm
    covered: np.ndarray       # (B,) share of the target within COVER_RADIUS of the achieved path:
                              # standing still at the start scores a small distance, and this says so
    timed_cm: np.ndarray      # (B,) mean distance to the target point of the same frame, cm
    frame_target: np.ndarray  # (B, N, 2) the target point of each generated frame
    types: list[str]
    start_root: np.ndarray    # (B, 3) root of the frame before each seed, as the clip's
    start_heading: np.ndarray  # (B,) its heading
    generated: Generated | None = None   # seed + generated frames, kept when ``follow(keep=True)``

    def motion(self, i: int, skeleton, ik: bool = True):
        """The generated frames of character ``i`` (seed left out) as a Motion in the world frame
        of ``target`` and ``achieved``: for rendering (needs ``follow(..., keep=True)``)."""
        if self.generated is None:
            raise ValueError("the generated frames were not kept: call follow(..., keep=True)")
        g = self.generated
        m = g.motion(i, skeleton, self.start_root[i], self.start_heading[i], ik=ik,
                     name=f"{self.model} {self.trajectory}")
        return m[g.n_seed:]


def follow(model, normaliser, ds, rows: list[int], name: str, speeds: dict[str, float], model_name: str = "",
           n_seed: int = N_SEED, backend: str = "torch", progress: bool = False, keep: bool = False) -> Following:
    """Generate every seed of ``rows`` along trajectory ``name`` in one batch (mean output);
    ``keep``: keep the generated frame vectors (for :meth:`Following.motion`)."""
    traj = load_trajectory(name)
    types = segment_types(traj)
    local, names = frame_path(traj, types, speeds)
    n_types = model.cfg.n_types
    arrs = [ds.clip_arrays(i) for i in rows]
    clips = ds.clips.iloc[rows]
    root_b = FeatureLayout(len(ds.joint_names), n_types).x_blocks["root"]
    seed_x = np.stack([a["x"][:n_seed] for a in arrs])
    n = len(local)
    paths, targets, starts, headings, labels = [], [], [], [], []
    for a, c, sx in zip(arrs, clips.itertuples(), seed_x):
        start, head = np.array([c.root_x, c.root_y, c.root_z]), float(c.heading)
        root, theta = integrate_root(sx[:, root_b], start, head)
        world = place(local, root[-1, [0, 2]], theta[-1])
        # frame index i of the generator's path is frame i of seed + generation
        paths.append(np.concatenate([np.repeat(world[:1], n_seed, 0), world[1:]]))
        targets.append(place(traj.points, root[-1, [0, 2]], theta[-1]))
        starts.append(start)
        headings.append(head)
        seed_label = one_hot([a["type_index"]], n_types)[0]
        labels.append(np.concatenate([np.repeat(seed_label[None], n_seed, 0),
                                      blended_types(names[1:], MOTION_TYPES[a["type_index"]], n_types)]))
    gen = Generator(model, normaliser, batch=len(rows), backend=backend)
    out = gen.run(seed_x, np.stack([a["skel"] for a in arrs]), np.stack(labels), n - 1,
                  PathControls(np.stack(paths), np.stack(starts), np.asarray(headings)),
                  seed_traj=np.stack([a["traj"][:n_seed] for a in arrs]), progress=progress)
    achieved, dist, covered, timed = [], [], [], []
    for i in range(len(rows)):
        root, _ = integrate_root(out.x[i][:, root_b], starts[i], headings[i])
        g = root[n_seed:, [0, 2]]
        achieved.append(g)
        dist.append(100.0 * polyline_distance(g, targets[i]).mean())
        covered.append(coverage(targets[i], g))
        timed.append(100.0 * np.linalg.norm(g - paths[i][n_seed:], axis=-1).mean())
    return Following(model_name, name, list(rows), np.stack(targets), np.stack(achieved), np.asarray(dist),
                     np.asarray(covered), np.asarray(timed), np.stack([p[n_seed:] for p in paths]), types,
                     np.stack(starts), np.asarray(headings), out if keep else None)


def standing_still(r: Following) -> Following:
    """What the trajectory measures give a character that stays where its seed ends."""
    still = np.repeat(r.frame_target[:, :1], r.frame_target.shape[1], axis=1)
    dist = np.array([100.0 * polyline_distance(s, t).mean() for s, t in zip(still, r.target)])
    covered = np.array([coverage(t, s) for s, t in zip(still, r.target)])
    timed = 100.0 * np.linalg.norm(still - r.frame_target, axis=-1).mean(axis=1)
    return Following("stand_still", r.trajectory, r.rows, r.target, still, dist, covered, timed, r.frame_target,
                     r.types, r.start_root, r.start_heading)


def following_table(results: list[Following]) -> pd.DataFrame:
    """Rows (model, mean_cm, std_cm, n, covered, timed_cm, timed_std_cm): the distances of every
    (seed, trajectory) of each model (std with ddof 0), the mean share of the target covered
    (:func:`coverage`) and the distance to the target point of the same frame; plus the row
    ``stand_still`` (:func:`standing_still`) over the first model's seeds and paths."""
    first = results[0].model if results else None
    results = list(results) + [standing_still(r) for r in results if r.model == first]
    rows = []
    for model in dict.fromkeys(r.model for r in results):
        pick = [r for r in results if r.model == model]
        d, timed = (np.concatenate([getattr(r, k) for r in pick]) for k in ("distance_cm", "timed_cm"))
        covered = np.concatenate([r.covered for r in pick])
        rows.append(dict(model=model, mean_cm=float(d.mean()), std_cm=float(d.std()), n=int(len(d)),
                         covered=float(covered.mean()), timed_cm=float(timed.mean()), timed_std_cm=float(timed.std())))
    return pd.DataFrame(rows)
