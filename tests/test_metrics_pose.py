"""Pose-level metrics: hand-computed arrays, and hand-made cases built from a real walk."""

import numpy as np
import pytest

from mocapviz import metrics
from mocapviz.features.ccnet import heading_angles
from mocapviz.heading import yaw_matrix
from mocapviz.motion import Motion

FPS = 60.0


def local_of(motion: Motion) -> np.ndarray:
    return metrics.local_positions(motion.positions(), motion.skeleton)


def test_pose_speed_and_activity_by_hand():
    # joint 0 still, joint 1 moves 0.1 m per frame along X at 10 fps: speeds 0 and 1 m/s
    local = np.zeros((3, 2, 3))
    local[:, 1, 0] = [0.0, 0.1, 0.2]
    np.testing.assert_allclose(metrics.pose_speed(local, 10.0), [0.5, 0.5])
    assert metrics.activity(local, 10.0) == pytest.approx(0.5)
    assert metrics.jitter(local, 10.0) == pytest.approx(0.0)  # constant velocity


def test_jitter_by_hand():
    local = np.zeros((4, 1, 3))
    local[:, 0, 1] = [0.0, 0.0, 0.3, 0.0]  # second differences 0.3, -0.6 (m per frame^2)
    assert metrics.jitter(local, 10.0) == pytest.approx((0.3 + 0.6) / 2 * 100)


def test_root_speed_by_hand():
    # 0.3 m along X then 0.4 m along Z per frame at 10 fps (height changes do not count): 3 and 4 m/s
    root = np.array([[0.0, 1.0, 0.0], [0.3, 0.9, 0.0], [0.3, 1.2, 0.4]])
    assert metrics.root_speed(root, 10.0) == pytest.approx(3.5)


def test_freezing_share_by_hand():
    # 2 s at 10 fps, one joint: first second still, second second moving 0.1 m/frame (1 m/s)
    x = np.concatenate([np.zeros(10), 0.1 * np.arange(1, 12)])
    local = np.zeros((21, 1, 3))
    local[:, 0, 0] = x
    np.testing.assert_allclose(metrics.window_speeds(local, 10.0), [0.1, 1.0])  # step 10->11 is 0.1 m
    assert metrics.freezing_share(local, 10.0, threshold=0.5) == 0.5
    assert metrics.freezing_share(local, 10.0, threshold=0.05) == 0.0
    with pytest.raises(ValueError):
        metrics.freezing_share(local[:5], 10.0)
    local[15, 0, 0] = np.nan   # a diverged pose: neither frozen nor moving
    assert np.isnan(metrics.freezing_share(local, 10.0))


def test_ground_penetration_by_hand():
    pos = np.zeros((2, 2, 3))
    pos[0, :, 1] = [0.5, -0.02]   # 2 cm under the floor
    pos[1, :, 1] = [0.5, 0.1]     # above it
    assert metrics.ground_penetration(pos) == pytest.approx(0.01)
    assert metrics.ground_penetration(pos, floor=0.2) == pytest.approx((0.22 + 0.1) / 2)


def test_ratio():
    assert metrics.ratio(3.0, [1.0, 2.0, 3.0]) == pytest.approx(1.5)


@pytest.fixture(scope="module")
def walks(data_dir):
    """CMU walks at 60 fps on the 25 CCNet joints: 35_01 and the other walk clips."""
    from data_prep.catalog import build_catalog, load_motion
    from mocapviz.features.ccnet import prepare_motion
    cat = build_catalog(data_dir)
    rows = cat[(cat.source == "cmu") & (cat.motion_type == "walk")]
    out = {r.clip: prepare_motion(load_motion(r._asdict())) for r in rows.itertuples()}
    assert "35_01" in out and len(out) >= 3
    return out


def test_real_walk_moves_like_other_walks(walks):
    m = walks["35_01"]
    local = local_of(m)
    assert metrics.freezing_share(local, FPS) == 0.0
    others = [local_of(w) for k, w in walks.items() if k != "35_01"]
    act = metrics.ratio(metrics.activity(local, FPS), [metrics.activity(o, FPS) for o in others])
    jit = metrics.ratio(metrics.jitter(local, FPS), [metrics.jitter(o, FPS) for o in others])
    assert 0.5 < act < 2.0 and 0.33 < jit < 3.0
    assert metrics.activity(local, FPS) > 10 * metrics.FROZEN_SPEED
    assert metrics.ground_penetration(m.positions()) < 0.01


def test_local_positions_ignore_where_the_body_is_and_faces(walks):
    m = walks["35_01"]
    turn = yaw_matrix(np.array(0.7))
    rot = m.rotations.copy()
    rot[:, 0] = turn @ rot[:, 0]
    moved = Motion(m.skeleton, rot, m.root_positions @ turn.T + [3.0, 0.0, -2.0], m.fps)
    np.testing.assert_allclose(local_of(moved), local_of(m), atol=1e-9)


def test_frozen_pose_gliding_and_turning_along_the_path_is_seen(walks):
    """The failure the velocity-block metric missed: one pose held while the root follows the
    real path and turns with the real heading."""
    m = walks["35_01"]
    theta = heading_angles(m.positions(), m.skeleton)
    k = m.n_frames // 2
    rot = np.repeat(m.rotations[k:k + 1], m.n_frames, axis=0)
    rot[:, 0] = yaw_matrix(theta - theta[k]) @ rot[:, 0]   # the held pose turns with the path
    statue = Motion(m.skeleton, rot, m.root_positions, m.fps)
    root_speed = np.linalg.norm(np.diff(statue.root_positions[:, [0, 2]], axis=0), axis=1).mean() * FPS
    assert root_speed > 0.5  # it does travel
    local = local_of(statue)
    assert metrics.freezing_share(local, FPS) == 1.0
    assert metrics.activity(local, FPS) < 1e-6
    real = metrics.activity(local_of(m), FPS)
    assert metrics.ratio(metrics.activity(local, FPS), [real]) < 1e-4


def test_noise_on_the_real_walk_is_jitter(walks):
    from mocapviz.rotations import matrix_to_rotvec, rotvec_to_matrix
    m = walks["35_01"]
    rng = np.random.default_rng(0)
    rv = matrix_to_rotvec(m.rotations)
    noisy_rv = rv + rng.normal(0.0, np.deg2rad(2.0), rv.shape)   # 2 degrees per joint and frame
    noisy = Motion(m.skeleton, rotvec_to_matrix(noisy_rv), m.root_positions, m.fps)
    clean_l, noisy_l = local_of(m), local_of(noisy)
    assert metrics.ratio(metrics.jitter(noisy_l, FPS), [metrics.jitter(clean_l, FPS)]) > 10
    assert metrics.freezing_share(noisy_l, FPS) == 0.0
    summary = metrics.pose_metrics(noisy.positions(), noisy.skeleton, noisy.fps)
    assert summary["jitter"] == pytest.approx(metrics.jitter(noisy_l, FPS))
    assert summary["freezing_share"] == 0.0


def test_pose_bank_distance_by_hand():
    bank = metrics.PoseBank(np.array([np.zeros((2, 3)), np.full((2, 3), 0.1)]))
    q = np.zeros((1, 2, 3))
    q[0, 0, 0] = 0.03  # 3 cm off the first pose at one of two joints: RMS 0.03 / sqrt(2)
    np.testing.assert_allclose(bank.distance(q, 1.0), [0.03 / np.sqrt(2)])
    np.testing.assert_allclose(bank.distance(np.full((1, 2, 3), 0.2), 2.0), [0.0], atol=1e-12)  # a 2x body
    with pytest.raises(ValueError, match="joints"):
        bank.distance(np.zeros((1, 3, 3)), 1.0)


def test_a_walk_drifting_into_impossible_poses_is_seen(walks):
    """The failure activity and jitter miss: every joint's rotation drifts smoothly away from the
    real walk (up to 1.5 rad by the end) while the pose changes at the walk's own pace."""
    from mocapviz.rotations import matrix_to_rotvec, rotvec_to_matrix
    m = walks["35_01"]
    h = m.skeleton.configuration()[0]
    bank = metrics.PoseBank(np.concatenate([local_of(w) / w.skeleton.configuration()[0]
                                            for k, w in walks.items() if k != "35_01"]))
    rv = matrix_to_rotvec(m.rotations)
    drift = np.linspace(0, 1, m.n_frames)[:, None, None] * np.random.default_rng(0).uniform(-1.5, 1.5, rv.shape[1:])
    drift[:, 0] = 0.0
    tumbling = Motion(m.skeleton, rotvec_to_matrix(rv + drift), m.root_positions, m.fps)
    real_l, tumbling_l = local_of(m), local_of(tumbling)
    real_d, tumbling_d = np.median(bank.distance(real_l, h)), np.median(bank.distance(tumbling_l, h))
    assert real_d < 0.06                 # a held-out real walk: a few % of the root height
    assert tumbling_d > 4 * real_d       # measured: 0.034 vs 0.25
    # ... while activity and jitter call it a walk
    assert 0.8 < metrics.ratio(metrics.activity(tumbling_l, FPS), [metrics.activity(real_l, FPS)]) < 1.25
    assert metrics.ratio(metrics.jitter(tumbling_l, FPS), [metrics.jitter(real_l, FPS)]) < 1.5


def test_forward_lean_sees_a_bent_spine_and_not_where_the_spine_joints_sit(walks):
    """The walk with everything above the hips pitched 20 degrees forward (about the heading
    frame's side axis) leans 20 degrees more; the same motion on a skeleton whose spine starts
    2 cm further back (its rest reclines, as a Mixamo one does) leans as before from its rest,
    while the hips -> neck angle from vertical, the measure this replaced, moves."""
    from mocapviz.skeleton import Skeleton

    m = walks["35_01"]
    sk = m.skeleton
    local = metrics.local_positions(m.positions(), sk)
    upright = metrics.forward_lean(local, sk)
    upper = [j for j in range(len(sk.names)) if _above(sk, j, sk.index("LowerBack"))]
    a = np.radians(20.0)
    pitch = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(a), -np.sin(a)], [0.0, np.sin(a), np.cos(a)]])
    bent = local.copy()
    bent[:, upper] = (local[:, upper] - local[:, :1]) @ pitch.T + local[:, :1]
    np.testing.assert_allclose(metrics.forward_lean(bent, sk) - upright, 20.0, atol=0.5)

    offsets = sk.offsets.copy()
    offsets[sk.index("LowerBack"), 2] -= 0.02
    reclined = Motion(Skeleton(sk.names, sk.parents, offsets, sk.end_sites), m.rotations, m.root_positions, m.fps)
    pos = reclined.positions()
    assert abs(metrics.forward_lean(pos, reclined.skeleton).mean() - upright.mean()) < 0.5
    v0 = m.positions()[:, sk.index("Neck")] - m.positions()[:, 0]
    v1 = pos[:, sk.index("Neck")] - pos[:, 0]
    vertical = [np.degrees(np.arccos(v[:, 1] / np.linalg.norm(v, axis=1))).mean() for v in (v0, v1)]
    assert abs(vertical[1] - vertical[0]) > 1.0


def _above(sk, j: int, ancestor: int) -> bool:
    while j >= 0:
        if j == ancestor:
            return True
        j = sk.parents[j]
    return False
