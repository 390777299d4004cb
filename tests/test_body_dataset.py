"""The body4d dataset build on one real subject: layout, ranges, split, cache round trip."""

from __future__ import annotations

import time

import numpy as np
import pandas as pd
import pytest

from data_prep.body4d_dataset import Body4DConfig, build_dataset
from data_prep.body4d_splits import gamma_scale, held_out_takes
from mocapviz.datasets.body4d import Body4DDataset


@pytest.fixture(scope="module")
def built(data_dir, tmp_path_factory):
    cache = tmp_path_factory.mktemp("body4d")
    cfg = Body4DConfig(subjects=("cmu07", "cmu09", "cmu08", "bd", "bandai1"), clips_per_type=1, fit_steps=40,
                       mirror=True)
    ds = build_dataset(cfg, data_dir, cache_dir=cache, progress=False)
    return cfg, ds, cache


def test_layout_ranges_and_split(built):
    cfg, ds, _ = built
    assert len(ds) >= 2
    assert ds.chi.shape[1:] == (100, 130) and ds.beta.shape == (len(ds), 6)
    n_theta = 126
    gamma, phi = ds.chi[..., n_theta:n_theta + 3], ds.chi[..., -1]
    train = (ds.cycles["split"] == "train").values
    # scaled by the training cycles alone: they span [-1, 1] on each axis; test cycles may not
    np.testing.assert_allclose(np.abs(gamma[train]).max(axis=(0, 1)), 1, atol=1e-6)
    assert phi.min() == 0 and phi.max() <= 1
    np.testing.assert_array_equal(gamma[:, 0], 0)
    assert set(ds.cycles.loc[ds.cycles.subject == "cmu09", "split"]) == {"test"}
    assert set(ds.cycles.loc[ds.cycles.subject == "cmu07", "split"]) == {"train"}
    assert set(ds.cycles.loc[ds.cycles.subject == "bd", "split"]) == {"train"}  # HDM05's bodies train
    assert set(ds.cycles.loc[ds.cycles.subject == "cmu09", "test_set"]) == {"held_out_subjects"}
    bandai = ds.cycles[ds.cycles.source == "bandai"]
    assert len(bandai) and set(bandai["test_set"]) <= {"", "held_out_takes", "held_out_bodies"}
    np.testing.assert_array_equal(bandai["clip"].isin(ds.meta["test_takes"]), bandai["split"] == "test")
    np.testing.assert_array_equal(bandai["clip"].isin(ds.meta["validation_takes"]), bandai["split"] == "val")
    # bodies: a training take on a training body, a held-out take on Bandai's body or a held-out one
    train_bodies, test_bodies = set(ds.meta["train_bodies"]), set(ds.meta["test_bodies"])
    assert set(bandai.loc[bandai.split != "test", "body"]) <= train_bodies
    assert set(bandai.loc[bandai.test_set == "held_out_takes", "body"]) == {"bandai1"}
    assert set(bandai.loc[bandai.test_set == "held_out_bodies", "body"]) <= test_bodies == {"cmu09"}
    assert not train_bodies & test_bodies
    other = ds.cycles[ds.cycles.source != "bandai"]
    assert (other["body"] == other["subject"]).all()
    # each cycle carries its body's beta
    fitted = ds.subjects.set_index("subject")
    for r, b in zip(ds.cycles.itertuples(), ds.beta):
        np.testing.assert_allclose(b, fitted.loc[r.body, ds.meta["beta_labels"]].to_numpy(float), atol=1e-5)
    assert (ds.subjects.err_after_cm < ds.subjects.err_before_cm).all()
    assert (ds.subjects.set_index("subject").loc[["bd"], "gender"] == 0).all()  # HDM05's actors are men
    assert ds.meta["chi_joints"][0] == "Hips" and len(ds.meta["chi_joints"]) == 21


def test_mirror_augmentation_swaps_the_cycle_sides(built):
    _, ds, _ = built
    c = ds.cycles
    train = c[c.split == "train"]  # only training cycles are augmented
    orig = {(r.clip, r.start, r.end, r.side) for r in train[~train.mirrored].itertuples()}
    mirr = {(r.clip, r.start, r.end, {"L": "R", "R": "L"}[r.side]) for r in c[c.mirrored].itertuples()}
    assert orig and orig == mirr
    assert ds.counts().loc["total", "total"] == int((~c.mirrored).sum())  # counts exclude the augmentation


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


def test_gamma_scale_comes_from_training_cycles_only(built):
    """Changing every test cycle leaves the scale unchanged; the stored scale is the training
    cycles' max |Gamma| (so chi times the scale gives back metres)."""
    _, ds, _ = built
    g = ds.chi[..., 126:129] * ds.gamma_scale  # metres
    train = (ds.cycles["split"] == "train").values
    assert (~train).any() and train.any()
    np.testing.assert_allclose(gamma_scale(g, train), ds.gamma_scale, rtol=1e-6)
    changed = g.copy()
    changed[~train] *= 10.0
    np.testing.assert_array_equal(gamma_scale(changed, train), gamma_scale(g, train))
    changed[np.flatnonzero(train)[0]] *= 10.0
    assert not np.allclose(gamma_scale(changed, train), gamma_scale(g, train))
    assert ds.meta["gamma_scale"] == list(ds.gamma_scale)


def test_no_cycle_under_0_3_or_over_3_s_and_rejections_listed(built):
    _, ds, _ = built
    assert ds.cycles["duration_s"].between(0.3, 3.0).all()
    np.testing.assert_allclose(ds.chi[:, -1, -1] * ds.meta["phi_scale"], ds.cycles["duration_s"], atol=1e-5)
    rej = ds.rejected
    assert set(rej["reason"]) <= {"edge", "shape", "duration", "half"}
    assert {"clip", "start", "end", "reason", "travel_m", "correlation"} <= set(rej.columns)


def test_mirrored_copies_stay_out_of_test_metrics(built):
    _, ds, _ = built
    test = ds.indices("test")
    assert len(test) and not ds.cycles["mirrored"].values[test].any()
    assert set(ds.cycles["split"].values[test]) == {"test"}
    assert len(ds.indices("test", mirrored=True)) == len(test)  # held-out cycles are not mirrored
    by_set = ds.indices("test", test_set="held_out_subjects")
    assert set(ds.cycles["subject"].values[by_set]) == {"cmu09"}


def test_counts_by_source_and_type(built):
    _, ds, _ = built
    table = ds.counts(["source", "type"], "split")
    real = ds.cycles[~ds.cycles["mirrored"]]
    assert table.loc[("total", ""), "total"] == len(real)
    for (source, typ), g in real.groupby(["source", "type"]):
        assert table.loc[(source, typ), "total"] == len(g)


def test_held_out_takes_share_per_content():
    cat = pd.DataFrame({"source": ["bandai"] * 12 + ["cmu"],
                        "description": ["walk"] * 10 + ["run"] * 2 + ["walk"],
                        "clip": [f"w{i}" for i in range(10)] + ["r0", "r1", "c0"]})
    takes = held_out_takes(cat, share=0.2, seed=3)
    assert len(takes & {f"w{i}" for i in range(10)}) == 2  # 20 % of 10
    assert not takes & {"r0", "r1", "c0"}  # under three takes: none; other sources: never
    assert held_out_takes(cat, share=0.2, seed=3) == takes
