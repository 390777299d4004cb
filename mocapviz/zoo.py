"""Named trained models: a committed checkpoint, else a cached run, else train it when asked to.

``load("ccnet_default", zoo_dir, cache_dir, dataset)`` returns ``(model, normaliser, meta)``. It
looks for ``<zoo_dir>/<name>.safetensors`` (committed, so notebooks and CI never retrain), then
for a cached run ``<cache_dir>/<name>-<hash>/`` (hash of the training config and the dataset).
With neither it raises :class:`ModelNotFound`, which names the command that trains the model;
with ``retrain_if_missing=True`` it trains that run instead (resuming if interrupted) with
:func:`mocapviz.training.trainer.train` and caches its best-by-validation model. The library
knows no repository paths: :mod:`data_prep.zoo` passes the repository's ``models/zoo/`` and
``cache/zoo/`` and the dataset builder.
"""

from __future__ import annotations

import hashlib
import os
import warnings
from dataclasses import replace
from pathlib import Path

from mocapviz.training.checkpoint import load_checkpoint
from mocapviz.training.config import TRAIN_CONFIGS
from mocapviz.training.runs import export_model
from mocapviz.training.trainer import train

# zoo name -> (TRAIN_CONFIGS key, the `python -m data_prep train` options that differ from it)
RECIPES = {f"ccnet_{k}": (k, {}) for k in TRAIN_CONFIGS if k != "paper_next_frame"}
# the paper's network as committed (trained for next-frame prediction on a CPU); TRAIN_CONFIGS["paper"],
# the paper's own schedule, is what `--config paper` trains
RECIPES["ccnet_paper"] = ("paper_next_frame", {})
# the CCNet baselines of paper §4.1.2 (mocapviz.models.baseline), each trained as its committed file was
# (pfnn: 400 steps, what one shared core had time for; docs/experiments.md)
RECIPES.update({f"{m}_quick": ("quick", {"model": m, "steps": n, "eval_every": n})
                for m, n in (("erd", 1200), ("dae_lstm", 1200), ("pfnn", 400))})


def _recipe_config(key: str, options: dict):
    cfg = replace(TRAIN_CONFIGS[key], **options)  # --eval-every sets the checkpoint cadence too
    return replace(cfg, checkpoint_every=cfg.eval_every) if "eval_every" in options else cfg


MODELS = {name: _recipe_config(k, o) for name, (k, o) in RECIPES.items()}  # name -> the config that makes it
# old zoo names -> their names by role; an old name still loads, with a DeprecationWarning
RENAMED = {"ccnet_phase_lerp_scale_root": "ccnet_generate", "ccnet_next_frame_cpu": "ccnet_paper"}
ZOO_ENV = "MOCAPVIZ_ZOO"  # folders (os.pathsep-separated) searched first for a model by name


def canonical_name(name: str) -> str:
    """``name``, or the name an old zoo name (:data:`RENAMED`) now has, with a DeprecationWarning."""
    if name in RENAMED:
        warnings.warn(f"model {name!r} is now called {RENAMED[name]!r}; the old name will go", DeprecationWarning,
                      stacklevel=3)
        return RENAMED[name]
    return name


def search_path(cwd=None) -> list[Path]:
    """Folders where :func:`find_checkpoint` looks for ``<name>.safetensors``, in order: each
    folder of ``$MOCAPVIZ_ZOO``, then ``models/zoo`` under the current directory and under each
    of its parents (a checkout of this repository, wherever the command runs inside it)."""
    env = [Path(p) for p in os.environ.get(ZOO_ENV, "").split(os.pathsep) if p]
    here = Path(cwd if cwd is not None else Path.cwd()).resolve()
    return env + [d / Path("models", "zoo") for d in (here, *here.parents)]


def find_checkpoint(name_or_file: str, cwd=None) -> Path:
    """A checkpoint file: ``name_or_file`` itself if it is a path (has a folder or the
    ``.safetensors`` suffix), else ``<name>.safetensors`` in the first folder of
    :func:`search_path` that has it. FileNotFoundError says where it looked."""
    p = Path(name_or_file)
    if p.suffix == ".safetensors" or len(p.parts) > 1:
        if p.is_file():
            return p
        raise FileNotFoundError(f"model file not found: {p}")
    name_or_file = canonical_name(name_or_file)
    tried = search_path(cwd)
    for folder in tried:
        if committed_path(name_or_file, folder).is_file():
            return committed_path(name_or_file, folder)
    raise FileNotFoundError(f"no model named {name_or_file!r}: looked for {name_or_file}.safetensors in "
                            f"{', '.join(map(str, tried))}; set {ZOO_ENV} to a folder of checkpoints "
                            "or pass a .safetensors file")


def committed_path(name: str, zoo_dir) -> Path:
    return Path(zoo_dir) / f"{canonical_name(name)}.safetensors"


class ModelNotFound(FileNotFoundError, KeyError):
    """A zoo name with no committed checkpoint (nor cached run): the message names the command that
    trains it and the names that have a file. A KeyError too, as an unknown name always was."""

    __str__ = FileNotFoundError.__str__


def train_command(name: str) -> str:
    """The command that trains the zoo model ``name`` (:data:`RECIPES`) and exports it to ``models/zoo``."""
    key, options = RECIPES[name]
    opts = "".join(f" --{k.replace('_', '-')} {v}" for k, v in options.items())
    return (f"python -m data_prep train --config {key}{opts} --out cache/runs/{name} "
            f"--export models/zoo/{name}.safetensors")


def committed_names(zoo_dir) -> list[str]:
    """The models with a checkpoint in ``zoo_dir`` (not the parts of split files)."""
    if zoo_dir is None or not Path(zoo_dir).is_dir():
        return []
    return sorted(p.name.removesuffix(".safetensors") for p in Path(zoo_dir).glob("*.safetensors")
                  if p.name.count(".") == 1)


def load(name: str = "ccnet_default", zoo_dir=None, cache_dir=None, dataset=None, retrain_if_missing: bool = False,
         prefer_committed: bool = True, progress: bool = True):
    """``(model, normaliser, meta)`` of ``name``: the committed ``<zoo_dir>/<name>.safetensors``, else
    a cached run in ``cache_dir``. With neither, :class:`ModelNotFound` says how to train it, unless
    ``retrain_if_missing`` (and ``cache_dir`` and ``dataset``) are given: then the run is trained
    (30-70 minutes for a CCNet on a CPU) and cached. ``dataset``: a CCNet dataset, or a function that
    builds one (called only when no committed checkpoint is used); it keys the cached run and is
    what a missing run trains on."""
    name = canonical_name(name)
    committed = committed_path(name, zoo_dir) if zoo_dir is not None else None
    if prefer_committed and committed is not None and committed.is_file():
        return load_checkpoint(committed)
    have = f"models with a file in {zoo_dir}: {', '.join(committed_names(zoo_dir)) or 'none'}"
    if name not in MODELS:
        raise ModelNotFound(f"unknown model {name!r}: no file {committed} and no training config of that name "
                            f"(mocapviz.zoo.RECIPES); {have}")
    missing = f"{name}: no committed checkpoint {committed}"
    how = (f"train it with `{train_command(name)}`, or load it with retrain_if_missing=True and a cache_dir and "
           f"dataset (data_prep.zoo.load passes both), which trains into the cache; {have}")
    if dataset is None or cache_dir is None:
        raise ModelNotFound(f"{missing}; pass cache_dir and dataset (a dataset or a builder) to use a cached run, "
                            f"or {how}")
    if not retrain_if_missing and not any(Path(cache_dir).glob(f"{name}-*/model.safetensors")):
        raise ModelNotFound(f"{missing} and no cached run in {cache_dir}: {how}")  # without building the data
    ds = dataset() if callable(dataset) else dataset
    cfg = MODELS[name]
    key = hashlib.sha256(f"{cfg.to_json()}\n{ds.meta['hash']}".encode()).hexdigest()[:12]
    run = Path(cache_dir) / f"{name}-{key}"
    model_file = run / "model.safetensors"
    if not model_file.is_file():
        if not retrain_if_missing:
            raise ModelNotFound(f"{missing} and no cached run {run}: {how}")
        train(ds, cfg, run, resume=True, progress=progress)
        export_model(run, model_file)  # the best-by-validation model of the run
    return load_checkpoint(model_file)


def load_cvae4d(name_or_file: str, zoo_dir=None):
    """(model, meta) of a committed 4D motion CVAE (``cvae4d_*``: phase 1, phase 2, ablations),
    from ``zoo_dir`` or the :func:`search_path`; trained by ``python -m data_prep train-cvae``."""
    from mocapviz.training.cvae4d import load_cvae

    path = committed_path(name_or_file, zoo_dir) if zoo_dir is not None else find_checkpoint(name_or_file)
    return load_cvae(path)


def cvae4d_epochs(name: str) -> tuple[int, int]:
    """(epochs run, epoch kept) of a committed 4D motion CVAE, from the ``<name>_losses.csv``
    beside it: a run with a time budget stops before its config's ``epochs``, and ``keep_best``
    keeps its best validation epoch (the last logged row's ``kept_epoch``; else the last)."""
    import pandas as pd

    log = pd.read_csv(find_checkpoint(name).with_name(f"{name}_losses.csv"))
    run = int(log.epoch.iloc[-1])
    kept = log.kept_epoch.dropna() if "kept_epoch" in log else pd.Series(dtype=float)
    return run, int(kept.iloc[-1]) if len(kept) else run


def load_residual_sup(name_or_file: str = "residual_sup", zoo_dir=None):
    """(model, meta) of a committed Residual-sup baseline (4D motion paper §5), from ``zoo_dir`` or
    the :func:`search_path`; trained by ``python -m data_prep cvae4d-prediction --train-baseline``."""
    from mocapviz.training.residual_sup import load_residual_sup as load

    path = committed_path(name_or_file, zoo_dir) if zoo_dir is not None else find_checkpoint(name_or_file)
    return load(path)
