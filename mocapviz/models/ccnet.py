"""CCNet (paper §3.2): encoder, separate residual blocks (SRBs), skip sum, decoder.

Parameters are Conv1d weights (paper's layers); the forward pass works in (B, T, C) and runs the
k=1 convs and the two taps of each k=2 dilated conv as matmuls (much faster than Conv1d on CPU).
Input index t carries the frame x_t and the controls c_{t+1} of the frame to predict; output
index t is the Gaussian of x_{t+1} (mean, sigma), its foot-contact logits, and the predicted
trajectory control c^d_{t+2} (mean, sigma), fed back when no user control is given. With
``cfg.residual`` the decoder's mean output is the change x_{t+1} - x_t, and the mean adds x_t.

SRB i (Fig. 2): z = DilatedCausalConv_{k=2,d_i}(h) + Conv1x1_s(c^s) + Conv1x1_d(c^d) + Conv1x1_t(c^t);
g = tanh(z_a) * sigmoid(z_b) (WaveNet's gated unit, 2C channels split in two halves);
h <- h + Conv1x1_res(g) (no bias); skip_i = Conv1x1_skip(g). The decoder sees sum_i skip_i (Eq. 4).

The same network run one frame at a time is in :mod:`mocapviz.models.steppers`; the config and
its presets in :mod:`mocapviz.models.ccnet_config`.
"""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from mocapviz.models.ccnet_config import CCNetConfig, make_config
from mocapviz.models.protocol import register_model


class SRB(nn.Module):
    """Separate residual block: dilated causal conv plus one 1x1 conv per control type."""

    def __init__(self, cfg: CCNetConfig, dilation: int):
        super().__init__()
        c = cfg.channels
        self.dilation = dilation
        self.conv = nn.Conv1d(c, 2 * c, kernel_size=2, dilation=dilation)
        self.ctrl_skel = nn.Conv1d(cfg.n_skel, 2 * c, 1, bias=False)
        self.ctrl_traj = nn.Conv1d(cfg.n_traj, 2 * c, 1, bias=False)
        self.ctrl_type = nn.Conv1d(cfg.n_types, 2 * c, 1, bias=False)
        self.res = nn.Conv1d(c, c, 1, bias=False)
        self.skip = nn.Conv1d(c, cfg.skip_channels, 1, bias=cfg.skip_bias)

    def forward(self, h, skel, traj, types):
        """(B, T, C) layout; 1x1 convs as matmuls. skel/types may be (B, 1, D) (broadcast)."""
        d = self.dilation
        past = F.pad(h, (0, 0, d, 0))[:, :h.shape[1]]  # h_{t-d}, zeros before the start
        w = self.conv.weight
        z = F.linear(past, w[:, :, 0], self.conv.bias) + F.linear(h, w[:, :, 1])
        z = z + F.linear(skel, self.ctrl_skel.weight[:, :, 0]) + F.linear(traj, self.ctrl_traj.weight[:, :, 0]) \
            + F.linear(types, self.ctrl_type.weight[:, :, 0])
        a, b = z.chunk(2, dim=-1)
        g = torch.tanh(a) * torch.sigmoid(b)
        return h + F.linear(g, self.res.weight[:, :, 0]), F.linear(g, self.skip.weight[:, :, 0], self.skip.bias)


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


@register_model("ccnet")
class CCNet(nn.Module):
    """The network of paper §3.2, registered as "ccnet" (see :mod:`mocapviz.models.protocol`);
    its loss is ``LOSSES["ccnet"]`` in :mod:`mocapviz.training.losses`."""

    config_class = CCNetConfig
    input_names = ("x", "skel", "traj", "types")

    def __init__(self, cfg: CCNetConfig):
        super().__init__()
        self.cfg = cfg
        self.dropout = nn.Dropout(cfg.dropout)
        self.encoder = nn.Conv1d(cfg.n_x, cfg.channels, 1)
        self.blocks = nn.ModuleList(SRB(cfg, d) for d in cfg.dilations)
        self.decoder = nn.Conv1d(cfg.skip_channels, cfg.n_out, 1)
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

    @classmethod
    def config_for(cls, train_cfg, layout) -> CCNetConfig:
        """The config of ``train_cfg`` (size preset, dilations, dropout, residual) for a feature layout."""
        return make_config(train_cfg.size, n_x=layout.n_x, n_skel=layout.n_skel,
                           n_traj=layout.n_traj + 2 * train_cfg.phase, phase=train_cfg.phase,
                           n_types=layout.n_types, dilations=train_cfg.dilations, dropout=train_cfg.dropout,
                           residual=train_cfg.residual, latent=train_cfg.latent, latent_hold=train_cfg.latent_hold,
                           latent_lerp=train_cfg.latent_lerp, traj_without_z=train_cfg.traj_without_z,
                           root_without_z=train_cfg.root_without_z, phase_harmonics=train_cfg.phase_harmonics)

    def stepper(self, batch: int = 1, backend: str = "torch"):
        """Incremental engine over this model's current weights: "torch" (:class:`CCNetStepper`,
        torch tensors in and out) or "numpy" (:class:`NumpyStepper`, numpy arrays)."""
        from mocapviz.models.steppers import CCNetStepper, NumpyStepper
        engines = {"torch": CCNetStepper, "numpy": NumpyStepper}
        if backend not in engines:
            raise ValueError(f"unknown backend {backend!r}; choose from {sorted(engines)}")
        return engines[backend](self, batch)

    @staticmethod
    def _ctrl(c):
        return c if c.dim() == 3 else c[:, None]

    def forward(self, x, skel, traj, types, target_x=None, z=None) -> dict[str, torch.Tensor]:
        """x (B, T, n_x); skel (B, n_skel) or (B, T, n_skel); traj (B, T, n_traj);
        types (B, n_types) or (B, T, n_types). Returns (B, T, .) tensors.

        With a latent (``cfg.latent``): ``target_x`` (B, T, n_x), the true next frames, gives z
        from the posterior (a sample in training mode, its mean in eval mode; the output then
        also holds ``z_mean``, ``z_logvar`` and the prior's ``prior_mean``, ``prior_logvar``, one
        per knot of :func:`latent_weights` (B, J, latent));
        else ``z`` (B, T, latent) is used, or the prior's mean."""
        skip = self.trunk(x, skel, traj, types)
        extra = {}
        if self.cfg.latent and (target_x is not None or z is None):
            # one z per knot: per block of k frames, or blended between knots k frames apart
            # (latent_weights), each drawn at a frame of knot_prior_frames
            k, n = self.cfg.latent_hold, skip.shape[1]
            w = torch.from_numpy(latent_weights(n, k, self.cfg.latent_lerp)).to(skip)
            at = torch.from_numpy(knot_prior_frames(n, k, self.cfg.latent_lerp))
            if target_x is not None:
                pool = w / w.sum(0)
                z_mean, z_logvar = (torch.einsum("tj,btl->bjl", pool, v) for v in self.posterior_of(skip, x, target_x))
                z_knots = z_mean + torch.exp(0.5 * z_logvar) * torch.randn_like(z_mean) if self.training else z_mean
                z = torch.einsum("tj,bjl->btl", w, z_knots)
                prior_mean, prior_logvar = self.prior_of(skip[:, at])
                extra = dict(z_mean=z_mean, z_logvar=z_logvar, prior_mean=prior_mean, prior_logvar=prior_logvar)
            else:  # the prior's mean per knot, as the generator's mean output
                z = torch.einsum("tj,bjl->btl", w, self.prior_mean(skip, types, at))
        out = self.split_output(self.head(skip, z, traj))
        if self.cfg.residual_slices:
            out["mean"] = self.cfg.add_residual(out["mean"].clone(), x)
        return dict(out, **extra)

    def trunk(self, x, skel, traj, types) -> torch.Tensor:
        """The causal stack: the skip sum (B, T, skip_channels) before the decoder's ReLU."""
        skel, traj, types = self._ctrl(skel), self._ctrl(traj), self._ctrl(types)
        h = torch.relu(F.linear(self.dropout(x), self.encoder.weight[:, :, 0], self.encoder.bias))
        skip = 0
        for blk in self.blocks:
            h, s = blk(h, skel, traj, types)
            skip = skip + s
        return skip

    def head(self, skip: torch.Tensor, z: torch.Tensor | None = None, traj: torch.Tensor | None = None) -> torch.Tensor:
        """The decoder: raw output (..., n_out) from the skip sum (and z, with a latent; and the
        phase in the control c^d ``traj``, with ``phase_harmonics``). The columns
        ``cfg.without_z_columns`` (the predicted c^d with ``traj_without_z``, the root with
        ``root_without_z``) are decoded from the skip sum alone."""
        if not self.cfg.latent:
            out = self._decode(skip, traj)
        else:
            out = self._decode(skip + self.z_in(z), traj)
            cols = self.cfg.without_z_columns
            if len(cols):
                idx = torch.from_numpy(cols).to(out.device)
                out = out.index_copy(-1, idx, self._decode(skip, traj, idx))
        return out

    def _decode(self, skip, traj, columns: slice | torch.Tensor = slice(None)) -> torch.Tensor:
        """The decoder's ``columns`` of the raw output from a skip sum (before the ReLU)."""
        h = torch.relu(skip)
        out = F.linear(h, self.decoder.weight[columns, :, 0], self.decoder.bias[columns])
        if self.cfg.phase_harmonics:
            out = out + F.linear(phase_basis(h, traj[..., -2:], self.cfg.phase_harmonics), self.phase_decoder.weight[columns])
        return out

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

    def split_output(self, out: torch.Tensor) -> dict[str, torch.Tensor]:
        """Named parts of the raw decoder output (..., n_out), with sigma = max(exp(-s), sigma_min)."""
        c = self.cfg
        p = {k: out[..., sl] for k, sl in c.output_slices.items()}
        return dict(mean=p["mean"], sigma=torch.exp(-p["s"]).clamp_min(c.sigma_min),
                    contact_logits=p["contact_logits"], traj_mean=p["traj_mean"],
                    traj_sigma=torch.exp(-p["traj_s"]).clamp_min(c.sigma_min))
