"""Motion metrics on tiny arrays whose values are worked out by hand in the comments."""

from __future__ import annotations

import numpy as np
import pytest

from mocapviz.metrics import foot_sliding, joint_position_errors, mean_joint_error


def test_joint_errors_by_hand():
    a = np.zeros((2, 2, 3))
    b = np.array([[[3.0, 4.0, 0.0], [0.0, 0.0, 1.0]],    # distances 5 and 1
                  [[0.0, 0.0, 0.0], [1.0, 2.0, 2.0]]])   # distances 0 and 3
    np.testing.assert_allclose(joint_position_errors(a, b), [[5.0, 1.0], [0.0, 3.0]])
    assert mean_joint_error(a, b) == (5 + 1 + 0 + 3) / 4


def test_foot_sliding_by_hand():
    fps = 10.0
    # one foot of two joints (ankle 0, toe 1); a frame pair counts the slower of the two
    pos = np.zeros((4, 2, 3))
    pos[:, 0, 0] = [0.0, 0.1, 0.1, 0.4]   # ankle X
    pos[:, 0, 2] = [0.0, 0.0, 0.0, 0.3]   # ankle Z: steps 0.1, 0, hypot(0.3, 0.3) = 0.424 m
    pos[:, 1, 0] = [0.2, 0.3, 0.5, 0.8]   # toe X:   steps 0.1, 0.2, 0.3 m
    pos[:, :, 1] = [[0.5], [0.5], [0.9], [0.0]]  # height is ignored
    # slowest joint per pair: 0.1, 0.0, 0.3 m in 0.1 s -> 1.0, 0.0, 3.0 m/s
    contacts = np.array([[True], [True], [True], [False]])  # pairs (0, 1), (1, 2): (1 + 0) / 2
    assert np.isclose(foot_sliding(pos, contacts, fps, [[0, 1]]), 0.5)
    contacts[:, 0] = [False, True, True, True]              # pairs (1, 2), (2, 3): (0 + 3) / 2
    assert np.isclose(foot_sliding(pos, contacts, fps, [[0, 1]]), 1.5)


def test_foot_sliding_pools_feet_and_is_nan_without_contacts():
    fps = 2.0
    pos = np.zeros((3, 2, 3))
    pos[:, 0, 2] = [0.0, 1.0, 1.0]        # foot 0 (joint 0): 2 m/s, then 0 m/s
    pos[:, 1, 0] = [0.0, 0.0, 3.0]        # foot 1 (joint 1): 0 m/s, then 6 m/s
    contacts = np.array([[True, False], [True, True], [True, True]])
    # foot 0 pairs (0,1), (1,2): 2, 0; foot 1 pair (1,2): 6 -> mean of three = 8 / 3
    assert np.isclose(foot_sliding(pos, contacts, fps, [[0], [1]]), 8 / 3)
    assert np.isnan(foot_sliding(pos, np.zeros((3, 2), bool), fps, [[0], [1]]))


def test_rel_p_by_hand():
    from mocapviz.metrics import rel_p
    true = np.array([[3.0, 4.0], [0.0, 2.0]])
    pred = np.array([[3.0, 4.0], [0.0, 3.0]])           # frame errors 0 / 5 and 1 / 2
    assert rel_p(pred, true) == pytest.approx(0.25)
    assert rel_p(np.zeros_like(true), true) == pytest.approx(1.0)
    assert rel_p(true, true) == 0.0
    with pytest.raises(ValueError, match="one shape"):
        rel_p(pred[:1], true)
