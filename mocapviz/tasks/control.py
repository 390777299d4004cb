"""Interactive control (paper §4.4): keys -> per-frame controls -> CCNet one frame at a time.

A pure function, a control source and a step-level generator:

- :func:`plan_controls`: key events -> per-frame motion-type label (number keys; the new label is
  blended in linearly over 20 frames), requested speed v_u (up/down; it moves to the new value
  over 20 frames) and turn (+1 left / -1 right on frames the key is down).
- :func:`mocapviz.tasks.controls.steer` (the source :class:`~mocapviz.tasks.controls.Steered`):
  the model's predicted c^d (six future root points, heading frame, metres) bent by a turn,
  o_n = [1, 0] h 0.015 added to point i with weight w_i = i/5 (i = 0..5; h the root height; +X
  is the character's left), then rescaled to v_u: the segments between the points are
  multiplied by v_u / v_cur, v_cur being the path length of the six points over their one second.
- :class:`ControlSession`: CCNet (or any model of the protocol) fed its own frames, with type,
  turn and speed allowed to change between any two frames; without keys it runs on its own
  predicted c^d, as the paper's demo does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mocapviz.features.ccnet import integrate_root
from mocapviz.features.motion_types import MOTION_TYPES
from mocapviz.tasks.controls import Steered
from mocapviz.tasks.controls import path_speed, steer  # noqa: F401 - re-exported: the keyboard control's API

# The paper's keys 1-5 are walk, run, jump (left foot), jump (right foot), jump (both feet); our
# vocabulary has no one-footed jumps, so 3-5 are its other locomotion types.
KEY_TYPES = {"1": "walk", "2": "jog", "3": "hop", "4": "dash", "5": "walk_back"}
BLEND_FRAMES = 20      # label blend and speed change, frames (paper §4.4)
SPEED_STEP = 0.5       # m/s per up/down press (the paper does not say)


@dataclass(frozen=True)
class KeyEvent:
    frame: int     # the generated frame (0 = the first one after the seed) at which the key is down
    key: str       # "1".."5", "up", "down", "left", "right"


def hold(key: str, start: int, frames: int) -> list[KeyEvent]:
    """A key held down for ``frames`` frames from ``start`` (one event per frame)."""
    return [KeyEvent(start + i, key) for i in range(frames)]


@dataclass
class ControlPlan:
    types: np.ndarray      # (T, n_types) motion-type label per frame (blends sum to 1)
    speed: np.ndarray      # (T,) requested speed v_u, m/s; NaN until the first up/down
    turn: np.ndarray       # (T,) +1 left, -1 right, 0 none


def _ramp(values: np.ndarray, frame: int, start, target, frames: int = BLEND_FRAMES) -> None:
    """In place: from ``frame`` on, ``values`` go linearly from ``start`` to ``target`` in
    ``frames`` frames (reached at ``frame + frames - 1``), then stay there."""
    k = np.minimum(np.arange(1, len(values) - frame + 1) / frames, 1.0)
    values[frame:] = start + np.multiply.outer(k, np.asarray(target) - start)


def plan_controls(events, n_frames: int, start_type: int, n_types: int, start_speed: float | None = None,
                  type_keys: dict[str, str] = KEY_TYPES, vocabulary=MOTION_TYPES) -> ControlPlan:
    """Per-frame controls of a key stream (a pure function). ``start_type``: index of the
    seed's type; ``start_speed``: the speed the first up/down starts from (m/s; None: the
    first press starts from 0 + SPEED_STEP)."""
    types = np.zeros((n_frames, n_types))
    types[:, start_type] = 1.0
    speed = np.full(n_frames, np.nan)
    turn = np.zeros(n_frames)
    level = start_speed
    for e in sorted(events, key=lambda e: e.frame):
        if not 0 <= e.frame < n_frames:
            continue
        if e.key in type_keys:
            _ramp(types, e.frame, types[max(e.frame - 1, 0)].copy(), np.eye(n_types)[vocabulary.index(type_keys[e.key])])
        elif e.key in ("up", "down"):
            before = level if level is not None else 0.0
            level = max(0.0, before + (SPEED_STEP if e.key == "up" else -SPEED_STEP))
            now = speed[e.frame - 1] if e.frame > 0 else np.nan
            _ramp(speed, e.frame, before if np.isnan(now) else now, level)
        elif e.key in ("left", "right"):
            turn[e.frame] = 1.0 if e.key == "left" else -1.0
        else:
            raise ValueError(f"unknown key {e.key!r}")
    return ControlPlan(types, speed, turn)


class ControlSession:
    """One character generated frame by frame under changing controls.

    ``seed_x`` (S, n_x) and ``seed_traj`` (S, 12) raw seed frames and their c^d, ``skel``
    (n_skel,) raw c^s (its first entry is the root height h), ``types`` (n_types,) the start
    label. Each :meth:`step` makes one frame."""

    def __init__(self, model, normaliser, seed_x, seed_traj, skel, types, sample: bool = False, seed: int = 0):
        from mocapviz.tasks.generate import (
            Generator,  # the frame writing (mean or sample, contacts)
        )
        self.gen = Generator(model, normaliser, batch=1, sample=sample, seed=seed, backend="numpy")
        self.norm = normaliser
        self.frames = [normaliser.norm_x(np.asarray(f, np.float32)[None])[0] for f in seed_x]
        self.n_seed = len(seed_x)
        self.controls: list[np.ndarray] = []     # raw c^d fed for each generated frame
        self.steered = Steered(float(skel[0]))   # the root height h scales the turn
        self.steered.start(normaliser, self.gen.layout, 1, self.n_seed)
        self.types = np.asarray(types, np.float32)
        self.gen.reset(normaliser.norm_skel(np.asarray(skel, np.float32)[None]), self.types[None])
        # a phase model (CCNetConfig.phase) sees the seed's local phase, then the phase turning on
        # at the seed's pace, as the Generator's default (features.phase.paced_phase)
        self.phase = None
        if model.cfg.phase:
            from mocapviz.features.phase import seed_phase
            usual = getattr(self.gen.type_prior, "phase_hz", None)
            self.phase, self.pace = seed_phase(np.asarray(seed_x, np.float32), self.gen.layout,
                                               fallback_hz=None if usual is None else usual[self.gen.type_index[0]])
        seed_n = normaliser.norm_traj(np.asarray(seed_traj, np.float32))
        for t in range(self.n_seed - 1):   # teacher-forced seed: frame t with the seed's c^d_{t+1}
            _, self.pred_traj = self.gen.advance(self.frames[t][None], self._with_phase(seed_n[t + 1][None], t + 1),
                                                 t, write=False)   # the model's next c^d, normalised

    def _with_phase(self, c: np.ndarray, frame: int) -> np.ndarray:
        """c^d (1, 12) of ``frame`` with a phase model's phase appended (1, 14)."""
        if self.phase is None:
            return c
        from mocapviz.features.phase import phase_channels
        angle = self.phase[frame] if frame < len(self.phase) else self.phase[-1] + self.pace * (frame - len(self.phase) + 1)
        return np.concatenate([c, phase_channels(np.array([angle]))], axis=1).astype(np.float32)

    def predicted_traj(self) -> np.ndarray:
        """The model's own c^d for the next frame, raw (12,)."""
        return self.norm.denorm_traj(self.pred_traj[0])

    def step(self, types=None, turn: float = 0.0, speed: float = np.nan) -> np.ndarray:
        """One frame under the given controls; returns it raw (n_x,)."""
        if types is not None and not np.array_equal(types, self.types):
            self.types = np.asarray(types, np.float32)
            self.gen.set_types(self.types[None])
        t = len(self.frames) - 1
        self.steered.set(turn, speed)
        c = self.steered.next(t, self.frames[-1][None], self.pred_traj)
        self.controls.append(self.steered.raw[0])
        nxt, self.pred_traj = self.gen.advance(self.frames[-1][None], self._with_phase(c, t + 1), t)
        self.frames.append(nxt[0])
        return self.norm.denorm_x(nxt)[0]

    def run(self, plan: ControlPlan) -> np.ndarray:
        """Every frame of ``plan``; returns the generated frames raw (T, n_x)."""
        return np.stack([self.step(plan.types[t], plan.turn[t], plan.speed[t]) for t in range(len(plan.turn))])

    def x(self) -> np.ndarray:
        """Seed and generated frames, raw (S + T, n_x)."""
        return self.norm.denorm_x(np.stack(self.frames))

    def root_path(self, start_root=(0.0, 0.0, 0.0), start_heading: float = 0.0):
        """Root positions (S + T, 3) and headings (S + T,) of the whole session."""
        return integrate_root(self.x()[:, self.gen.layout.x_blocks["root"]], start_root, start_heading)
