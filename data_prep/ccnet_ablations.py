"""``python -m data_prep ccnet-ablations``: CCNet's ablations (paper §4.8, Figs. 11-12) into
``results/ccnet_ablations.csv`` and their loss curves into ``results/ccnet_ablation_curves.csv``.

Each run changes one setting of a reference CCNet (CRL 41: dilation 2 in all 20 SRBs; NCF 240;
joint rotations and angular velocities in the input; the smoothness loss; c^s) and trains from
scratch with the same schedule, seed and number of steps (:data:`ABLATIONS`):

- CRL 31 (dilations 1, 2, 1, 2, ...) and 46 (1, 2, 4, 1, 2, 4, ...), 20 SRBs each (Eq. 3);
- NCF 60 and 120 frames per training window; every run is scored on windows of 240 frames
  (``TrainConfig.eval_window``), as the paper scores its NCF runs;
- w/o ROT: the joint rotations and angular velocities hidden from the input (their training
  mean, ``TrainConfig.hidden_inputs``), still predicted; w/o SK: c^s hidden the same way, which
  leaves each SRB's c^s convolution a constant (its bias): the paper "disconnected" them;
- w/o Smooth: the smoothness term's weight 0;
- SRBs replaced by LSTMs: CCNet's loss and output layout on an encoder, 1 or 2 LSTM layers of 512
  and a decoder (``mocapviz.models.erd`` sizes ``lstm1x512``/``lstm2x512``); c^s enters at the
  encoder (an LSTM has no per-block control convolutions).

Scale (a deviation, named in the table): the quick CCNet size (32 channels), batches of 16
windows, ``--steps`` Adam steps (lr 1e-3 to 1e-5) on the full dataset, one CPU thread per run.
The paper trained each run for its whole budget at width 256 with RMSprop; its LSTMs needed an
initial learning rate of 1e-5 to converge, ours share the reference's schedule. The columns
compare runs by the NLL (the same term in every run's loss) and by the loss L of Eq. 6 with the
reference's weights, computed on the final model for every run (w/o Smooth trained without the
smoothness term, but is scored with it). Run folders: ``cache/runs/ablation_<name>/``
(resumed; a finished run is not retrained). ``--only NAME ...`` trains some runs (two shells can
share the list); the table is written once every run exists.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

OUT_NAME = "ccnet_ablations.csv"
CURVES_NAME = "ccnet_ablation_curves.csv"
RUN_DIR = Path("cache") / "runs"
COMMAND = "python -m data_prep ccnet-ablations"


def reference_config(steps: int):
    from mocapviz.training.config import TrainConfig
    return TrainConfig(size="quick", steps=steps, batch_size=16, window=240, eval_window=240, lr=1e-3,
                       lr_final=1e-5, optimizer="adam", eval_every=max(1, steps // 10),
                       checkpoint_every=max(1, steps // 10))


def ablations() -> dict[str, tuple[str, str, dict]]:
    """Run name -> (ablation, setting, TrainConfig overrides of the reference)."""
    from mocapviz.training.losses import LAMBDAS
    return {
        "reference": ("reference", "CRL 41, NCF 240", {}),
        "crl31": ("CRL", "31", dict(dilations=(1, 2) * 10)),
        "crl46": ("CRL", "46", dict(dilations=(1, 2, 4) * 6 + (1, 2))),
        "ncf60": ("NCF", "60", dict(window=60)),
        "ncf120": ("NCF", "120", dict(window=120)),
        "no_rot": ("ROT", "w/o", dict(hidden_inputs=("rotations",))),
        "no_smooth": ("Smooth", "w/o", dict(lambdas=(0.0,) + tuple(LAMBDAS[1:]))),
        "no_sk": ("SK", "w/o", dict(hidden_inputs=("skeleton",))),
        "lstm1": ("SRB2LSTM", "LSTM 1 x 512", dict(model="erd", size="lstm1x512")),
        "lstm2": ("SRB2LSTM", "LSTM 2 x 512", dict(model="erd", size="lstm2x512")),
    }


def receptive_field(dilations, kernel: int = 2) -> int:
    """CRL of Eq. 3: (k - 1) + sum_i d_i (k - 1)."""
    return (kernel - 1) + sum(d * (kernel - 1) for d in dilations)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--steps", type=int, default=1500, help="optimiser steps of every run (default 1500)")
    p.add_argument("--only", nargs="+", help=f"train these runs only (of: {', '.join(ablations())})")
    p.add_argument("--quick", action="store_true", help="the quick dataset and --steps 4: a smoke test")
    p.add_argument("--data-dir")
    p.add_argument("--out", default="results", help="folder of the two CSVs")


def run(a: argparse.Namespace) -> int:
    import pandas as pd

    from data_prep.ccnet_dataset import DatasetConfig, build_dataset
    from mocapviz.training.trainer import train

    steps = 4 if a.quick and a.steps == 1500 else a.steps
    runs = ablations()
    unknown = set(a.only or ()) - set(runs)
    if unknown:
        raise SystemExit(f"unknown ablation run(s) {sorted(unknown)}; choose from {', '.join(runs)}")
    ds = build_dataset(DatasetConfig.quick() if a.quick else DatasetConfig(), a.data_dir)
    root = RUN_DIR / ("ablation_quick" if a.quick else "ablation")
    for name in a.only or runs:
        print(f"ablation {name}: {runs[name][0]} {runs[name][1]}")
        train(ds, config_of(name, steps), root / name)
    missing = [n for n in runs if not finished(root / n, steps)]
    if missing:
        print(f"not writing the table yet: runs {missing} are missing or still training")
        return 0
    table, curves = ablation_table(ds, root, steps, "quick" if a.quick else "full")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / OUT_NAME, index=False)
    curves.to_csv(out / CURVES_NAME, index=False)
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(table[["run", "ablation", "setting", "train_loss_end", "val_nll_end", "test_nll_end",
                     "test_loss_ref"]].to_string(index=False))
    print(f"written {out / OUT_NAME} and {out / CURVES_NAME}")
    return 0


def finished(run_dir: Path, steps: int) -> bool:
    """Whether the run in ``run_dir`` has logged its last step (another shell may be training it)."""
    from mocapviz.training.runs import read_log
    rows = read_log(run_dir / "losses.csv")
    return bool(rows) and int(rows[-1]["step"]) >= steps


def config_of(name: str, steps: int):
    return replace(reference_config(steps), **ablations()[name][2])


def ablation_table(ds, root: Path, steps: int, mode: str):
    """(table, curves): one row per run, and its logged losses at every evaluation (the training
    loss there is the mean over the steps since the last evaluation)."""
    import pandas as pd
    import torch

    from mocapviz.training.checkpoint import load_checkpoint
    from mocapviz.training.losses import LAMBDAS
    from mocapviz.training.runs import CHECKPOINT, read_log
    from mocapviz.training.trainer import evaluate
    from mocapviz.training.windows import WindowData

    rows, curves = [], []
    for name, (ablation, setting, _) in ablations().items():
        cfg = config_of(name, steps)
        log = pd.DataFrame(read_log(root / name / "losses.csv")).apply(pd.to_numeric, errors="coerce")
        evals = log.dropna(subset=["test_nll"])
        model = load_checkpoint(root / name / CHECKPOINT)[0]
        data = WindowData(ds, cfg.eval_window, hidden_inputs=cfg.hidden_inputs)
        with torch.no_grad():
            test = evaluate(model, data, data.test, LAMBDAS)
        last, best = evals.iloc[-1], evals.loc[evals.val_nll.idxmin()]
        tail = log.loss.iloc[-max(1, len(log) // 10):]
        rows.append(dict(run=name, ablation=ablation, setting=setting, model=cfg.model, size=cfg.size,
                         crl=receptive_field(cfg.dilations) if cfg.model == "ccnet" else "",
                         ncf=cfg.window, eval_window=cfg.eval_window, hidden_inputs="+".join(cfg.hidden_inputs),
                         smoothness_weight=cfg.lambdas[0], steps=int(last.step), epochs=float(last.epoch),
                         parameters=sum(p.numel() for p in model.parameters()),
                         wall_minutes=round(float(log.seconds.iloc[-1]) / 60, 2),
                         train_loss_end=round(float(tail.mean()), 3), val_nll_end=float(last.val_nll),
                         test_nll_end=float(last.test_nll), test_loss_ref=round(test["loss"], 3),
                         best_val_nll=float(best.val_nll), best_step=int(best.step), mode=mode,
                         command=COMMAND + (" --quick" if mode == "quick" else "") + f" --steps {steps}"))
        prev = 0
        for r in evals.itertuples():
            window = log[(log.step > prev) & (log.step <= r.step)]
            curves.append(dict(run=name, step=int(r.step), epoch=float(r.epoch),
                               train_loss=round(float(window.loss.mean()), 3), train_nll=round(float(window.nll.mean()), 3),
                               val_nll=float(r.val_nll), val_loss=float(r.val_loss), test_nll=float(r.test_nll),
                               test_loss=float(r.test_loss)))
            prev = r.step
    return pd.DataFrame(rows), pd.DataFrame(curves)
