"""``python -m data_prep fit-type-prior --model ccnet_generate``: fit a latent CCNet's
prior of z given the motion type (:mod:`mocapviz.tasks.type_prior_fit`) on the training clips of the
CCNet dataset, and write it beside the checkpoint, where loading the model finds it.
"""

from __future__ import annotations

import argparse


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--model", required=True, help="a .safetensors checkpoint, or a model name in models/zoo/")
    p.add_argument("--data-dir")
    p.add_argument("--dataset", choices=("full", "quick"), default="full",
                   help="the CCNet dataset whose training clips are fitted (the model's own)")


def run(a: argparse.Namespace) -> int:
    import numpy as np

    from data_prep.ccnet_dataset import DatasetConfig, build_dataset
    from mocapviz.features.motion_types import MOTION_TYPES
    from mocapviz.models.type_prior import sidecar_path
    from mocapviz.tasks.type_prior_fit import fit_type_prior
    from mocapviz.training.checkpoint import load_checkpoint
    from mocapviz.zoo import find_checkpoint

    path = find_checkpoint(a.model)
    model, norm, _ = load_checkpoint(path)
    ds = build_dataset(DatasetConfig.quick() if a.dataset == "quick" else DatasetConfig(), a.data_dir,
                       progress=True).with_vocabulary(model.cfg.n_types)
    rows = np.flatnonzero(((ds.clips.split == "train") & ds.clips.trainable).values)
    prior = fit_type_prior(model, norm, (ds.clip_arrays(int(r)) for r in rows), progress=True, total=len(rows))
    out = prior.save(sidecar_path(path))
    for t in np.flatnonzero(prior.counts):
        cov = prior.chol[t] @ prior.chol[t].T
        print(f"{MOTION_TYPES[t]:18s} {prior.counts[t]:6d} knots  |mean| {np.linalg.norm(prior.mean[t]):5.2f}  "
              f"trace(cov) {np.trace(cov):6.2f}")
    print(f"written {out}")
    return 0
