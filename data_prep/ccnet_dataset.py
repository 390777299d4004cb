"""Build and cache the CCNet dataset (frame vectors, controls, split, normaliser).

``python -m data_prep build ccnet`` (or ``python -m data_prep.ccnet_dataset``) builds it from
the HDM05 and CMU clips of the catalog: 25 joints, 60 fps, features of
:mod:`mocapviz.features.ccnet`. The result is cached as one ``.npz`` under
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
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from data_prep.cached import load_or_build
from data_prep.catalog import CACHE_DIR, build_catalog, cache_key, load_motion
from data_prep.sources import find_data_dir
from mocapviz.atomic import atomic_path
from mocapviz.features import ccnet as feat
from mocapviz.skeleton import CCNET_25_JOINTS

DATASET_VERSION = 3  # 2: validation split; 3: validation = one whole held-out actor


@dataclass(frozen=True)
class DatasetConfig:
    fps: float = feat.FPS
    window: int = 60                       # NCF: frames per training window
    sources: tuple[str, ...] = ("hdm05", "cmu")
    test_subject: str = ""                 # "" = random HDM05 actor (seeded)
    val_subject: str = "mm"                # whole actor held out for validation (model selection)
    seed: int = 7
    joints: tuple[str, ...] = field(default=CCNET_25_JOINTS)

    def key(self) -> str:
        return json.dumps(asdict(self), sort_keys=True)


@dataclass
class CCNetDataset:
    """Frame vectors of every clip, stacked; ``clips`` says where each clip's rows are."""

    x: np.ndarray             # (N, n_x) raw (unnormalised) frame vectors
    traj: np.ndarray          # (N, 12) raw c^d
    skel: np.ndarray          # (n_clips, 3J-2) raw c^s per clip
    clips: pd.DataFrame       # clip, subject, source, motion_type, type, type_index, split
                              # (train / val / test), start, stop, ...
    normaliser: feat.Normaliser
    config: DatasetConfig
    joint_names: tuple[str, ...]
    offsets: np.ndarray       # (n_clips, J, 3) rest offsets per clip (its skeleton)
    parents: np.ndarray       # (J,)
    meta: dict

    @property
    def layout(self) -> feat.FeatureLayout:
        return feat.FeatureLayout(len(self.joint_names))

    def skeleton(self, clip_row: int):
        from mocapviz.skeleton import Skeleton
        return Skeleton(self.joint_names, self.parents, self.offsets[clip_row])

    def window_starts(self, split: str, window: int | None = None, stride: int = 1) -> np.ndarray:
        """(n, 2) array of (clip row, start within the clip's rows) of every window of the split.

        A window of length W at start s uses inputs s..s+W-1, controls and targets s+1..s+W
        and predicted controls s+2..s+W+1, all inside the clip.
        """
        w = window or self.config.window
        out = []
        for i, r in enumerate(self.clips.itertuples()):
            n = r.stop - r.start
            if r.split != split or not r.trainable or n < w + 2:
                continue
            s = np.arange(0, n - w - 1, stride)
            out.append(np.stack([np.full(len(s), i), s], axis=1))
        return np.concatenate(out) if out else np.zeros((0, 2), dtype=np.int64)

    def clip_arrays(self, clip_row: int) -> dict[str, np.ndarray]:
        r = self.clips.iloc[clip_row]
        sl = slice(int(r.start), int(r.stop))
        return dict(x=self.x[sl], traj=self.traj[sl], skel=self.skel[clip_row],
                    type_index=int(r.type_index))

    def clip_motion(self, clip_row: int):
        """The clip as a Motion rebuilt from its features (frames 1.. of the 60 fps clip)."""
        r = self.clips.iloc[clip_row]
        return feat.features_to_motion(self.x[int(r.start):int(r.stop)], self.skeleton(clip_row),
                                       (r.root_x, r.root_y, r.root_z), r.heading, self.config.fps,
                                       name=r.clip)

    def clip_row(self, name: str) -> int:
        hits = np.flatnonzero(self.clips["clip"].values == name)
        if not len(hits):
            raise KeyError(f"no clip {name!r} in the dataset")
        return int(hits[0])


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
    h.update(Path(feat.__file__).read_bytes())
    h.update(Path(__file__).read_bytes())
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
        mtype = feat.merged_type(r.source, r.motion_type)
        n = len(f.x)
        rows.append(dict(clip=r.clip, subject=r.subject, source=r.source, motion_type=r.motion_type,
                         type=mtype, type_index=feat.MOTION_TYPES.index(mtype), trainable=bool(r.trainable),
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
    return load_or_build(path, lambda p: load_dataset(p, config), lambda: _build(config, root, path, progress),
                         save_dataset, cache)


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
                                     layout.n_cont)
    train_speed = feat.joint_speed(x[train_rows], layout)
    meta = dict(version=DATASET_VERSION, config=json.loads(config.key()), data_dir=str(root),
                hash=path.stem, build_seconds=round(time.perf_counter() - t0, 2),
                test_subject=str(clips[clips.split == "test"].subject.value_counts().index[0]),
                test_clips=clips[clips.split == "test"]["clip"].tolist(),
                val_subject=config.val_subject,
                val_clips=clips[clips.split == "val"]["clip"].tolist(),
                n_train_clips=int(train_clips.sum()), n_frames=int(len(x)),
                n_train_frames=int(len(train_rows)), train_mean_joint_speed=float(train_speed.mean()),
                motion_types=list(feat.MOTION_TYPES), joint_names=list(names))
    return CCNetDataset(x, traj, skel, clips, normaliser, config, names, offsets, parents, meta)


def save_dataset(ds: CCNetDataset, path: Path) -> None:
    arrays = dict(x=ds.x, traj=ds.traj, skel=ds.skel, offsets=ds.offsets, parents=ds.parents,
                  clips=np.frombuffer(ds.clips.to_json(orient="split").encode(), dtype=np.uint8),
                  meta=np.frombuffer(json.dumps(ds.meta).encode(), dtype=np.uint8))
    arrays.update({f"norm_{k}": v for k, v in ds.normaliser.state_dict().items()})
    with atomic_path(path, suffix=".tmp.npz") as tmp:
        np.savez(tmp, **arrays)


def load_dataset(path: str | Path, config: DatasetConfig | None = None) -> CCNetDataset:
    from io import StringIO
    with np.load(path) as z:
        meta = json.loads(z["meta"].tobytes().decode())
        clips = pd.read_json(StringIO(z["clips"].tobytes().decode()), orient="split")
        norm = feat.Normaliser.from_state_dict({k[5:]: z[k] for k in z.files if k.startswith("norm_")})
        cfg = config or DatasetConfig(**{k: tuple(v) if isinstance(v, list) else v
                                         for k, v in meta["config"].items()})
        return CCNetDataset(z["x"], z["traj"], z["skel"], clips, norm, cfg, tuple(meta["joint_names"]),
                            z["offsets"], z["parents"], meta)


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
