"""Build and cache the CCNet dataset (frame vectors, controls, split, normaliser), version 4.

``python -m data_prep build ccnet [--quick]`` (or ``python -m data_prep.ccnet_dataset``) builds
it from the HDM05, CMU and Bandai clips of the catalog: 25 joints, 60 fps (Bandai's 30 fps
resampled by ``Motion.resample``), features of :mod:`mocapviz.features.ccnet`, into a
:class:`mocapviz.datasets.ccnet.CCNetDataset`, cached as one ``.npz`` under ``cache/ccnet/``,
keyed by a hash of the config, the data files and the code, and written atomically.
``DatasetConfig.quick()`` keeps three Bandai takes of each content (CI and quick mode).

Bandai on the same frame vector: its rig rest pose (bones along local X, body folded flat) is
replaced by a T-pose with world-aligned joint frames like HDM05's and CMU's
(:func:`mocapviz.features.ccnet_joints.rebase_rest`, from the standing first frame of
:data:`BANDAI_REST_REFERENCE`; FK positions unchanged), and the four joints it lacks are filled
in by :func:`mocapviz.features.ccnet_joints.complete_ccnet25` with identity rotations: LHipJoint,
RHipJoint and LowerBack at their parent (zero length, as in CMU), Neck1 halfway up the neck.
So the rotation blocks of those joints are constant for Bandai, as LHipJoint's are everywhere.

Split. HDM05/CMU (the analog of the paper's §4.1.1): one whole subject is held out for test
(a seeded HDM05 actor, ``tr`` with seed 7, or ``test_subject``), plus one seeded clip of every
other subject that has at least two clips long enough for a window; validation (model
selection, so the test split never picks a checkpoint) is the whole HDM05 actor
``val_subject`` (``mm``) except the clip the test draw took, so that model selection measures
generalisation to an unseen body. Bandai's actors are not recorded and all share one skeleton,
so no subject can be held out: a seeded share of its takes per content (``bandai_test_share``,
10 %, at least one of a content with three takes) is test and another share
(``bandai_val_share``, 10 %) validation, drawn with their own
generator so the HDM05/CMU draws do not depend on Bandai. Validation takes Bandai takes too
because Bandai holds ~90 % of the frames: a validation set of ``mm`` alone would pick
checkpoints by one body's short HDM05 clips and ignore how the model does on the locomotion it
mostly trains on. Normalisation statistics come from the training clips only. ``meta`` lists
``test_clips``, ``val_clips``, ``val_subject`` and ``motion_types`` (the c^t vocabulary).
Windows never cross clip boundaries.

Window length (the paper's NCF, 240 there): 120 frames (2 s, about two gait cycles of a walk).
Clips and frames (60 fps, trainable clips) that give at least one window, per NCF:

=====  ===================  ==================  =================
NCF    HDM05 (287 clips)    CMU (11)            Bandai (1,256)
=====  ===================  ==================  =================
60     233 clips, 93 %      11, 100 %           1,252, 100 %
120    106, 59 %            8, 83 %             1,223, 99 %
180    40, 32 %             0                   1,049, 92 %
240    22, 21 %             0                   799, 79 %
=====  ===================  ==================  =================

Bandai's one skeleton carries no body variety: that comes from HDM05's five actors and the CMU
subjects, whose clips are short (HDM05 median ~1.8 s). 180 or 240 frames would drop every CMU
body and most HDM05 clips; 120 keeps 99 % of Bandai (runs are 2-3 s), most CMU bodies and the
longer HDM05 clips, and is long enough for two strides. Shorter HDM05 clips stay in the
dataset (test seeds, tables) but give no training windows.
"""

from __future__ import annotations

import hashlib
import json
import time
from functools import lru_cache
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

import data_prep.motion_types as motion_types
import mocapviz.datasets.ccnet as container
import mocapviz.features.ccnet_joints as joints
from data_prep.cached import load_or_build
from mocapviz.atomic import atomic_path
from data_prep.catalog import CACHE_DIR, build_catalog, cache_key, load_motion
from data_prep.motion_types import merged_type, source_label
from data_prep.sources import find_data_dir
from mocapviz.datasets.ccnet import CCNetDataset, DatasetConfig
from mocapviz.features.motion_types import MOTION_TYPES
from mocapviz.features import ccnet as feat

DATASET_VERSION = 4  # 2: validation split; 3: validation = one whole held-out actor; 4: + Bandai, NCF 120
# The Bandai take and frame whose standing pose (straightened) becomes Bandai's rest pose.
BANDAI_REST_REFERENCE = ("dataset-1_bow_normal_001", 0)


def _choose_split(clips: pd.DataFrame, config: DatasetConfig, long_enough: np.ndarray) -> np.ndarray:
    rng = np.random.default_rng(config.seed)
    test_subject = config.test_subject
    if not test_subject:
        actors = sorted(clips[clips.source == "hdm05"].subject.unique())
        test_subject = str(rng.choice(actors))
    if test_subject not in set(clips.subject):
        raise ValueError(f"test subject {test_subject!r} is not in the data")
    split = np.where(clips.subject.values == test_subject, "test", "train").astype(object)
    for subject in sorted(set(clips[clips.source != "bandai"].subject) - {test_subject}):
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
    _split_bandai(clips, config, split)
    return split


def _split_bandai(clips: pd.DataFrame, config: DatasetConfig, split: np.ndarray) -> None:
    """Seeded test and validation shares of Bandai's takes, per content, into ``split``."""
    rng = np.random.default_rng([config.seed, 4])  # its own stream: HDM05/CMU draws stay put
    bandai = clips[clips.source == "bandai"]
    for _, g in bandai.groupby("description", sort=True):
        order = rng.permutation(g.index.values)
        # at least one take each when the content has three (so the quick config has some)
        n_test, n_val = (max(int(round(share * len(order))), int(len(order) >= 3))
                         for share in (config.bandai_test_share, config.bandai_val_share))
        split[order[:n_test]] = "test"
        split[order[n_test:n_test + n_val]] = "val"


def dataset_hash(config: DatasetConfig, root: Path) -> str:
    h = hashlib.sha256(f"v{DATASET_VERSION}\n{config.key()}\n{cache_key(root)}\n".encode())
    for code in (feat.__file__, container.__file__, __file__, joints.__file__, motion_types.__file__):
        h.update(Path(code).read_bytes())
    return h.hexdigest()[:16]


def _catalog(config: DatasetConfig, root: Path) -> pd.DataFrame:
    """The catalog rows of the config's sources (``bandai_takes_per_content`` seeded takes of
    each Bandai content when it is set)."""
    cat = build_catalog(root, sources=tuple(config.sources))
    cat = cat[cat.source.isin(config.sources)]
    k = config.bandai_takes_per_content
    if k:
        rng = np.random.default_rng([config.seed, 5])
        keep = [rng.choice(g.index.values, min(k, len(g)), replace=False)
                for _, g in cat[cat.source == "bandai"].groupby("description", sort=True)]
        cat = pd.concat([cat[cat.source != "bandai"], cat.loc[np.sort(np.concatenate(keep))]])
    return cat.reset_index(drop=True)


@lru_cache(maxsize=2)
def bandai_alignment(root: Path) -> np.ndarray:
    """Bandai's rest re-basing (J, 3, 3) from :data:`BANDAI_REST_REFERENCE` (one skeleton for all)."""
    cat = build_catalog(root, sources=("bandai",))
    clip, frame = BANDAI_REST_REFERENCE
    m = load_motion(cat[cat["clip"] == clip].iloc[0])
    pos, rot = m.global_pose()
    return joints.rest_alignment(m.skeleton, pos[frame], rot[frame])


def write_known_rests(root: Path, path: Path = joints.KNOWN_RESTS_FILE) -> Path:
    """Write the rest re-basing of Bandai's skeleton (:func:`bandai_alignment`) for the mapped
    joints, keyed by their offsets, to ``path`` (read by
    :func:`mocapviz.features.ccnet_joints.known_alignment`)."""
    cat = build_catalog(root, sources=("bandai",))
    m = load_motion(cat[cat["clip"] == BANDAI_REST_REFERENCE[0]].iloc[0])
    sk, a = m.skeleton, bandai_alignment(root)
    mapped = [j for j, name in enumerate(sk.names) if name in joints.CCNET_25_PARENTS]
    entry = {"reference": f"{BANDAI_REST_REFERENCE[0]} frame {BANDAI_REST_REFERENCE[1]}",
             "offsets": {sk.names[j]: np.round(sk.offsets[j], 6).tolist() for j in mapped if j != 0},
             "alignment": {sk.names[j]: np.round(a[j], 9).ravel().tolist() for j in mapped}}
    with atomic_path(path) as tmp:
        Path(tmp).write_text(json.dumps({"bandai": entry}, indent=1) + "\n")
    return path


def load_ccnet_motion(row, root: Path, fps: float = feat.FPS):
    """A catalog row as a Motion on the 25 CCNet joints at ``fps`` (Bandai re-based; see above)."""
    m = load_motion(row)
    if row["source"] == "bandai":
        m = joints.rebase_rest(m, bandai_alignment(root))
    return feat.prepare_motion(m, fps)


def _extract(config: DatasetConfig, root: Path, progress: bool):
    cat = _catalog(config, root)
    xs, trajs, skels, offs, rows = [], [], [], [], []
    parents = names = None
    at = 0
    for r in tqdm(cat.itertuples(), total=len(cat), desc="ccnet features", disable=not progress):
        m = load_ccnet_motion(r._asdict(), root, config.fps)
        if m.n_frames < 3:
            continue
        if m.skeleton.names != tuple(config.joints):
            raise ValueError(f"{r.clip}: joints {m.skeleton.names} are not the config's {config.joints}")
        f = feat.motion_features(m, config.fps)
        names, parents = m.skeleton.names, m.skeleton.parents
        mtype = merged_type(r.source, source_label(r))
        n = len(f.x)
        rows.append(dict(clip=r.clip, subject=r.subject, source=r.source, motion_type=r.motion_type,
                         description=r.description, style=r.style, type=mtype,
                         type_index=MOTION_TYPES.index(mtype), trainable=bool(r.trainable),
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


def _train_rows(clips: pd.DataFrame) -> np.ndarray:
    return np.concatenate([np.arange(r.start, r.stop) for r in clips.itertuples() if r.split == "train"])


def fit_normaliser(x: np.ndarray, traj: np.ndarray, skel: np.ndarray, clips: pd.DataFrame,
                   layout: feat.FeatureLayout) -> feat.Normaliser:
    """The normaliser of the training clips' rows of x (N, n_x), traj (N, 12) and their c^s."""
    rows = _train_rows(clips)
    frame_clip = np.repeat(np.arange(len(clips)), (clips.stop - clips.start).values)
    return feat.Normaliser.fit(x[rows], skel[frame_clip[rows]], traj[rows], layout.n_continuous)


def _build(config: DatasetConfig, root: Path, path: Path, progress: bool) -> CCNetDataset:
    t0 = time.perf_counter()
    x, traj, skel, clips, offsets, names, parents = _extract(config, root, progress)
    layout = feat.FeatureLayout(len(names), len(MOTION_TYPES))
    long_enough = ((clips.stop - clips.start) >= config.window + 2).values & clips.trainable.values
    clips["split"] = _choose_split(clips, config, long_enough)
    train_rows = _train_rows(clips)
    train_clips = (clips.split == "train").values
    normaliser = fit_normaliser(x, traj, skel, clips, layout)
    train_speed = feat.joint_speed(x[train_rows], layout)
    meta = dict(version=DATASET_VERSION, config=json.loads(config.key()), data_dir=str(root),
                hash=path.stem, build_seconds=round(time.perf_counter() - t0, 2),
                test_subject=str(clips[(clips.split == "test") & (clips.source != "bandai")].subject.value_counts().index[0]),
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
        ds = build_dataset(DatasetConfig.quick() if quick else DatasetConfig(), data_dir)
        return (f"{len(ds.clips)} clips, {len(ds.x)} frames at {ds.config.fps:g} fps, test subject "
                f"{ds.meta['test_subject']} ({time.perf_counter() - t:.1f} s)")
except ImportError:
    pass


def main(argv=None) -> int:
    import argparse
    p = argparse.ArgumentParser(prog="python -m data_prep.ccnet_dataset", description=__doc__.split("\n")[0])
    p.add_argument("--data-dir")
    p.add_argument("--no-cache", action="store_true")
    p.add_argument("--quick", action="store_true", help="3 Bandai takes per content (DatasetConfig.quick)")
    a = p.parse_args(argv)
    t = time.perf_counter()
    ds = build_dataset(DatasetConfig.quick() if a.quick else DatasetConfig(), a.data_dir, cache=not a.no_cache)
    m = ds.meta
    print(f"{len(ds.clips)} clips, {m['n_frames']} frames ({m['n_train_frames']} train) at "
          f"{ds.config.fps:g} fps; test subject {m['test_subject']} + {len(m['test_clips'])} test clips "
          f"in all; {len(m['val_clips'])} validation clips; {time.perf_counter() - t:.1f} s ({m['hash']})")
    print(ds.table().to_string())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
