"""``python -m data_prep one-step --model NAME_OR_FILE [...]``: teacher-forced one-step error
of CCNet models on the held-out clips, beside copying the last frame and constant velocity.

For each model and split (``val``: model selection's clips; ``test``: the held-out subject
``tr``, one clip of every other subject and Bandai's test takes), the medians of
:func:`mocapviz.tasks.one_step.one_step_table` per block of x (normalised units, training
standard deviations). A model that predicts the next frame from the true past better than
doing nothing has ``mean_error`` below ``copy_last`` and ``extrapolate`` in every block.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd


def one_step_report(models: dict, ds, splits=("val", "test")) -> pd.DataFrame:
    """Rows (model, split, block); columns of :data:`mocapviz.tasks.one_step.COLUMNS` and
    ``beats_copy_last``, ``beats_constant_velocity``. ``models``: name -> (model, normaliser)."""
    from mocapviz.tasks.one_step import one_step_table

    tables = []
    for name, (model, norm) in models.items():
        for split in splits:
            rows = np.flatnonzero(((ds.clips.split == split) & (ds.clips.stop - ds.clips.start > 3)).values)
            t = one_step_table(model, norm, ds, rows)
            t.index.name = "block"
            tables.append(t.assign(model=name, split=split, clips=len(rows)).reset_index())
    out = pd.concat(tables, ignore_index=True)
    out["beats_copy_last"] = out.mean_error < out.copy_last
    out["beats_constant_velocity"] = out.mean_error < out.extrapolate
    return out[["model", "split", "clips", "block", "mean_error", "copy_last", "extrapolate", "sigma",
                "beats_copy_last", "beats_constant_velocity"]]


def add_arguments(p) -> None:
    p.add_argument("--model", action="append", required=True, help="zoo name or .safetensors file (repeatable)")
    p.add_argument("--packed", help="a compact dataset copy (data_prep/pack.py) instead of the raw data")
    p.add_argument("--split", action="append", choices=("val", "test"), help="default: val and test")
    p.add_argument("--csv", help="also write the table here")


def run(a) -> int:
    from mocapviz.training.checkpoint import load_checkpoint
    from mocapviz.zoo import find_checkpoint

    if a.packed:
        from data_prep.pack import unpack
        ds = unpack(Path(a.packed))
    else:
        from data_prep.ccnet_dataset import DatasetConfig, build_dataset
        ds = build_dataset(DatasetConfig())
    models = {}
    for m in a.model:
        model, norm, _ = load_checkpoint(find_checkpoint(m))
        p = Path(m)
        name = (p.parent.name if p.stem == "best" else p.stem) if p.suffix == ".safetensors" else m
        models[name] = (model.float(), norm)
    table = one_step_report(models, ds, tuple(a.split or ("val", "test")))
    with pd.option_context("display.width", 200, "display.max_rows", 200):
        print(table.to_string(index=False, float_format=lambda v: f"{v:.4f}"))
    if a.csv:
        Path(a.csv).parent.mkdir(parents=True, exist_ok=True)
        table.to_csv(a.csv, index=False, float_format="%.5f")
    return 0
