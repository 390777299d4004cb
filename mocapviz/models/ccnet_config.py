"""CCNet's configuration (sizes of x_n, c_n and the network) and the named presets."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass

import numpy as np

ROOT_CHANNELS = 4   # the root block (vx, vz, heading rate, height) ends x's continuous part (features.ccnet)


@dataclass(frozen=True)
class CCNetConfig:
    n_x: int = 306            # frame vector size (continuous + 2 contacts)
    n_contact: int = 2
    n_skel: int = 73          # c^s
    n_traj: int = 12          # c^d
    n_types: int = 13         # c^t
    channels: int = 48        # residual channels C (the gated unit has 2C)
    skip_channels: int = 64
    dilations: tuple[int, ...] = (2,) * 20
    kernel_size: int = 2
    dropout: float = 0.5
    sigma_min: float = 1e-4
    skip_bias: bool = False   # 20 skip biases add up in Eq. 4; without them the decoder's ReLU stays alive more often
    # residual: the mean is x_t + decoder output (the network predicts the change to the next
    # frame). Off by default: the paper's network is not residual, and ours with it no longer
    # froze but drifted without bound in generation (mean |z| of the frame 0.6 -> 23 over 60 s,
    # docs/experiments.md). False for checkpoints saved before the option existed.
    residual: bool = False
    # residual_ranges: the mean adds x_t only on these [start, stop) channel ranges of the
    # continuous part. Tried on dataset v4: with every channel residual the root height
    # random-walked to -23x..+37x the seed's in 60 s; with the rotations and positions residual and
    # the velocities and root block absolute, generation never froze and kept its height, but
    # tumbled through impossible poses (6-26x the real pose distance). Off by default.
    residual_ranges: tuple[tuple[int, int], ...] = ()
    # residual_gain g: the mean on the residual channels is g * x_t + decoder output. g = 1 is a
    # pure integrator (a drift is carried on for ever); g < 1 leaks: the decoder has to supply
    # (1 - g) x_t itself, from the features it has learnt, so a drift it cannot represent decays
    # by g per frame while the motion it can represent is kept.
    residual_gain: float = 1.0
    # latent: size of a per-frame latent z (a conditional VAE on top of the causal stack, as in
    # Ling et al. 2020's motion VAE; 0 = the paper's network). The decoder sees the skip sum plus
    # a projection of z before its ReLU; in training z comes from a posterior that also sees the
    # true next frame, in generation from the prior (a draw when sampling, its mean for the mean
    # output). Tried: a Gaussian output trained on one-step targets averages the
    # possible continuations (the mean freezes), and its per-frame sigma is far above a real
    # frame's change (samples are noise). Drawing z instead of the frame lowered the sampled
    # jitter (default width, N(0, I) prior, rollouts from frame 40: 2-33x the real clips', and
    # 0.4-7x with the Generator's noise_correlation 0.95, against ccnet_wide's 25-909x), but the
    # mean output still froze on 6 of 10 test seeds: the causal stack tracks its input no better
    # (one_step.drift_table, depth 1: 0.24 against ccnet_wide's 0.17). Off by default; the runs
    # are in docs/experiments.md.
    latent: int = 0
    posterior_hidden: int = 256
    # learned_prior: z's prior is N(mu(past), sigma(past)^2) from the skip sum (a conditional
    # prior, as in VRNN-style sequence VAEs) instead of N(0, I); the mean output then uses the
    # prior's mean, the likeliest z for this past, not 0. It did not help either: config
    # wide_latent froze on 6 of 10 test seeds, both walks among them. With knots of z
    # (latent_hold), each knot's prior reads the past at the frame generation draws it
    # (models.ccnet.knot_prior_frames).
    learned_prior: bool = False
    # latent_hold: one z per this many consecutive frames, in training (the posterior's mean and
    # log-variance averaged over the block, one KL per block) and in generation (a draw every
    # latent_hold frames): z becomes a short plan that the decoder follows for a while, not a
    # per-frame innovation. Why: drawn independently every frame, a per-frame z made samples
    # shake (ccnet_phase: jitter 2.7-28x the real clips'), and held over frames at generation only
    # (noise_correlation 0.95) it was a push the network never saw persist (walks ran at ~3x pace).
    # Tried on the phase config (run P9 in docs/experiments.md, latent_hold 15): sampled jitter 1.2-19x
    # the real clips' on the validation seeds (walks 4.5x instead of 8x), still above 3x on most,
    # and the mean output's run and dash slowed to a quarter of their pace. Off by default.
    latent_hold: int = 1
    # latent_lerp: with latent_hold k, z is not held over a block but blended linearly between
    # knots k frames apart (models.ccnet.latent_weights), in training and generation: z's path is
    # continuous, so a new draw is no jump. Why: held z made every block boundary a kick (P9's
    # sampled jitter still 1.2-19x the real clips'), and per-frame z, whatever its prior
    # (latent_ar), carried each frame's residual, which sampling turns into shaking. With knots
    # 10 frames apart and traj_without_z (config phase_lerp, ccnet_phase_lerp): sampled jitter
    # 0.41-2.2x the real clips' on 9 of the 10 test seeds (ccnet_phase: 2.7-28x). Off by default.
    latent_lerp: bool = False
    # traj_without_z: the predicted c^d (the free-running controller's plan: where the root will
    # be over the next second) is decoded from the skip sum without z, so it comes from the past
    # alone. Why: with a blended z (latent_lerp) a knot carried the next frames' pace, and the mean
    # output's z = 0 planned an average pace: fed back as c^d, the run slowed to 0.95 m/s against
    # its 3.6 (2.58 with the clip's own c^d).
    traj_without_z: bool = False
    # root_without_z: the root's mean and s (the root block: planar velocity, heading rate,
    # height) are decoded from the skip sum without z too, so the root comes from the past alone.
    # Why: with knots of z 10 frames apart and an N(0, I) prior, z carried the root's pace and the
    # mean output's z = 0 decoded an average one: teacher-forced on the training clips of the
    # standing types, ccnet_phase_lerp_scale's mean root went 0.25-0.30 m/s forward
    # (one_step.root_bias_table), and its generated wavings walked off at that speed.
    root_without_z: bool = False
    # latent_ar rho: z's prior is a stationary AR(1) process, z_1 ~ N(0, I) and
    # z_t ~ N(rho z_{t-1}, (1 - rho^2) I) (one step per knot), in training (the KL of each z
    # against the prior given the sampled z before it) and in generation (each draw continues the
    # last). Every z is still N(0, I) on its own. Why it was tried: on real clips the posterior
    # means of ccnet_phase's per-frame z are correlated from frame to frame (lag one 0.3-0.99 on
    # the validation seeds), unlike its N(0, I) prior's independent draws (sampled jitter 2.7-28x).
    # It did not help (runs A95, A98 in docs/experiments.md: 2.1-29x and 1.5-21x): z still carried
    # each frame's residual, in steps the decoder scaled back up. 0: independent draws.
    latent_ar: float = 0.0
    # phase: the last two channels of c^d are a local motion phase (sin, cos)
    # (:mod:`mocapviz.features.phase`), given as an input and predicted with c^d; generation turns
    # it on at the seed's pace, or feeds the predicted one back (Generator's phase_source).
    # False: the paper's c^d.
    phase: bool = False
    # phase_harmonics K (needs phase): the decoder's weights and bias are a Fourier series in the
    # phase, W(p) = W_0 + sum_k W_k^c cos(k p) + W_k^s sin(k p), k <= K (a phase-functioned
    # decoder, after Holden et al. 2017's PFNN, whose weights are a spline in the phase). Why:
    # given the phase only as an input, the trained network barely used it (measured: with the
    # phase kept turning, the held-out subject's seeds still moved at 1-3 % of the real activity);
    # with phase-dependent weights even a stalled causal stack decodes a cycle of poses.
    phase_harmonics: int = 0
    # height_anchor (a, b): the root height channel is modelled relative to the body's standing
    # root height, the first value of c^s: the network takes x_h - o as input and its mean output
    # is o + the decoder's, o = a * c^s_0 + b (both normalised: a = skel_std_0 / x_std_h,
    # b = (skel_mean_0 - x_mean_h) / x_std_h, Normaliser.height_anchor). Why: dataset v4 is 90 %
    # Bandai's one body, and ccnet_phase_lerp (absolute height) learnt Bandai's root height, not the
    # body's: teacher-forced on CMU 35_01 (a training clip, root at 1.02 m) it predicted 0.80 m with
    # sigma 0.17 m, and generated bodies other than Bandai's dropped 0.1-0.2 m on the first frame and
    # walked on bent knees. Tried alone (run H1, config phase_lerp_anchor, docs/experiments.md)
    # it did not help: teacher-forced CMU 35_01 0.89 m, the CMU file seeds slower (activity 0.36-0.48x).
    # (): the absolute height (the paper's; older checkpoints).
    height_anchor: tuple[float, ...] = ()

    def __post_init__(self):
        if self.kernel_size != 2:
            raise ValueError("CCNet's SRBs use kernel size 2 (paper §3.2.2)")
        if not self.dilations or min(self.dilations) < 1:
            raise ValueError("dilations must be positive")
        object.__setattr__(self, "dilations", tuple(int(d) for d in self.dilations))
        object.__setattr__(self, "residual_ranges", tuple((int(a), int(b)) for a, b in self.residual_ranges))
        object.__setattr__(self, "height_anchor", tuple(float(v) for v in self.height_anchor))
        if self.height_anchor and len(self.height_anchor) != 2:
            raise ValueError(f"height_anchor is (a, b) or (), got {self.height_anchor}")
        if self.height_anchor and any(sl.start <= self.height_channel < sl.stop for sl in self.residual_slices):
            raise ValueError("the root height is either anchored to c^s or residual, not both")
        if not 0.0 < self.residual_gain <= 1.0:
            raise ValueError(f"residual_gain must lie in (0, 1], got {self.residual_gain}")
        if self.phase and self.n_traj < 2:
            raise ValueError("a phase needs two c^d channels")
        if self.phase_harmonics and not self.phase:
            raise ValueError("phase_harmonics needs phase")
        if self.latent < 0:
            raise ValueError(f"latent must be >= 0, got {self.latent}")
        if self.latent_hold < 1:
            raise ValueError(f"latent_hold must be >= 1, got {self.latent_hold}")
        if not 0.0 <= self.latent_ar < 1.0:
            raise ValueError(f"latent_ar must lie in [0, 1), got {self.latent_ar}")
        if self.latent_ar and self.learned_prior:
            raise ValueError("latent_ar and learned_prior are two different priors: choose one")
        if any(not 0 <= a < b <= self.n_continuous for a, b in self.residual_ranges):
            raise ValueError(f"residual_ranges must lie in [0, {self.n_continuous}): {self.residual_ranges}")

    @property
    def residual_slices(self) -> list[slice]:
        """The continuous channels whose mean is x_t + the decoder's output (none: the paper's)."""
        if self.residual:
            return [slice(0, self.n_continuous)]
        return [slice(a, b) for a, b in self.residual_ranges]

    def add_residual(self, mean, x):
        """The residual rule, the one home of it: on each residual slice the decoder gave the
        change from g x_t, so ``mean[..., sl] += g * x[..., sl]``, in place (numpy arrays or torch
        tensors, ``x`` the input frames). Returns ``mean``."""
        for sl in self.residual_slices:
            mean[..., sl] += self.residual_gain * x[..., sl]
        return mean

    @property
    def height_channel(self) -> int:
        """The root height in x: the last continuous channel (the root block, vx, vz, heading
        rate, height, ends the continuous part: mocapviz.features.ccnet)."""
        return self.n_continuous - 1

    def height_offset(self, skel):
        """o (...,): the anchored root height's offset (normalised units of x) for normalised
        c^s (..., n_skel), numpy or torch; the one home of the rule (see ``height_anchor``)."""
        a, b = self.height_anchor
        return a * skel[..., 0] + b

    @property
    def n_continuous(self) -> int:
        """Channels of x modelled by the Gaussian: all but the contact labels."""
        return self.n_x - self.n_contact

    @property
    def receptive_field(self) -> int:
        return receptive_field(self.dilations, self.kernel_size)

    @property
    def output_slices(self) -> dict[str, slice]:
        """Where each part sits in the decoder's raw output (..., n_out): the Gaussian mean and
        its s (sigma = exp(-s)) of x_{t+1}'s continuous part, the contact logits, and the mean
        and s of the predicted trajectory control c^d_{t+2}. The one home of this layout."""
        n, k, d = self.n_continuous, self.n_contact, self.n_traj
        out, at = {}, 0
        for name, size in (("mean", n), ("s", n), ("contact_logits", k), ("traj_mean", d), ("traj_s", d)):
            out[name] = slice(at, at + size)
            at += size
        return out

    @property
    def without_z_columns(self) -> np.ndarray:
        """Columns of the raw output decoded from the skip sum without z (``traj_without_z``:
        the predicted c^d's mean and s; ``root_without_z``: the root block's mean and s, the
        last ROOT_CHANNELS of x's continuous part), ascending."""
        out = self.output_slices
        cols = []
        if self.root_without_z:
            for part in ("mean", "s"):
                cols += range(out[part].stop - ROOT_CHANNELS, out[part].stop)
        if self.traj_without_z:
            cols += range(out["traj_mean"].start, self.n_out)
        return np.asarray(cols, dtype=np.int64)

    @property
    def n_out(self) -> int:
        return 2 * self.n_continuous + self.n_contact + 2 * self.n_traj

    def to_json(self) -> str:
        return json.dumps(asdict(self), sort_keys=True)

    @classmethod
    def from_json(cls, s: str) -> "CCNetConfig":
        d = json.loads(s)
        d["dilations"] = tuple(d["dilations"])
        return cls(**d)


def receptive_field(dilations, kernel_size: int = 2) -> int:
    """Eq. 3: CRL = (k - 1) + sum_i d_i (k - 1) frames."""
    return (kernel_size - 1) + sum(int(d) * (kernel_size - 1) for d in dilations)


# Named sizes. "paper": 20 SRBs with d = 2 (CRL 41); the paper's Fig. 2 channel counts are not
# legible in our copy, so 256 residual/skip channels (a WaveNet-typical width) is our reading.
SIZES = {
    "quick": dict(channels=32, skip_channels=32),
    "default": dict(channels=48, skip_channels=64),
    "wide": dict(channels=96, skip_channels=128),
    "paper": dict(channels=256, skip_channels=256),
}


def make_config(size: str = "default", **overrides) -> CCNetConfig:
    if size not in SIZES:
        raise KeyError(f"unknown CCNet size {size!r}; choose from {sorted(SIZES)}")
    return CCNetConfig(**{**SIZES[size], **overrides})
