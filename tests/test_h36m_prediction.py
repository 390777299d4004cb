"""The H3.6M prediction protocol (Martinez et al. 2017): seeds, Euler angles, error, baselines."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocapviz.features.ccnet import FeatureLayout, motion_features
from mocapviz.io.h36m import h36m_motion, integrate_root
from mocapviz.tasks import h36m_prediction as hp

# S5 walking_1 / walking_2 have 3000 and 2521 frames at 50 fps: 1500 and 1261 at 25 fps.
WALKING_STARTS = [(1, 1087), (2, 955), (1, 1145), (2, 332), (1, 660), (2, 304), (1, 201), (2, 54)]


def test_srnn_starts_follow_the_randomstate_recipe():
    assert hp.frames_at_fps(3000) == 1500 and hp.frames_at_fps(2521) == 1261
    rng = np.random.RandomState(1234567890)   # Martinez' find_indices_srnn, written out
    expected = []
    for _ in range(4):
        expected += [(1, rng.randint(16, 1500 - 150)), (2, rng.randint(16, 1261 - 150))]
    assert hp.srnn_starts(1500, 1261) == expected == WALKING_STARTS


def test_s5_walking_sequences(data_dir):
    seqs = hp.srnn_sequences(data_dir / "h36m", "walking")
    assert [(s.subaction, s.start) for s in seqs] == WALKING_STARTS
    raw = hp.read_take(data_dir / "h36m" / "S5" / "walking_2.txt")
    s = seqs[1]                                   # subaction 2, seed frames 955..1004 at 25 fps
    np.testing.assert_array_equal(s.seed(), raw[2 * 955:2 * 1005:2])
    np.testing.assert_array_equal(s.target(25), raw[2 * 1005:2 * 1030:2])
    assert s.motion.fps == 25.0 and s.motion.n_frames == 1261


def test_euler_matches_scipy_and_the_papers_formula():
    rng = np.random.default_rng(0)
    rotvec = rng.normal(size=(200, 3))
    ours = hp.expmap_to_euler(rotvec)
    # scipy: the file's exp-map r is our rotation exp(-r); the angles are its intrinsic ZYX, reversed
    np.testing.assert_allclose(ours, Rotation.from_rotvec(-rotvec).as_euler("ZYX")[:, ::-1], atol=1e-10)
    # the papers' rotmat2euler on the row-vector matrix R = Rodrigues(r)
    r_file = Rotation.from_rotvec(rotvec).as_matrix()
    paper = np.stack([np.arctan2(r_file[:, 1, 2], r_file[:, 2, 2]), -np.arcsin(r_file[:, 0, 2]),
                      np.arctan2(r_file[:, 0, 1], r_file[:, 0, 0])], axis=1)
    np.testing.assert_allclose(ours, paper, atol=1e-10)
    # by hand: exp-map (a, 0, 0) is R = Rx(a); atan2(R12, R22) = atan2(-sin a, cos a) = -a
    np.testing.assert_allclose(hp.expmap_to_euler(np.array([0.3, 0.0, 0.0])), [-0.3, 0.0, 0.0], atol=1e-12)


def test_euler_error_by_hand():
    # one sequence, 3 frames, 3 channels; channel 1 is constant in the target, so it is left out
    target = np.array([[[0.0, 5.0, 1.0], [0.1, 5.0, 1.0], [0.2, 5.0, 2.0]]])
    pred = np.array([[[0.3, 0.0, 1.4], [0.1, 9.0, 1.0], [0.2, 5.0, 2.0]]])
    np.testing.assert_allclose(hp.euler_error(target, pred), [0.5, 0.0, 0.0], atol=1e-12)  # sqrt(.09 + .16)
    # a frozen prediction is scored on the target's varying channels (not on its own: it has none)
    frozen = np.repeat(target[:, :1], 3, axis=1)
    np.testing.assert_allclose(hp.euler_error(target, frozen), [0.0, 0.1, np.hypot(0.2, 1.0)], atol=1e-12)
    # the mean over sequences
    two = hp.euler_error(np.concatenate([target, target]), np.concatenate([pred, target]))
    np.testing.assert_allclose(two, [0.25, 0.0, 0.0], atol=1e-12)
    assert hp.at_horizons(np.arange(25.0)) == {80: 1.0, 160: 3.0, 320: 7.0, 400: 9.0, 1000: 24.0}


def test_zero_velocity_repeats_the_last_seed_row():
    values = np.arange(60 * 99, dtype=float).reshape(60, 99)
    seq = hp.SeedSequence("walking", 1, 3, values, motion=None)
    pred = hp.zero_velocity([seq], 4)
    assert pred.shape == (1, 4, 99)
    np.testing.assert_array_equal(pred[0], np.repeat(values[52:53], 4, axis=0))


def test_zero_velocity_reproduces_martinez_table(data_dir):
    """Martinez et al. 2017, Table 1, zero-velocity row (80, 160, 320, 400 ms), to their 2 decimals."""
    published = {"walking": (0.39, 0.68, 0.99, 1.15), "eating": (0.27, 0.48, 0.73, 0.86),
                 "smoking": (0.26, 0.48, 0.97, 0.95)}
    seqs = {a: hp.srnn_sequences(data_dir / "h36m", a) for a in published}
    table = hp.evaluate({"zero_velocity": hp.zero_velocity}, seqs, horizons_ms=(80, 160, 320, 400))
    for action, values in published.items():
        ours = table[table.action == action].sort_values("ms").mae.values
        np.testing.assert_allclose(ours, values, atol=0.005 + 1e-9)


def test_integrate_root_by_hand():
    values = np.zeros((3, 99))
    values[:, 2] = 10.0                 # 10 mm forward (+Z of the previous root frame) per frame
    values[1:, 4] = -np.pi / 2          # our yaw rate is -v_y: turn +90 degrees at frames 1 and 2
    rot, pos = integrate_root(values)
    # frame 0: 1 cm along +Z; frame 1: along +Z still (the previous heading), then turned to +X;
    # frame 2: 1 cm along +X (heading 90 deg) and turned to 180 deg
    np.testing.assert_allclose(pos[:, [0, 2]], [[0, 0.01], [0, 0.02], [0.01, 0.02]], atol=1e-12)
    np.testing.assert_allclose(rot[2] @ [0, 0, 1], [0, 0, -1], atol=1e-12)


def test_integrated_walk_moves_where_it_faces(h36m_files):
    from mocapviz.features.ccnet import heading_angles
    from mocapviz.heading import heading_of, wrap_angle
    walk = next(p for p in h36m_files if p.name == "walking_1.txt")
    m = h36m_motion(hp.read_take(walk), root="integrated")
    facing = heading_angles(m.positions(), m.skeleton)[1:]
    step = np.diff(m.root_positions, axis=0)
    moving = np.linalg.norm(step, axis=1) * m.fps > 0.3
    assert np.degrees(np.median(np.abs(wrap_angle(heading_of(step) - facing)[moving]))) < 20


def test_ccnet_rotation_block_gives_back_the_files_euler_angles(h36m_files):
    """What the CCNet predictor does with generated frames (-rotvec of the rot block), on real ones."""
    values = hp.read_take(h36m_files[0])[:200]
    m = h36m_motion(values, root="integrated", every=2)
    x = motion_features(m, hp.FPS).x
    rows = np.zeros((len(x), 99))
    rows[:, 3:] = -x[:, FeatureLayout(32, 4).x_blocks["rot"]]
    np.testing.assert_allclose(hp.euler_channels(rows), hp.euler_channels(values[2::2]), atol=1e-5)  # float32 x


def test_paper_rows_are_table6():
    rows = hp.paper_rows()
    assert len(rows) == 4 * 5 * 5
    ccnet = rows[(rows.model == "paper_ccnet") & (rows.action == "walking")].mae.tolist()
    assert ccnet == [1.34, 1.40, 1.45, 1.46, 1.55]


def test_missing_s5_discussion_says_so(data_dir):
    if (data_dir / "h36m" / "S5" / "discussion_1.txt").is_file():
        pytest.skip("this copy of the data has S5 discussion")
    with pytest.raises(FileNotFoundError):
        hp.srnn_sequences(data_dir / "h36m", "discussion")


def test_committed_table_is_what_the_code_gives(data_dir):
    """results/ccnet_table6_h36m.csv against a fresh evaluation of the committed checkpoints."""
    import pandas as pd

    from data_prep.h36m_dataset import prediction_table
    from mocapviz.training.checkpoint import load_checkpoint
    from mocapviz.zoo import find_checkpoint
    repo = Path(__file__).resolve().parent.parent
    names = ("ccnet_h36m", "ccnet_h36m_residual")
    fresh = prediction_table({n: load_checkpoint(find_checkpoint(n, cwd=repo))[:2] for n in names}, data_dir)
    committed = pd.read_csv(repo / "results" / "ccnet_table6_h36m.csv")
    assert len(committed) == len(fresh) == 4 * 5 * 5 + 4 * 5 * 3   # paper rows + ours (discussion NaN)
    merged = fresh.merge(committed, on=["action", "ms", "model"], suffixes=("", "_csv"))
    assert len(merged) == len(fresh)
    np.testing.assert_allclose(merged.mae, merged.mae_csv, atol=1e-4)   # the CSV keeps 4 decimals
    assert merged[merged.action == "discussion"].query("not model.str.startswith('paper')").mae.isna().all()
