"""Autoregressive motion synthesis with CCNet (paper §3.1, §4.2).

Seed frames are fed through the network (teacher forcing), then each new frame is the mean of
the predicted Gaussian (or a sample from it) with the predicted contact labels, fed back as the
next input. A CCNet with a latent (``CCNetConfig.latent``) samples its z from the prior instead
(its type prior given the motion type when it has one: :mod:`mocapviz.models.type_prior`; per
frame, or per knot every ``latent_hold`` frames, held or blended: ``latent_lerp``) and writes the
decoder's mean (the prior's mean z for the mean output). The trajectory
control c^d comes from one of:

- ``traj``: an array of raw c^d per frame (e.g. taken from a clip; repeated cyclically);
- ``path``: a user path of world ground points (X, Z) per frame; c^d is recomputed every frame
  from the character's integrated root and heading, so the character steers onto the path;
- neither: the network's own predicted c^d (free-running, the paper's interactive fallback), as
  predicted or (``pace="seed"``) scaled to the speed of the seed's last c^d (:func:`at_speed`).

A CCNet with a phase (``CCNetConfig.phase``) sees the seed's local phase
(:func:`mocapviz.features.phase.paced_phase`, from the seed frames alone), then the phase turning
on at the seed's pace (``phase_source="seed_pace"``) or its own predicted phase put back on the unit
circle (``"network"``), whatever the source of the rest of c^d.

The output frame vectors turn back into poses with :func:`features_to_motion` (exp maps through
FK, integrated root path) and, unless switched off, contact-triggered two-bone leg IK.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from mocapviz.features.ccnet import FPS, TRAJ_STEPS, FeatureLayout, Normaliser, features_to_motion
from mocapviz.features.phase import on_circle, paced_phase
from mocapviz.heading import from_heading_frame_xz, to_heading_frame_xz
from mocapviz.ik import remove_foot_sliding
from mocapviz.models.ccnet import CCNet
from mocapviz.motion import Motion
from mocapviz.skeleton import Skeleton
from mocapviz.tasks.generation_defaults import PACES


@dataclass
class Generated:
    x: np.ndarray            # (B, T, n_x) raw frame vectors, seed frames first
    n_seed: int
    x_norm: np.ndarray | None = None   # the same, normalised (what the network saw)
    phase: np.ndarray | None = None    # (B, T, 2) the phase (sin, cos) the network saw (CCNetConfig.phase)

    def motion(self, i: int, skeleton: Skeleton, start_root=(0.0, 0.0, 0.0), start_heading: float = 0.0,
               ik: bool = True, include_seed: bool = True, name: str = "generated") -> Motion:
        x = self.x[i] if include_seed else self.x[i, self.n_seed:]
        m = features_to_motion(x, skeleton, start_root, start_heading, FPS, name=name)
        return remove_foot_sliding(m, m.meta["contacts"]) if ik else m


def plan_speed(c_d: np.ndarray) -> np.ndarray:
    """Ground speed (m/s) a raw c^d (B, >= 12) plans: the length of the path through its six
    points (root, then 10, 20, ..., 60 frames ahead), over the one second they span."""
    pts = np.concatenate([np.zeros((len(c_d), 1, 2), np.float32), c_d[:, :2 * len(TRAJ_STEPS)].reshape(len(c_d), -1, 2)], 1)
    return np.linalg.norm(np.diff(pts, axis=1), axis=-1).sum(1) * FPS / TRAJ_STEPS[-1]


# plans slower than this (m/s) have no direction to keep: at_speed scales them by pace / this at most
MIN_PLAN_SPEED = 0.05


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


class Generator:
    """Batched autoregressive generation with the incremental stepper.

    ``backend``: "numpy" (fastest for a few characters: a frame is ~140 tiny calls and numpy's
    per-call cost is a fraction of torch's) or "torch" (better for large batches), the engines of
    :mod:`mocapviz.models.steppers` made by ``model.stepper``; "auto" picks numpy up to 8 characters.
    """

    def __init__(self, model: CCNet, normaliser: Normaliser, batch: int = 1, sample: bool = False,
                 seed: int = 0, backend: str = "auto", temperature: float = 1.0, noise_correlation: float = 0.0,
                 phase_source: str = "seed_pace", pace: str = "network", type_prior: bool = True):
        if temperature < 0:
            raise ValueError(f"temperature must be >= 0, got {temperature}")
        if not 0.0 <= noise_correlation < 1.0:
            raise ValueError(f"noise_correlation must lie in [0, 1), got {noise_correlation}")
        self.model = model.eval()
        self.norm = normaliser
        self.batch = batch
        self.sample = sample
        # sampling draws from N(mean, (temperature * sigma)^2): 1 is the predicted Gaussian, 0 the
        # mean; a latent model draws z from its prior, spread scaled by temperature, instead (_latent)
        self.temperature = float(temperature)
        # the draws' correlation from one frame to the next (AR(1); 0: independent draws, the
        # paper's). Every frame's draw is still N(0, 1), so every frame is still a sample of its
        # predicted PDF; only the joint over time changes. Why: the PDF is of the next frame given
        # the past, and independent draws make every frame jump by sigma, while a model's errors
        # are slow drifts, not white noise (measured: jitter 25-909x the real clips' with 0).
        self.noise_correlation = float(noise_correlation)
        # a phase model's phase after the seed (CCNetConfig.phase): "seed_pace" turns it on at the
        # seed's own pace (features.phase.phase_pace), "network" feeds back the network's
        # prediction. Why "seed_pace": the predicted phase stalled with the pose on the held-out
        # subject's seeds (measured: 0.00 cycles/s after 10 s), and a stalled phase cannot help.
        if phase_source not in ("seed_pace", "network"):
            raise ValueError(f"phase_source must be 'seed_pace' or 'network', got {phase_source!r}")
        self.phase_source = phase_source
        # the ground speed of a free-running plan (the network's own c^d): "network", as predicted;
        # "seed", rescaled every frame to the speed of the c^d the last seed frame was fed (at_speed:
        # the paper's interactive velocity control, §4.4, with the user's speed the seed's), until
        # the character's motion type changes (a run after a walk has its own pace). Why: fed
        # back, the predicted plan slows (measured: ccnet_phase_lerp's test run seed at 0.27x the real
        # runs' ground speed over seconds 30-60; held, 0.84x)
        if pace not in PACES:
            raise ValueError(f"pace must be one of {PACES}, got {pace!r}")
        self.pace = pace
        self._noise = None
        self._z_past = []
        self.rng = np.random.default_rng(seed)
        self.cfg = model.cfg
        self.layout = FeatureLayout.of_model(self.cfg)
        self.parts = self.cfg.output_slices  # where mean, s, contact logits, c^d sit in a raw output
        self.backend = ("numpy" if batch <= 8 else "torch") if backend == "auto" else backend
        self.stepper = model.stepper(batch, self.backend)
        st, t = self.stepper, torch.from_numpy
        self.latent = self.cfg.latent  # a CCNet with a latent z (CCNetConfig.latent; baselines: 0)
        # z from the model's prior given the motion type (mocapviz.models.type_prior), when it has one
        # and ``type_prior``; else from its training prior. Why: N(0, I)'s mean z = 0 decodes an
        # average of all types (measured: the waving stepped its feet in place)
        self.type_prior = getattr(model, "type_prior", None) if type_prior and self.latent else None
        self._type_index = None
        if self.backend == "numpy":
            self._plain_step = st.step
            if self.latent:
                self._trunk, self._head = st.trunk_step, st.head
        else:
            self._plain_step = lambda x, c: st.step(t(x), t(c)).numpy()
            if self.latent:
                self._trunk = lambda x, c: st.trunk_step(t(x), t(c))
                self._head = lambda skip, z, c: st.head(skip, t(z), t(c)).numpy()
        self.constant = normaliser.constant_channels()  # written as their training value (0 normalised)
        self.keep_outputs = False     # keep every raw step output (tests / benchmark)
        self.raw_outputs: list[np.ndarray] = []

    def _write_next(self, raw: np.ndarray, dest: np.ndarray) -> np.ndarray:
        """Frame t+1 into ``dest`` (B, n_x): the mean (or a Gaussian sample) and the contact
        labels (logit > 0); returns the predicted c^d (normalised), a view of ``raw``."""
        n, out = self.cfg.n_continuous, self.parts
        if self.sample and not self.latent:  # a latent model samples z instead (_latent)
            sigma = np.maximum(np.exp(-raw[:, out["s"]]), self.cfg.sigma_min)
            dest[:, :n] = raw[:, out["mean"]] + self.temperature * sigma * self._draw(sigma.shape)
        else:
            dest[:, :n] = raw[:, out["mean"]]
        dest[:, :n][:, self.constant] = 0.0
        np.greater(raw[:, out["contact_logits"]], 0, out=dest[:, n:], casting="unsafe")
        return raw[:, out["traj_mean"]]

    def _step(self, x: np.ndarray, c: np.ndarray, t: int) -> np.ndarray:
        """The raw output (B, n_out) for frame t+1 from frame t and c^d_{t+1} (numpy arrays)."""
        if not self.latent:
            return self._plain_step(x, c)
        skip = self._trunk(x, c)
        k = self.cfg.latent_hold
        if t % k == 0:  # a new knot of z every latent_hold frames (CCNetConfig.latent_hold)
            # blended (latent_lerp): frames t..t+k-1 lie between this knot and the next, so the
            # next is drawn now (models.ccnet_extensions.knot_prior_frames)
            for _ in range(2 if self.cfg.latent_lerp and not self._z_past else 1):
                self._z_past = [self._latent(skip)] + self._z_past[:1]  # the knot and the one before
        if self.cfg.latent_lerp:
            a = np.float32((t % k) / k)
            z = (1 - a) * self._z_past[1] + a * self._z_past[0]
        else:
            z = self._z_past[0]
        return self._head(skip, z, c)

    def _latent(self, skip) -> np.ndarray:
        """z of a latent model for the next knot, from its type prior (``self.type_prior``) or else
        N(0, I) (``CCNet.prior_of``): the prior's mean, or a draw from it with the spread scaled by
        ``temperature`` when sampling. The frame is then the decoder's mean: the variation comes
        from z, not from per-frame Gaussian noise on the frame."""
        if self.type_prior is not None:
            if not self.sample:
                return self.type_prior.mean[self._type_index]
            return self.type_prior.draw(self._type_index, self.temperature * self._draw((len(skip), self.latent)))
        mean = np.zeros((len(skip), self.latent), dtype=np.float32)  # N(0, I) without a torch call per frame
        if not self.sample:
            return mean
        return mean + self.temperature * self._draw(mean.shape)

    def _draw(self, shape) -> np.ndarray:
        """This frame's N(0, 1) draws: independent of the last frame's, or AR(1) with lag-one
        correlation ``noise_correlation`` (rho e_prev + sqrt(1 - rho^2) e_new keeps N(0, 1))."""
        e = self.rng.standard_normal(shape, dtype=np.float32)
        rho = self.noise_correlation
        if rho and self._noise is not None:
            e = np.float32(rho) * self._noise + np.float32(np.sqrt(1.0 - rho * rho)) * e
        self._noise = e
        return e

    def run(self, seed_x: np.ndarray, skel: np.ndarray, types: np.ndarray, n_frames: int,
            traj: np.ndarray | None = None, path: np.ndarray | None = None,
            seed_traj: np.ndarray | None = None, start_root=None, start_heading=None,
            progress: bool = False) -> Generated:
        """seed_x (B, S, n_x) raw seed frames; skel (B, n_skel) raw c^s; types (B, n_types) or
        (B, S + n_frames, n_types); traj (B, T_c, 12) raw c^d indexed by frame (repeated
        cyclically); path (B, T_p, 2) world X/Z per frame (needs start_root (B, 3) and
        start_heading (B,) of the frame before the seed, as the clip's); seed_traj (B, S, 12) raw
        c^d of the seed frames (default, and in its NaN rows: from ``traj``, ``path``, or the network's
        prediction)."""
        from tqdm.auto import tqdm
        with torch.inference_mode():
            return self._run(seed_x, skel, types, n_frames, traj, path, seed_traj, start_root,
                             start_heading, progress, tqdm)

    def _run(self, seed_x, skel, types, n_frames, traj, path, seed_traj, start_root, start_heading,
             progress, tqdm) -> Generated:
        b, s = seed_x.shape[:2]
        total = s + n_frames
        norm = self.norm
        skel_n = norm.norm_skel(skel)
        types = np.asarray(types, dtype=np.float32)
        per_frame_types = types.ndim == 3
        cur_type = types[:, 0] if per_frame_types else types
        self.stepper.reset()
        self.raw_outputs = []
        self._noise = None
        self._z_past = []  # the last two knots of z, newest first (blended between)
        stepper_static = (lambda sk, ty: self.stepper.set_static(torch.from_numpy(sk), torch.from_numpy(ty))) \
            if self.backend == "torch" else self.stepper.set_static

        def set_static(sk, ty):
            stepper_static(sk, ty)
            self._type_index = ty.argmax(1)  # the type prior's (one-hot types)
        set_static(skel_n, cur_type)
        xs = np.zeros((b, total, self.cfg.n_x), dtype=np.float32)
        xs[:, :s] = norm.norm_x(seed_x)
        traj_n = None if traj is None else norm.norm_traj(traj)
        seed_n = None if seed_traj is None else norm.norm_traj(seed_traj)
        root_b = self.layout.x_blocks["root"]
        if path is not None:
            root_xz = np.asarray(start_root, dtype=np.float64)[:, [0, 2]].copy()
            heading = np.asarray(start_heading, dtype=np.float64).copy()
        pred_traj = np.zeros((b, self.cfg.n_traj), dtype=np.float32)
        speed = None  # with pace "seed": the speed of the plan the last seed frame was generated under
        phase = None
        if self.cfg.phase:  # a seed without a cycle turns at its type's usual pace (TypePrior.phase_hz)
            usual = getattr(self.type_prior, "phase_hz", None)
            phase = paced_phase(seed_x, self.layout, total,
                                fallback_hz=None if usual is None else usual[self._type_index])
        for t in tqdm(range(total - 1), desc="generate", disable=not progress):
            if per_frame_types and not np.array_equal(types[:, t + 1], cur_type):
                if speed is not None:  # a new motion type has its own pace: the network's plan from here on
                    speed[(types[:, t + 1] != cur_type).any(axis=1)] = np.nan
                cur_type = types[:, t + 1]
                set_static(skel_n, cur_type)
            x_t = xs[:, t]
            if path is not None:  # integrate the root of frame t (raw units) for c^d_{t+1}
                r = x_t[:, root_b] * norm.x_std[root_b] + norm.x_mean[root_b]  # (vx, vz, yaw rate, height)
                root_xz += from_heading_frame_xz(r[:, :2], heading) / FPS
                heading += r[:, 2] / FPS
            if traj_n is not None:
                c_next = traj_n[:, (t + 1) % traj_n.shape[1]]
            elif path is not None:
                c_next = norm.norm_traj(path_controls(path, t + 1, root_xz, heading))
            elif speed is not None:  # the plan at the held speed (NaN: as predicted)
                free = np.isnan(speed)
                held = norm.norm_traj(at_speed(norm.denorm_traj(pred_traj), np.where(free, 0.0, speed)))
                c_next = np.where(free[:, None], pred_traj[:, :held.shape[1]], held) if free.any() else held
            else:
                c_next = pred_traj
            if t + 1 < s and seed_n is not None:  # the seed's own c^d where it has one (not NaN)
                seed_c = seed_n[:, t + 1]
                c_next = np.where(np.isnan(seed_c), c_next[:, :seed_c.shape[1]], seed_c)
            if phase is not None:  # the seed's phase, then turned on at its pace or the network's own
                if t + 1 >= s and self.phase_source == "network":
                    phase[:, t + 1] = on_circle(pred_traj[:, -2:])
                c_next = np.concatenate([c_next[:, :self.cfg.n_traj - 2], phase[:, t + 1]], axis=1)
            if self.pace == "seed" and t + 2 == s:
                speed = plan_speed(norm.denorm_traj(c_next))
            raw = self._step(x_t, np.ascontiguousarray(c_next), t)
            # a view of raw: the residual channels get g x_t added in place
            self.cfg.add_residual(raw[:, self.parts["mean"]], x_t)
            if self.keep_outputs:
                self.raw_outputs.append(raw.copy())
            if t + 1 >= s:
                pred_traj = self._write_next(raw, xs[:, t + 1]).copy()
            else:
                pred_traj = raw[:, self.parts["traj_mean"]].copy()
        return Generated(norm.denorm_x(xs), s, xs, phase)
