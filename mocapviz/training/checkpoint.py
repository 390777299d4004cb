"""Checkpoints: one safetensors file rebuilds model + normaliser (config in metadata).

Tensors: ``model.*`` (state dict), ``norm.*`` (normalisation statistics), optionally ``optim.*``
(optimizer state, for exact resume). Metadata (strings): ``model`` (the registered model name,
:mod:`mocapviz.models.protocol`), ``model_config`` (JSON of the model's config), ``train_config``,
``dataset`` (JSON: hash, test subject, joint names, motion types, fps, training mean joint speed),
``step``, ``format``. A latent CCNet's type prior, fitted after training, lives beside the file
(:func:`mocapviz.models.type_prior.sidecar_path`) and is attached on loading. Files of format
``mocapviz.ccnet.v1`` (before the model registry) have no ``model`` key and hold a CCNet. Writes
are atomic.
"""

from __future__ import annotations

import json
from pathlib import Path

import torch
from safetensors import safe_open
from safetensors.torch import save_file

from mocapviz.atomic import atomic_path
from mocapviz.features.ccnet import Normaliser
from mocapviz.models.protocol import build_model
from mocapviz.models.type_prior import TypePrior, sidecar_path

FORMAT = "mocapviz.checkpoint.v2"
LEGACY_FORMATS = {"mocapviz.ccnet.v1": "ccnet"}  # format -> the model every such file holds


def _optim_tensors(opt: torch.optim.Optimizer) -> tuple[dict, str]:
    sd = opt.state_dict()
    tensors = {}
    for pid, st in sd["state"].items():
        for k, v in st.items():
            tensors[f"optim.{pid}.{k}"] = torch.as_tensor(v).detach().cpu().clone()
    return tensors, json.dumps(sd["param_groups"])


def save_checkpoint(path, model: torch.nn.Module, normaliser: Normaliser, meta: dict | None = None,
                    optimizer: torch.optim.Optimizer | None = None) -> Path:
    path = Path(path)
    tensors = {f"model.{k}": v.detach().cpu().contiguous().clone() for k, v in model.state_dict().items()}
    tensors.update({f"norm.{k}": torch.from_numpy(v) for k, v in normaliser.state_dict().items()})
    metadata = {"format": FORMAT, "model": model.name, "model_config": model.cfg.to_json()}
    for k, v in (meta or {}).items():
        if k not in metadata:  # format, model and its config describe this file, not the source's
            metadata[k] = v if isinstance(v, str) else json.dumps(v)
    if optimizer is not None:
        t, groups = _optim_tensors(optimizer)
        tensors.update(t)
        metadata["optim_param_groups"] = groups
    with atomic_path(path) as tmp:
        save_file(tensors, tmp, metadata=metadata)
    return path


def split_checkpoint(src, dest, max_bytes: int) -> list[Path]:
    """Rewrite the checkpoint ``src`` as ``dest`` plus ``<dest stem>.partK.safetensors`` files of
    at most about ``max_bytes`` of tensors each (the repository keeps files under 3 MiB);
    ``dest``'s metadata lists the parts and :func:`read_checkpoint` reads them back. Returns
    every file written, ``dest`` first."""
    dest = Path(dest)
    with safe_open(str(src), framework="pt") as f:
        meta = dict(f.metadata() or {})
        tensors = {k: f.get_tensor(k) for k in f.keys()}
    groups, size = [{}], 0
    for k, v in tensors.items():
        nbytes = v.numel() * v.element_size()
        if groups[-1] and size + nbytes > max_bytes:
            groups.append({})
            size = 0
        groups[-1][k] = v
        size += nbytes
    parts = [dest.with_name(f"{dest.stem}.part{i}.safetensors") for i in range(1, len(groups))]
    meta["parts"] = json.dumps([p.name for p in parts])
    for path, group, md in zip([dest, *parts], groups, [meta] + [{"format": meta["format"]}] * len(parts)):
        with atomic_path(path) as tmp:
            save_file(group, tmp, metadata=md)
    return [dest, *parts]


def read_checkpoint(path) -> tuple[dict[str, torch.Tensor], dict[str, str]]:
    with safe_open(str(path), framework="pt") as f:
        meta = f.metadata() or {}
        tensors = {k: f.get_tensor(k) for k in f.keys()}
    for name in json.loads(meta.get("parts", "[]")):  # a checkpoint split by split_checkpoint
        with safe_open(str(Path(path).with_name(name)), framework="pt") as f:
            tensors.update({k: f.get_tensor(k) for k in f.keys()})
    fmt = meta.get("format")
    if fmt in LEGACY_FORMATS:
        meta = {**meta, "model": LEGACY_FORMATS[fmt]}
    elif fmt != FORMAT:
        raise ValueError(f"{path}: not a mocapviz checkpoint (format {fmt!r})")
    return tensors, meta


def load_checkpoint(path, optimizer: torch.optim.Optimizer | None = None, model: torch.nn.Module | None = None):
    """(model in eval mode, normaliser, metadata dict with JSON values decoded).

    Pass ``model`` and ``optimizer`` to restore into existing objects (for resuming).
    """
    tensors, meta = read_checkpoint(path)
    if model is None:
        model = build_model(meta["model"], meta["model_config"])
    model.load_state_dict({k[6:]: v for k, v in tensors.items() if k.startswith("model.")})
    if sidecar_path(path).is_file():  # fitted after training (mocapviz.models.type_prior)
        model.type_prior = TypePrior.load(sidecar_path(path))
    norm = Normaliser.from_state_dict({k[5:]: v.numpy() for k, v in tensors.items() if k.startswith("norm.")})
    if optimizer is not None:
        if "optim_param_groups" not in meta:
            raise ValueError(f"{path} holds no optimizer state; cannot resume from it")
        state: dict = {}
        for k, v in tensors.items():
            if k.startswith("optim."):
                _, pid, name = k.split(".", 2)
                state.setdefault(int(pid), {})[name] = v
        optimizer.load_state_dict({"state": state, "param_groups": json.loads(meta["optim_param_groups"])})
    model.eval()
    return model, norm, decode_metadata(meta)


def decode_metadata(meta: dict[str, str]) -> dict:
    """Checkpoint metadata with its JSON values decoded (plain strings stay strings)."""
    decoded = {}
    for k, v in meta.items():
        try:
            decoded[k] = json.loads(v)
        except (json.JSONDecodeError, TypeError):
            decoded[k] = v
    return decoded
