"""``python -m data_prep train --config quick --out cache/runs/quick``: train a model on the
CCNet dataset (built or loaded from ``cache/ccnet/``) with :func:`mocapviz.training.trainer.train`.

Runs under ``torchrun`` unchanged (``torchrun --nproc_per_node=2 -m data_prep train ...``).
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path



def add_arguments(p: argparse.ArgumentParser) -> None:
    # no import of the trainer here (torch): `python -m data_prep catalog` stays light
    p.add_argument("--config", default="quick", help="named training config: quick, default or paper "
                   "(mocapviz.training.config.TRAIN_CONFIGS)")
    p.add_argument("--out", required=True, help="run folder (resumed if it holds a checkpoint)")
    p.add_argument("--model", help="registered model to train instead of the config's (ccnet, erd, dae_lstm, pfnn)")
    p.add_argument("--steps", type=int)
    p.add_argument("--size", help="model size instead of the config's (quick, default, wide, paper)")
    p.add_argument("--batch-size", type=int)
    p.add_argument("--eval-every", type=int)
    p.add_argument("--device", help="torch device to train on (cpu, cuda)")
    p.add_argument("--minutes", type=float, help="a time budget: the steps are set from the measured step time")
    p.add_argument("--packed", help="train on a compact dataset copy (data_prep/pack.py) instead of the raw data")
    p.add_argument("--data-dir")
    p.add_argument("--dataset", choices=("full", "quick"), default="full",
                   help="CCNet dataset: full (HDM05 + CMU + every Bandai take) or quick (3 Bandai takes per content)")
    p.add_argument("--export", help="also write a model-only checkpoint here: the best-by-validation model "
                   "(lowest validation NLL over the evaluations, not the last step); its metadata records "
                   "the step it came from and its validation and test NLL")
    p.add_argument("--no-resume", action="store_true")
    p.add_argument("--init", help="fine-tune this model (zoo name or .safetensors file): its network and "
                   "normaliser, the config's schedule")


def run(a: argparse.Namespace) -> int:
    from data_prep.ccnet_dataset import DatasetConfig, build_dataset
    from mocapviz.training.checkpoint import load_checkpoint
    from mocapviz.training.config import TRAIN_CONFIGS
    from mocapviz.training.distributed import finish, rank_from_env
    from mocapviz.training.runs import LOG, best_row, export_model, read_log
    from mocapviz.training.trainer import train

    if a.config not in TRAIN_CONFIGS:
        raise KeyError(f"unknown training config {a.config!r}; choose from {', '.join(TRAIN_CONFIGS)}")
    cfg = TRAIN_CONFIGS[a.config]
    for name in ("model", "size", "steps", "batch_size", "eval_every", "device", "minutes"):
        if getattr(a, name):
            cfg = replace(cfg, **{name: getattr(a, name)})
    if a.eval_every:
        cfg = replace(cfg, checkpoint_every=a.eval_every)
    rank = rank_from_env()
    if a.packed:
        from data_prep.pack import unpack
        ds = unpack(Path(a.packed))
    else:
        ds = build_dataset(DatasetConfig.quick() if a.dataset == "quick" else DatasetConfig(), a.data_dir,
                           progress=rank == 0)
    init = None
    if a.init:
        from mocapviz.zoo import find_checkpoint
        init = find_checkpoint(a.init)
    ckpt = train(ds, cfg, a.out, resume=not a.no_resume, init=init)
    if rank == 0:
        _, _, meta = load_checkpoint(ckpt)
        rows = read_log(Path(a.out) / LOG)
        last = [r for r in rows if r["test_nll"] != ""][-1]
        best = best_row(rows)
        print(f"step {meta['step']}: val NLL {float(last['val_nll']):.2f}, test NLL {float(last['test_nll']):.2f} "
              f"nats/frame (normalised units), test loss {float(last['test_loss']):.2f}")
        print(f"best by validation: step {best['step']}: val NLL {float(best['val_nll']):.2f}, "
              f"test NLL {float(best['test_nll']):.2f}")
        if a.export:
            print(f"exported {export_model(Path(a.out), a.export)} (step {best['step']})")
    finish()
    return 0
