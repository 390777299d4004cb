"""Residual-sup (Martinez, Black, Romero, *On human motion prediction using recurrent neural
networks*, CVPR 2017): the baseline of the 4D motion paper's prediction (§5, Fig. 7).

A sequence-to-sequence GRU with the three choices of that paper:

- **one GRU cell** reads the observed frames (encoder) and then runs on (decoder), its weights
  tied between the two (Martinez' "tied" architecture);
- **residual connection** on the output: frame_{t+1} = frame_t + W h_t (the network predicts
  the change; ``out`` starts at zero, so an untrained model is the zero-velocity baseline);
- **sampling-based loss**: during training, too, the decoder is fed its own predictions, never
  the true frames, so it learns to recover from its own errors;
- "sup": the motion type enters as a one-hot beside the frame at every step (Martinez'
  supervised, multi-action variant).

Our frame (the paper: "we replace the skeleton used by this method by the SMPL skeleton"): the
body's joint rotations and root translation as in chi, Theta (6-D rotations of the kept anny
joints minus the identity) and Gamma (root translation from the cycle start / gamma_scale), at a
fixed frame rate (100 fps, as the paper resamples); no Phi: time is the frame index. Martinez
used 1024 GRU units on exp-maps of Human3.6M; ours are :attr:`ResidualSupConfig.hidden` (CPU).
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass

import torch
from torch import nn


@dataclass(frozen=True)
class ResidualSupConfig:
    n_state: int = 129           # numbers per frame: 6 x kept joints (Theta) + 3 (Gamma)
    types: tuple[str, ...] = ()  # motion types, in one-hot order
    hidden: int = 128            # GRU units (Martinez: 1024)
    fps: float = 100.0

    def __post_init__(self):
        object.__setattr__(self, "types", tuple(self.types))

    def to_json(self) -> str:
        return json.dumps(asdict(self), sort_keys=True)

    @classmethod
    def from_json(cls, s: str) -> ResidualSupConfig:
        return cls(**json.loads(s))


class ResidualSup(nn.Module):
    def __init__(self, cfg: ResidualSupConfig):
        super().__init__()
        self.cfg = cfg
        self.cell = nn.GRUCell(cfg.n_state + len(cfg.types), cfg.hidden)
        self.out = nn.Linear(cfg.hidden, cfg.n_state)
        nn.init.zeros_(self.out.weight)  # start as zero velocity: the residual adds nothing
        nn.init.zeros_(self.out.bias)

    def one_hot(self, types) -> torch.Tensor:
        """(B, n_types) one-hot of motion type names; ValueError for a type the model never saw."""
        unknown = sorted(set(types) - set(self.cfg.types))
        if unknown:
            raise ValueError(f"motion types {unknown} are not among the model's {list(self.cfg.types)}")
        idx = torch.tensor([self.cfg.types.index(t) for t in types])
        return nn.functional.one_hot(idx, len(self.cfg.types)).float()

    def forward(self, observed: torch.Tensor, labels: torch.Tensor, n_future: int) -> torch.Tensor:
        """observed frames (B, T, n_state), labels (B, n_types) one-hot -> the next ``n_future``
        frames (B, n_future, n_state), each decoder step fed the previous prediction."""
        h = observed.new_zeros(observed.shape[0], self.cfg.hidden)
        for t in range(observed.shape[1] - 1):  # the encoder: every observed frame but the last
            h = self.cell(torch.cat([observed[:, t], labels], -1), h)
        frame, out = observed[:, -1], []
        for _ in range(n_future):  # the decoder starts from the last observed frame
            h = self.cell(torch.cat([frame, labels], -1), h)
            frame = frame + self.out(h)
            out.append(frame)
        return torch.stack(out, 1) if out else observed[:, :0]
