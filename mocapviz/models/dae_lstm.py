"""DAE-LSTM (Ghosh et al. 2017): a denoising autoencoder over poses, then an LSTM on its codes.

The autoencoder maps a frame's continuous channels to a code and back; it is **pretrained
alone** (:meth:`DAELSTM.pretrain`: inputs corrupted by Gaussian noise and dropped channels,
target the clean frame), and the trainer calls that before the first step. After that its
weights stay fixed: the three-layer LSTM (Ghosh's LSTM-3LR) reads the code of each input
frame (so a noisy input is filtered by the autoencoder first) with the contact labels and the
controls (c^s at its first layer) and writes CCNet's output layout
(:mod:`mocapviz.models.baseline`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from mocapviz.models.baseline import BaselineConfig, BaselineModel
from mocapviz.models.protocol import register_model


@dataclass(frozen=True)
class DAELSTMConfig(BaselineConfig):
    dae_hidden: int = 256
    code: int = 64
    hidden: int = 128         # LSTM units per layer
    layers: int = 3           # Ghosh's LSTM-3LR
    pretrain_steps: int = 600
    pretrain_noise: float = 0.1     # std of the corruption, normalised units
    pretrain_drop: float = 0.2      # share of channels zeroed in the corruption


@register_model("dae_lstm")
class DAELSTM(BaselineModel):
    config_class = DAELSTMConfig
    # ~0.7M parameters, minutes on one core; paper: Ghosh's LSTM-3LR had 1024 units
    SIZES = {"quick": {}, "default": {}, "paper": dict(dae_hidden=512, code=128, hidden=1024, pretrain_steps=5000)}

    def __init__(self, cfg: DAELSTMConfig):
        super().__init__()
        self.cfg = cfg
        n = cfg.n_continuous
        self.dae_encoder = nn.Sequential(nn.Linear(n, cfg.dae_hidden), nn.ReLU(), nn.Linear(cfg.dae_hidden, cfg.code))
        self.dae_decoder = nn.Sequential(nn.ReLU(), nn.Linear(cfg.code, cfg.dae_hidden), nn.ReLU(),
                                         nn.Linear(cfg.dae_hidden, n))
        self.lstm = nn.LSTM(cfg.n_in - n + cfg.code, cfg.hidden, num_layers=cfg.layers, batch_first=True)
        self.head = nn.Linear(cfg.hidden, cfg.n_out)

    def run(self, inp: torch.Tensor, state=None):
        """inp (B, T, n_in) -> raw (B, T, n_out) and the LSTM state after the last frame."""
        n = self.cfg.n_continuous
        with torch.no_grad():   # the pretrained autoencoder is not trained further
            code = self.dae_encoder(inp[..., :n])
        h, state = self.lstm(torch.cat([code, inp[..., n:]], -1), state)
        return self.head(h), state

    def reconstruct(self, frames: torch.Tensor) -> torch.Tensor:
        """The autoencoder: frames (..., n_continuous) normalised -> their reconstruction."""
        return self.dae_decoder(self.dae_encoder(frames))

    def pretrain(self, data, seed: int = 0, batch: int = 32, lr: float = 1e-3) -> list[float]:
        """Train the autoencoder alone on ``data``'s training windows (a
        :class:`mocapviz.training.windows.WindowData`): corrupted frame -> clean frame, mean
        squared error over the varying channels. Returns the loss per step."""
        c = self.cfg
        params = list(self.dae_encoder.parameters()) + list(self.dae_decoder.parameters())
        opt = torch.optim.Adam(params, lr=lr)
        rng = np.random.default_rng([seed, 1])
        gen = torch.Generator().manual_seed(seed)
        losses = []
        for _ in range(c.pretrain_steps):
            b = data.batch(data.train[rng.integers(len(data.train), size=batch)])
            clean = b["x"][..., :c.n_continuous].reshape(-1, c.n_continuous)
            keep = (torch.rand(clean.shape, generator=gen) >= c.pretrain_drop).to(clean.dtype)
            noisy = (clean + c.pretrain_noise * torch.randn(clean.shape, generator=gen)) * keep
            loss = ((self.reconstruct(noisy) - clean)[:, b["varying"]] ** 2).mean()
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            losses.append(loss.item())
        opt.zero_grad(set_to_none=True)   # leave no gradient behind for the main optimiser
        return losses
