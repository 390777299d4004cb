"""CCNet Figs. 9-10, a body no one captured (7b: tr's legs scaled by 0.8): the scaled skeleton, the
retargeted seed, the seed-to-generation jump on a hand-made failure and on real clips, the
command's quick run and the committed table (mocapviz/tasks/unseen_body.py,
data_prep/unseen_body_table.py)."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from data_prep import unseen_body_table
from mocapviz.features.ccnet_joints import CCNET_25_PARENTS
from mocapviz.motion import Motion
from mocapviz.skeleton import CCNET_25_JOINTS, Skeleton
from mocapviz.tasks import unseen_body as ub
from mocapviz.tasks.rig import floor_height, hip_midpoint, leg_length

RESULTS = Path(__file__).resolve().parent.parent / "results"
LEG_JOINTS = {"LHipJoint", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase",
              "RHipJoint", "RightUpLeg", "RightLeg", "RightFoot", "RightToeBase"}


def toy_skeleton() -> Skeleton:
    """The 25 CCNet joints with random non-zero offsets and end sites at a toe and the head."""
    names = CCNET_25_JOINTS
    parents = np.array([-1] + [names.index(CCNET_25_PARENTS[n]) for n in names[1:]])
    offsets = np.random.default_rng(0).uniform(0.05, 0.3, (len(names), 3))
    offsets[0] = 0.0
    ends = ((names.index("LeftToeBase"), (0.0, 0.0, 0.05)), (names.index("Head"), (0.0, 0.1, 0.0)))
    return Skeleton(names, parents, offsets, ends)


def test_scaled_lower_body_scales_the_legs_and_nothing_else():
    sk = toy_skeleton()
    b7 = ub.scaled_lower_body(sk, 0.8)
    assert {sk.names[j] for j in ub.lower_body_joints(sk)} == LEG_JOINTS
    for j, name in enumerate(sk.names):
        np.testing.assert_allclose(b7.offsets[j], (0.8 if name in LEG_JOINTS else 1.0) * sk.offsets[j], err_msg=name)
    assert leg_length(b7) == pytest.approx(0.8 * leg_length(sk))     # thigh + shin
    ends, ends7 = dict(sk.end_sites), dict(b7.end_sites)
    np.testing.assert_allclose(ends7[sk.index("LeftToeBase")], 0.8 * np.asarray(ends[sk.index("LeftToeBase")]))
    np.testing.assert_allclose(ends7[sk.index("Head")], ends[sk.index("Head")])
    assert b7.names == sk.names and np.array_equal(b7.parents, sk.parents)


@pytest.fixture(scope="module")
def seed(ds):
    """tr's first jog clip (the dataset's frames) and the same clip on 7b."""
    row = ub.seed_rows(ds)[0]
    return ds, row, ub.body_dataset(ds, [row])


def test_seeds_are_the_test_subjects_locomotion_long_enough(ds):
    rows = ub.seed_rows(ds)
    c = ds.clips.iloc[rows]
    assert len(rows) >= 3 and set(c.subject) == {ds.meta["test_subject"]} == {"tr"}
    assert set(c.type) == {"jog"} and ((c.stop - c.start) > ub.SEED_FRAMES).all()


def test_retargeted_seed_has_7bs_legs_and_its_feet_on_the_floor(seed):
    ds, row, bds = seed
    src = ds.clip_motion(row)
    b7 = ub.scaled_lower_body(src.skeleton)
    m = ub.retarget_seed(src, b7)
    p, sp = m.positions(), src.scaled(0.8).positions()
    # FK of the retargeted motion: every bone at 7b's length, thighs and shins 0.8x tr's
    for j in range(1, b7.n_joints):
        bone = np.linalg.norm(p[:, j] - p[:, b7.parents[j]], axis=-1)
        np.testing.assert_allclose(bone, np.linalg.norm(b7.offsets[j]), atol=1e-9, err_msg=b7.names[j])
    # the hips follow the scaled source's, the IK puts the ankles on its ankles (within a mm)
    np.testing.assert_allclose(hip_midpoint(b7, p), hip_midpoint(src.skeleton, sp), atol=1e-9)
    for ankle in ("LeftFoot", "RightFoot"):
        assert np.abs(p[:, b7.index(ankle)] - sp[:, src.skeleton.index(ankle)]).max() < 1e-3
    # feet on the floor: in every frame the lowest joint is as high as the scaled capture's (within a
    # mm), so the floor is tr's times 0.8 (a few mm: tr's floor is near 0)
    np.testing.assert_allclose(p[..., 1].min(axis=-1), sp[..., 1].min(axis=-1), atol=1e-3)
    floor, floor_tr = floor_height(p), floor_height(src.positions())
    assert abs(floor - 0.8 * floor_tr) < 0.002 and abs(floor - floor_tr) < 0.015 and abs(floor) < 0.1
    # the dataset rows: 7b's c^s (its root 0.8x as high above its feet), frames of the retargeted motion
    assert bds.skel[0][0] == pytest.approx(b7.configuration()[0], abs=1e-6)
    assert bds.skel[0][0] < 0.85 * ds.skel[row][0]
    np.testing.assert_allclose(bds.clip_motion(0).positions(), p[1:], atol=1e-4)
    assert bds.clips.type[0] == "jog" and len(bds.x) == src.n_frames - 1


def test_jump_sees_a_displaced_start_and_not_a_real_cut(seed):
    ds, row, _ = seed
    m = ds.clip_motion(row)
    p, sk, s = m.positions(), m.skeleton, 100
    # a real clip split in two: about 1 (the fastest of 3 frames against the median of the last second)
    assert 0.7 < ub.seam_jump(p, sk, s) < 2.0
    assert 0.8 < ub.real_cut_jump(m) < 2.0
    # the failure: the generated part starts from another pose (the clip 20 frames earlier, moved to the
    # root where the seed ends), then goes on smoothly
    other = p.copy()
    other[s:] = p[s - 20:len(p) - 20] - p[s - 20:len(p) - 20, :1] + p[s:, :1]
    assert ub.seam_jump(other, sk, s) > 5
    # ... or the body drops 10 cm at the seam: the jump sees it, the pose alone does not
    low = p.copy()
    low[s:, :, 1] -= 0.1
    assert ub.seam_jump(low, sk, s) > 5 and ub.seam_jump(low, sk, s, height=False) < 2.0
    # a freeze is not a jump (the freezing measures' business)
    frozen = ub.held_last(m[:s], 20)
    assert ub.seam_jump(frozen.positions(), sk, s) == 0.0
    with pytest.raises(ValueError):
        ub.seam_jump(p[:s + 1], sk, s)


def test_foot_ground_measures_depth_under_and_height_over_the_floor():
    p = np.zeros((4, 2, 3))
    p[:, 0, 1] = [0.1, -0.05, 0.0, 0.2]     # the lowest joint's heights (m)
    p[:, 1, 1] = 1.0
    g = ub.foot_ground(p, floor=0.0)
    assert g["penetration_cm"] == pytest.approx(100 * 0.05 / 4) and g["foot_height_cm"] == pytest.approx(5.0)


@pytest.mark.slow
def test_quick_command_writes_the_table(tmp_path, data_dir):
    out = tmp_path / "unseen.csv"
    from data_prep.cli import main
    assert main(["unseen-body", "--quick", "--out", str(out), "--data-dir", str(data_dir)]) == 0
    t = pd.read_csv(out)
    assert list(t.columns) == list(unseen_body_table.COLUMNS)
    assert set(t["mode"]) == {"quick"} and t.command.str.startswith("python -m data_prep unseen-body").all()
    assert set(t.body) == {"7b"} and (t.n_seeds == 1).all()
    walk, follow = (t[t.task == k].set_index(["model", "pipeline"]) for k in ("walk", "follow"))
    assert set(unseen_body_table.MODELS) | {"real_clip", "copy_last"} == set(walk.index.get_level_values(0))
    assert set(unseen_body_table.MODELS) | {"stand_still"} == set(follow.index.get_level_values(0))
    assert walk.jump.notna().all() and walk.loc[("copy_last", "-")].jump == 0
    assert 0.5 < walk.loc[("real_clip", "-")].jump < 2.5
    assert follow.distance_cm.notna().all()
    assert follow[follow.index.get_level_values(0) != "stand_still"].jump.notna().all()


def test_committed_table_has_every_row_and_says_how_it_was_made():
    t = pd.read_csv(RESULTS / unseen_body_table.OUT_NAME)
    assert list(t.columns) == list(unseen_body_table.COLUMNS)
    assert set(t["mode"]) == {"full"} and t.command.str.startswith("python -m data_prep unseen-body").all()
    assert set(t.body) == {"7b", "tr"} and (t.n_seeds >= 3).all()
    for body, rows in t.groupby("body"):
        assert set(unseen_body_table.MODELS) <= set(rows.model[rows.task == "walk"])
        assert set(unseen_body_table.MODELS) <= set(rows.model[rows.task == "follow"])
        assert {"real_clip", "copy_last", "stand_still"} <= set(rows.model)
        assert rows[rows.task == "follow"].distance_cm.notna().all()


def test_verdicts_by_hand():
    assert ub.seam_verdict(1.3 * ub.SHARP + 0.1, 1.3) == "sharp" and ub.seam_verdict(2.0, 1.3) == "smooth"
    assert ub.ground_verdict(ub.FLOOR_CM + 1, 0.0) == "through the floor"
    assert ub.ground_verdict(0.0, ub.FLOOR_CM + 1) == "floating"
    assert ub.ground_verdict(1.0, -1.0) == "on the floor"
