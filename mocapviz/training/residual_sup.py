"""Train the Residual-sup baseline (:mod:`mocapviz.models.residual_sup`) on the 4D dataset's
training cycles, as the 4D motion paper's §5 prepares it: every training cycle resampled to a
fixed 100 fps (its frames read at k / 100 s by their real timestamps,
:func:`mocapviz.features.chi_time.interpolate_chi`), the first ``observed_s`` = 0.25 s given,
the rest of the cycle predicted.

Loss: mean squared error over the predicted frames of each cycle (Theta and Gamma of chi, frames
past a cycle's end masked), with the decoder fed its own outputs (Martinez' sampling-based
loss). Adam (Martinez used SGD at 0.005 for 10^5 steps; Adam converges in the few thousand
steps a shared CPU core affords), gradients clipped at norm 5 as Martinez'. The training cycles
start where the prediction starts, at a gait cycle's first frame, with the root at the origin
facing +Z (the dataset's canonical frame). The last step is the model (no selection).

Checkpoints: safetensors with the model and training configs and the dataset's layout in the
metadata (:func:`save_residual_sup`, :func:`load_residual_sup`).
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass

import numpy as np
import torch
from safetensors import safe_open
from safetensors.torch import save_file
from tqdm.auto import tqdm

from mocapviz.atomic import atomic_path
from mocapviz.features.chi_time import chi_times, interpolate_chi, time_grid
from mocapviz.models.residual_sup import ResidualSup, ResidualSupConfig
from mocapviz.training.checkpoint import decode_metadata

FORMAT = "mocapviz.residual_sup.v1"


@dataclass(frozen=True)
class ResidualSupTrainConfig:
    hidden: int = 128
    steps: int = 1500
    batch_size: int = 32
    lr: float = 1e-3
    grad_clip: float = 5.0
    fps: float = 100.0
    observed_s: float = 0.25
    eval_every: int = 250
    seed: int = 0
    threads: int = 1

    def to_json(self) -> str:
        return json.dumps(asdict(self), sort_keys=True)


def n_observed(fps: float, observed_s: float) -> int:
    """Frames of the first ``observed_s`` seconds at ``fps`` (times k / fps < observed_s)."""
    return int(np.ceil(observed_s * fps - 1e-9))


def grid_frames(chi: torch.Tensor, fps: float) -> tuple[torch.Tensor, torch.Tensor]:
    """Cycles chi (B, N, C) at a fixed frame rate: frames (B, K, C - 1) (Theta and Gamma read
    at k / fps by the real timestamps; Phi dropped) and mask (B, K), True up to each cycle's end."""
    chi = torch.as_tensor(chi, dtype=torch.float32)
    times, mask = time_grid(chi_times(chi)[:, -1], fps)
    return interpolate_chi(chi, times)[..., :-1], mask


def masked_mse(pred: torch.Tensor, target: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Mean squared error over the frames where ``mask`` (B, T) is True."""
    sq = (pred - target).pow(2).mean(-1)
    return (sq * mask).sum() / mask.sum().clamp_min(1)


# The held-out source (HDM05) has types no training cycle has; Residual-sup's one-hot then names the
# nearest training type (a jog is a slow run, a sneak a slow walk). Only held-out cycles need it.
LABEL_FALLBACK = {"jog": "run", "sneak": "walk"}


def labels_for(model: ResidualSup, types) -> torch.Tensor:
    """The one-hot labels (B, n_types) of motion types, unseen ones by :data:`LABEL_FALLBACK`."""
    known = set(model.cfg.types)
    return model.one_hot([t if t in known else LABEL_FALLBACK.get(t, t) for t in types])


def rollout_loss(model: ResidualSup, chi: torch.Tensor, types, cfg: ResidualSupTrainConfig) -> torch.Tensor:
    frames, mask = grid_frames(chi, cfg.fps)
    k = n_observed(cfg.fps, cfg.observed_s)
    pred = model(frames[:, :k], labels_for(model, types), frames.shape[1] - k)
    return masked_mse(pred, frames[:, k:], mask[:, k:])


def train(ds, cfg: ResidualSupTrainConfig, train_idx: np.ndarray, held_idx: np.ndarray | None = None,
          progress: bool = True) -> tuple[ResidualSup, list[dict]]:
    """The model after ``cfg.steps`` steps on the cycles ``train_idx`` of a body4d dataset, and
    its log (loss per step; held-out loss on ``held_idx`` every ``eval_every`` steps)."""
    torch.manual_seed(cfg.seed)
    torch.set_num_threads(cfg.threads)
    rng = np.random.default_rng(cfg.seed)
    types = ds.cycles["type"].to_numpy()
    mcfg = ResidualSupConfig(n_state=ds.chi.shape[-1] - 1, types=tuple(sorted(set(types[train_idx]))),
                             hidden=cfg.hidden, fps=cfg.fps)
    model = ResidualSup(mcfg)
    opt = torch.optim.Adam(model.parameters(), lr=cfg.lr)
    rows, t0 = [], time.perf_counter()
    for step in tqdm(range(1, cfg.steps + 1), desc="residual-sup", disable=not progress):
        b = rng.choice(train_idx, size=min(cfg.batch_size, len(train_idx)), replace=False)
        loss = rollout_loss(model, torch.as_tensor(ds.chi[b]), types[b], cfg)
        opt.zero_grad()
        loss.backward()
        torch.nn.utils.clip_grad_norm_(model.parameters(), cfg.grad_clip)
        opt.step()
        row = dict(step=step, loss=float(loss.detach()), seconds=round(time.perf_counter() - t0, 2))
        if held_idx is not None and len(held_idx) and (step % cfg.eval_every == 0 or step == cfg.steps):
            row["held_loss"] = evaluate(model, ds, held_idx, cfg)
        rows.append(row)
    model.eval()
    return model, rows


@torch.no_grad()
def evaluate(model, ds, idx: np.ndarray, cfg: ResidualSupTrainConfig, batch: int = 128) -> float:
    """The rollout loss over cycles ``idx`` (frame-weighted mean over batches)."""
    types = ds.cycles["type"].to_numpy()
    total, n = 0.0, 0
    for i in range(0, len(idx), batch):
        b = idx[i:i + batch]
        total += float(rollout_loss(model, torch.as_tensor(ds.chi[b]), types[b], cfg)) * len(b)
        n += len(b)
    return total / max(n, 1)


def save_residual_sup(path, model: ResidualSup, meta: dict) -> None:
    """Weights (float32) and metadata: model config, and whatever ``meta`` holds (JSON)."""
    tensors = {f"model.{k}": v.detach().contiguous().clone() for k, v in model.state_dict().items()}
    metadata = {"format": FORMAT, "model_config": model.cfg.to_json()}
    metadata.update({k: v if isinstance(v, str) else json.dumps(v) for k, v in meta.items()})
    with atomic_path(path) as tmp:
        save_file(tensors, tmp, metadata=metadata)


def load_residual_sup(path) -> tuple[ResidualSup, dict]:
    """(model in eval mode, decoded metadata) of a Residual-sup checkpoint."""
    with safe_open(str(path), framework="pt") as f:
        meta = f.metadata() or {}
        tensors = {k[6:]: f.get_tensor(k) for k in f.keys() if k.startswith("model.")}
    if meta.get("format") != FORMAT:
        raise ValueError(f"{path}: not a Residual-sup checkpoint (format {meta.get('format')!r})")
    model = ResidualSup(ResidualSupConfig.from_json(meta["model_config"]))
    model.load_state_dict(tensors)
    model.eval()
    return model, decode_metadata(meta)
