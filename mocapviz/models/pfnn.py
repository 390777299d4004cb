"""PFNN (Holden et al. 2017): a phase-functioned MLP, as a CCNet baseline.

Each layer has four weight sets; the weights of a frame are their cubic Catmull-Rom blend at the
frame's phase p in [0, 2 pi) (Holden's Eq. 2-3). Since the blend is linear in the weight sets,
we apply the four sets and blend the four results with the Catmull-Rom coefficients: the same
numbers without building a weight matrix per frame. The inputs (frame, c^s at the first layer,
the trajectory control c^d as PFNN's trajectory inputs, c^t as its gait one-hot) and the outputs
are CCNet's (:mod:`mocapviz.models.baseline`).

The phase comes from the foot contacts of the input frames, causally (:func:`track_phase`):
a left touchdown sets it to 0, a right touchdown to pi, and in between it advances at the rate
of the last half cycle. Holden labelled phases offline by interpolating between touchdowns; a
causal tracker gives the same phase on steady gait and also works frame by frame in generation,
where the contacts are the network's own predictions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import nn

from mocapviz.models.baseline import BaselineConfig, BaselineModel
from mocapviz.models.protocol import register_model

TWO_PI = 2 * math.pi
DEFAULT_RATE = TWO_PI / 60     # rad/frame before two touchdowns are seen: one cycle per second at 60 fps
HALF_CYCLE = (8, 60)           # frames between opposite touchdowns that define a rate (0.13-1 s at 60 fps)


@dataclass(frozen=True)
class PFNNConfig(BaselineConfig):
    hidden: int = 128
    dropout: float = 0.0      # Holden: 0.3 (keep 0.7) on 512 units; off at our small width


def catmull_rom_coefficients(phase: torch.Tensor) -> torch.Tensor:
    """(N, 4) weights of the four control sets at ``phase`` (N,) radians (cyclic Catmull-Rom).

    With w the fractional position between control points k1 = floor(4 p / 2 pi) and k1 + 1,
    Holden's blend a1 + w (a2 - a0)/2 + w^2 (a0 - 5/2 a1 + 2 a2 - a3/2) + w^3 (3/2 a1 - 3/2 a2
    + a3/2 - a0/2) of the sets k0..k3 = k1 - 1 .. k1 + 2 (mod 4), grouped by set."""
    s = (phase % TWO_PI) * (4 / TWO_PI)
    k1 = torch.floor(s).long() % 4
    w = s - torch.floor(s)
    w2, w3 = w * w, w * w * w
    coef = torch.stack([-0.5 * w + w2 - 0.5 * w3, 1 - 2.5 * w2 + 1.5 * w3,
                        0.5 * w + 2 * w2 - 1.5 * w3, -0.5 * w2 + 0.5 * w3], -1)   # for k0, k1, k2, k3
    idx = (k1[:, None] + torch.arange(-1, 3)) % 4
    return torch.zeros_like(coef).scatter_add_(1, idx, coef)


class PhaseLinear(nn.Module):
    """A linear layer with four weight sets blended by phase."""

    def __init__(self, n_in: int, n_out: int):
        super().__init__()
        self.weight = nn.Parameter(torch.empty(4, n_in, n_out))
        self.bias = nn.Parameter(torch.zeros(4, n_out))
        bound = 1 / math.sqrt(n_in)
        nn.init.uniform_(self.weight, -bound, bound)

    def forward(self, x: torch.Tensor, coef: torch.Tensor) -> torch.Tensor:
        """x (N, n_in), coef (N, 4) -> (N, n_out)."""
        z = torch.einsum("ni,kio->nko", x, self.weight) + self.bias
        return torch.einsum("nk,nko->no", coef, z)


def track_phase(contacts: torch.Tensor, state=None):
    """Causal phase (B, T) radians from foot contacts (B, T, 2) (left, right; > 0.5 is contact).

    ``state`` (phase, rate, last touchdown frame, its foot, previous contacts, frame count)
    continues a sequence; None starts one (phase 0, no touchdown before its first frame)."""
    on = contacts > 0.5
    b, t = on.shape[:2]
    if state is None:
        z = torch.zeros(b, dtype=torch.float64)
        state = (z, z + DEFAULT_RATE, z - 1e9, torch.full((b,), -1), on[:, 0], 0)
    phase, rate, last_t, last_foot, prev, n = state
    out = []
    for i in range(t):
        if n > 0:
            down = on[:, i] & ~prev
            foot = torch.where(down[:, 0], 0, torch.where(down[:, 1], 1, -1))
            gap = n - last_t
            new_rate = (foot >= 0) & (last_foot >= 0) & (foot != last_foot) \
                & (gap >= HALF_CYCLE[0]) & (gap <= HALF_CYCLE[1])
            rate = torch.where(new_rate, math.pi / gap, rate)
            phase = torch.where(foot >= 0, foot.double() * math.pi, (phase + rate) % TWO_PI)
            last_t = torch.where(foot >= 0, torch.as_tensor(n, dtype=torch.float64), last_t)
            last_foot = torch.where(foot >= 0, foot, last_foot)
        prev = on[:, i]
        n += 1
        out.append(phase)
    return torch.stack(out, 1), (phase, rate, last_t, last_foot, prev, n)


@register_model("pfnn")
class PFNN(BaselineModel):
    config_class = PFNNConfig
    # Holden's 512 hidden units x 3 layers x 4 sets is ~4M weights; 128 keeps the committed
    # file small and one-core training to minutes (~0.6M parameters)
    SIZES = {"quick": dict(hidden=128), "default": dict(hidden=128), "paper": dict(hidden=512, dropout=0.3)}

    def __init__(self, cfg: PFNNConfig):
        super().__init__()
        self.cfg = cfg
        self.layers = nn.ModuleList([PhaseLinear(cfg.n_in, cfg.hidden), PhaseLinear(cfg.hidden, cfg.hidden),
                                     PhaseLinear(cfg.hidden, cfg.n_out)])
        self.dropout = nn.Dropout(cfg.dropout)

    def run(self, inp: torch.Tensor, state=None):
        """inp (B, T, n_in) -> raw (B, T, n_out) and the phase tracker's state."""
        c = self.cfg
        phase, state = track_phase(inp[..., c.n_continuous:c.n_x], state)
        b, t = inp.shape[:2]
        coef = catmull_rom_coefficients(phase.reshape(-1)).to(inp.dtype)
        h = inp.reshape(b * t, -1)
        for i, layer in enumerate(self.layers):
            h = layer(self.dropout(h), coef)
            if i + 1 < len(self.layers):
                h = F.elu(h)
        return h.reshape(b, t, -1), state
