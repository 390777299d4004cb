"""``python -m data_prep cvae4d-prediction``: the 4D motion paper's prediction (§5, Fig. 7).

    python -m data_prep cvae4d-prediction --train-baseline --export   # residual_sup (models/zoo)
    python -m data_prep cvae4d-prediction --table                     # results/cvae4d_prediction.csv

``--train-baseline`` trains Residual-sup (:mod:`mocapviz.training.residual_sup`, config
``--steps``/``--hidden``) on the training cycles of the full body4d dataset at 100 fps; the run
goes to ``cache/runs/pred_residual_sup/``, ``--export`` also writes
``models/zoo/residual_sup.safetensors`` and ``residual_sup_losses.csv``. ``--table`` predicts
every held-out cycle (all test sets, no mirrored copies) from its first 0.25 s with the committed
``cvae4d_phase2`` (fit of (z, beta), :mod:`mocapviz.tasks.cvae4d_prediction`) and the committed
``residual_sup``, and writes the mean vertex error over time. ``--dataset quick`` uses the quick
build (its table is not the committed one: ``--out`` it elsewhere).
"""

from __future__ import annotations

import argparse
import shutil
import time
from pathlib import Path

TABLE = Path("results") / "cvae4d_prediction.csv"
BASELINE = "residual_sup"
CVAE = "cvae4d_phase2"


def add_arguments(p: argparse.ArgumentParser) -> None:
    what = p.add_mutually_exclusive_group(required=True)
    what.add_argument("--train-baseline", action="store_true", help="train Residual-sup")
    what.add_argument("--table", action="store_true", help=f"evaluate both models, write {TABLE}")
    p.add_argument("--steps", type=int, help="Residual-sup training steps (default: the config's)")
    p.add_argument("--hidden", type=int, help="Residual-sup GRU units (default: the config's)")
    p.add_argument("--export", action="store_true", help=f"also write models/zoo/{BASELINE}.safetensors")
    p.add_argument("--fit-steps", type=int, help="Adam steps of the CVAE fit (default: the FitConfig's)")
    p.add_argument("--dataset", choices=("full", "quick"), default="full")
    p.add_argument("--data-dir")
    p.add_argument("--out", help=f"table path (default {TABLE})")


def _dataset(a):
    from data_prep.body4d_dataset import Body4DConfig, build_dataset
    return build_dataset(Body4DConfig.quick() if a.dataset == "quick" else Body4DConfig(), a.data_dir)


def train_baseline(a) -> int:
    from dataclasses import replace

    from data_prep.catalog import CACHE_DIR
    from data_prep.zoo import ZOO_DIR
    from mocapviz.training.cvae4d import dataset_meta, split_indices, write_log
    from mocapviz.training.residual_sup import ResidualSupTrainConfig, save_residual_sup, train

    ds = _dataset(a)
    cfg = ResidualSupTrainConfig()
    cfg = replace(cfg, **{k: v for k, v in dict(steps=a.steps, hidden=a.hidden).items() if v is not None})
    train_idx, held_idx = split_indices(ds)
    cpu0 = time.process_time()
    model, rows = train(ds, cfg, train_idx, held_idx)
    cpu = time.process_time() - cpu0
    command = (f"python -m data_prep cvae4d-prediction --train-baseline --steps {cfg.steps} --hidden {cfg.hidden}"
               f"{' --dataset quick' if a.dataset == 'quick' else ''}")
    meta = dict(train_config=cfg.to_json(), dataset=dataset_meta(ds), cpu_seconds=round(cpu, 1),
                seconds=rows[-1]["seconds"], command=command)
    run = CACHE_DIR / "runs" / f"pred_{BASELINE}"
    run.mkdir(parents=True, exist_ok=True)
    save_residual_sup(run / "model.safetensors", model, meta)
    write_log(run / "losses.csv", rows)
    held = [r["held_loss"] for r in rows if "held_loss" in r]
    print(f"{BASELINE}: {cfg.steps} steps, {cpu / 60:.1f} CPU min ({rows[-1]['seconds']:.0f} s wall); last loss "
          f"{rows[-1]['loss']:.5f}, held-out {held[-1] if held else float('nan'):.5f}; run {run}")
    if a.export:
        shutil.copyfile(run / "model.safetensors", ZOO_DIR / f"{BASELINE}.safetensors")
        shutil.copyfile(run / "losses.csv", ZOO_DIR / f"{BASELINE}_losses.csv")
        print(f"exported {ZOO_DIR / f'{BASELINE}.safetensors'}")
    return 0


def write_table(a) -> int:
    from dataclasses import replace

    from data_prep.sources import REPO_ROOT
    from mocapviz.tasks.cvae4d_eval import on_scale
    from mocapviz.tasks.cvae4d_fit import FitConfig
    from mocapviz.tasks.cvae4d_prediction import PredictionSetup, error_table, prediction_errors
    from mocapviz.training.cvae4d import split_indices
    from mocapviz.zoo import load_cvae4d, load_residual_sup

    cvae, meta = load_cvae4d(CVAE)
    ds = on_scale(_dataset(a), meta["dataset"]["gamma_scale"])
    rsup, _ = load_residual_sup(BASELINE)
    _, held_idx = split_indices(ds)
    fit = FitConfig() if a.fit_steps is None else replace(FitConfig(), steps=a.fit_steps)
    setup = PredictionSetup(fit=fit)
    pred = prediction_errors(ds, held_idx, {CVAE: cvae}, {BASELINE: rsup}, setup, progress=True)
    table = error_table(pred, setup)
    out = Path(a.out) if a.out else REPO_ROOT / TABLE
    out.parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(out, index=False)
    print(table.groupby("model")["mean_mm"].describe().round(1).to_string())
    print(f"CVAE fit: {pred.fit_seconds:.0f} s wall for {len(held_idx)} cycles in batches of "
          f"{setup.batch} ({pred.fit_seconds / len(held_idx):.2f} s per cycle)")
    print(f"written {out} (dataset {a.dataset}, {ds.meta.get('hash')})")
    return 0


def run(a: argparse.Namespace) -> int:
    return train_baseline(a) if a.train_baseline else write_table(a)
