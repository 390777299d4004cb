"""CCNet features and dataset (v4, quick config) on the real data: round trip, Bandai on the
25 joints, controls, split, normaliser, windows, type vocabulary."""

from pathlib import Path

import numpy as np
import pytest
import torch

from data_prep.motion_types import merged_type, source_label
from mocapviz.features.motion_types import MOTION_TYPES
from mocapviz.features import ccnet as feat

BANDAI_WALK, BANDAI_RUN = "dataset-2_walk_normal_001", "dataset-2_run_normal_001"


@pytest.fixture(scope="module")
def full_catalog(data_dir):
    from data_prep.catalog import build_catalog
    from data_prep.sources import SOURCES
    return build_catalog(data_dir, sources=SOURCES)


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
    mocap = clips[clips.source != "bandai"]
    for subject, g in mocap[mocap.subject != test_subject].groupby("subject"):
        usable = g[(g.stop - g.start >= ds.config.window + 2) & g.trainable]
        n_test = (g.split == "test").sum()
        assert n_test == (1 if len(usable) >= 2 else 0), subject
        if subject == val_subject:
            # the whole validation actor, except the clip the test draw took
            assert (g.split == "val").sum() == len(g) - n_test, subject
        else:
            assert not (g.split == "val").any(), subject
    # validation: one whole actor plus Bandai takes, nothing else
    assert set(clips[clips.split == "val"].subject) == {val_subject, "bandai1", "bandai2"}
    assert set(ds.meta["test_clips"]) == set(clips[clips.split == "test"]["clip"])
    assert set(ds.meta["val_clips"]) == set(clips[clips.split == "val"]["clip"])
    assert ds.meta["n_train_clips"] == (clips.split == "train").sum()
    # splits are disjoint: every clip (name) is in exactly one split
    assert clips["clip"].is_unique
    by_split = {s: set(clips[clips.split == s]["clip"]) for s in ("train", "val", "test")}
    assert not (by_split["train"] & by_split["val"] or by_split["train"] & by_split["test"]
                or by_split["val"] & by_split["test"])


def test_bandai_test_and_val_takes_are_seeded_shares_per_content(ds):
    from dataclasses import replace

    from data_prep.ccnet_dataset import _choose_split
    bandai = ds.clips[ds.clips.source == "bandai"]
    for content, g in bandai.groupby("description"):
        n = len(g)
        want = max(int(round(0.1 * n)), int(n >= 3))
        assert (g.split == "test").sum() == want and (g.split == "val").sum() == want, content
    # another seed draws other Bandai takes; the HDM05/CMU part does not depend on Bandai's draw
    long_enough = ((ds.clips.stop - ds.clips.start) >= ds.config.window + 2).values & ds.clips.trainable.values
    other = _choose_split(ds.clips, replace(ds.config, bandai_val_share=0.5), long_enough)
    mocap = (ds.clips.source != "bandai").values
    np.testing.assert_array_equal(other[mocap], ds.clips.split.values[mocap])
    assert (other[~mocap] == "val").sum() > (ds.clips.split.values[~mocap] == "val").sum()


def test_dataset_counts_match_the_catalog(ds, full_catalog):
    """Clips per source/content and frames per clip, against the catalog (frames at 60 fps:
    a clip of duration d seconds has floor(60 d) + 1 frames, its first gives no frame vector)."""
    cat = full_catalog[full_catalog.source.isin(ds.config.sources)]
    clips = ds.clips.set_index("clip")
    mocap = cat[cat.source != "bandai"]
    assert set(mocap["clip"]) == set(clips.index[clips.source != "bandai"])
    k = ds.config.bandai_takes_per_content
    per_content = cat[cat.source == "bandai"].groupby("description").size()
    got = clips[clips.source == "bandai"].groupby("description").size()
    assert got.to_dict() == {c: min(k, n) for c, n in per_content.items()}
    rows = cat.set_index("clip").loc[clips.index]
    np.testing.assert_array_equal((clips.stop - clips.start).values,
                                  np.floor(rows.duration_s.values * 60 + 1e-9).astype(int))
    assert (clips["style"][clips.source == "bandai"] != "").all() and (clips["style"][clips.source != "bandai"] == "").all()
    t = ds.table()
    assert t[("frames", "all")].loc[("all", "")] == len(ds.x)
    for split in ("train", "val", "test"):
        assert t[("frames", split)].loc[("all", "")] == (clips.stop - clips.start)[clips.split == split].sum()
    np.testing.assert_allclose(t[("minutes", "all")].loc[("all", "")], len(ds.x) / 3600, atol=0.05)


def test_bandai_features_round_trip_to_poses(ds, full_catalog):
    """Bandai at 60 fps on the 25 joints: features -> poses within the tolerance of the other
    sources, and re-basing + filled joints keep every original joint where the file puts it."""
    from data_prep.catalog import load_motion
    from data_prep.ccnet_dataset import load_ccnet_motion
    from mocapviz.features.ccnet_joints import ZERO_LENGTH_JOINTS
    row = full_catalog[full_catalog["clip"] == BANDAI_WALK].iloc[0]
    m = load_ccnet_motion(row, Path(ds.meta["data_dir"]))
    assert m.skeleton.names == feat.CCNET_25_JOINTS and m.fps == 60
    raw = load_motion(row).resample(60)
    idx = [m.skeleton.index(n) for n in raw.skeleton.names]
    assert np.abs(m.positions()[:, idx] - raw.positions()).max() < 1e-9
    # the filled joints: identity rotations, hip stubs/LowerBack on Hips, Neck1 halfway up the neck
    p = m.positions()
    for name in ZERO_LENGTH_JOINTS + ("Neck1",):
        assert np.allclose(m.rotations[:, m.skeleton.index(name)], np.eye(3))
    for name in ZERO_LENGTH_JOINTS:
        np.testing.assert_allclose(p[:, m.skeleton.index(name)], p[:, 0], atol=1e-12)
    np.testing.assert_allclose(p[:, m.skeleton.index("Neck1")],
                               (p[:, m.skeleton.index("Neck")] + p[:, m.skeleton.index("Head")]) / 2, atol=1e-12)
    # rest pose: the VICON T-pose facing +Z of HDM05/CMU (legs splayed 20 degrees, arms out to
    # the sides, feet forward); compared with a CMU skeleton's rest, bone by bone
    from data_prep.catalog import load_motion as load
    cmu = feat.prepare_motion(load(full_catalog[full_catalog["clip"] == "35_01"].iloc[0])[:2]).skeleton
    rest, cmu_rest = m.skeleton.rest_positions(), cmu.rest_positions()
    j = m.skeleton.index
    for a, b in (("LeftUpLeg", "LeftLeg"), ("RightLeg", "RightFoot"), ("LeftArm", "LeftForeArm"),
                 ("RightForeArm", "RightHand"), ("Spine", "Spine1")):
        u, v = rest[j(b)] - rest[j(a)], cmu_rest[cmu.index(b)] - cmu_rest[cmu.index(a)]
        angle = np.degrees(np.arccos(np.clip(u @ v / np.linalg.norm(u) / np.linalg.norm(v), -1, 1)))  # parallel: 1 + 1e-16
        assert angle < 7.0, (a, b, angle)
    assert rest[j("LeftHand"), 0] - rest[j("LeftArm"), 0] > 0.4 > abs(rest[j("LeftHand"), 1] - rest[j("LeftArm"), 1])
    assert rest[j("RightHand"), 0] - rest[j("RightArm"), 0] < -0.4
    toe = rest[j("LeftToeBase")] - rest[j("LeftFoot")]
    assert toe[2] > 0.05 and toe[1] < 0  # the foot points forward and down, as it stands
    f = feat.motion_features(m)
    back = feat.features_to_motion(f.x, m.skeleton, f.start_root, f.start_heading)
    assert np.abs(back.positions() - m.positions()[1:]).max() < 1e-5  # float32 storage
    i = ds.clip_row(BANDAI_WALK) if BANDAI_WALK in set(ds.clips["clip"]) else None
    if i is not None:
        np.testing.assert_allclose(ds.x[ds.clips.start[i]:ds.clips.stop[i]], f.x, atol=1e-6)


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
    mocap = (ds.clips.source != "bandai").values
    assert set(ds.clips.subject[(other == "val") & mocap]) == {"bk"}
    np.testing.assert_array_equal(other[~mocap], ds.clips.split.values[~mocap])  # Bandai's draw stays


def test_normaliser_uses_training_clips_only(ds):
    from data_prep.ccnet_dataset import fit_normaliser
    train = np.concatenate([np.arange(r.start, r.stop) for r in ds.clips.itertuples() if r.split == "train"])
    n = ds.layout.n_continuous
    np.testing.assert_allclose(ds.normaliser.x_mean, ds.x[train, :n].mean(0), rtol=1e-4, atol=1e-5)
    assert not np.allclose(ds.normaliser.x_mean, ds.x[:, :n].mean(0), rtol=1e-4, atol=1e-5)
    refit = fit_normaliser(ds.x, ds.traj, ds.skel, ds.clips, ds.layout)
    # changing every test and validation clip (frames, c^d, c^s) leaves the normaliser as it is
    x, traj, skel = ds.x.copy(), ds.traj.copy(), ds.skel.copy()
    for i, r in enumerate(ds.clips.itertuples()):
        if r.split != "train":
            x[r.start:r.stop] += 10.0
            traj[r.start:r.stop] -= 3.0
            skel[i] *= 2.0
    changed = fit_normaliser(x, traj, skel, ds.clips, ds.layout)
    for k, v in refit.state_dict().items():
        np.testing.assert_array_equal(changed.state_dict()[k], v, err_msg=k)
        np.testing.assert_allclose(ds.normaliser.state_dict()[k], v, rtol=1e-6, err_msg=k)
    # ... while changing one training clip does change it
    r = ds.clips[ds.clips.split == "train"].iloc[0]
    x[r.start:r.stop] += 10.0
    assert not np.allclose(fit_normaliser(x, ds.traj, ds.skel, ds.clips, ds.layout).x_mean, refit.x_mean)


def test_windows_stay_inside_clips(ds):
    w = ds.config.window
    for split in ("train", "val", "test"):
        pairs = ds.window_starts(split)
        assert len(pairs)
        clips = ds.clips.iloc[pairs[:, 0]]
        assert (clips.split == split).all()
        # inputs s..s+W-1, targets up to s+W, predicted controls up to s+W+1: all in the clip
        assert (pairs[:, 1] >= 0).all() and (pairs[:, 1] + w + 1 < (clips.stop - clips.start).values).all()


def test_every_catalog_type_is_merged(full_catalog):
    rows = full_catalog[full_catalog.source.isin(["hdm05", "cmu", "bandai"])]
    merged = {merged_type(r.source, source_label(r)) for r in rows.itertuples()}
    assert merged == set(MOTION_TYPES)  # every type has clips (punch from Bandai)
    assert len({t for s, t in zip(rows.source, rows.motion_type) if s == "hdm05"}) == 11
    assert merged_type("cmu", "run") == merged_type("hdm05", "jogLeftCircle4StepsRstart") == "jog"
    assert merged_type("bandai", "run") == "jog" and merged_type("bandai", "walk-turn-left") == "walk"
    assert merged_type("bandai", "walk-left") == merged_type("bandai", "walk-right") == "side_step"


def test_type_vocabulary_is_stored_and_old_checkpoints_keep_their_indices(ds):
    """The dataset stores its vocabulary; ``ccnet_v3_rmsprop`` (13 types, dataset v3) reads index i
    as MOTION_TYPES[i] and runs (evaluation and generation) on the dataset restricted to its own
    vocabulary, and on a dataset built with its vocabulary's sources (HDM05 + CMU)."""
    from data_prep import zoo
    from data_prep.ccnet_dataset import DatasetConfig, build_dataset
    from mocapviz.features.motion_types import one_hot, vocabulary
    from mocapviz.tasks.generate import Generator
    from mocapviz.training.checkpoint import load_checkpoint
    from mocapviz.training.trainer import evaluate
    from mocapviz.training.windows import WindowData
    assert ds.motion_types == MOTION_TYPES and ds.layout.n_types == len(MOTION_TYPES) == 21
    model, norm, meta = load_checkpoint(zoo.committed_path("ccnet_v3_rmsprop"))
    old = vocabulary(model.cfg.n_types, meta["dataset"]["motion_types"])
    assert model.cfg.n_types == 13 and old == MOTION_TYPES[:13] and "walk_back" not in old
    with pytest.raises(ValueError, match="not the first"):
        vocabulary(2, ("jog", "walk"))
    sub = ds.with_vocabulary(model.cfg.n_types)
    assert sub.layout.n_types == 13 and set(sub.clips.type) == set(ds.clips.type) & set(old)
    assert set(sub.clips.source) == {"hdm05", "cmu", "bandai"}  # Bandai walks, runs, kicks, punches
    i = sub.clip_row(BANDAI_WALK) if BANDAI_WALK in set(sub.clips["clip"]) else sub.clip_row("91_02")
    np.testing.assert_array_equal(sub.clip_arrays(i)["skel"], ds.clip_arrays(ds.clip_row(sub.clips["clip"][i]))["skel"])
    data = WindowData(sub, 60, normaliser=norm)
    losses = evaluate(model, data, data.test[:64])
    assert np.isfinite(list(losses.values())).all()
    v3 = build_dataset(DatasetConfig(sources=("hdm05", "cmu"), window=60), progress=False)
    assert v3.clips.type_index.max() < model.cfg.n_types
    a = v3.clip_arrays(v3.clip_row("91_02"))
    assert old[a["type_index"]] == "walk"
    gen = Generator(model, norm).run(a["x"][None, :60], a["skel"][None], one_hot([a["type_index"]], model.cfg.n_types),
                                     30, seed_traj=a["traj"][None, :60])
    assert gen.x.shape[1] == 90 and np.isfinite(gen.x).all()


def test_scaled_batch_is_the_scaled_motions_features(ds):
    """WindowData.scaled(b, s) equals the normalised features of the motion s times as large
    (Motion.scaled) on x's continuous channels, c^s and c^d's ground positions; the phase columns
    and the contact labels stay as they were (the labels' thresholds are in metres, so labels
    computed afresh on the grown body would differ on a few frames: the feet are down at the same
    frames)."""
    from data_prep.catalog import build_catalog, load_motion
    from mocapviz.training.windows import WindowData
    data, norm, n, nt = WindowData(ds, 60, phase=True), ds.normaliser, ds.layout.n_continuous, ds.layout.n_traj
    cat = build_catalog()
    m = feat.prepare_motion(load_motion(cat[cat["clip"] == "35_01"].iloc[0]))
    b = data.batch(np.array([[ds.clip_row("35_01"), 5], [ds.clip_row("35_01"), 5]]))
    got = data.scaled(b, [1.15, 0.9])
    for i, s in enumerate((1.15, 0.9)):
        f = feat.motion_features(m.scaled(s))
        np.testing.assert_allclose(got["x"][i, :, :n], norm.norm_x(f.x[5:65])[:, :n], atol=1e-4)
        np.testing.assert_allclose(got["target_x"][i, :, :n], norm.norm_x(f.x[6:66])[:, :n], atol=1e-4)
        np.testing.assert_allclose(got["skel"][i], norm.norm_skel(f.skel), atol=1e-4)
        np.testing.assert_allclose(got["traj"][i, :, :nt], norm.norm_traj(f.traj[6:66]), atol=1e-4)
        np.testing.assert_allclose(got["target_traj"][i, :, :nt], norm.norm_traj(f.traj[7:67]), atol=1e-4)
    for key in ("x", "target_x", "traj"):
        tail = slice(n, None) if key != "traj" else slice(nt, None)
        assert torch.equal(got[key][..., tail], b[key][..., tail])
    assert not torch.allclose(got["x"][..., :n], b["x"][..., :n], atol=1e-2)   # it did grow


def test_contact_labels_on_bandai_gait_look_like_the_other_sources(full_catalog, data_dir):
    """The contact thresholds (tuned on HDM05/CMU) on Bandai at 60 fps: a walk has each foot down
    about 60 % of the time and never both feet up; a run has short stances and flight phases
    (both feet up), as CMU's walk and run at the same thresholds (figure checked by eye)."""
    from data_prep.ccnet_dataset import load_ccnet_motion
    from mocapviz.ik import FEET
    from mocapviz.kinematics import foot_contacts

    def contacts(clip):
        m = load_ccnet_motion(full_catalog[full_catalog["clip"] == clip].iloc[0], Path(data_dir))
        feet = [[m.skeleton.index(n) for n in foot] for foot in FEET]
        return foot_contacts(m.positions(), 60, feet)
    walk, run, cmu_walk, cmu_run = (contacts(c) for c in (BANDAI_WALK, BANDAI_RUN, "35_01", "09_01"))
    assert np.all((0.4 < walk.mean(0)) & (walk.mean(0) < 0.7)) and (~walk.any(1)).mean() < 0.02
    assert np.all((0.1 < run.mean(0)) & (run.mean(0) < 0.35)) and (~run.any(1)).mean() > 0.4
    assert np.abs(walk.mean() - cmu_walk.mean()) < 0.1 and np.abs(run.mean() - cmu_run.mean()) < 0.1
