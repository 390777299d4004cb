"""Train the 4D motion CVAE in two phases (multi-frame 4D motion paper §3.3, §4.2).

- **Phase 1** (``L_init``): tasks pose, translation and time, each the mean squared error of its
  part of the normalised chi (Theta, Gamma, Phi); Adam 1e-3, batch 256.
- **Phase 2** (``L``): tasks spatial -- the squared L2 distance between the meshes of chi_hat and
  chi (metres; per vertex, averaged over frames and vertices; both meshed on the true beta by
  :class:`mocapviz.bodies.torch_mesh.ChiMesher`, optionally on a fixed vertex subset) -- and
  time; Adam 1e-4, batch 16; starts from a phase-1 model.

In both, the task weights are GradNorm's (:mod:`.gradnorm`; re-initialised at phase 2 since
the tasks change) and the KL term (:func:`mocapviz.models.cvae4d.kl_divergence`) has the fixed
weight ``kl_weight`` (0.01). Each epoch's log row holds the mean task losses, weights (``w_``),
weighted gradient norms (``G_``) and rates (``r_``) over its steps and ``w_ratio_max``, the largest
ratio of two weights at any of its steps. Training uses the cycles whose ``split`` is ``"train"`` (mirrored
copies included), drawn so that every body is equally likely (``balance_bodies``); every
``eval_every`` epochs the same losses (z = mu) are logged on the validation cycles (``split``
"val"; :func:`validation_indices`), and the weights of the best validation evaluation are the
model (``keep_best``). The test cycles are never seen in training.

Why not :mod:`.trainer`: that loop draws CCNet windows, owns a feature normaliser, and minimises
one total loss; here a step is per whole cycle, the loss is a set of GradNorm-weighted tasks that
change between phases, and phase 2 needs the body model. Runs are short (minutes), so a run is
not resumable; it is reproducible (seeded shuffles and noise).

Checkpoints are safetensors (format ``mocapviz.cvae4d.v1``): the model's state dict plus the
model config, training config and the dataset's chi layout and scales in the metadata, so the
file alone decodes chi into meshes. :func:`load_cvae` reads them; :mod:`mocapviz.zoo` finds them.
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from safetensors import safe_open
from safetensors.torch import save_file
from tqdm.auto import tqdm

from mocapviz.atomic import atomic_path
from mocapviz.models.cvae4d import CVAE4DConfig, kl_divergence
from mocapviz.models.protocol import build_model, model_class
from mocapviz.training.checkpoint import decode_metadata
from mocapviz.training.gradnorm import DEFAULT_ALPHA, DEFAULT_LR, GradNorm

FORMAT = "mocapviz.cvae4d.v1"
TASKS = {1: ("pose", "trans", "time"), 2: ("spatial", "time")}


@dataclass(frozen=True)
class CVAETrainConfig:
    phase: int = 1
    epochs: int = 2000
    batch_size: int = 256
    lr: float = 1e-3
    lr_end: float = 1.0                     # the learning rate at the end, as a fraction of lr (cosine decay; 1: constant)
    kl_weight: float = 0.01
    latent: int = 64
    hidden: tuple[int, ...] = CVAE4DConfig.hidden  # (256, 256): see there
    alpha: float = DEFAULT_ALPHA            # GradNorm asymmetry
    gradnorm_lr: float = DEFAULT_LR
    gradnorm_step: str = "log"              # GradNorm's Adam step on the log-weights, or "additive" (Chen et al.)
    vertex_subset: int = 0                  # phase 2: 0 = every vertex, else a fixed subset of that size
    eval_every: int = 50                    # epochs between validation evaluations
    seed: int = 0
    threads: int = 1
    balance_bodies: bool = True             # draw each epoch's cycles with every body equally likely
    balance_types: float = 0.0              # and each cycle's draws times (its body's cycles of its type)^-this
    minutes: float = 0.0                    # wall-clock budget (0: none); stops after the epoch that passes it
    keep_best: bool = True                  # return the weights of the best validation evaluation

    def __post_init__(self):
        if self.phase not in TASKS:
            raise ValueError(f"phase must be 1 or 2, got {self.phase}")
        if self.gradnorm_step not in ("log", "additive"):
            raise ValueError(f"gradnorm_step must be 'log' or 'additive', got {self.gradnorm_step!r}")
        if not 0 < self.lr_end <= 1:
            raise ValueError(f"lr_end is a fraction of lr in (0, 1], got {self.lr_end}")
        object.__setattr__(self, "hidden", tuple(int(h) for h in self.hidden))

    def to_json(self) -> str:
        return json.dumps(asdict(self), sort_keys=True)

    @classmethod
    def from_json(cls, s: str) -> CVAETrainConfig:
        return cls(**json.loads(s))


# The paper trains 5000 epochs (phase 1) and 200 (phase 2) on 13 121 cycles with a GPU. Ours
# train on the full body4d dataset (3,482 training cycles on 15 bodies) on one CPU thread within
# a wall-clock budget (``minutes``), keeping the best validation evaluation: a phase-1 epoch
# (14 steps of 256) costs ~4 s at widths (256, 256), a phase-2 epoch (218 steps of 16 on a
# 1024-vertex subset) ~45 s. The subset keeps phase 2 cheap; evaluation always uses every vertex.
# "paper_*": the paper's epochs, for a GPU.
CVAE_CONFIGS = {
    "phase1": CVAETrainConfig(phase=1, epochs=5000, batch_size=256, lr=1e-3, eval_every=25, minutes=40),
    "phase2": CVAETrainConfig(phase=2, epochs=200, batch_size=16, lr=1e-4, vertex_subset=1024, eval_every=2,
                              minutes=25),
    "paper_phase1": CVAETrainConfig(phase=1, epochs=5000, batch_size=256, lr=1e-3, eval_every=250),
    "paper_phase2": CVAETrainConfig(phase=2, epochs=200, batch_size=16, lr=1e-4, eval_every=10),
}


# ---------------------------------------------------------------------------------- data
def split_indices(ds) -> tuple[np.ndarray, np.ndarray]:
    """(training cycles: split "train", mirrored included; held-out: split "test", no mirrored copies)."""
    split = ds.cycles["split"].to_numpy()
    return np.flatnonzero(split == "train"), np.flatnonzero((split == "test") & ~_mirrored(ds))


def validation_indices(ds) -> np.ndarray:
    """Validation cycles (split "val", no mirrored copies): what every training choice is made on.
    A dataset without them (older builds) validates on its held-out cycles."""
    idx = np.flatnonzero((ds.cycles["split"].to_numpy() == "val") & ~_mirrored(ds))
    return idx if len(idx) else split_indices(ds)[1]


def _mirrored(ds) -> np.ndarray:
    return ds.cycles["mirrored"].to_numpy().astype(bool) if "mirrored" in ds.cycles else np.zeros(len(ds), bool)


def body_weights(ds, idx: np.ndarray, type_power: float = 0.0) -> np.ndarray:
    """Sampling probabilities of cycles ``idx`` that give every body (``body`` column, else
    ``subject``) the same share of the draws; with ``type_power`` p > 0, within a body a cycle
    of a type the body has n cycles of is drawn n^-p times as often (p = 1: every type of a body
    alike). Why: by body alone, walk-back is 1 % of the draws and its translation the seeds'
    largest difference (docs/method.md)."""
    col = "body" if "body" in ds.cycles else "subject"
    bodies = ds.cycles[col].to_numpy()[idx]
    w = np.ones(len(idx))
    if type_power:
        kinds = ds.cycles["motion_type"].astype(str).to_numpy()[idx]
        _, inverse, counts = np.unique(np.char.add(bodies.astype(str), "|" + kinds), return_inverse=True,
                                       return_counts=True)
        w = counts[inverse] ** -float(type_power)
    _, inverse = np.unique(bodies, return_inverse=True)
    w = w / np.bincount(inverse, weights=w)[inverse]  # every body's draws sum to the same
    return w / w.sum()


def dataset_meta(ds) -> dict:
    """What a checkpoint needs to turn its chi back into meshes (and which data it saw)."""
    m = ds.meta
    return dict(hash=m.get("hash"), fingerprint=data_fingerprint(ds), gamma_scale=[float(g) for g in ds.gamma_scale], phi_scale=m.get("phi_scale"),
                chi_joints=m.get("chi_joints"), beta_labels=m.get("beta_labels"), n_frames=int(ds.chi.shape[1]),
                n_train=len(split_indices(ds)[0]))


def data_fingerprint(ds) -> str:
    """A hash of the numbers a model sees (chi, beta, split): equal for equal data, whatever the
    cache file's name (which also changes with the code of mocapviz.bodies)."""
    h = hashlib.sha256(np.ascontiguousarray(ds.chi).tobytes())
    h.update(np.ascontiguousarray(ds.beta).tobytes())
    h.update("|".join(map(str, ds.cycles["split"])).encode())
    return h.hexdigest()[:16]


def make_mesher(body, gamma_scale, n_subset: int = 0):
    """The chi -> mesh path on every vertex (``n_subset`` 0) or on the body's fixed subset."""
    from mocapviz.bodies.anny_model import NEUTRAL_BETA, farthest_point_sampling
    from mocapviz.bodies.torch_mesh import ChiMesher

    subset = None
    if n_subset:  # as BodyModel.vertex_subset, for any size
        subset = farthest_point_sampling(body.rest_model(NEUTRAL_BETA)["vertices"][0].numpy(), n_subset)
    return ChiMesher(body, gamma_scale, vertices=subset)


# ---------------------------------------------------------------------------------- losses
def _squared_l2(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Squared L2 distance per cycle (summed over all but the batch axis), averaged over the batch."""
    return F.mse_loss(a, b) * (a[0].numel())


def task_losses(phase: int, chi_hat: torch.Tensor, chi: torch.Tensor, beta: torch.Tensor, mesher=None) -> list:
    """The phase's task losses (order of ``TASKS[phase]``) for chi_hat vs chi (B, N, C): squared
    L2 distances per cycle, as the paper writes them (sums, not means: the fixed KL weight 0.01
    is relative to this scale). Phase 2's spatial loss on a vertex subset is scaled by anny's
    vertex count / the subset's, an estimate of the whole mesh's sum."""
    n_theta = chi.shape[-1] - 4
    time_loss = _squared_l2(chi_hat[..., -1], chi[..., -1])
    if phase == 1:
        return [_squared_l2(chi_hat[..., :n_theta], chi[..., :n_theta]),
                _squared_l2(chi_hat[..., n_theta:n_theta + 3], chi[..., n_theta:n_theta + 3]), time_loss]
    with torch.no_grad():
        truth = mesher(chi, beta, vertex_major=True)
    pred = mesher(chi_hat, beta, vertex_major=True)
    scale = mesher.body.n_vertices / mesher.n_vertices
    return [scale * _squared_l2(pred, truth), time_loss]


@torch.no_grad()
def evaluate(model, ds, idx: np.ndarray, phase: int, kl_weight: float, mesher=None, batch: int = 16) -> dict:
    """Mean task losses and KL (z = mu) over cycles ``idx``."""
    was = model.training
    model.eval()
    sums, n = {}, 0
    for i in range(0, len(idx), batch):
        b = idx[i:i + batch]
        chi, beta = torch.as_tensor(ds.chi[b]), torch.as_tensor(ds.beta[b])
        out = model(chi, beta)
        parts = dict(zip(TASKS[phase], task_losses(phase, out["chi"], chi, beta, mesher)))
        parts["kl"] = kl_divergence(out["mu"], out["logvar"])
        for k, v in parts.items():
            sums[k] = sums.get(k, 0.0) + float(v) * len(b)
        n += len(b)
    model.train(was)
    return {k: v / max(n, 1) for k, v in sums.items()}


# ---------------------------------------------------------------------------------- training
def train(ds, cfg: CVAETrainConfig, init=None, body=None, progress: bool = True) -> tuple:
    """Train on ``ds`` (a :class:`mocapviz.datasets.body4d.Body4DDataset`); phase 2 starts from
    ``init`` (a phase-1 model). Returns (model, log rows: one per epoch)."""
    torch.set_num_threads(cfg.threads)
    train_idx, _ = split_indices(ds)
    val_idx = validation_indices(ds)
    if len(train_idx) == 0:
        raise ValueError("the dataset has no training cycles (split == 'train')")
    torch.manual_seed(cfg.seed)
    layout = (ds.chi.shape[1], ds.chi.shape[2], ds.beta.shape[1])
    if init is None:
        if cfg.phase == 2:
            raise ValueError("phase 2 starts from a phase-1 model: pass init")
        model = model_class("cvae4d")(model_class("cvae4d").config_for(cfg, layout))
    else:
        model = build_model("cvae4d", init.cfg.to_json())
        model.load_state_dict(init.state_dict())
    mesher = None
    if cfg.phase == 2:
        from mocapviz.bodies.anny_model import body_model
        mesher = make_mesher(body or body_model(), ds.gamma_scale, cfg.vertex_subset)
    model.train()
    opt = torch.optim.Adam(model.parameters(), lr=cfg.lr)
    gradnorm = GradNorm(TASKS[cfg.phase], alpha=cfg.alpha, lr=cfg.gradnorm_lr, keep_history=False,
                        additive=cfg.gradnorm_step == "additive")
    weights = body_weights(ds, train_idx, cfg.balance_types) if cfg.balance_bodies else None
    best = _Best()
    rows, t0 = [], time.perf_counter()
    for epoch in tqdm(range(1, cfg.epochs + 1), desc=f"cvae4d phase {cfg.phase}", disable=not progress):
        for group in opt.param_groups:
            group["lr"] = learning_rate(cfg, epoch, time.perf_counter() - t0)
        rng = np.random.default_rng([cfg.seed, epoch])
        order = rng.permutation(train_idx) if weights is None else rng.choice(train_idx, len(train_idx), p=weights)
        sums, n, w_ratio = {}, 0, 1.0
        for i in range(0, len(order), cfg.batch_size):
            b = order[i:i + cfg.batch_size]
            chi, beta = torch.as_tensor(ds.chi[b]), torch.as_tensor(ds.beta[b])
            out = model(chi, beta)
            losses = task_losses(cfg.phase, out["chi"], chi, beta, mesher)
            kl = kl_divergence(out["mu"], out["logvar"])
            opt.zero_grad(set_to_none=True)
            info = gradnorm.step(losses, out["chi"], model.shared_layer, extra=cfg.kl_weight * kl)
            opt.step()
            values = {**dict(zip(TASKS[cfg.phase], (float(v.detach()) for v in losses))), "kl": float(kl.detach()),
                      **info}
            for k, v in values.items():
                sums[k] = sums.get(k, 0.0) + v * len(b)
            n += len(b)
            w = [info[f"w_{t}"] for t in TASKS[cfg.phase]]
            w_ratio = max(w_ratio, max(w) / min(w))
        seconds = time.perf_counter() - t0
        last = epoch == cfg.epochs or (cfg.minutes and seconds > 60 * cfg.minutes)
        row = dict(epoch=epoch, **{k: round(v / n, 6) for k, v in sums.items()}, w_ratio_max=round(w_ratio, 4),
                   lr=float(f"{opt.param_groups[0]['lr']:.4g}"), seconds=round(seconds, 2))
        if len(val_idx) and (epoch % cfg.eval_every == 0 or last):
            val = evaluate(model, ds, val_idx, cfg.phase, cfg.kl_weight, mesher)
            row.update({f"val_{k}": round(v, 6) for k, v in val.items()})
            row["val_score"] = round(best.offer(model, epoch, [val[t] for t in TASKS[cfg.phase]]), 6)
        rows.append(row)
        if last:
            break
    if cfg.keep_best and best.state is not None:
        model.load_state_dict(best.state)
        rows[-1]["kept_epoch"] = best.epoch
    model.eval()
    return model, rows


def learning_rate(cfg: CVAETrainConfig, epoch: int, seconds: float) -> float:
    """The learning rate of ``epoch`` (1-based): a cosine from ``lr`` at the first epoch to
    ``lr * lr_end`` at the last, the run's progress being whichever of its epochs and its
    wall-clock budget (``minutes``) is further along."""
    progress = (epoch - 1) / max(cfg.epochs - 1, 1)
    if cfg.minutes:
        progress = max(progress, seconds / (60 * cfg.minutes))
    cosine = 0.5 * (1 + math.cos(math.pi * min(progress, 1.0)))
    return cfg.lr * (cfg.lr_end + (1 - cfg.lr_end) * cosine)


class _Best:
    """The weights at the lowest validation score: the sum of the task losses, each relative to
    its value at the first evaluation (tasks on different scales count alike)."""

    def __init__(self):
        self.first, self.score, self.state, self.epoch = None, float("inf"), None, 0

    def offer(self, model, epoch: int, losses: list[float]) -> float:
        self.first = self.first or [max(v, 1e-12) for v in losses]
        score = sum(v / f for v, f in zip(losses, self.first))
        if score < self.score:
            self.score, self.epoch = score, epoch
            self.state = {k: v.detach().clone() for k, v in model.state_dict().items()}
        return score


# ---------------------------------------------------------------------------------- files
def save_cvae(path, model, meta: dict, half: bool = False) -> Path:
    """The model (float16 tensors with ``half``: half the file, ~1e-3 relative weight error) and
    its metadata (model and training configs, dataset layout) as one safetensors file."""
    path = Path(path)
    dtype = torch.float16 if half else torch.float32
    tensors = {f"model.{k}": v.detach().to(dtype).contiguous().clone() for k, v in model.state_dict().items()}
    metadata = {"format": FORMAT, "model": model.name, "model_config": model.cfg.to_json()}
    metadata.update({k: v if isinstance(v, str) else json.dumps(v) for k, v in meta.items() if k not in metadata})
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        save_file(tensors, tmp, metadata=metadata)
    return path


def load_cvae(path) -> tuple:
    """(model in float32 eval mode, metadata with JSON values decoded) of a CVAE checkpoint."""
    with safe_open(str(path), framework="pt") as f:
        meta = f.metadata() or {}
        tensors = {k[6:]: f.get_tensor(k).float() for k in f.keys() if k.startswith("model.")}
    if meta.get("format") != FORMAT:
        raise ValueError(f"{path}: not a 4D CVAE checkpoint (format {meta.get('format')!r})")
    model = build_model(meta["model"], meta["model_config"])
    model.load_state_dict(tensors)
    model.eval()
    return model, decode_metadata(meta)


def write_log(path, rows: list[dict]) -> Path:
    """The per-epoch log as CSV (held-out columns empty between evaluations)."""
    fields = list(dict.fromkeys(k for r in rows for k in r))
    with atomic_path(Path(path)) as tmp, open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fields, restval="")
        w.writeheader()
        w.writerows(rows)
    return Path(path)


def with_overrides(cfg: CVAETrainConfig, **kw) -> CVAETrainConfig:
    """``cfg`` with the given fields replaced (None values ignored)."""
    return replace(cfg, **{k: v for k, v in kw.items() if v is not None})
