"""A training run's folder: checkpoint, best-by-validation model, loss log; and the export of a
run's model for the zoo.

``<run>/checkpoint.safetensors`` (model + optimizer, for exact resume), ``<run>/best.safetensors``
(the model with the lowest validation NLL so far, model only) and ``<run>/losses.csv`` (one row
per step; validation and test columns at the evaluation steps).
"""

from __future__ import annotations

import csv
from pathlib import Path

from mocapviz.atomic import atomic_path
from mocapviz.training.checkpoint import load_checkpoint, save_checkpoint

CHECKPOINT, BEST, LOG = "checkpoint.safetensors", "best.safetensors", "losses.csv"
CSV_FIELDS = ["step", "epoch", "lr", "loss", "nll", "smooth", "contact", "traj_nll", "kl", "val_nll", "val_loss",
              "test_nll", "test_loss", "seconds"]
LEGACY_COLUMNS = {"direction": "traj_nll"}  # logs written before the rename


def write_log(path: Path, rows: list[dict]) -> None:
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, CSV_FIELDS)
        w.writeheader()
        w.writerows(rows)


def read_log(path: Path, upto: int | None = None) -> list[dict]:
    """The logged rows (strings) up to step ``upto`` (all when None); [] without a log."""
    if not path.is_file():
        return []
    with open(path, newline="") as f:
        rows = [{LEGACY_COLUMNS.get(k, k): v for k, v in r.items()} for r in csv.DictReader(f)]
    return [r for r in rows if upto is None or int(r["step"]) <= upto]


def best_row(rows: list[dict]) -> dict | None:
    """The logged row with the lowest validation NLL (the first of ties), or None."""
    ev = [r for r in rows if r.get("val_nll") not in ("", None)]
    return min(ev, key=lambda r: float(r["val_nll"])) if ev else None


def export_model(ckpt, dest, half: bool = False) -> Path:
    """Model-only copy of a checkpoint (no optimizer state), e.g. for the zoo; with ``half`` the
    model's weights are stored as float16 (half the file; loading casts them back to float32).

    ``ckpt`` is a checkpoint file or a run folder; for a folder the best-by-validation model
    (``best.safetensors``) is exported, with its step and validation/test NLL in the metadata,
    plus ``final_step`` (how far the run went).
    """
    ckpt = Path(ckpt)
    extra = {}
    if ckpt.is_dir():
        _, _, last = load_checkpoint(ckpt / CHECKPOINT)
        extra["final_step"] = str(last["step"])
        ckpt = ckpt / BEST
        if not ckpt.is_file():
            raise FileNotFoundError(f"{ckpt} is missing: the run has not been evaluated yet")
    model, norm, meta = load_checkpoint(ckpt)
    keep = {k: v for k, v in meta.items() if k != "optim_param_groups"}
    if half:
        model = model.half()
        keep["weights"] = "float16"
    return save_checkpoint(dest, model, norm, dict(keep, **extra))
