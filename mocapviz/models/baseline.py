"""What the CCNet baselines (ERD-4LR, DAE-LSTM, PFNN; paper §4.1.2) share: their frame I/O.

Every baseline reads, per frame t, the same inputs as CCNet concatenated at its **first layer**
(the paper "added parameters to their first layers to accept skeleton configurations"):
x_t (n_x), c^s (n_skel), c^d_{t+1} (n_traj) and c^t (n_types); and writes CCNet's decoder
output layout (Gaussian mean and s of x_{t+1}, contact logits, c^d_{t+2} mean and s), so they
train with CCNet's loss, run in :class:`mocapviz.tasks.generate.Generator` and denoise through
the same code. A model implements ``run(inp (B, T, n_in), state) -> (raw (B, T, n_out), state)``;
``state`` is what it carries from frame to frame (LSTM states, the phase tracker), None at the
start. ``forward`` and the stepper are both ``run``: one on the whole window, one frame per call.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, replace

import numpy as np
import torch
from torch import nn

from mocapviz.models.ccnet import CCNet
from mocapviz.models.ccnet_config import CCNetConfig


@dataclass(frozen=True)
class BaselineConfig:
    n_x: int = 306
    n_contact: int = 2
    n_skel: int = 73
    n_traj: int = 12
    n_types: int = 21
    sigma_min: float = 1e-4
    residual: bool = False    # the generator asks; no baseline predicts the change
    latent = 0                # nor has a latent z (the generator and trainer ask, as of CCNet)
    phase = False             # nor a phase in c^d (CCNetConfig.phase)

    # the same output layout as CCNet (one home: CCNetConfig)
    n_continuous = CCNetConfig.n_continuous
    output_slices = CCNetConfig.output_slices
    n_out = CCNetConfig.n_out
    add_residual = CCNetConfig.add_residual

    @property
    def residual_slices(self) -> list[slice]:
        """None: every baseline predicts the frame itself (the generator asks, as of CCNet)."""
        return []

    @property
    def n_in(self) -> int:
        """First-layer width: x_t, c^s, c^d_{t+1}, c^t."""
        return self.n_x + self.n_skel + self.n_traj + self.n_types

    def to_json(self) -> str:
        return json.dumps(asdict(self), sort_keys=True)

    @classmethod
    def from_json(cls, s: str):
        return cls(**json.loads(s))


class BaselineModel(nn.Module):
    """Base of the baselines: inputs at the first layer, CCNet's output head, a stepper."""

    config_class = BaselineConfig
    input_names = ("x", "skel", "traj", "types")
    SIZES: dict[str, dict] = {}   # named sizes (the training config's ``size``)

    split_output = CCNet.split_output   # raw (..., n_out) -> named parts, as CCNet's decoder

    @classmethod
    def config_for(cls, train_cfg, layout):
        if train_cfg.size not in cls.SIZES:
            raise KeyError(f"unknown {cls.name} size {train_cfg.size!r}; choose from {sorted(cls.SIZES)}")
        if train_cfg.phase:
            raise ValueError(f"{cls.name} takes no phase input (TrainConfig.phase is CCNet's)")
        base = cls.config_class(n_x=layout.n_x, n_skel=layout.n_skel, n_traj=layout.n_traj, n_types=layout.n_types)
        return replace(base, **cls.SIZES[train_cfg.size])

    @staticmethod
    def inputs(x, skel, traj, types) -> torch.Tensor:
        """(B, T, n_in): x (B, T, n_x), traj (B, T, n_traj); skel, types (B, D) or (B, T, D)."""
        b, t = x.shape[:2]
        per_frame = [c if c.dim() == 3 else c[:, None].expand(b, t, -1) for c in (skel, types)]
        return torch.cat([x, per_frame[0], traj, per_frame[1]], -1)

    def run(self, inp: torch.Tensor, state=None):
        raise NotImplementedError

    def forward(self, x, skel, traj, types) -> dict[str, torch.Tensor]:
        """Named (B, T, .) outputs for a whole window, as ``CCNet.forward``."""
        return self.split_output(self.run(self.inputs(x, skel, traj, types))[0])

    def stepper(self, batch: int = 1, backend: str = "torch"):
        """One frame per call; "numpy" takes and returns numpy arrays (the generator's default)."""
        if backend not in ("torch", "numpy"):
            raise ValueError(f"unknown backend {backend!r}; choose from ['numpy', 'torch']")
        return RecurrentStepper(self, batch, numpy_io=backend == "numpy")


class RecurrentStepper:
    """:class:`mocapviz.models.protocol.Stepper` over a baseline's ``run`` with T = 1."""

    def __init__(self, model: BaselineModel, batch: int = 1, numpy_io: bool = False):
        self.model, self.batch, self.numpy_io = model.eval(), batch, numpy_io
        self.reset()

    def reset(self):
        self.state = None
        self.t = 0

    def set_static(self, skel, types):
        self._static = (torch.as_tensor(np.asarray(skel, np.float32)) if self.numpy_io else skel,
                        torch.as_tensor(np.asarray(types, np.float32)) if self.numpy_io else types)

    @torch.no_grad()
    def step(self, x, traj):
        """x (B, n_x) frame t, traj (B, n_traj) c^d_{t+1} -> raw output (B, n_out) for frame t+1."""
        if self.numpy_io:
            x, traj = torch.from_numpy(np.asarray(x, np.float32)), torch.from_numpy(np.asarray(traj, np.float32))
        skel, types = self._static
        inp = self.model.inputs(x[:, None], skel, traj[:, None], types)
        raw, self.state = self.model.run(inp, self.state)
        self.t += 1
        return raw[:, 0].numpy() if self.numpy_io else raw[:, 0]
