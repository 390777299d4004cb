"""The 4D body-motion dataset container: one chi = [Theta, Gamma, Phi] and beta per gait cycle,
with the per-subject shape fits and per-clip retargeting numbers, meshes on demand and a
``.npz`` save/load.

Built (shape fits, retargeting, DTW cycles) and cached by :mod:`data_prep.body4d_dataset`.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from io import StringIO
from pathlib import Path

import numpy as np
import pandas as pd

from mocapviz.atomic import atomic_path


def _frame_bytes(df: pd.DataFrame) -> np.ndarray:
    return np.frombuffer(df.to_json(orient="split", double_precision=15).encode(), dtype=np.uint8)


@dataclass
class Body4DDataset:
    """chi (N, n_frames, 6K+4) float32, beta (N, 6), one row per cycle in ``cycles``,
    per-subject shape fits in ``subjects``, per-clip retargeting numbers in ``clips``, and the
    segments the segmentation rejected (with a ``reason``: edge, shape, duration, half) in
    ``rejected``.

    Columns of ``cycles`` a model uses: ``split`` ('train'/'val'/'test'), ``test_set``
    ('held_out_subjects', 'held_out_takes', 'held_out_bodies', '' for training and validation),
    ``mirrored`` (an augmentation copy: never in a metric, see :meth:`indices`), ``source``,
    ``type``, ``subject`` (the performer) and ``body`` (whose beta the cycle is on).
    """

    chi: np.ndarray
    beta: np.ndarray
    cycles: pd.DataFrame
    subjects: pd.DataFrame
    clips: pd.DataFrame
    meta: dict = field(default_factory=dict)
    rejected: pd.DataFrame = field(default_factory=pd.DataFrame)

    def __len__(self) -> int:
        return len(self.chi)

    @property
    def gamma_scale(self) -> np.ndarray:
        return np.asarray(self.meta["gamma_scale"])

    def mesh(self, i: int, body=None, on_ground: bool = True):
        """Vertices (n_frames, V, 3) of cycle i (metres, Y up), from chi and beta.

        ``on_ground`` puts the first frame's root back at its height (the Hips above the
        floor), facing +Z at the origin; otherwise the first root is at the origin."""
        from mocapviz.bodies.anny_model import body_model
        from mocapviz.bodies.representation import mesh_chi

        body = body or body_model()
        root0 = (0.0, float(self.cycles["root0_y"].iloc[i]), 0.0) if on_ground else (0.0, 0.0, 0.0)
        return mesh_chi(body, self.beta[i], self.chi[i], self.gamma_scale, root0)

    def indices(self, split: str | None = None, test_set: str | None = None, mirrored: bool = False) -> np.ndarray:
        """Row indices of the cycles of ``split`` ('train'/'val'/'test'; None: all) and ``test_set``
        (None: all), without mirrored copies unless ``mirrored``: what a test metric averages."""
        c = self.cycles
        keep = np.ones(len(c), dtype=bool) if mirrored else ~c["mirrored"].astype(bool).values
        if split is not None:
            keep &= (c["split"] == split).values
        if test_set is not None:
            keep &= (c["test_set"] == test_set).values
        return np.flatnonzero(keep)

    def counts(self, rows="type", columns="subject", table: str = "cycles") -> pd.DataFrame:
        """Cycles (mirrored copies excluded) per ``rows`` and ``columns`` (column names or lists
        of them, e.g. ``counts(["source", "type"], "split")``), with totals; ``table='rejected'``
        counts the rejected segments instead."""
        c = getattr(self, table)
        if not len(c):
            return pd.DataFrame()
        c = c[~c["mirrored"].astype(bool)]

        def cols(k):
            return [c[n] for n in ([k] if isinstance(k, str) else k)]
        return pd.crosstab(cols(rows), cols(columns), margins=True, margins_name="total")

    def save(self, path: str | Path) -> None:
        """One ``.npz`` (tables and meta as JSON bytes), written atomically."""
        arrays = dict(chi=self.chi, beta=self.beta, cycles=_frame_bytes(self.cycles),
                      subjects=_frame_bytes(self.subjects), clips=_frame_bytes(self.clips),
                      rejected=_frame_bytes(self.rejected),
                      meta=np.frombuffer(json.dumps(self.meta).encode(), dtype=np.uint8))
        with atomic_path(Path(path), suffix=".tmp.npz") as tmp:
            np.savez(tmp, **arrays)

    @classmethod
    def load(cls, path: str | Path) -> "Body4DDataset":
        def frame(z, k):
            return pd.read_json(StringIO(z[k].tobytes().decode()), orient="split", dtype=False)

        with np.load(path) as z:
            return cls(z["chi"], z["beta"], frame(z, "cycles"), frame(z, "subjects"), frame(z, "clips"),
                       json.loads(z["meta"].tobytes().decode()),
                       frame(z, "rejected") if "rejected" in z.files else pd.DataFrame())
