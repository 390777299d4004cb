"""The repository's trained models: :func:`mocapviz.zoo.load` with ``models/zoo/`` (committed
checkpoints), ``cache/zoo/`` (cached runs) and the CCNet dataset builder. Models retired from
``models/zoo/`` (:data:`RETIRED`) are read from the git tag that still holds them."""

from __future__ import annotations

import subprocess
import warnings
from pathlib import Path

from data_prep.catalog import CACHE_DIR
from data_prep.sources import REPO_ROOT
from mocapviz import zoo
from mocapviz.training.checkpoint import load_checkpoint

ZOO_DIR = REPO_ROOT / "models" / "zoo"
RUNS_DIR = CACHE_DIR / "zoo"
HISTORY_TAG = "zoo-history-2026-12"  # the zoo before the models below were retired (models/README.md)
# nothing but their own history used them (docs/experiments.md): the generation runs before ccnet_generate
RETIRED = ("ccnet_phase", "ccnet_phase_lerp", "ccnet_phase_lerp_scale", "ccnet_wide")


def committed_path(name: str) -> Path:
    return zoo.committed_path(name, ZOO_DIR)


def retired_checkpoint(name: str) -> Path:
    """The checkpoint of a retired model (with its parts), read from :data:`HISTORY_TAG` into
    ``cache/zoo/<tag>/`` the first time."""
    dest = RUNS_DIR / HISTORY_TAG
    restore = f"git checkout {HISTORY_TAG} -- models/zoo/{name}.safetensors (and its .partK files)"
    try:
        listed = subprocess.run(["git", "-C", str(REPO_ROOT), "ls-tree", "--name-only", HISTORY_TAG, "models/zoo/"],
                                capture_output=True, text=True, check=True).stdout.split()
        files = [Path(f).name for f in listed if Path(f).name == f"{name}.safetensors"
                 or Path(f).name.startswith(f"{name}.part")]
        for f in files:
            if not (dest / f).is_file():
                blob = subprocess.run(["git", "-C", str(REPO_ROOT), "show", f"{HISTORY_TAG}:models/zoo/{f}"],
                                      capture_output=True, check=True).stdout
                dest.mkdir(parents=True, exist_ok=True)
                (dest / f).write_bytes(blob)
    except (OSError, subprocess.CalledProcessError) as e:
        raise zoo.ModelNotFound(f"{name} is retired and the tag {HISTORY_TAG} could not be read ({e}); in a "
                                f"clone with the tag: {restore}") from None
    if f"{name}.safetensors" not in files:
        raise zoo.ModelNotFound(f"{name} is retired, but the tag {HISTORY_TAG} holds no such file")
    return dest / f"{name}.safetensors"


def load(name: str = "ccnet_default", retrain_if_missing: bool = False, prefer_committed: bool = True,
         progress: bool = True):
    """(model, normaliser, meta) of ``name``: committed, else cached; else trained (and cached) if
    ``retrain_if_missing``, or :class:`mocapviz.zoo.ModelNotFound` naming the command that trains it.
    A retired model (:data:`RETIRED`) is read from the tag :data:`HISTORY_TAG`, with a warning."""
    if name in RETIRED and not committed_path(name).is_file():
        warnings.warn(f"{name} is retired from models/zoo: read from the git tag {HISTORY_TAG} "
                      "(models/README.md, 'Retired models')", stacklevel=2)
        return load_checkpoint(retired_checkpoint(name))

    def dataset():
        from data_prep.ccnet_dataset import DatasetConfig, build_dataset
        return build_dataset(DatasetConfig(), progress=progress)

    return zoo.load(name, ZOO_DIR, RUNS_DIR, dataset, retrain_if_missing=retrain_if_missing,
                    prefer_committed=prefer_committed, progress=progress)


def load_cvae4d(name: str = "cvae4d_phase2"):
    """(model, meta) of a committed 4D motion CVAE in ``models/zoo/``."""
    return zoo.load_cvae4d(name, ZOO_DIR)
