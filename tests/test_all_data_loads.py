"""Every file of the real data folder loads, and FK keeps every bone length on every frame."""

from __future__ import annotations

import numpy as np
import pytest

from data_prep.catalog import load_motion
from mocapviz.skeleton import VICON_BVH_TO_ASF


@pytest.mark.parametrize("source", ["hdm05", "cmu", "h36m"])
def test_every_file_loads_and_keeps_bone_lengths(catalog, data_dir, source):
    rows = catalog[catalog.source == source]
    on_disk = {"hdm05": "*/*.amc", "cmu": "*/*.bvh", "h36m": "S*/*.txt"}[source]
    assert len(rows) == len(list((data_dir / source).glob(on_disk))) > 0
    worst = 0.0
    for _, row in rows.iterrows():
        m = load_motion(row)
        assert m.n_frames == row["frames"] and m.fps == row["fps"], row["clip"]
        assert np.isfinite(m.rotations).all() and np.isfinite(m.root_positions).all()
        if source in ("hdm05", "cmu"):
            assert set(m.skeleton.names) == set(VICON_BVH_TO_ASF), row["clip"]
        sk = m.skeleton
        pos = m.positions()
        seg = np.linalg.norm(pos[:, 1:] - pos[:, sk.parents[1:]], axis=-1)
        worst = max(worst, float(np.abs(seg - sk.bone_lengths()[1:]).max()))
    assert worst < 1e-6, f"{source}: a bone length changed by {worst:.2e} m"
