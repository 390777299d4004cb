"""ERD-4LR (Fragkiadaki et al. 2015, with four LSTM layers as Lee et al. 2018 used it): a CCNet baseline.

Encoder MLP (two ReLU layers) -> four stacked LSTM layers -> decoder MLP (one ReLU layer) ->
CCNet's output layout (:mod:`mocapviz.models.baseline`). The skeleton configuration c^s enters
at the encoder's first layer with the frame and the other controls. Fragkiadaki's ERD had a
500-500 encoder, 1000-unit LSTMs and a Gaussian-mixture output; we keep one Gaussian (CCNet's
loss, which the paper derived from that mixture loss) and CPU-sized widths (``SIZES``).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn

from mocapviz.models.baseline import BaselineConfig, BaselineModel
from mocapviz.models.protocol import register_model


@dataclass(frozen=True)
class ERDConfig(BaselineConfig):
    encoder: int = 128        # width of both encoder layers
    hidden: int = 128         # LSTM units per layer
    layers: int = 4           # the "4LR" of ERD-4LR
    decoder: int = 128


@register_model("erd")
class ERD(BaselineModel):
    config_class = ERDConfig
    # quick/default: ~0.7M parameters (CCNet default ~0.4M), trained in minutes on one core;
    # paper: Fragkiadaki's 500-unit encoder and Lee et al.'s 4 x 1024 LSTM layers
    SIZES = {"quick": dict(encoder=128, hidden=128, decoder=128),
             "default": dict(encoder=128, hidden=128, decoder=128),
             "paper": dict(encoder=500, hidden=1024, decoder=500),
             # CCNet's ablation "SRBs replaced by LSTMs" (paper §4.8.3: 1 or 2 layers of 512)
             "lstm1x512": dict(encoder=128, hidden=512, layers=1, decoder=128),
             "lstm2x512": dict(encoder=128, hidden=512, layers=2, decoder=128)}

    def __init__(self, cfg: ERDConfig):
        super().__init__()
        self.cfg = cfg
        self.encoder = nn.Sequential(nn.Linear(cfg.n_in, cfg.encoder), nn.ReLU(),
                                     nn.Linear(cfg.encoder, cfg.encoder), nn.ReLU())
        self.lstm = nn.LSTM(cfg.encoder, cfg.hidden, num_layers=cfg.layers, batch_first=True)
        self.decoder = nn.Sequential(nn.Linear(cfg.hidden, cfg.decoder), nn.ReLU(), nn.Linear(cfg.decoder, cfg.n_out))

    def run(self, inp: torch.Tensor, state=None):
        """inp (B, T, n_in) -> raw (B, T, n_out) and the LSTM state (h, c) after the last frame."""
        h, state = self.lstm(self.encoder(inp), state)
        return self.decoder(h), state
