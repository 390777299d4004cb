"""The CCNet dataset container: stacked frame vectors and controls of every clip, its split,
normaliser and skeletons, with the training windows and a ``.npz`` save/load.

Built (features of every catalog clip, the split, the normaliser) and cached by
:mod:`data_prep.ccnet_dataset`; see there for the split and the window-length choice.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field, replace
from io import StringIO
from pathlib import Path

import numpy as np
import pandas as pd

from mocapviz.atomic import atomic_path
from mocapviz.features import ccnet as feat
from mocapviz.features.motion_types import MOTION_TYPES, vocabulary
from mocapviz.skeleton import CCNET_25_JOINTS, Skeleton


@dataclass(frozen=True)
class DatasetConfig:
    fps: float = feat.FPS
    window: int = 120                      # NCF: frames per training window (2 s; see data_prep)
    sources: tuple[str, ...] = ("hdm05", "cmu", "bandai")
    test_subject: str = ""                 # "" = random HDM05 actor (seeded)
    val_subject: str = "mm"                # whole actor held out for validation (model selection)
    bandai_test_share: float = 0.1         # seeded share of Bandai takes per content: test
    bandai_val_share: float = 0.1          # ... and validation
    bandai_takes_per_content: int = 0      # 0 = every take; the quick config keeps a few
    seed: int = 7
    joints: tuple[str, ...] = field(default=CCNET_25_JOINTS)

    @classmethod
    def quick(cls) -> "DatasetConfig":
        """HDM05 + CMU + 3 Bandai takes of each content (seconds to build; CI and quick mode)."""
        return cls(bandai_takes_per_content=3)

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
    offsets: np.ndarray       # (n_clips, J, 3) rest offsets per clip (its skeleton), m
    parents: np.ndarray       # (J,)
    meta: dict

    @property
    def motion_types(self) -> tuple[str, ...]:
        """The dataset's type vocabulary (c^t columns), stored in its metadata."""
        return tuple(self.meta.get("motion_types", MOTION_TYPES))

    @property
    def layout(self) -> feat.FeatureLayout:
        return feat.FeatureLayout(len(self.joint_names), len(self.motion_types))

    def with_vocabulary(self, n_types: int) -> "CCNetDataset":
        """This dataset for a model that knows only the first ``n_types`` motion types (an older
        checkpoint: ``ccnet_default`` has dataset v3's 13): the clips of those types, with a
        c^t one-hot ``n_types`` wide. Frame rows are shared, not copied; indices keep their
        meaning because the vocabulary is append-only (:data:`MOTION_TYPES`)."""
        names = vocabulary(n_types, self.motion_types[:n_types])
        keep = np.flatnonzero(self.clips.type_index.values < n_types)
        return replace(self, clips=self.clips.iloc[keep].reset_index(drop=True), skel=self.skel[keep],
                       offsets=self.offsets[keep], meta={**self.meta, "motion_types": list(names)})

    def table(self) -> pd.DataFrame:
        """Frames (at the dataset's fps) and minutes by (source, type) x split, with totals."""
        c = self.clips.assign(frames=self.clips.stop - self.clips.start)
        t = c.pivot_table(index=["source", "type"], columns="split", values="frames", aggfunc="sum",
                          fill_value=0).reindex(columns=["train", "val", "test"], fill_value=0)
        t["all"] = t.sum(axis=1)
        t.loc[("all", ""), :] = t.sum(axis=0)
        t = t.astype(int)
        minutes = (t / self.config.fps / 60).round(1)
        return pd.concat({"frames": t, "minutes": minutes}, axis=1)

    def skeleton(self, clip_row: int) -> Skeleton:
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
                                       name=r["clip"])

    def clip_row(self, name: str) -> int:
        hits = np.flatnonzero(self.clips["clip"].values == name)
        if not len(hits):
            raise KeyError(f"no clip {name!r} in the dataset")
        return int(hits[0])

    def save(self, path: str | Path) -> None:
        """One ``.npz`` (tables and meta as JSON bytes), written atomically."""
        arrays = dict(x=self.x, traj=self.traj, skel=self.skel, offsets=self.offsets, parents=self.parents,
                      clips=np.frombuffer(self.clips.to_json(orient="split").encode(), dtype=np.uint8),
                      meta=np.frombuffer(json.dumps(self.meta).encode(), dtype=np.uint8))
        arrays.update({f"norm_{k}": v for k, v in self.normaliser.state_dict().items()})
        with atomic_path(Path(path), suffix=".tmp.npz") as tmp:
            np.savez(tmp, **arrays)

    @classmethod
    def load(cls, path: str | Path, config: DatasetConfig | None = None) -> "CCNetDataset":
        """The dataset saved at ``path``; its config comes from its metadata unless given."""
        with np.load(path) as z:
            meta = json.loads(z["meta"].tobytes().decode())
            clips = pd.read_json(StringIO(z["clips"].tobytes().decode()), orient="split")
            norm = feat.Normaliser.from_state_dict({k[5:]: z[k] for k in z.files if k.startswith("norm_")})
            cfg = config or DatasetConfig(**{k: tuple(v) if isinstance(v, list) else v
                                             for k, v in meta["config"].items()})
            return cls(z["x"], z["traj"], z["skel"], clips, norm, cfg, tuple(meta["joint_names"]),
                       z["offsets"], z["parents"], meta)
