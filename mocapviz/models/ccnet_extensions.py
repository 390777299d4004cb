"""Our additions to the paper's CCNet (:mod:`mocapviz.models.ccnet`), each off by default in
:class:`~mocapviz.models.ccnet_config.CCNetConfig`; ``ccnet_generate`` uses them all. Why each
was added, and what it measured: docs/experiments.md.

- **A latent z** (``latent``; Ling et al. 2020's motion VAE on the causal stack): the decoder sees
  the skip sum plus a projection of z. In training z comes from a posterior that also sees the
  true next frame (an ELBO: the loss adds its KL to the N(0, I) prior); in generation from the
  prior, or from the type prior fitted after training (:mod:`mocapviz.models.type_prior`). One z
  per knot ``latent_hold`` frames apart, held over its block or blended between knots
  (``latent_lerp``: :func:`latent_weights`); the predicted c^d and the root can be decoded
  without z (``traj_without_z``, ``root_without_z``), from the past alone.
- **A local motion phase** (``phase``, :mod:`mocapviz.features.phase`): the last two channels of
  c^d, (sin, cos); with ``phase_harmonics`` K the decoder's weights are a Fourier series in it,
  W(p) = W_0 + sum_k W_k^c cos(k p) + W_k^s sin(k p), k <= K (a phase-functioned decoder, after
  Holden et al. 2017's PFNN).

:class:`CCNetExtensions` is CCNet's base class: the parameters live on the CCNet module, so
checkpoints keep their names (``z_in``, ``posterior``, ``phase_decoder``). The steppers
(:mod:`mocapviz.models.steppers`) run the same parts one frame at a time.
"""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn


def phase_waves(phase, harmonics: int):
    """(..., 2K): cos(k p) for k = 1..K, then sin(k p), of the phase p given as (sin p, cos p)
    (..., 2) on the unit circle. Torch or numpy. The harmonics come from the angle-sum formulas,
    not from an arctan2 and K cos/sin calls: this runs once per generated frame."""
    lib = torch if torch.is_tensor(phase) else np
    s1, c1 = phase[..., :1], phase[..., 1:]
    cos_k, sin_k = [c1], [s1]
    for _ in range(1, harmonics):
        c, s = cos_k[-1], sin_k[-1]
        cos_k.append(c * c1 - s * s1)
        sin_k.append(s * c1 + c * s1)
    return lib.concatenate(cos_k + sin_k, -1)


def phase_basis(h, phase, harmonics: int):
    """(..., 2K (S + 1)): the decoder input h (..., S) with a 1 appended, times the
    :func:`phase_waves` of the phase (..., 2). Torch or numpy."""
    lib = torch if torch.is_tensor(h) else np
    waves = phase_waves(phase, harmonics)                            # (..., 2K)
    hb = lib.concatenate([h, lib.ones_like(h[..., :1])], -1)         # (..., S + 1)
    return (waves[..., :, None] * hb[..., None, :]).reshape(*h.shape[:-1], -1)


def latent_weights(n_frames: int, k: int, lerp: bool = False) -> np.ndarray:
    """(T, J) weights from J knots of z to the T frames: frame t's z is sum_j W[t, j] z_j.

    Held (``lerp`` False, CCNetConfig.latent_hold): one knot per block of ``k`` frames, W[t, t // k]
    = 1. Blended (``lerp``, CCNetConfig.latent_lerp): knots at frames 0, k, 2k, ... up to the first
    at or past the last frame, and z between two knots is their linear blend (hat functions), so
    z's path has no jumps. A knot's posterior pools the frames' posteriors with these weights
    (the columns normalised); for k = 1 both are the identity (a z per frame)."""
    t = np.arange(n_frames)
    if not lerp:
        return (t[:, None] // k == np.arange(-(-n_frames // k))[None]).astype(np.float32)
    knots = np.arange(-(-(n_frames - 1) // k) + 1) * k
    return np.clip(1.0 - np.abs(t[:, None] - knots[None]) / k, 0.0, None).astype(np.float32)


def knot_prior_frames(n_frames: int, k: int, lerp: bool = False) -> np.ndarray:
    """(J,) the frame at which generation draws each knot of :func:`latent_weights` (whose motion
    type a type prior reads). Held: its block's first frame. Blended: a knot is drawn when z
    starts moving towards it, k frames early, so knot j is drawn at frame (j - 1) k, and knots 0
    and 1 both at frame 0."""
    j = np.arange(latent_weights(n_frames, k, lerp).shape[1])
    return np.maximum(j - 1, 0) * k if lerp else j * k


class CCNetExtensions(nn.Module):
    """The latent and phase parts of :class:`~mocapviz.models.ccnet.CCNet` (its base class)."""

    def add_extensions(self, cfg) -> None:
        """z's projection and posterior, the phase-functioned decoder, and the type prior's slot;
        made after the paper's layers (the order of the random initialisation)."""
        if cfg.latent:
            self.z_in = nn.Linear(cfg.latent, cfg.skip_channels, bias=False)
            self.posterior = nn.Sequential(
                nn.Linear(cfg.skip_channels + 2 * cfg.n_x, cfg.posterior_hidden), nn.ELU(),
                nn.Linear(cfg.posterior_hidden, cfg.posterior_hidden), nn.ELU(),
                nn.Linear(cfg.posterior_hidden, 2 * cfg.latent))
        if cfg.phase_harmonics:  # W_k^c, W_k^s on the skip units and the bias terms of every harmonic
            self.phase_decoder = nn.Linear(2 * cfg.phase_harmonics * (cfg.skip_channels + 1), cfg.n_out, bias=False)
            nn.init.zeros_(self.phase_decoder.weight)  # starts as the plain decoder
        # p(z | motion type), fitted after training (mocapviz.models.type_prior); set by load_checkpoint
        self.type_prior = None

    def latent_z(self, skip, x, types, target_x=None, z=None) -> tuple[torch.Tensor | None, dict]:
        """(z (B, T, latent) for the decoder, extra outputs). Without a latent, or with ``z`` given
        and no ``target_x``: ``z`` as given, nothing extra. Else one z per knot (per block of k
        frames, or blended between knots k frames apart: :func:`latent_weights`, each drawn at a
        frame of :func:`knot_prior_frames`): with ``target_x`` (B, T, n_x), the true next frames,
        from the posterior (a sample in training mode, its mean in eval mode; extra holds
        ``z_mean``, ``z_logvar``, ``prior_mean``, ``prior_logvar``, one per knot (B, J, latent)),
        else the prior's mean (:meth:`prior_mean`, the generator's mean output)."""
        if not self.cfg.latent or (target_x is None and z is not None):
            return z, {}
        k, n = self.cfg.latent_hold, skip.shape[1]
        w = torch.from_numpy(latent_weights(n, k, self.cfg.latent_lerp)).to(skip)
        at = torch.from_numpy(knot_prior_frames(n, k, self.cfg.latent_lerp))
        if target_x is None:
            return torch.einsum("tj,bjl->btl", w, self.prior_mean(skip, types, at)), {}
        pool = w / w.sum(0)
        z_mean, z_logvar = (torch.einsum("tj,btl->bjl", pool, v) for v in self.posterior_of(skip, x, target_x))
        z_knots = z_mean + torch.exp(0.5 * z_logvar) * torch.randn_like(z_mean) if self.training else z_mean
        prior_mean, prior_logvar = self.prior_of(skip[:, at])
        return torch.einsum("tj,bjl->btl", w, z_knots), dict(z_mean=z_mean, z_logvar=z_logvar, prior_mean=prior_mean,
                                                              prior_logvar=prior_logvar)

    def latent_head(self, skip: torch.Tensor, z: torch.Tensor, traj: torch.Tensor | None) -> torch.Tensor:
        """The decoder's raw output with z added to the skip sum; the columns
        ``cfg.without_z_columns`` (the predicted c^d with ``traj_without_z``, the root with
        ``root_without_z``) decoded from the skip sum alone."""
        out = self._decode(skip + self.z_in(z), traj)
        cols = self.cfg.without_z_columns
        if len(cols):
            idx = torch.from_numpy(cols).to(out.device)
            out = out.index_copy(-1, idx, self._decode(skip, traj, idx))
        return out

    def phase_term(self, h: torch.Tensor, traj: torch.Tensor, columns) -> torch.Tensor:
        """The phase-functioned decoder's ``columns`` for the decoder input ``h`` (after the ReLU)
        and the phase in the last two channels of the control ``traj``."""
        return F.linear(phase_basis(h, traj[..., -2:], self.cfg.phase_harmonics), self.phase_decoder.weight[columns])

    def posterior_of(self, skip, x, target_x) -> tuple[torch.Tensor, torch.Tensor]:
        """q(z | past, x_t, x_{t+1}): its mean and log-variance (..., latent)."""
        return self._mean_logvar(self.posterior(torch.cat([skip, x, target_x], -1)))

    def prior_of(self, skip) -> tuple[torch.Tensor, torch.Tensor]:
        """p(z): N(0, I), its mean and log-variance (..., latent) for skip sums (..., S)."""
        zero = skip.new_zeros(skip.shape[:-1] + (self.cfg.latent,))
        return zero, zero

    def prior_mean(self, skip, types, at) -> torch.Tensor:
        """(B, J, latent): the z the mean output decodes at knots whose prior reads the frames
        ``at`` (J,): the mean of the type prior (``self.type_prior``) of each knot's type (one-hot
        ``types``, (B, n_types) or (B, T, n_types)) when the model has one, else the prior's."""
        if self.type_prior is None:
            return self.prior_of(skip[:, at])[0]
        types = self._ctrl(types)
        index = types[:, at].argmax(-1) if types.shape[1] > 1 else types[:, [0] * len(at)].argmax(-1)
        return torch.as_tensor(self.type_prior.mean).to(skip)[index]

    def _mean_logvar(self, p: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """A Gaussian's mean and log-variance from an MLP's (..., 2 latent) output; the
        log-variance clamped to [-12, 6] so that exp() stays finite early in training."""
        return p[..., :self.cfg.latent], p[..., self.cfg.latent:].clamp(-12.0, 6.0)
