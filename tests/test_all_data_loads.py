"""Every file of the real data folder loads, and FK keeps every bone length on every frame."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from data_prep.catalog import build_catalog, load_motion
from data_prep.sources import SOURCES
from mocapviz.skeleton import CCNET_25_JOINTS, VICON_BVH_TO_ASF


@pytest.fixture(scope="module")
def all_sources(data_dir):
    return build_catalog(data_dir, cache=False, sources=SOURCES)


@pytest.mark.parametrize("source", SOURCES)
def test_every_file_loads_and_keeps_bone_lengths(all_sources, data_dir, source):
    catalog = all_sources
    if not (data_dir / source).is_dir():
        pytest.skip(f"no {source} folder in {data_dir}")
    rows = catalog[catalog.source == source]
    on_disk = {"hdm05": "*/*.amc", "cmu": "*/*.bvh", "h36m": "S*/*.txt", "bandai": "*/*.bvh"}[source]
    assert len(rows) == len(list((data_dir / source).glob(on_disk))) > 0
    worst = 0.0
    for _, row in rows.iterrows():
        m = load_motion(row)
        assert m.n_frames == row["frames"] and m.fps == row["fps"], row["clip"]
        assert np.isfinite(m.rotations).all() and np.isfinite(m.root_positions).all()
        if source in ("hdm05", "cmu"):
            assert set(m.skeleton.names) == set(VICON_BVH_TO_ASF), row["clip"]
        if source == "bandai":
            assert set(m.skeleton.names) < set(CCNET_25_JOINTS) and m.skeleton.names[0] == "Hips"
            np.testing.assert_allclose(m.root_positions, bandai_reference_hips(row["path"]), atol=1e-6,
                                       err_msg=row["clip"])
        sk = m.skeleton
        pos = m.positions()
        seg = np.linalg.norm(pos[:, 1:] - pos[:, sk.parents[1:]], axis=-1)
        worst = max(worst, float(np.abs(seg - sk.bone_lengths()[1:]).max()))
    assert worst < 1e-6, f"{source}: a bone length changed by {worst:.2e} m"


def bandai_reference_hips(path) -> np.ndarray:
    """Hips' world trajectory (F, 3) in metres, straight from the file: the reference root's
    translation plus its rotation (channels Z X Y, intrinsic) applied to Hips' position channels."""
    with open(path) as f:
        for line in f:
            if line.strip().startswith("Frame Time"):
                break
        values = np.loadtxt(f, ndmin=2)
    assert values.shape[1] == 132  # 22 joints x 6 channels
    root_rot = Rotation.from_euler("ZXY", values[:, 3:6], degrees=True)
    return (values[:, 0:3] + root_rot.apply(values[:, 6:9])) * 0.01
