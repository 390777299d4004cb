"""The repository's trained models: :func:`mocapviz.zoo.load` with ``models/zoo/`` (committed
checkpoints), ``cache/zoo/`` (cached runs) and the CCNet dataset builder."""

from __future__ import annotations

from pathlib import Path

from data_prep.catalog import CACHE_DIR
from data_prep.sources import REPO_ROOT
from mocapviz import zoo

ZOO_DIR = REPO_ROOT / "models" / "zoo"
RUNS_DIR = CACHE_DIR / "zoo"


def committed_path(name: str) -> Path:
    return zoo.committed_path(name, ZOO_DIR)


def load(name: str = "ccnet_default", retrain_if_missing: bool = False, prefer_committed: bool = True,
         progress: bool = True):
    """(model, normaliser, meta) of ``name``: committed, else cached; else trained (and cached) if
    ``retrain_if_missing``, or :class:`mocapviz.zoo.ModelNotFound` naming the command that trains it."""
    def dataset():
        from data_prep.ccnet_dataset import DatasetConfig, build_dataset
        return build_dataset(DatasetConfig(), progress=progress)

    return zoo.load(name, ZOO_DIR, RUNS_DIR, dataset, retrain_if_missing=retrain_if_missing,
                    prefer_committed=prefer_committed, progress=progress)


def load_cvae4d(name: str = "cvae4d_phase2"):
    """(model, meta) of a committed 4D motion CVAE in ``models/zoo/``."""
    return zoo.load_cvae4d(name, ZOO_DIR)
