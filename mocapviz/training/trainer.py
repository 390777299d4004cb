"""Train CCNet (paper §4.2): RMSprop, lr 1e-4 decaying to 1e-6, input noise, whole windows.

Every step draws ``batch_size`` windows of ``window`` frames at random (clip, then start), adds
i.i.d. N(0, 0.03^2) noise to the normalised inputs, and trains on every frame of the window at
once (the network is causal, so output t sees inputs <= t only). The learning rate decays
exponentially from ``lr`` to ``lr_final`` over ``steps``.

Reproducible and resumable: the random draws of step k (windows, noise, dropout) come from
generators seeded with (seed, rank, k), so a run resumed from a checkpoint continues exactly the
loss curve of an uninterrupted run. Checkpoints (safetensors, written atomically) hold model,
optimizer, normaliser and configs; a CSV logs the losses.

Model selection uses the validation split only: every ``eval_every`` steps the validation and
test losses are computed (the test columns are for reporting), and the model with the lowest
validation NLL so far is kept as ``best.safetensors`` (model only; its metadata records the step
and its validation and test NLL). On resume the best-so-far value comes back from the CSV. Under ``torchrun`` (WORLD_SIZE > 1)
the model is wrapped in DistributedDataParallel (gloo), each rank draws its own windows, and only
rank 0 writes files.
"""

from __future__ import annotations

import csv
import json
import math
import os
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
import torch
import torch.distributed as dist
from tqdm.auto import tqdm

from mocapviz.atomic import atomic_path
from mocapviz.features.ccnet import FeatureLayout
from mocapviz.models.ccnet import CCNet, CCNetConfig, make_config
from mocapviz.training.checkpoint import load_checkpoint, save_checkpoint
from mocapviz.training.losses import LAMBDAS, ccnet_loss

CSV_FIELDS = ["step", "epoch", "lr", "loss", "nll", "smooth", "contact", "direction", "val_nll", "val_loss",
              "test_nll", "test_loss", "seconds"]


@dataclass(frozen=True)
class TrainConfig:
    size: str = "default"           # model size name (mocapviz.models.ccnet.SIZES)
    steps: int = 4000
    batch_size: int = 32            # windows per step (split across ranks under DDP)
    window: int = 60                # NCF (must not exceed the dataset's window)
    lr: float = 1e-4
    lr_final: float = 1e-6
    noise_std: float = 0.03
    lambdas: tuple[float, float, float] = LAMBDAS
    dilations: tuple[int, ...] = (2,) * 20
    dropout: float = 0.5
    seed: int = 0
    eval_every: int = 250
    checkpoint_every: int = 250
    threads: int = 1               # 1 is fastest on a shared 2-core machine; raise on your own

    def model_config(self, layout: FeatureLayout) -> CCNetConfig:
        return make_config(self.size, n_x=layout.n_x, n_skel=layout.n_skel, n_traj=layout.n_traj,
                           n_types=layout.n_types, dilations=self.dilations, dropout=self.dropout)

    def to_json(self) -> str:
        return json.dumps(asdict(self), sort_keys=True)

    @classmethod
    def from_json(cls, s: str | dict) -> "TrainConfig":
        d = json.loads(s) if isinstance(s, str) else dict(s)
        d["lambdas"], d["dilations"] = tuple(d["lambdas"]), tuple(d["dilations"])
        return cls(**d)


# The named training configs. "paper": the paper's sizes and schedule (RMSprop, lr 1e-4 decaying
# to 1e-6, batch 256). "quick" (a few minutes on 2 CPU cores) and "default" (the committed
# checkpoint models/zoo/ccnet_default.safetensors, ~12 min on one shared core) keep the paper's
# 100x exponential decay but start at 1e-3: with 1e-4 the NLL falls ~10x slower per step, and a
# CPU budget of a few thousand steps (vs. the paper's 2000 epochs on a GPU) does not get far.
TRAIN_CONFIGS = {
    "quick": TrainConfig(size="quick", steps=1200, batch_size=16, lr=1e-3, lr_final=1e-5,
                         eval_every=200, checkpoint_every=200),
    "default": TrainConfig(size="default", steps=3000, batch_size=32, lr=1e-3, lr_final=1e-5),
    "paper": TrainConfig(size="paper", steps=200_000, batch_size=256, eval_every=2000,
                         checkpoint_every=2000),
}


class WindowData:
    """Normalised arrays of a CCNet dataset and a sampler of training windows.

    ``ds`` is a :class:`data_prep.ccnet_dataset.CCNetDataset` (anything with the same fields).
    """

    def __init__(self, ds, window: int, normaliser=None):
        norm = normaliser or ds.normaliser
        self.window = window
        self.layout = ds.layout
        self.x = torch.from_numpy(norm.norm_x(ds.x))
        self.traj = torch.from_numpy(norm.norm_traj(ds.traj))
        self.skel = torch.from_numpy(norm.norm_skel(ds.skel))
        types = np.zeros((len(ds.clips), self.layout.n_types), dtype=np.float32)
        types[np.arange(len(ds.clips)), ds.clips.type_index.values] = 1.0
        self.types = torch.from_numpy(types)
        self.clip_start = ds.clips.start.values
        self.train = ds.window_starts("train", window)
        self.test = ds.window_starts("test", window, stride=window)
        # validation (the whole held-out actor mm by default, 43 clips): every window (stride 1),
        # so every frame counts at every context length; ~3400 windows, a few seconds per evaluation
        self.val = ds.window_starts("val", window, stride=1)
        self.n_train_frames = int(sum(r.stop - r.start for r in ds.clips.itertuples() if r.split == "train"))

    def batch(self, pairs: np.ndarray) -> dict[str, torch.Tensor]:
        """Inputs x_t, controls c_{t+1}, targets x_{t+1} and c^d_{t+2} for windows (clip, start)."""
        clip = pairs[:, 0]
        g = self.clip_start[clip] + pairs[:, 1]
        idx = torch.from_numpy(g[:, None] + np.arange(self.window)[None])
        return dict(x=self.x[idx], traj=self.traj[idx + 1], skel=self.skel[clip], types=self.types[clip],
                    target_x=self.x[idx + 1], target_traj=self.traj[idx + 2])


def _dist_info() -> tuple[int, int]:
    world = int(os.environ.get("WORLD_SIZE", "1"))
    if world > 1 and not dist.is_initialized():
        dist.init_process_group("gloo")
    return (dist.get_rank(), world) if world > 1 else (0, 1)


def lr_at(cfg: TrainConfig, step: int) -> float:
    return cfg.lr * (cfg.lr_final / cfg.lr) ** (step / max(1, cfg.steps))


@torch.no_grad()
def evaluate(model: CCNet, data: WindowData, pairs: np.ndarray, lambdas=LAMBDAS, batch: int = 128) -> dict:
    """Mean per-frame losses (no noise, dropout off) over the windows ``pairs``."""
    was = model.training
    model.eval()
    sums, n = {}, 0
    for i in range(0, len(pairs), batch):
        b = data.batch(pairs[i:i + batch])
        out = model(b["x"], skel=b["skel"], traj=b["traj"], types=b["types"])
        parts = ccnet_loss(out, b["target_x"], b["target_traj"], model.cfg.n_cont, lambdas)
        k = len(pairs[i:i + batch])
        for name, v in parts.items():
            sums[name] = sums.get(name, 0.0) + float(v) * k
        n += k
    model.train(was)
    return {k: v / max(n, 1) for k, v in sums.items()}


def _write_csv(path: Path, rows: list[dict]) -> None:
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, CSV_FIELDS)
        w.writeheader()
        w.writerows(rows)


def _read_csv(path: Path, upto: int) -> list[dict]:
    if not path.is_file():
        return []
    with open(path, newline="") as f:
        return [r for r in csv.DictReader(f) if int(r["step"]) <= upto]


def best_row(rows: list[dict]) -> dict | None:
    """The logged row with the lowest validation NLL (the first of ties), or None."""
    ev = [r for r in rows if r.get("val_nll") not in ("", None)]
    return min(ev, key=lambda r: float(r["val_nll"])) if ev else None


def train(ds, cfg: TrainConfig, out_dir, resume: bool = True, progress: bool = True,
          stop_after: int | None = None) -> Path:
    """Train on ``ds`` into ``out_dir`` (``checkpoint.safetensors``, ``best.safetensors``, ``losses.csv``).

    With ``resume`` an existing checkpoint in ``out_dir`` is continued exactly. ``stop_after``
    ends the run early at that step (a checkpoint is written), as if interrupted.
    Returns the checkpoint path.
    """
    rank, world = _dist_info()
    torch.set_num_threads(max(1, cfg.threads // world))
    out_dir = Path(out_dir)
    ckpt, csv_path = out_dir / "checkpoint.safetensors", out_dir / "losses.csv"
    best_path = out_dir / "best.safetensors"
    if cfg.window > ds.config.window:
        raise ValueError(f"window {cfg.window} exceeds the dataset's {ds.config.window}")
    data = WindowData(ds, cfg.window)
    if len(data.train) == 0:
        raise ValueError("the dataset has no training windows")
    if len(data.val) == 0:
        raise ValueError("the dataset has no validation windows (rebuild it: dataset version >= 2)")
    mcfg = cfg.model_config(data.layout)
    torch.manual_seed(cfg.seed)
    model = CCNet(mcfg)
    opt = torch.optim.RMSprop(model.parameters(), lr=cfg.lr)
    start = 0
    rows: list[dict] = []
    if resume and ckpt.is_file():
        _, _, meta = load_checkpoint(ckpt, optimizer=opt, model=model)
        if TrainConfig.from_json(meta["train_config"]) != cfg:
            raise ValueError(f"{ckpt} was trained with another config; use a new out_dir or resume=False")
        start = int(meta["step"])
        rows = _read_csv(csv_path, start)
    best = best_row(rows)
    best_val = float(best["val_nll"]) if best else math.inf
    model.train()
    # static_graph: the last block's residual 1x1 conv feeds nothing (only its skip is used)
    net = torch.nn.parallel.DistributedDataParallel(model, static_graph=True) if world > 1 else model
    per_rank = max(1, cfg.batch_size // world)
    meta = dict(train_config=cfg.to_json(), dataset=json.dumps(_dataset_meta(ds)))
    end = cfg.steps if stop_after is None else min(cfg.steps, stop_after)
    t0 = time.perf_counter() - (float(rows[-1]["seconds"]) if rows else 0.0)
    bar = tqdm(range(start, end), initial=start, total=cfg.steps, desc=f"train ccnet-{cfg.size}",
               disable=not progress or rank != 0)
    for step in bar:
        lr = lr_at(cfg, step)
        for group in opt.param_groups:
            group["lr"] = lr
        rng = np.random.default_rng([cfg.seed, rank, step])
        torch.manual_seed(int(rng.integers(2 ** 62)))
        b = data.batch(data.train[rng.integers(len(data.train), size=per_rank)])
        x = b["x"] + cfg.noise_std * torch.randn_like(b["x"])
        out = net(x, skel=b["skel"], traj=b["traj"], types=b["types"])
        parts = ccnet_loss(out, b["target_x"], b["target_traj"], mcfg.n_cont, cfg.lambdas)
        opt.zero_grad(set_to_none=True)
        parts["loss"].backward()
        opt.step()
        done = step + 1
        row = dict(step=done, epoch=round(done * cfg.batch_size * cfg.window / data.n_train_frames, 3),
                   lr=lr, **{k: round(float(v.detach()), 5) for k, v in parts.items()}, val_nll="", val_loss="",
                   test_nll="", test_loss="",
                   seconds=round(time.perf_counter() - t0, 2))
        # evaluate on the schedule only (not at a stop_after step), so interrupted runs log and
        # select exactly what an uninterrupted run does
        if done % cfg.eval_every == 0 or done == cfg.steps:
            va = evaluate(model, data, data.val, cfg.lambdas)
            ev = evaluate(model, data, data.test, cfg.lambdas)
            row.update(val_nll=round(va["nll"], 5), val_loss=round(va["loss"], 5),
                       test_nll=round(ev["nll"], 5), test_loss=round(ev["loss"], 5))
            # select on the logged (rounded) value, so that a resumed run restores the same best
            if row["val_nll"] < best_val:
                best_val = row["val_nll"]
                if rank == 0:
                    save_checkpoint(best_path, model, ds.normaliser,
                                    dict(meta, step=str(done), val_nll=str(row["val_nll"]),
                                         val_loss=str(row["val_loss"]), test_nll=str(row["test_nll"]),
                                         test_loss=str(row["test_loss"]), selected_by="val_nll"))
        rows.append(row)
        if rank == 0:
            bar.set_postfix(loss=f"{row['loss']:.1f}", val_nll=row["val_nll"], best=f"{best_val:.1f}")
            if done % cfg.checkpoint_every == 0 or done == end:
                save_checkpoint(ckpt, model, ds.normaliser, dict(meta, step=str(done)), optimizer=opt)
                _write_csv(csv_path, rows)
    if world > 1:
        dist.barrier()
    return ckpt


def _dataset_meta(ds) -> dict:
    m = ds.meta
    return dict(hash=m.get("hash"), test_subject=m.get("test_subject"), val_clips=m.get("val_clips"),
                joint_names=list(ds.joint_names),
                parents=[int(p) for p in ds.parents], motion_types=m.get("motion_types"),
                fps=ds.config.fps, window=ds.config.window,
                train_mean_joint_speed=m.get("train_mean_joint_speed"))


def export_model(ckpt, dest) -> Path:
    """Model-only copy of a checkpoint (no optimizer state), e.g. for the zoo.

    ``ckpt`` is a checkpoint file or a run folder; for a folder the best-by-validation model
    (``best.safetensors``) is exported, with its step and validation/test NLL in the metadata,
    plus ``final_step`` (how far the run went).
    """
    ckpt = Path(ckpt)
    extra = {}
    if ckpt.is_dir():
        _, _, last = load_checkpoint(ckpt / "checkpoint.safetensors")
        extra["final_step"] = str(last["step"])
        ckpt = ckpt / "best.safetensors"
        if not ckpt.is_file():
            raise FileNotFoundError(f"{ckpt} is missing: the run has not been evaluated yet")
    model, norm, meta = load_checkpoint(ckpt)
    keep = {k: v for k, v in meta.items() if k != "optim_param_groups"}
    return save_checkpoint(dest, model, norm, dict(keep, **extra))


def main(argv=None) -> int:
    """``python -m mocapviz.training.trainer --config quick --out cache/runs/quick``."""
    import argparse

    from data_prep.ccnet_dataset import DatasetConfig, build_dataset
    p = argparse.ArgumentParser(description=main.__doc__)
    p.add_argument("--config", default="quick", choices=sorted(TRAIN_CONFIGS))
    p.add_argument("--out", required=True)
    p.add_argument("--steps", type=int)
    p.add_argument("--batch-size", type=int)
    p.add_argument("--eval-every", type=int)
    p.add_argument("--export", help="also write a model-only checkpoint here: the best-by-validation model "
                   "(lowest validation NLL over the evaluations, not the last step); its metadata records "
                   "the step it came from and its validation and test NLL")
    p.add_argument("--no-resume", action="store_true")
    a = p.parse_args(argv)
    cfg = TRAIN_CONFIGS[a.config]
    for name in ("steps", "batch_size", "eval_every"):
        if getattr(a, name):
            cfg = replace(cfg, **{name: getattr(a, name)})
    if a.eval_every:
        cfg = replace(cfg, checkpoint_every=a.eval_every)
    rank = int(os.environ.get("RANK", "0"))
    ds = build_dataset(DatasetConfig(), progress=rank == 0)
    ckpt = train(ds, cfg, a.out, resume=not a.no_resume)
    if rank == 0:
        _, _, meta = load_checkpoint(ckpt)
        rows = _read_csv(Path(a.out) / "losses.csv", 10 ** 12)
        last = [r for r in rows if r["test_nll"] != ""][-1]
        best = best_row(rows)
        print(f"step {meta['step']}: val NLL {float(last['val_nll']):.2f}, test NLL {float(last['test_nll']):.2f} "
              f"nats/frame (normalised units), test loss {float(last['test_loss']):.2f}")
        print(f"best by validation: step {best['step']}: val NLL {float(best['val_nll']):.2f}, "
              f"test NLL {float(best['test_nll']):.2f}")
        if a.export:
            print(f"exported {export_model(Path(a.out), a.export)} (step {best['step']})")
    if dist.is_initialized():
        dist.destroy_process_group()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
