"""Where a generated character's trajectory control c^d comes from: the control sources that
:meth:`mocapviz.tasks.generate.Generator.run` asks for c^d frame by frame.

- :class:`ClipControls`: raw c^d per frame (e.g. a clip's), repeated cyclically;
- :class:`PathControls`: a user path of world ground points; c^d is recomputed every frame from
  the character's integrated root and heading (:func:`path_controls`), so it steers onto the path;
- :class:`FreeRunning`: the network's own predicted c^d (the paper's interactive fallback), as
  predicted (``pace="network"``) or scaled to the seed's pace (``"seed"``, the speed of its
  last known c^d, :func:`at_speed`) until the character's motion type changes;
- :class:`Steered`: the predicted c^d bent by a turn and rescaled to a requested speed
  (:func:`steer`, paper §4.4), both set before each frame (:class:`mocapviz.tasks.control.ControlSession`).

The protocol (:class:`ControlSource`): :meth:`~ControlSource.start` before the first frame,
:meth:`~ControlSource.next` for the normalised c^d of frame t+1, :meth:`~ControlSource.fed` with
what the generator then fed (the seed's own c^d and a phase model's phase put in), and
:meth:`~ControlSource.types_changed` when characters' motion types change. The generator puts
the seed's own c^d and the phase over whatever a source gives.
"""

from __future__ import annotations

import numpy as np

from mocapviz.features.ccnet import FPS, TRAJ_STEPS
from mocapviz.heading import from_heading_frame_xz, to_heading_frame_xz
from mocapviz.tasks.generation_defaults import PACES

TURN_GAIN = 0.015      # o_n = [1, 0] * h * 0.015
TURN_WEIGHTS = np.arange(6) / 5.0   # w_i = i / 5, i = 0..5
# plans slower than this (m/s) have no direction to keep: at_speed scales them by pace / this at most
MIN_PLAN_SPEED = 0.05


def plan_speed(c_d: np.ndarray) -> np.ndarray:
    """Ground speed (m/s) a raw c^d (B, >= 12) plans: the length of the path through its six
    points (root, then 10, 20, ..., 60 frames ahead), over the one second they span."""
    pts = np.concatenate([np.zeros((len(c_d), 1, 2), np.float32), c_d[:, :2 * len(TRAJ_STEPS)].reshape(len(c_d), -1, 2)], 1)
    return np.linalg.norm(np.diff(pts, axis=1), axis=-1).sum(1) * FPS / TRAJ_STEPS[-1]


def at_speed(c_d: np.ndarray, speed: np.ndarray) -> np.ndarray:
    """Raw c^d (B, 12) with its six points scaled about the root so that it plans ``speed`` (B,)
    m/s: the paper's interactive velocity control (§4.4: the points' spacing times v_u / v_cur)."""
    ratio = speed / np.maximum(plan_speed(c_d), MIN_PLAN_SPEED)
    out = c_d.copy()
    out[:, :2 * len(TRAJ_STEPS)] *= ratio[:, None].astype(np.float32)
    return out


def path_controls(path_xz: np.ndarray, n: int, root_xz: np.ndarray, heading: np.ndarray) -> np.ndarray:
    """c^d (B, 12) at frame n: path points n+10..n+60 relative to the root, in its heading frame."""
    idx = np.minimum(n + np.asarray(TRAJ_STEPS), path_xz.shape[1] - 1)
    d = path_xz[:, idx] - root_xz[:, None]                     # (B, 6, 2) world X, Z
    return to_heading_frame_xz(d, heading[:, None]).reshape(len(d), -1)


def path_speed(traj: np.ndarray) -> np.ndarray:
    """v_cur (...,) m/s: length of the polyline root -> six c^d points (..., 12), over its seconds
    (float64, for the keyboard's speeds; :func:`plan_speed` is the batched float32 one)."""
    p = np.concatenate([np.zeros(traj.shape[:-1] + (1, 2)), traj.reshape(traj.shape[:-1] + (6, 2))], -2)
    return np.linalg.norm(np.diff(p, axis=-2), axis=-1).sum(-1) / (TRAJ_STEPS[-1] / FPS)


def steer(traj: np.ndarray, turn: float, speed: float, root_height: float) -> np.ndarray:
    """c^d (12,) raw (heading frame, metres) after a turn (+1 left, -1 right) and a speed
    request ``speed`` (m/s; NaN keeps the speed). A standing path (v_cur ~ 0) asked to move
    goes straight ahead at that speed."""
    p = np.asarray(traj, dtype=np.float64).reshape(6, 2).copy()
    p[:, 0] += turn * root_height * TURN_GAIN * TURN_WEIGHTS
    if not np.isnan(speed):
        v_cur = path_speed(p.reshape(-1))
        if v_cur > 1e-3:
            seg = np.diff(np.concatenate([np.zeros((1, 2)), p]), axis=0) * (speed / v_cur)
            p = np.cumsum(seg, axis=0)
        else:
            p = np.stack([np.zeros(6), speed * np.asarray(TRAJ_STEPS) / FPS], 1)
    return p.reshape(-1).astype(np.float32)


class ControlSource:
    """The protocol, with do-nothing defaults. ``x_t`` and every c^d are normalised (the
    generator's :class:`~mocapviz.features.ccnet.Normaliser`); a returned c^d may be 12 wide
    (the points) or the network's full width (a phase model's phase columns are replaced)."""

    def start(self, norm, layout, batch: int, n_seed: int) -> None:
        """Before frame 0 of a run: the normaliser, the frame layout, the characters, the seed frames."""
        self.norm, self.layout, self.batch, self.n_seed = norm, layout, batch, n_seed

    def next(self, t: int, x_t: np.ndarray, pred_traj: np.ndarray) -> np.ndarray:
        """c^d (B, >= 12) for frame t+1, given frame t (B, n_x) and the c^d the network predicted
        at frame t (B, n_traj; zeros before the first step)."""
        raise NotImplementedError

    def fed(self, t: int, c_next: np.ndarray, known: np.ndarray | None = None) -> None:
        """The c^d (B, n_traj) the generator fed with frame t; ``known`` (B,) bool, during the
        seed: the row is the seed's own c^d (not a prediction)."""

    def types_changed(self, changed: np.ndarray) -> None:
        """``changed`` (B,) bool: these characters' motion types change from this frame on."""


class ClipControls(ControlSource):
    """Raw c^d (B, T_c, >= 12) indexed by frame, repeated cyclically."""

    def __init__(self, traj: np.ndarray):
        self.traj = traj

    def start(self, norm, layout, batch, n_seed):
        super().start(norm, layout, batch, n_seed)
        self.traj_n = norm.norm_traj(self.traj)

    def next(self, t, x_t, pred_traj):
        return self.traj_n[:, (t + 1) % self.traj_n.shape[1]]


class PathControls(ControlSource):
    """World ground points (B, T_p, 2) (X, Z) per frame, seed frames first; ``start_root`` (B, 3)
    and ``start_heading`` (B,) of the frame before the seed, as a clip's. The root is integrated
    from the generated frames, and c^d of frame t+1 is the path ahead of it (:func:`path_controls`)."""

    def __init__(self, path: np.ndarray, start_root, start_heading):
        self.path, self.start_root, self.start_heading = path, start_root, start_heading

    def start(self, norm, layout, batch, n_seed):
        super().start(norm, layout, batch, n_seed)
        self.root_b = layout.x_blocks["root"]
        self.root_xz = np.asarray(self.start_root, dtype=np.float64)[:, [0, 2]].copy()
        self.heading = np.asarray(self.start_heading, dtype=np.float64).copy()

    def next(self, t, x_t, pred_traj):
        n, b = self.norm, self.root_b
        r = x_t[:, b] * n.x_std[b] + n.x_mean[b]  # frame t's root, raw: (vx, vz, yaw rate, height)
        self.root_xz += from_heading_frame_xz(r[:, :2], self.heading) / FPS
        self.heading += r[:, 2] / FPS
        return n.norm_traj(path_controls(self.path, t + 1, self.root_xz, self.heading))


class FreeRunning(ControlSource):
    """The network's own predicted c^d. ``pace="seed"``: rescaled every frame to the seed's pace
    (:func:`at_speed`), per character until its motion type changes (a run after a walk has its
    own pace); ``"network"``: as predicted. Why "seed": fed back, the predicted plan slows
    (measured: ccnet_phase_lerp's test run seed at 0.27x the real runs' ground speed over seconds
    30-60; held, 0.84x).

    The seed's pace is the speed of the last c^d fed during the seed that was the seed's own
    (``known`` in :meth:`fed`): a seed cut from a file knows no future in its last second, so its
    last known plan is the one that spans that second; where no fed c^d was known, that of the last
    seed frame (then the network's prediction). Why not the plan at the seed's end: there the
    network predicts it, and on the held-out HDM05 subject's sneak (0.56 m/s in its last second)
    it planned 2.6 m/s, so the generated sneak went at 4.95x the seed's ground speed."""

    def __init__(self, pace: str = "network"):
        if pace not in PACES:
            raise ValueError(f"pace must be one of {PACES}, got {pace!r}")
        self.pace = pace

    def start(self, norm, layout, batch, n_seed):
        super().start(norm, layout, batch, n_seed)
        self.speed = None  # (B,) m/s once the seed's last c^d is fed; NaN: as predicted
        self.known_speed = np.full(batch, np.nan)  # the speed of the last fed c^d that was the seed's own

    def next(self, t, x_t, pred_traj):
        if self.speed is None:
            return pred_traj
        n, free = self.norm, np.isnan(self.speed)
        held = n.norm_traj(at_speed(n.denorm_traj(pred_traj), np.where(free, 0.0, self.speed)))
        return np.where(free[:, None], pred_traj[:, :held.shape[1]], held) if free.any() else held

    def fed(self, t, c_next, known=None):
        if self.pace != "seed" or t + 1 >= self.n_seed:
            return
        speed = plan_speed(self.norm.denorm_traj(c_next))
        if known is not None:
            self.known_speed = np.where(known, speed, self.known_speed)
        if t + 2 == self.n_seed:
            self.speed = np.where(np.isnan(self.known_speed), speed, self.known_speed)

    def types_changed(self, changed):
        if self.speed is not None:
            self.speed[changed] = np.nan


class Steered(ControlSource):
    """The predicted c^d bent by a turn and rescaled to a speed (:func:`steer`), both set with
    :meth:`set` before each frame (default: straight on at the predicted speed); ``root_height``
    (B,) or a number, the bodies' root heights h. ``raw`` is the last c^d given, raw (B, 12)."""

    def __init__(self, root_height):
        self.root_height = np.atleast_1d(np.asarray(root_height, dtype=np.float64))
        self.turn, self.speed, self.raw = 0.0, np.nan, None

    def set(self, turn=0.0, speed=np.nan) -> None:
        """The next frame's turn (+1 left, -1 right) and speed (m/s; NaN: as predicted), per
        character or one for all."""
        self.turn, self.speed = turn, speed

    def next(self, t, x_t, pred_traj):
        plan = self.norm.denorm_traj(pred_traj)
        turn, speed = (np.broadcast_to(v, len(plan)) for v in (self.turn, self.speed))
        h = np.broadcast_to(self.root_height, len(plan))
        self.raw = np.stack([steer(p, turn[i], speed[i], h[i]) for i, p in enumerate(plan)])
        return self.norm.norm_traj(self.raw)
