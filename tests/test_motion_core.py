"""Motion core: rotations, FK (numpy/torch), resampling, mirroring, topology maps, contacts."""

from __future__ import annotations

import numpy as np
import pytest
import roma
import torch
from scipy.spatial.transform import Rotation

from mocapviz.io._text import LENGTH_UNITS
from mocapviz.io.asfamc import read_amc
from mocapviz.io.bvh import read_bvh
from mocapviz.io.h36m import read_h36m
from mocapviz.kinematics import foot_contacts, forward_kinematics
from mocapviz.motion import Motion
from mocapviz.rotations import euler_to_matrix, rotvec_to_matrix
from mocapviz.skeleton import ASF_TO_VICON_BVH, CCNET_25_JOINTS, Skeleton

torch.set_num_threads(1)


@pytest.fixture(scope="module")
def cmu(cmu_files):
    return read_bvh(next(p for p in cmu_files if p.stem == "16_27"), length_unit=LENGTH_UNITS["cmu"])[1:]


@pytest.fixture(scope="module")
def hdm05(hdm05_files, hdm05_asf):
    path = next(p for p in hdm05_files if "jogLeftCircle" in p.name)
    m = read_amc(path, hdm05_asf(path))
    m.skeleton = m.skeleton.renamed(ASF_TO_VICON_BVH)
    return m


ORDERS = ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX", "XYX", "XZX", "YXY", "YZY", "ZXZ", "ZYZ"]


@pytest.mark.parametrize("order", ORDERS)
def test_euler_matches_scipy(order):
    angles = np.random.default_rng(0).uniform(-720, 720, (200, 3))
    ref = Rotation.from_euler(order, angles, degrees=True).as_matrix()
    np.testing.assert_allclose(euler_to_matrix(angles, order), ref, atol=1e-12)
    axes = Rotation.random(200, random_state=1).as_matrix()
    np.testing.assert_allclose(euler_to_matrix(angles, order, axes=axes),
                               axes @ ref @ np.swapaxes(axes, -1, -2), atol=1e-12)


def test_rotvec_matches_roma():
    r = np.random.default_rng(2).normal(size=(500, 3)) * 2
    r[:3] *= 1e-12
    r[3] = 0
    np.testing.assert_allclose(rotvec_to_matrix(r), roma.rotvec_to_rotmat(torch.from_numpy(r)).numpy(), atol=1e-12)


def test_fk_numpy_and_torch_agree_and_torch_is_differentiable(cmu):
    m = cmu[:20]
    sk = m.skeleton
    ref = m.positions()
    rot = torch.tensor(m.rotations, requires_grad=True)
    root = torch.tensor(m.root_positions, requires_grad=True)
    pos = forward_kinematics(rot, root, sk.offsets, sk.parents)
    np.testing.assert_allclose(pos.detach().numpy(), ref, atol=1e-12)
    # gradient of one hand coordinate wrt the shoulder rotation, against finite differences
    hand, shoulder = sk.index("LeftHand"), sk.index("LeftArm")
    pos[3, hand, 0].backward()
    g = rot.grad[3, shoulder].numpy()
    assert np.abs(g).max() > 1e-3 and np.all(root.grad[3].numpy() == [1, 0, 0])
    eps = 1e-6
    for a, b in [(0, 1), (2, 0)]:
        pert = m.rotations.copy()
        pert[3, shoulder, a, b] += eps
        fd = (forward_kinematics(pert, m.root_positions, sk.offsets, sk.parents)[3, hand, 0] - ref[3, hand, 0]) / eps
        assert fd == pytest.approx(g[a, b], abs=1e-5)
    # and global rotations agree too
    _, gr = forward_kinematics(m.rotations, m.root_positions, sk.offsets, sk.parents, return_rotations=True)
    _, grt = forward_kinematics(torch.tensor(m.rotations), torch.tensor(m.root_positions), sk.offsets,
                                sk.parents, return_rotations=True)
    np.testing.assert_allclose(grt.numpy(), gr, atol=1e-12)


@pytest.mark.parametrize("fps", [30.0, 60.0, 24.0, 240.0])
def test_resample_keeps_duration_and_frames(cmu, fps):
    r = cmu.resample(fps)
    assert r.fps == fps
    assert abs(r.duration - cmu.duration) < 1.0 / fps
    assert r.duration <= cmu.duration + 1e-12
    # bone lengths are those of the skeleton on every resampled frame
    pos = r.positions()
    seg = np.linalg.norm(pos[:, 1:] - pos[:, r.skeleton.parents[1:]], axis=-1)
    np.testing.assert_allclose(seg, np.broadcast_to(r.skeleton.bone_lengths()[1:], seg.shape), atol=1e-9)
    if 120.0 % fps == 0:  # new frames that fall on old frames are those frames
        step = int(120.0 / fps)
        np.testing.assert_allclose(r.rotations, cmu.rotations[::step][:r.n_frames], atol=1e-12)
        np.testing.assert_allclose(r.root_positions, cmu.root_positions[::step][:r.n_frames], atol=1e-12)


def test_resample_midpoints_are_slerp_and_lerp(cmu):
    r = cmu.resample(240.0)
    a, b, mid = cmu.rotations[10], cmu.rotations[11], r.rotations[21]
    ang = lambda x, y: np.arccos(np.clip((np.trace(np.swapaxes(x, -1, -2) @ y, axis1=-2, axis2=-1) - 1) / 2, -1, 1))
    np.testing.assert_allclose(ang(a, mid), ang(mid, b), atol=1e-7)
    np.testing.assert_allclose(ang(a, mid), ang(a, b) / 2, atol=1e-7)
    np.testing.assert_allclose(r.root_positions[21], (cmu.root_positions[10] + cmu.root_positions[11]) / 2)


def test_resample_h36m_keeps_duration(h36m_files):
    m = read_h36m(h36m_files[0])
    r = m.resample(25.0)
    assert r.n_frames == (m.n_frames - 1) // 2 + 1 and abs(r.duration - m.duration) < 1 / 25


def test_scaled_motion_is_scaled_fk(cmu):
    """Motion.scaled(k): FK k times as large, the same rotations; 1/k scales it back."""
    big = cmu.scaled(1.15)
    np.testing.assert_allclose(big.positions(), 1.15 * cmu.positions(), atol=1e-9)
    np.testing.assert_array_equal(big.rotations, cmu.rotations)
    np.testing.assert_allclose(big.scaled(1 / 1.15).positions(), cmu.positions(), atol=1e-9)


@pytest.mark.parametrize("which", ["cmu", "hdm05"])
def test_mirror_equals_reflected_fk_with_sides_swapped(which, request):
    m = request.getfixturevalue(which)
    mir = m.mirrored()
    partner = m.skeleton.mirror_map()
    assert m.skeleton.names[partner[m.skeleton.index("LeftUpLeg")]] == "RightUpLeg"
    assert m.skeleton.names[partner[m.skeleton.index("LThumb")]] == "RThumb"
    assert partner[m.skeleton.index("Spine")] == m.skeleton.index("Spine")
    expected = m.positions()[:, partner] * np.array([-1.0, 1.0, 1.0])
    np.testing.assert_allclose(mir.positions(), expected, atol=1e-9)
    np.testing.assert_allclose(mir.mirrored().positions(), m.positions(), atol=1e-9)


def test_31_to_25_joints_keeps_fk(cmu, hdm05):
    for m in (cmu, hdm05):
        assert len(m.skeleton.names) == 31
        sub = m.keep_joints(CCNET_25_JOINTS)
        assert sub.skeleton.n_joints == 25 and set(sub.skeleton.names) == set(CCNET_25_JOINTS)
        idx = [m.skeleton.index(n) for n in sub.skeleton.names]
        np.testing.assert_allclose(sub.positions(), m.positions()[:, idx], atol=1e-12)
        for j, name in enumerate(sub.skeleton.names):  # parents are the same joints as before
            p = sub.skeleton.parents[j]
            full_p = m.skeleton.parents[m.skeleton.index(name)]
            assert (p < 0 and full_p < 0) or sub.skeleton.names[p] == m.skeleton.names[full_p]


def test_hdm05_and_cmu_share_the_31_joint_topology(cmu, hdm05):
    assert hdm05.skeleton.names == cmu.skeleton.names
    assert np.array_equal(hdm05.skeleton.parents, cmu.skeleton.parents)


def test_foot_contacts_hand_computed():
    # one foot joint, 6 frames at 10 fps; heights and x positions chosen by hand
    y = np.array([0.00, 0.01, 0.20, 0.30, 0.02, 0.00])
    x = np.array([0.00, 0.00, 0.00, 0.50, 1.00, 1.00])
    pos = np.zeros((6, 1, 3))
    pos[:, 0, 0], pos[:, 0, 1] = x, y
    # speeds (m/s): f1: 0.1, f2: 1.9, f3: 5.1, f4: 5.0, f5: 0.2; f0 copies f1
    got = foot_contacts(pos, fps=10, feet=[[0]], height_threshold=0.05, speed_threshold=0.5, floor=0.0)
    assert got[:, 0].tolist() == [True, True, False, False, False, True]


def test_configuration_hand_computed():
    sk = Skeleton(("root", "a", "b"), [-1, 0, 1], [[0, 0, 0], [0, -0.5, 0], [0.1, -0.4, 0]],
                  end_sites=((2, (0.0, -0.05, 0.2)),))
    c = sk.configuration()
    # lowest point is the end site at y = -0.95; root height 0.95; then root-relative joints
    np.testing.assert_allclose(c, [0.95, 0, -0.5, 0, 0.1, -0.9, 0])


def test_lazy_rotations_equal_eager_and_survive_pickle(data_dir):
    import pickle


    lazy = read_bvh(data_dir / "cmu" / "35" / "35_01.bvh")
    assert "rotations" not in lazy.__dict__  # not computed yet
    assert lazy.n_frames == 359 and lazy.duration == pytest.approx(358 / 120)
    eager = Motion(lazy.skeleton, lazy.rotations, lazy.root_positions, lazy.fps)
    clone = pickle.loads(pickle.dumps(read_bvh(data_dir / "cmu" / "35" / "35_01.bvh")))
    np.testing.assert_array_equal(clone.rotations, eager.rotations)
    bad = Motion(lazy.skeleton, lambda: np.zeros((3, 31, 3, 3)), lazy.root_positions, lazy.fps)
    with pytest.raises(ValueError, match="rotations must be"):
        bad.rotations


def test_derived_motions_keep_per_frame_meta_consistent(data_dir):
    from mocapviz.io.bvh import write_bvh

    motion = read_bvh(data_dir / "cmu" / "35" / "35_01.bvh")
    part = motion[10:20]
    np.testing.assert_array_equal(part.meta["channel_values"], motion.meta["channel_values"][10:20])
    assert "channel_values" not in motion.resample(60).meta
    assert "channel_values" not in motion.mirrored().meta
    small = motion.keep_joints(CCNET_25_JOINTS)
    assert "channels" not in small.meta and "channel_values" not in small.meta
    again = read_bvh("part.bvh", text=write_bvh(part), length_unit=motion.meta["length_unit"])
    np.testing.assert_allclose(again.positions(), part.positions(), atol=1e-6)
    again = read_bvh("small.bvh", text=write_bvh(small), length_unit=motion.meta["length_unit"])
    np.testing.assert_allclose(again.positions(), small.positions(), atol=1e-6)


def test_resampling_carries_joint_translations(data_dir):
    bandai = sorted((data_dir / "bandai").glob("*/*.bvh")) if (data_dir / "bandai").is_dir() else []
    if not bandai:
        pytest.skip("no bandai folder in the data folder")
    m = read_bvh(bandai[0])[:20]  # 30 fps, every joint with per-frame translations
    assert len(m.translations) >= 10  # most joints (those whose channels do not repeat OFFSET)
    up = m.resample(60.0)
    assert up.n_frames == 39 and set(up.translations) == set(m.translations)
    for j, t in m.translations.items():
        np.testing.assert_allclose(up.translations[j][::2], t, atol=1e-12)  # old frames kept
        np.testing.assert_allclose(up.translations[j][1::2], (t[:-1] + t[1:]) / 2, atol=1e-12)  # lerp
    np.testing.assert_allclose(up.positions()[::2], m.positions(), atol=1e-12)
    part = m.sample([2.0, 7.0])
    np.testing.assert_allclose(part.positions(), m.positions()[[2, 7]], atol=1e-12)
    # mirroring, slicing and dropping joints keep them consistent with FK too
    np.testing.assert_allclose(m.mirrored().positions()[:, m.skeleton.mirror_map()] * [-1, 1, 1],
                               m.positions(), atol=1e-12)
    np.testing.assert_allclose(m[5:9].positions(), m.positions()[5:9], atol=1e-12)


def test_torch_fk_uses_joint_translations(data_dir):
    bandai = sorted((data_dir / "bandai").glob("*/*.bvh")) if (data_dir / "bandai").is_dir() else []
    if not bandai:
        pytest.skip("no bandai folder in the data folder")
    m = read_bvh(bandai[0])[:10]
    sk = m.skeleton
    pos = forward_kinematics(torch.tensor(m.rotations), torch.tensor(m.root_positions), sk.offsets, sk.parents,
                             translations={j: torch.tensor(t) for j, t in m.translations.items()})
    np.testing.assert_allclose(pos.numpy(), m.positions(), atol=1e-12)
    rigid = forward_kinematics(m.rotations, m.root_positions, sk.offsets, sk.parents)
    assert np.abs(rigid - m.positions()).max() > 0.5  # without them Bandai's body stays at the origin
