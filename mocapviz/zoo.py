"""Named trained models: load the committed checkpoint, else train (and cache) it.

``load("ccnet_default")`` returns ``(model, normaliser, meta)``. It looks for
``models/zoo/<name>.safetensors`` (committed, so notebooks and CI never retrain), then for a
cached run under ``cache/zoo/<name>-<hash>/`` (hash of the training config and the dataset),
and otherwise trains that run (resuming if interrupted) with
:func:`mocapviz.training.trainer.train` and caches its best-by-validation model.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from mocapviz.training.checkpoint import load_checkpoint
from mocapviz.training.trainer import TRAIN_CONFIGS, export_model, train

REPO_ROOT = Path(__file__).resolve().parent.parent
ZOO_DIR = REPO_ROOT / "models" / "zoo"
CACHE_DIR = REPO_ROOT / "cache" / "zoo"

MODELS = {f"ccnet_{k}": k for k in TRAIN_CONFIGS}


def committed_path(name: str) -> Path:
    return ZOO_DIR / f"{name}.safetensors"


def load(name: str = "ccnet_default", retrain_if_missing: bool = True, prefer_committed: bool = True,
         progress: bool = True):
    if name not in MODELS:
        raise KeyError(f"unknown model {name!r}; known: {sorted(MODELS)}")
    path = committed_path(name)
    if prefer_committed and path.is_file():
        return load_checkpoint(path)
    from data_prep.ccnet_dataset import DatasetConfig, build_dataset
    ds = build_dataset(DatasetConfig(), progress=progress)
    cfg = TRAIN_CONFIGS[MODELS[name]]
    key = hashlib.sha256(f"{cfg.to_json()}\n{ds.meta['hash']}".encode()).hexdigest()[:12]
    run = CACHE_DIR / f"{name}-{key}"
    model_file = run / "model.safetensors"
    if not model_file.is_file():
        if not retrain_if_missing:
            raise FileNotFoundError(f"{name}: no committed checkpoint at {path} and no cached run {run}")
        train(ds, cfg, run, resume=True, progress=progress)
        export_model(run, model_file)  # the best-by-validation model of the run
    return load_checkpoint(model_file)
