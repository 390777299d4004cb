"""The body4d dataset build on one real subject: layout, ranges, split, cache round trip."""

from __future__ import annotations

import time

import numpy as np
import pandas as pd
import pytest

from data_prep.body4d_dataset import Body4DConfig, build_dataset
from mocapviz.datasets.body4d import Body4DDataset


@pytest.fixture(scope="module")
def built(data_dir, tmp_path_factory):
    cache = tmp_path_factory.mktemp("body4d")
    cfg = Body4DConfig(subjects=("cmu07", "cmu09"), clips_per_type=1, fit_steps=40, mirror=True)
    ds = build_dataset(cfg, data_dir, cache_dir=cache, progress=False)
    return cfg, ds, cache


def test_layout_ranges_and_split(built):
    cfg, ds, _ = built
    assert len(ds) >= 2
    assert ds.chi.shape[1:] == (100, 130) and ds.beta.shape == (len(ds), 6)
    n_theta = 126
    gamma, phi = ds.chi[..., n_theta:n_theta + 3], ds.chi[..., -1]
    assert np.abs(gamma).max() <= 1 + 1e-6 and np.isclose(np.abs(gamma).max(), 1)
    assert phi.min() == 0 and phi.max() <= 1
    np.testing.assert_array_equal(gamma[:, 0], 0)
    assert set(ds.cycles.loc[ds.cycles.subject == "cmu09", "split"]) == {"test"}
    assert set(ds.cycles.loc[ds.cycles.subject == "cmu07", "split"]) == {"train"}
    assert (ds.subjects.err_after_cm < ds.subjects.err_before_cm).all()
    assert ds.meta["chi_joints"][0] == "Hips" and len(ds.meta["chi_joints"]) == 21


def test_mirror_augmentation_swaps_the_cycle_sides(built):
    _, ds, _ = built
    c = ds.cycles
    orig = {(r.clip, r.start, r.end, r.side) for r in c[~c.mirrored].itertuples()}
    mirr = {(r.clip, r.start, r.end, {"L": "R", "R": "L"}[r.side]) for r in c[c.mirrored].itertuples()}
    assert orig and orig == mirr
    assert ds.counts().loc["total", "total"] == len(orig)  # counts exclude the augmentation


def test_cache_round_trip(built, data_dir):
    cfg, ds, cache = built
    files = list(cache.glob("body4d-*.npz"))
    assert len(files) == 1
    t = time.perf_counter()
    again = build_dataset(cfg, data_dir, cache_dir=cache, progress=False)
    assert time.perf_counter() - t < 5
    np.testing.assert_array_equal(again.chi, ds.chi)
    np.testing.assert_array_equal(Body4DDataset.load(files[0]).beta, ds.beta)
    pd.testing.assert_frame_equal(again.cycles, ds.cycles, check_dtype=False, rtol=1e-12)


def test_mesh_on_demand_stands_on_the_ground(built):
    _, ds, _ = built
    v = ds.mesh(0).numpy()
    assert v.shape == (100, 13718, 3)
    assert abs(v[:, :, 1].min()) < 0.08  # feet near the floor (y = 0) somewhere in the cycle
