"""Autoregressive motion synthesis with CCNet (paper §3.1, §4.2).

Seed frames are fed through the network (teacher forcing), then each new frame is the mean of
the predicted Gaussian (or a sample from it) with the predicted contact labels, fed back as the
next input. A CCNet with a latent (``CCNetConfig.latent``) samples its z from the prior instead
(its type prior given the motion type when it has one: :mod:`mocapviz.models.type_prior`; per
frame, or per knot every ``latent_hold`` frames, held or blended: ``latent_lerp``) and writes the
decoder's mean (the prior's mean z for the mean output).

The trajectory control c^d comes from a control source (:mod:`mocapviz.tasks.controls`): a
clip's c^d repeated (``ClipControls``), a user path the character steers onto
(``PathControls``), the network's own prediction (``FreeRunning``, the default: as predicted or
held at the seed's pace) or a steered one (``Steered``, the interactive control); the seed's own
c^d, where given, is fed over it on the seed frames. :meth:`Generator.run` makes whole sequences;
:meth:`Generator.reset`, :meth:`~Generator.set_types` and :meth:`~Generator.advance` are its
single steps (used by :class:`mocapviz.tasks.control.ControlSession`).

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

from mocapviz.features.ccnet import FPS, FeatureLayout, Normaliser, features_to_motion
from mocapviz.features.phase import on_circle, paced_phase
from mocapviz.ik import remove_foot_sliding
from mocapviz.models.ccnet import CCNet
from mocapviz.motion import Motion
from mocapviz.skeleton import Skeleton
from mocapviz.tasks.controls import ClipControls, ControlSource, FreeRunning, PathControls
from mocapviz.tasks.controls import at_speed, path_controls, plan_speed  # noqa: F401 - re-exported: the generation API
from mocapviz.tasks.generation_defaults import PACES, Z_SOURCES


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


class Generator:
    """Batched autoregressive generation with the incremental stepper.

    ``backend``: "numpy" (fastest for a few characters: a frame is ~140 tiny calls and numpy's
    per-call cost is a fraction of torch's) or "torch" (better for large batches), the engines of
    :mod:`mocapviz.models.steppers` made by ``model.stepper``; "auto" picks numpy up to 8 characters.
    """

    def __init__(self, model: CCNet, normaliser: Normaliser, batch: int = 1, sample: bool = False,
                 seed: int = 0, backend: str = "auto", temperature: float = 1.0, noise_correlation: float = 0.0,
                 phase_source: str = "seed_pace", pace: str = "network", type_prior: bool = True,
                 z_source: str = "type", z_shift: np.ndarray | None = None):
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
        # the ground speed of the default control source, the network's own c^d (controls.FreeRunning):
        # "network", as predicted; "seed", held at the seed's last plan speed until the type changes
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
        # where a latent model's z comes from once the seed ends (Z_SOURCES): "type", the prior above;
        # "seed", the posterior's mean over the seed's own frames (:meth:`_use_seed_z`), held while the
        # motion type stays the seed's. Why "seed": z carries how the body holds itself, and the
        # type's mean z stood every HDM05 sneak up within a second (docs/experiments.md)
        if z_source not in Z_SOURCES:
            raise ValueError(f"z_source must be one of {Z_SOURCES}, got {z_source!r}")
        self.z_source = z_source
        # (B, latent) or None: added to the seed's z once read (mocapviz.tasks.posture_search picks it)
        self.z_shift = None if z_shift is None else np.asarray(z_shift, dtype=np.float32)
        self._z_seed = None    # (B, latent) the seed's z, once the seed has been read
        self._z_seed_on = None  # (B,) whose z it still is (their motion type is the seed's)
        self._seed_skips = []  # the trunk's output at each seed step z is read from
        self._skip = None      # the last trunk output (a latent model's; the seed's posterior reads it)
        self._type_index = None
        self._skel_n = None  # the characters' normalised c^s (reset)
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
        skip = self._skip = self._trunk(x, c)
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
        ``temperature`` when sampling; with ``z_source="seed"`` the seed's own z stands in for the
        mean while the motion type is the seed's (:meth:`_use_seed_z`). The frame is then the
        decoder's mean: the variation comes from z, not from per-frame Gaussian noise on the frame."""
        b = len(skip)
        if self.type_prior is not None:
            mean = self.type_prior.mean[self._type_index]
            z = self.type_prior.draw(self._type_index, self.temperature * self._draw((b, self.latent))) \
                if self.sample else mean
        else:
            mean = np.zeros((b, self.latent), dtype=np.float32)  # N(0, I) without a torch call per frame
            z = mean + self.temperature * self._draw(mean.shape) if self.sample else mean
        if self._z_seed is not None:  # the same spread around the seed's z
            z = z + np.where(self._z_seed_on[:, None], self._z_seed - mean, 0.0).astype(np.float32)
        return z

    def _use_seed_z(self, xs: np.ndarray, steps: range) -> None:
        """z from here on: the mean of the posterior's means at the seed ``steps`` (those with the
        whole receptive field behind them, or all but the first of a shorter seed), each given the
        true next frame of ``xs`` (B, T, n_x, normalised), plus ``z_shift`` where given; the knots
        already drawn are replaced. A one-frame seed has none and keeps the type's prior."""
        if not steps:
            return
        t = lambda a: torch.as_tensor(np.asarray(a, np.float32))  # noqa: E731
        skips = t(np.stack(self._seed_skips, axis=1))  # (B, S', skip channels)
        a, b = steps.start, steps.stop
        means = self.model.posterior_of(skips, t(xs[:, a:b]), t(xs[:, a + 1:b + 1]))[0]  # x_t and the true x_{t+1}
        self._z_seed = means.mean(1).numpy().astype(np.float32)
        if self.z_shift is not None:
            self._z_seed = self._z_seed + self.z_shift
        self._z_seed_on = np.ones(len(self._z_seed), bool)
        self._z_past = [self._z_seed.copy() for _ in self._z_past]

    def _draw(self, shape) -> np.ndarray:
        """This frame's N(0, 1) draws: independent of the last frame's, or AR(1) with lag-one
        correlation ``noise_correlation`` (rho e_prev + sqrt(1 - rho^2) e_new keeps N(0, 1))."""
        e = self.rng.standard_normal(shape, dtype=np.float32)
        rho = self.noise_correlation
        if rho and self._noise is not None:
            e = np.float32(rho) * self._noise + np.float32(np.sqrt(1.0 - rho * rho)) * e
        self._noise = e
        return e

    def reset(self, skel_n: np.ndarray, types: np.ndarray) -> None:
        """Start new characters: the stepper's history, the noise and z cleared; ``skel_n``
        (B, n_skel) normalised c^s and ``types`` (B, n_types) their c^t (:meth:`set_types`)."""
        self.stepper.reset()
        self.raw_outputs = []
        self._noise = None
        self._z_past = []  # the last two knots of z, newest first (blended between)
        self._z_seed, self._seed_skips = None, []
        self._skel_n = skel_n
        self.set_types(types)

    def set_types(self, types: np.ndarray) -> None:
        """The motion types c^t (B, n_types) float32 from the next step on."""
        if self.backend == "torch":
            self.stepper.set_static(torch.from_numpy(self._skel_n), torch.from_numpy(types))
        else:
            self.stepper.set_static(self._skel_n, types)
        index = types.argmax(1)  # the type prior's (one-hot types)
        if self._z_seed is not None:  # the seed's z is of the seed's type: a character given another takes its prior
            self._z_seed_on &= index == self._type_index
        self._type_index = index

    @property
    def type_index(self) -> np.ndarray | None:
        """(B,) each character's motion type index (the largest entry of its c^t)."""
        return self._type_index

    def advance(self, x_t: np.ndarray, c_next: np.ndarray, t: int, write: bool = True):
        """One step from frame t (B, n_x) and c^d_{t+1} (B, n_traj), both normalised: (frame t+1
        (B, n_x) normalised, or None without ``write`` (teacher-forced seed frames), and the c^d
        the network predicts for frame t+2, normalised). A residual model's x_t is added here."""
        raw = self._step(x_t, c_next, t)
        # a view of raw: the residual channels get g x_t added in place
        self.cfg.add_residual(raw[:, self.parts["mean"]], x_t)
        if self.keep_outputs:
            self.raw_outputs.append(raw.copy())
        if not write:
            return None, raw[:, self.parts["traj_mean"]].copy()
        frame = np.zeros((len(raw), self.cfg.n_x), dtype=np.float32)
        return frame, self._write_next(raw, frame).copy()

    def run(self, seed_x: np.ndarray, skel: np.ndarray, types: np.ndarray, n_frames: int,
            controls: ControlSource | None = None, seed_traj: np.ndarray | None = None,
            progress: bool = False, *, traj: np.ndarray | None = None, path: np.ndarray | None = None,
            start_root=None, start_heading=None) -> Generated:
        """seed_x (B, S, n_x) raw seed frames; skel (B, n_skel) raw c^s; types (B, n_types) or
        (B, S + n_frames, n_types); controls: the source of c^d (:mod:`mocapviz.tasks.controls`;
        default ``FreeRunning(self.pace)``); seed_traj (B, S, 12) raw c^d of the seed frames
        (default, and in its NaN rows: from ``controls``). Shorthands: ``traj`` (B, T_c, 12) for
        ``ClipControls(traj)``, ``path`` (B, T_p, 2) with ``start_root`` (B, 3) and
        ``start_heading`` (B,) for ``PathControls(path, start_root, start_heading)``."""
        from tqdm.auto import tqdm
        if traj is not None or path is not None:
            if controls is not None or (traj is not None and path is not None):
                raise ValueError("give one control source: controls, traj or path")
            controls = ClipControls(traj) if traj is not None else PathControls(path, start_root, start_heading)
        with torch.inference_mode():
            return self._run(seed_x, skel, types, n_frames, controls or FreeRunning(self.pace), seed_traj,
                             progress, tqdm)

    def _run(self, seed_x, skel, types, n_frames, controls, seed_traj, progress, tqdm) -> Generated:
        b, s = seed_x.shape[:2]
        total = s + n_frames
        norm = self.norm
        types = np.asarray(types, dtype=np.float32)
        per_frame_types = types.ndim == 3
        cur_type = types[:, 0] if per_frame_types else types
        self.reset(norm.norm_skel(skel), cur_type)
        controls.start(norm, self.layout, b, s)
        xs = np.zeros((b, total, self.cfg.n_x), dtype=np.float32)
        xs[:, :s] = norm.norm_x(seed_x)
        seed_n = None if seed_traj is None else norm.norm_traj(seed_traj)
        pred_traj = np.zeros((b, self.cfg.n_traj), dtype=np.float32)
        phase = None
        if self.cfg.phase:  # a seed without a cycle turns at its type's usual pace (TypePrior.phase_hz)
            usual = getattr(self.type_prior, "phase_hz", None)
            phase = paced_phase(seed_x, self.layout, total,
                                fallback_hz=None if usual is None else usual[self._type_index])
        read_seed = self.z_source == "seed" and bool(self.latent)  # z from the seed (_use_seed_z)
        seed_steps = range(max(0, min(self.cfg.receptive_field, s - 2)), s - 1) if read_seed else range(0)
        for t in tqdm(range(total - 1), desc="generate", disable=not progress):
            if per_frame_types and not np.array_equal(types[:, t + 1], cur_type):
                controls.types_changed((types[:, t + 1] != cur_type).any(axis=1))
                cur_type = types[:, t + 1]
                self.set_types(cur_type)
            c_next, known = controls.next(t, xs[:, t], pred_traj), None
            if t + 1 < s and seed_n is not None:  # the seed's own c^d where it has one (not NaN)
                seed_c = seed_n[:, t + 1]
                known = ~np.isnan(seed_c).any(axis=1)
                c_next = np.where(np.isnan(seed_c), c_next[:, :seed_c.shape[1]], seed_c)
            if phase is not None:  # the seed's phase, then turned on at its pace or the network's own
                if t + 1 >= s and self.phase_source == "network":
                    phase[:, t + 1] = on_circle(pred_traj[:, -2:])
                c_next = np.concatenate([c_next[:, :self.cfg.n_traj - 2], phase[:, t + 1]], axis=1)
            c_next = np.ascontiguousarray(c_next)
            controls.fed(t, c_next, known)
            if t + 1 == s and read_seed:
                self._use_seed_z(xs, seed_steps)
            frame, pred_traj = self.advance(xs[:, t], c_next, t, write=t + 1 >= s)
            if t in seed_steps:  # a copy: the stepper may reuse its buffers
                self._seed_skips.append(np.array(np.asarray(self._skip), dtype=np.float32, copy=True))
            if frame is not None:
                xs[:, t + 1] = frame
        return Generated(norm.denorm_x(xs), s, xs, phase)
