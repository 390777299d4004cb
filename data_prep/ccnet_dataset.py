"""Build and cache the CCNet dataset (frame vectors, controls, split, normaliser).

``python -m data_prep build ccnet`` (or ``python -m data_prep.ccnet_dataset``) builds it from
the HDM05 and CMU clips of the catalog: 25 joints, 60 fps, features of
:mod:`mocapviz.features.ccnet`, into a :class:`mocapviz.datasets.ccnet.CCNetDataset`. The
result is cached as one ``.npz`` under
``cache/ccnet/``, keyed by a hash of the config, the data files and the feature code, and
written atomically.

Split (the analog of the paper's §4.1.1): one whole subject is held out (chosen at random with
the config's seed among the HDM05 actors, or named by ``test_subject``), plus one random clip
of every other subject that has at least two clips long enough for a window (the CMU subjects
here have one usable clip each, so holding one out would hold out the subject). Validation
(for model selection, so the test split never picks a checkpoint) is one other whole HDM05
actor, ``val_subject`` (``mm`` by default, the other test actor of the HDM05 source split), so
that model selection measures generalisation to an unseen body and style as the test subject
does: every clip of that actor is validation except the one the test draw took (the test draw
is the same as in dataset versions 1 and 2, from the config's seed, so the test split is
unchanged; with seed 7 it takes one clip of ``mm``, which stays in test). Version 2 used one
clip of each training actor for validation instead; its validation NLL kept falling while the
held-out subject's rose (overfitting to the training actors). ``meta`` lists ``test_clips``,
``val_clips`` and ``val_subject``. Normalisation statistics come from the training clips only.
Windows never cross clip boundaries.

Window length (the paper's NCF, 240 there): our clips are short (HDM05 median ~1.8 s), so NCF
defaults to 60 frames (1 s, the shortest NCF of the paper's §4.8.1): with 60, 244 of 302
clips give windows, 93% of the frames; with 240 only 22 clips would. 60 still exceeds the
receptive field (41), so most of every window is predicted with full context.
"""

from __future__ import annotations

import hashlib
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

import mocapviz.datasets.ccnet as container
from data_prep.cached import load_or_build
from data_prep.catalog import CACHE_DIR, build_catalog, cache_key, load_motion
from data_prep.motion_types import merged_type
from data_prep.sources import find_data_dir
from mocapviz.datasets.ccnet import CCNetDataset, DatasetConfig
from mocapviz.features.motion_types import MOTION_TYPES
from mocapviz.features import ccnet as feat

DATASET_VERSION = 3  # 2: validation split; 3: validation = one whole held-out actor


def _choose_split(clips: pd.DataFrame, config: DatasetConfig, long_enough: np.ndarray) -> np.ndarray:
    rng = np.random.default_rng(config.seed)
    test_subject = config.test_subject
    if not test_subject:
        actors = sorted(clips[clips.source == "hdm05"].subject.unique())
        test_subject = str(rng.choice(actors))
    if test_subject not in set(clips.subject):
        raise ValueError(f"test subject {test_subject!r} is not in the data")
    split = np.where(clips.subject.values == test_subject, "test", "train").astype(object)
    for subject in sorted(set(clips.subject) - {test_subject}):
        cand = np.flatnonzero((clips.subject.values == subject) & long_enough)
        if len(cand) >= 2:
            split[rng.choice(cand)] = "test"
    # validation: every remaining clip of one whole other actor (its test clip, if the draw above
    # took one, stays in test so that the test split is the one of dataset versions 1 and 2)
    val_subject = config.val_subject
    if not val_subject:
        raise ValueError("val_subject must name a subject (a whole actor held out for validation)")
    if val_subject == test_subject:
        raise ValueError(f"val_subject {val_subject!r} is the test subject; choose another actor")
    if val_subject not in set(clips.subject):
        raise ValueError(f"validation subject {val_subject!r} is not in the data")
    split[(clips.subject.values == val_subject) & (split == "train")] = "val"
    return split


def dataset_hash(config: DatasetConfig, root: Path) -> str:
    h = hashlib.sha256(f"v{DATASET_VERSION}\n{config.key()}\n{cache_key(root)}\n".encode())
    for code in (feat.__file__, container.__file__, __file__):
        h.update(Path(code).read_bytes())
    return h.hexdigest()[:16]


def _extract(config: DatasetConfig, root: Path, progress: bool):
    cat = build_catalog(root)
    cat = cat[cat.source.isin(config.sources)].reset_index(drop=True)
    xs, trajs, skels, offs, rows = [], [], [], [], []
    parents = names = None
    at = 0
    for r in tqdm(cat.itertuples(), total=len(cat), desc="ccnet features", disable=not progress):
        m = feat.prepare_motion(load_motion(r._asdict()), config.fps)
        if m.n_frames < 3:
            continue
        m = m.keep_joints(config.joints) if m.skeleton.names != tuple(config.joints) else m
        f = feat.motion_features(m, config.fps)
        names, parents = m.skeleton.names, m.skeleton.parents
        mtype = merged_type(r.source, r.motion_type)
        n = len(f.x)
        rows.append(dict(clip=r.clip, subject=r.subject, source=r.source, motion_type=r.motion_type,
                         type=mtype, type_index=MOTION_TYPES.index(mtype), trainable=bool(r.trainable),
                         start=at, stop=at + n, root_x=f.start_root[0], root_y=f.start_root[1],
                         root_z=f.start_root[2], heading=f.start_heading,
                         height=m.skeleton.standing_height()))
        xs.append(f.x)
        trajs.append(f.traj)
        skels.append(f.skel)
        offs.append(m.skeleton.offsets)
        at += n
    clips = pd.DataFrame(rows)
    return (np.concatenate(xs), np.concatenate(trajs), np.stack(skels), clips, np.stack(offs),
            tuple(names), np.asarray(parents))


def build_dataset(config: DatasetConfig = DatasetConfig(), data_dir=None, cache: bool = True,
                  cache_dir: str | Path | None = None, progress: bool = True) -> CCNetDataset:
    """The CCNet dataset for ``config``, from the cache when the inputs are unchanged."""
    root = find_data_dir(data_dir)
    cache_dir = Path(cache_dir) if cache_dir is not None else CACHE_DIR / "ccnet"
    path = cache_dir / f"ccnet-{dataset_hash(config, root)}.npz"
    return load_or_build(path, lambda p: CCNetDataset.load(p, config), lambda: _build(config, root, path, progress),
                         CCNetDataset.save, cache)


def _build(config: DatasetConfig, root: Path, path: Path, progress: bool) -> CCNetDataset:
    t0 = time.perf_counter()
    x, traj, skel, clips, offsets, names, parents = _extract(config, root, progress)
    layout = feat.FeatureLayout(len(names))
    long_enough = ((clips.stop - clips.start) >= config.window + 2).values & clips.trainable.values
    clips["split"] = _choose_split(clips, config, long_enough)
    train_rows = np.concatenate([np.arange(r.start, r.stop) for r in clips.itertuples() if r.split == "train"])
    train_clips = (clips.split == "train").values
    frame_clip = np.repeat(np.arange(len(clips)), (clips.stop - clips.start).values)
    normaliser = feat.Normaliser.fit(x[train_rows], skel[frame_clip[train_rows]], traj[train_rows],
                                     layout.n_continuous)
    train_speed = feat.joint_speed(x[train_rows], layout)
    meta = dict(version=DATASET_VERSION, config=json.loads(config.key()), data_dir=str(root),
                hash=path.stem, build_seconds=round(time.perf_counter() - t0, 2),
                test_subject=str(clips[clips.split == "test"].subject.value_counts().index[0]),
                test_clips=clips[clips.split == "test"]["clip"].tolist(),
                val_subject=config.val_subject,
                val_clips=clips[clips.split == "val"]["clip"].tolist(),
                n_train_clips=int(train_clips.sum()), n_frames=int(len(x)),
                n_train_frames=int(len(train_rows)), train_mean_joint_speed=float(train_speed.mean()),
                motion_types=list(MOTION_TYPES), joint_names=list(names))
    return CCNetDataset(x, traj, skel, clips, normaliser, config, names, offsets, parents, meta)


try:  # register `python -m data_prep build ccnet` when the build registry exists
    from data_prep.build import register_build

    @register_build("ccnet", help="CCNet frame vectors, controls, split and normaliser (cache/ccnet/)")
    def build_ccnet_target(data_dir=None, quick=False) -> str:
        t = time.perf_counter()
        ds = build_dataset(DatasetConfig(), data_dir)
        return (f"{len(ds.clips)} clips, {len(ds.x)} frames at {ds.config.fps:g} fps, test subject "
                f"{ds.meta['test_subject']} ({time.perf_counter() - t:.1f} s)")
except ImportError:
    pass


def main(argv=None) -> int:
    import argparse
    p = argparse.ArgumentParser(prog="python -m data_prep.ccnet_dataset", description=__doc__.split("\n")[0])
    p.add_argument("--data-dir")
    p.add_argument("--no-cache", action="store_true")
    a = p.parse_args(argv)
    t = time.perf_counter()
    ds = build_dataset(DatasetConfig(), a.data_dir, cache=not a.no_cache)
    m = ds.meta
    print(f"{len(ds.clips)} clips, {m['n_frames']} frames ({m['n_train_frames']} train) at "
          f"{ds.config.fps:g} fps; test subject {m['test_subject']} + {len(m['test_clips'])} test clips "
          f"in all; {len(m['val_clips'])} validation clips; {time.perf_counter() - t:.1f} s ({m['hash']})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
