"""CCNet features and dataset on the real data: round trip, controls, split, normaliser, windows."""

import numpy as np
import pytest

from data_prep.motion_types import merged_type
from mocapviz.features.motion_types import MOTION_TYPES
from mocapviz.features import ccnet as feat


@pytest.fixture(scope="module")
def ds(data_dir):
    from data_prep.ccnet_dataset import DatasetConfig, build_dataset
    return build_dataset(DatasetConfig(), data_dir, progress=False)


def test_features_round_trip_to_poses(ds):
    from data_prep.catalog import build_catalog, load_motion
    cat = build_catalog()
    for clip in ("35_01", "HDM_bk_jogLeftCircle4StepsRstart_003_120"):
        m = feat.prepare_motion(load_motion(cat[cat["clip"] == clip].iloc[0]))
        f = feat.motion_features(m)
        back = feat.features_to_motion(f.x, m.skeleton, f.start_root, f.start_heading)
        assert np.abs(back.positions() - m.positions()[1:]).max() < 1e-5  # float32 storage
        # the stored dataset rows are the same features
        i = ds.clip_row(clip)
        np.testing.assert_allclose(ds.x[ds.clips.start[i]:ds.clips.stop[i]], f.x, atol=1e-6)


def test_layout_sizes():
    lay = feat.FeatureLayout(25)
    assert lay.n_x == 306 and lay.n_continuous == 304 and lay.n_skel == 73 and lay.n_traj == 12
    assert lay.x_blocks["contact"] == slice(304, 306)


def test_trajectory_control_hand_case():
    # walking along +X at 1 m/s while facing +X (heading pi/2): c^d is (0, k/60) forward
    n = 120
    root = np.stack([np.arange(n) / 60.0, np.ones(n), np.zeros(n)], 1)
    theta = np.full(n, np.pi / 2)
    c = feat.trajectory_control(root, theta)
    expect = np.ravel([[0.0, k / 60.0] for k in feat.TRAJ_STEPS])
    np.testing.assert_allclose(c[0], expect, atol=1e-6)
    np.testing.assert_allclose(c[-1], expect, atol=1e-6)  # extrapolated past the end at the same speed


def test_split_holds_out_a_test_subject_a_val_subject_and_one_clip_per_other_subject(ds):
    clips = ds.clips
    test_subject, val_subject = ds.meta["test_subject"], ds.meta["val_subject"]
    assert (test_subject, val_subject) == ("tr", "mm")
    assert set(clips.split) == {"train", "val", "test"}
    assert (clips[clips.subject == test_subject].split == "test").all()
    for subject, g in clips[clips.subject != test_subject].groupby("subject"):
        usable = g[(g.stop - g.start >= ds.config.window + 2) & g.trainable]
        n_test = (g.split == "test").sum()
        assert n_test == (1 if len(usable) >= 2 else 0), subject
        if subject == val_subject:
            # the whole validation actor, except the clip the (unchanged) test draw took
            assert (g.split == "val").sum() == len(g) - n_test, subject
        else:
            assert not (g.split == "val").any(), subject
            assert (usable.split == "train").sum() >= min(1, len(usable)), subject
    # validation is one whole actor and nothing else
    assert set(clips[clips.split == "val"].subject) == {val_subject}
    assert set(ds.meta["test_clips"]) == set(clips[clips.split == "test"]["clip"])
    assert set(ds.meta["val_clips"]) == set(clips[clips.split == "val"]["clip"])
    assert ds.meta["n_train_clips"] == (clips.split == "train").sum()
    # per-split clip counts (seed 7): mm has 44 clips, one of which the test draw took
    assert clips.split.value_counts().to_dict() == {"train": 200, "test": 59, "val": 43}
    # the test split is the one of dataset versions 1 and 2 (seed 7): tr + one clip per other
    # subject, including this mm clip, which stays in test
    assert len(ds.meta["test_clips"]) == 59
    assert clips[(clips.subject == val_subject) & (clips.split == "test")]["clip"].tolist() == [
        "HDM_mm_kickLFront1Reps_023_120"]


def test_val_subject_must_differ_from_test_subject_and_exist(ds):
    from dataclasses import replace

    from data_prep.ccnet_dataset import _choose_split
    long_enough = ((ds.clips.stop - ds.clips.start) >= ds.config.window + 2).values & ds.clips.trainable.values
    np.testing.assert_array_equal(_choose_split(ds.clips, ds.config, long_enough), ds.clips.split.values)
    with pytest.raises(ValueError, match="is the test subject"):
        _choose_split(ds.clips, replace(ds.config, test_subject="mm"), long_enough)
    with pytest.raises(ValueError, match="not in the data"):
        _choose_split(ds.clips, replace(ds.config, val_subject="zz"), long_enough)
    # another validation actor: the test split does not move
    other = _choose_split(ds.clips, replace(ds.config, val_subject="bk"), long_enough)
    np.testing.assert_array_equal(other == "test", ds.clips.split.values == "test")
    assert set(ds.clips.subject[other == "val"]) == {"bk"}


def test_normaliser_uses_training_clips_only(ds):
    train = np.concatenate([np.arange(r.start, r.stop) for r in ds.clips.itertuples() if r.split == "train"])
    with_val = np.concatenate([np.arange(r.start, r.stop) for r in ds.clips.itertuples() if r.split != "test"])
    n = ds.layout.n_continuous
    np.testing.assert_allclose(ds.normaliser.x_mean, ds.x[train, :n].mean(0), rtol=1e-4, atol=1e-5)
    assert not np.allclose(ds.normaliser.x_mean, ds.x[:, :n].mean(0), rtol=1e-4, atol=1e-5)
    assert not np.allclose(ds.normaliser.x_mean, ds.x[with_val, :n].mean(0), rtol=1e-5, atol=1e-6)


def test_windows_stay_inside_clips(ds):
    w = ds.config.window
    for split in ("train", "val", "test"):
        pairs = ds.window_starts(split)
        assert len(pairs)
        clips = ds.clips.iloc[pairs[:, 0]]
        assert (clips.split == split).all()
        # inputs s..s+W-1, targets up to s+W, predicted controls up to s+W+1: all in the clip
        assert (pairs[:, 1] >= 0).all() and (pairs[:, 1] + w + 1 < (clips.stop - clips.start).values).all()


def test_every_catalog_type_is_merged(catalog):
    rows = catalog[catalog.source.isin(["hdm05", "cmu"])]
    merged = {merged_type(s, t) for s, t in zip(rows.source, rows.motion_type)}
    assert merged <= set(MOTION_TYPES)
    assert len({t for s, t in zip(rows.source, rows.motion_type) if s == "hdm05"}) == 11
    assert merged_type("cmu", "run") == merged_type("hdm05", "jogLeftCircle4StepsRstart") == "jog"
