"""Two-bone IK on a real clip (CMU 35_01): the ankle reaches reachable targets, and unreachable
ones end on the line from the hip at full leg length."""

from __future__ import annotations

import numpy as np
import pytest

from mocapviz.ik import LEGS, two_bone_ik
from mocapviz.io.bvh import read_bvh
from mocapviz.kinematics import forward_kinematics, global_to_local


@pytest.fixture(scope="module")
def walk(data_dir):
    m = read_bvh(data_dir / "cmu" / "35" / "35_01.bvh")
    pos, glob = forward_kinematics(m.rotations, m.root_positions, m.skeleton.offsets, m.skeleton.parents,
                                   return_rotations=True)
    return m, pos, glob


def _solve(walk, targets):
    """Positions (F, J, 3) and global rotations after the IK, through local rotations and FK."""
    m, pos, glob = walk
    sk = m.skeleton
    local = global_to_local(two_bone_ik(glob, pos, sk, targets), sk.parents)
    return forward_kinematics(local, m.root_positions, sk.offsets, sk.parents, return_rotations=True)


def _leg(sk, leg):
    h, k, a = (sk.index(n) for n in leg)
    return h, k, a, np.linalg.norm(sk.offsets[k]), np.linalg.norm(sk.offsets[a])


def _directions(n, seed):
    d = np.random.default_rng(seed).normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


@pytest.mark.parametrize("distance", [0.05, 0.15])
def test_ankle_reaches_reachable_targets(walk, distance):
    m, pos, glob = walk
    sk = m.skeleton
    targets = {leg[2]: pos[:, sk.index(leg[2])] + distance * _directions(m.n_frames, i) for i, leg in enumerate(LEGS)}
    new_pos, new_glob = _solve(walk, targets)
    legs = set()
    for leg in LEGS:
        h, k, a, l1, l2 = _leg(sk, leg)
        legs |= {h, k, a, sk.index(leg[2].replace("Foot", "ToeBase"))}
        reach = np.linalg.norm(targets[leg[2]] - pos[:, h], axis=1)
        ok = (reach > abs(l1 - l2) + 1e-3) & (reach < l1 + l2 - 1e-3)
        assert ok.sum() > 0.5 * m.n_frames  # most frames test the reachable case
        err = np.linalg.norm(new_pos[ok, a] - targets[leg[2]][ok], axis=1)
        assert err.max() < 1e-6, (leg, err.max())
        np.testing.assert_allclose(new_glob[:, a], glob[:, a], atol=1e-9)  # the foot keeps its orientation
        np.testing.assert_allclose(np.linalg.norm(new_pos[:, k] - new_pos[:, h], axis=1), l1, atol=1e-9)
        np.testing.assert_allclose(np.linalg.norm(new_pos[:, a] - new_pos[:, k], axis=1), l2, atol=1e-9)
    others = [j for j in range(sk.n_joints) if j not in legs]
    np.testing.assert_allclose(new_pos[:, others], pos[:, others], atol=1e-9)


def test_unreachable_target_ends_on_the_hip_line_at_full_length(walk):
    m, pos, glob = walk
    sk = m.skeleton
    targets = {}
    for i, leg in enumerate(LEGS):
        h, k, a, l1, l2 = _leg(sk, leg)
        targets[leg[2]] = pos[:, h] + 1.3 * (l1 + l2) * _directions(m.n_frames, 10 + i)
    new_pos, _ = _solve(walk, targets)
    for leg in LEGS:
        h, k, a, l1, l2 = _leg(sk, leg)
        line = targets[leg[2]] - pos[:, h]
        expected = pos[:, h] + (l1 + l2) * line / np.linalg.norm(line, axis=1, keepdims=True)
        err = np.linalg.norm(new_pos[:, a] - expected, axis=1)
        assert err.max() < 1e-6, (leg, err.max())
