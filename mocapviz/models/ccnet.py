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
its presets in :mod:`mocapviz.models.ccnet_config`; our additions, off by default (a latent z, a
local motion phase and a phase-functioned decoder), in :mod:`mocapviz.models.ccnet_extensions`.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from mocapviz.models.ccnet_config import CCNetConfig, make_config
from mocapviz.models.ccnet_extensions import CCNetExtensions
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


@register_model("ccnet")
class CCNet(CCNetExtensions):
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
        self.add_extensions(cfg)  # z's projection and posterior, the phase-functioned decoder (when configured)

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
        types (B, n_types) or (B, T, n_types). Returns (B, T, .) tensors: :meth:`split_output`.

        A latent model's z: ``z`` (B, T, latent), or from the posterior given ``target_x``, the
        true next frames, or the prior's mean (:meth:`CCNetExtensions.latent_z`)."""
        skip = self.trunk(x, skel, traj, types)
        z, extra = self.latent_z(skip, x, types, target_x, z)
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
        """The decoder (Eq. 5): raw output (..., n_out) from the skip sum (and z, with a latent:
        :meth:`CCNetExtensions.latent_head`)."""
        if self.cfg.latent:
            return self.latent_head(skip, z, traj)
        return self._decode(skip, traj)

    def _decode(self, skip, traj, columns: slice | torch.Tensor = slice(None)) -> torch.Tensor:
        """The decoder's ``columns`` of the raw output from a skip sum (before the ReLU); the
        phase-functioned decoder's term added with ``phase_harmonics``."""
        h = torch.relu(skip)
        out = F.linear(h, self.decoder.weight[columns, :, 0], self.decoder.bias[columns])
        if self.cfg.phase_harmonics:
            out = out + self.phase_term(h, traj, columns)
        return out

    def split_output(self, out: torch.Tensor) -> dict[str, torch.Tensor]:
        """Named parts of the raw decoder output (..., n_out), with sigma = max(exp(-s), sigma_min)."""
        c = self.cfg
        p = {k: out[..., sl] for k, sl in c.output_slices.items()}
        return dict(mean=p["mean"], sigma=torch.exp(-p["s"]).clamp_min(c.sigma_min),
                    contact_logits=p["contact_logits"], traj_mean=p["traj_mean"],
                    traj_sigma=torch.exp(-p["traj_s"]).clamp_min(c.sigma_min))
