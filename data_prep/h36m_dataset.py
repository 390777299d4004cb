"""CCNet on Human3.6M (paper §4.7, Table 6): the dataset, a training run and the table.

``python -m data_prep.h36m_dataset build | train | table``

**What CCNet's representation needs from the exp-map form, and what we did.** The frame vector
x_n (:mod:`mocapviz.features.ccnet`) is built by the same code as for HDM05/CMU/Bandai, on the
H3.6M 32-joint skeleton (n_x = 12 * 32 + 6 = 390) at the protocol's 25 fps (every second
frame), so the network is CCNet "without any additional modifications" but for its sizes:

- *Root.* The files hold root velocities, not poses. :func:`mocapviz.io.h36m.integrate_root`
  integrates the yaw rate and the ground displacement at 50 fps (the full rotation drifts in
  tilt, so the root stays upright at the rest height); that gives the root block (planar
  velocity, heading rate, height), the heading frames and the trajectory control c^d.
- *Skeleton condition c^s.* One skeleton (the prediction papers' bone lengths) for every
  subject, so c^s is constant: the normaliser leaves it at 0 and it carries no information.
- *Motion type c^t.* The action: a one-hot over walking, eating, smoking, discussion.
- *Contacts.* From the feet (LeftFoot/LeftToeBase, ...) as everywhere.

Split: train on S1, S6, S7, S8, S9 and S11 subaction 1; validation (model selection) on S11
subaction 2, the protocol giving no validation set and S5 being the test subject; test on S5
(the trainer's teacher-forced test NLL; Table 6's errors come from
:mod:`mocapviz.tasks.h36m_prediction`). S5 discussion and S7/S9 discussion and smoking are
missing, and S8 smoking was removed (a copy of S5's); see the data README.

Training (:func:`train_config`) is the ``quick`` CCNet on one thread; evaluation
(:func:`mocapviz.tasks.h36m_prediction.ccnet_predictor`) predicts with the generator from the
seed's features (c^d of the seed from its own root path, extrapolated past its end, then the
network's own predicted c^d: no future leaks in).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

import mocapviz.datasets.ccnet as container
from data_prep.cached import load_or_build
from data_prep.catalog import CACHE_DIR
from data_prep.ccnet_dataset import fit_normaliser
from data_prep.sources import find_data_dir
from mocapviz.datasets.ccnet import CCNetDataset, DatasetConfig
from mocapviz.features import ccnet as feat
from mocapviz.io.h36m import H36M_NAMES, h36m_motion
from mocapviz.tasks import h36m_prediction as protocol

DATASET_VERSION = 1
VALIDATION = (11, 2)          # (subject, subaction) held out for model selection
CONFIG = DatasetConfig(fps=protocol.FPS, window=60, sources=("h36m",), test_subject=f"S{protocol.TEST_SUBJECT}",
                       val_subject=f"S{VALIDATION[0]}", seed=0, joints=H36M_NAMES)
MODEL_NAME = "ccnet_h36m"


def _takes(root: Path) -> list[tuple[int, str, int, Path]]:
    """(subject, action, subaction, path) of every file present for the four actions."""
    out = []
    for subject in sorted((*protocol.TRAIN_SUBJECTS, protocol.TEST_SUBJECT)):
        for action in protocol.ACTIONS:
            for sub in (1, 2):
                path = root / "h36m" / f"S{subject}" / f"{action}_{sub}.txt"
                if path.is_file():
                    out.append((subject, action, sub, path))
    return out


def _split(subject: int, sub: int) -> str:
    if subject == protocol.TEST_SUBJECT:
        return "test"
    return "val" if (subject, sub) == VALIDATION else "train"


def dataset_hash(root: Path) -> str:
    h = hashlib.sha256(f"v{DATASET_VERSION}\n{CONFIG.key()}\n".encode())
    for _, _, _, path in _takes(root):
        st = path.stat()
        h.update(f"{path.relative_to(root)}\t{st.st_size}\t{st.st_mtime_ns}\n".encode())
    for code in (feat.__file__, container.__file__, __file__, protocol.__file__):
        h.update(Path(code).read_bytes())
    return h.hexdigest()[:16]


def build_dataset(data_dir=None, cache: bool = True, cache_dir=None) -> CCNetDataset:
    """The H3.6M CCNet dataset (25 fps, 32 joints), from ``cache/h36m/`` when unchanged."""
    root = find_data_dir(data_dir, "h36m")
    cache_dir = Path(cache_dir) if cache_dir is not None else CACHE_DIR / "h36m"
    path = cache_dir / f"h36m-{dataset_hash(root)}.npz"
    return load_or_build(path, lambda p: CCNetDataset.load(p, CONFIG), lambda: _build(root, path),
                         CCNetDataset.save, cache)


def _build(root: Path, path: Path) -> CCNetDataset:
    t0 = time.perf_counter()
    xs, trajs, skels, offsets, rows = [], [], [], [], []
    at = 0
    for subject, action, sub, file in _takes(root):
        m = h36m_motion(protocol.read_take(file), root="integrated", every=2, name=f"S{subject}_{action}_{sub}")
        f = feat.motion_features(m, protocol.FPS)
        n = len(f.x)
        rows.append(dict(clip=m.name, subject=f"S{subject}", source="h36m", motion_type=action,
                         description=action, style="", type=action, type_index=protocol.ACTIONS.index(action),
                         trainable=True, split=_split(subject, sub), start=at, stop=at + n,
                         root_x=f.start_root[0], root_y=f.start_root[1], root_z=f.start_root[2],
                         heading=f.start_heading, height=m.skeleton.standing_height()))
        xs.append(f.x)
        trajs.append(f.traj)
        skels.append(f.skel)
        offsets.append(m.skeleton.offsets)
        at += n
    clips = pd.DataFrame(rows)
    x, traj, skel = np.concatenate(xs), np.concatenate(trajs), np.stack(skels)
    layout = feat.FeatureLayout(len(H36M_NAMES), len(protocol.ACTIONS))
    normaliser = fit_normaliser(x, traj, skel, clips, layout)
    train_rows = np.concatenate([np.arange(r.start, r.stop) for r in clips.itertuples() if r.split == "train"])
    meta = dict(version=DATASET_VERSION, config=json.loads(CONFIG.key()), data_dir=str(root), hash=path.stem,
                build_seconds=round(time.perf_counter() - t0, 2), test_subject=CONFIG.test_subject,
                test_clips=clips[clips.split == "test"]["clip"].tolist(), val_subject=CONFIG.val_subject,
                val_clips=clips[clips.split == "val"]["clip"].tolist(),
                n_train_clips=int((clips.split == "train").sum()), n_frames=len(x),
                n_train_frames=len(train_rows),
                train_mean_joint_speed=float(feat.joint_speed(x[train_rows], layout).mean()),
                motion_types=list(protocol.ACTIONS), joint_names=list(H36M_NAMES))
    return CCNetDataset(x, traj, skel, clips, normaliser, CONFIG, tuple(H36M_NAMES),
                        np.stack(offsets), m.skeleton.parents, meta)


def train_config(steps: int = 2000, size: str = "quick", residual: bool = False):
    """The ``quick`` training config (batch 16, 60-frame windows, Adam 1e-3 decaying to 1e-5, one
    thread) with ``steps`` steps and a CCNet of ``size`` (quick: 20 SRBs, d = 2, CRL 41 frames =
    1.6 s at 25 fps, C = 32); ``steps`` sets the CPU budget. ``residual``: the network predicts
    x_{t+1} - x_t (:class:`mocapviz.models.ccnet_config.CCNetConfig`; not the paper's network)."""
    from mocapviz.training.config import TRAIN_CONFIGS
    return replace(TRAIN_CONFIGS["quick"], size=size, steps=steps, residual=residual, eval_every=250,
                   checkpoint_every=250)


def prediction_table(models: dict | None = None, data_dir=None) -> pd.DataFrame:
    """Table 6 rows (action, ms, model, mae, note): zero-velocity and each CCNet of ``models``
    (name -> (model, normaliser)) on every action whose S5 files exist, the paper's rows beside
    them, and ``not available`` rows (mae NaN) for actions whose test files are missing."""
    root = find_data_dir(data_dir, "h36m") / "h36m"
    seqs, missing = {}, []
    for action in protocol.ACTIONS:
        try:
            seqs[action] = protocol.srnn_sequences(root, action)
        except FileNotFoundError:
            missing.append(action)
    predictors = {"zero_velocity": protocol.zero_velocity}
    predictors.update({name: protocol.ccnet_predictor(*m) for name, m in (models or {}).items()})
    ours = protocol.evaluate(predictors, seqs)
    gaps = pd.DataFrame([dict(action=a, ms=ms, model=m, mae=np.nan, note=f"not available: no S{protocol.TEST_SUBJECT} "
                              f"{a} files in this copy of the data")
                         for a in missing for m in predictors for ms in protocol.HORIZONS_MS])
    return pd.concat([ours.assign(note=""), gaps, protocol.paper_rows().assign(note="CCNet paper, Table 6")],
                     ignore_index=True)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m data_prep.h36m_dataset", description=__doc__.split("\n")[0])
    p.add_argument("command", choices=("build", "train", "table"))
    p.add_argument("--data-dir")
    p.add_argument("--steps", type=int, default=2000, help="train: optimiser steps")
    p.add_argument("--size", default="quick", help="train: CCNet size (quick, default, paper)")
    p.add_argument("--residual", action="store_true", help="train: residual output (x_t + change)")
    p.add_argument("--out", help="train: run folder; table: CSV path")
    p.add_argument("--export", help="train: write the best-by-validation model here")
    p.add_argument("--model", action="append", default=[],
                   help="table: a CCNet checkpoint (repeatable; named by its file stem)")
    a = p.parse_args(argv)
    t = time.perf_counter()
    if a.command == "build":
        ds = build_dataset(a.data_dir)
        print(f"{len(ds.clips)} takes, {ds.meta['n_frames']} frames ({ds.meta['n_train_frames']} train) at "
              f"{ds.config.fps:g} fps; {time.perf_counter() - t:.1f} s ({ds.meta['hash']})")
        print(ds.table().to_string())
    elif a.command == "train":
        from mocapviz.training.runs import export_model
        from mocapviz.training.trainer import train
        train(build_dataset(a.data_dir), train_config(a.steps, a.size, a.residual), a.out or "cache/runs/ccnet_h36m")
        if a.export:
            print(f"exported {export_model(Path(a.out or 'cache/runs/ccnet_h36m'), a.export)}")
    else:
        from mocapviz.training.checkpoint import load_checkpoint
        models = {Path(f).stem: load_checkpoint(f)[:2] for f in a.model}
        table = prediction_table(models, a.data_dir)
        if a.out:
            table.to_csv(a.out, index=False, float_format="%.4f")
        print(table[table.model.isin(["zero_velocity", "paper_ccnet", *models])]
              .pivot_table(index=["action", "model"], columns="ms", values="mae").round(3).to_string())
        print(f"{time.perf_counter() - t:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
