"""mocapviz.heading on hand-computed cases (and scipy for the shortest arc)."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocapviz import heading as hd
from mocapviz.skeleton import Skeleton

S2 = np.sqrt(0.5)


def test_yaw_matrix_turns_z_onto_the_heading_direction():
    r = hd.yaw_matrix(np.array([0.0, np.pi / 2, np.pi]))
    np.testing.assert_allclose(r @ [0.0, 0.0, 1.0], [[0, 0, 1], [1, 0, 0], [0, 0, -1]], atol=1e-15)
    np.testing.assert_allclose(r[1] @ [1.0, 0.0, 0.0], [0, 0, -1], atol=1e-15)  # +X -> -Z at +90 deg
    np.testing.assert_allclose(r[1], Rotation.from_euler("y", 90, degrees=True).as_matrix(), atol=1e-15)


def test_heading_of_directions_and_rotations():
    assert hd.heading_of([1.0, 5.0, 1.0]) == pytest.approx(np.pi / 4)  # Y is ignored
    assert hd.heading_of([-1.0, 0.0, 0.0]) == pytest.approx(-np.pi / 2)
    assert hd.rotation_heading(hd.yaw_matrix(0.3)) == pytest.approx(0.3)
    # a tilt about X does not change where +Z points on the ground
    tilt = Rotation.from_euler("x", 20, degrees=True).as_matrix()
    assert hd.rotation_heading(hd.yaw_matrix(-1.2) @ tilt) == pytest.approx(-1.2)


def test_facing_direction_of_a_body_with_left_at_plus_x_is_plus_z():
    np.testing.assert_allclose(hd.facing_direction(np.array([0.3, 0.0, 0.0])), [0, 0, 0.3])
    np.testing.assert_allclose(hd.facing_direction(np.array([0.0, 0.0, -1.0])), [1, 0, 0])  # left at -Z: faces +X


def test_across_vector_sums_left_minus_right_pairs():
    sk = Skeleton(("Hips", "LeftUpLeg", "RightUpLeg"), np.array([-1, 0, 0]),
                  np.array([[0, 1, 0], [0.1, 0, 0], [-0.1, 0, 0]], dtype=float))
    pos = sk.rest_positions()[None]
    np.testing.assert_allclose(hd.across_vector(pos, sk, [("LeftUpLeg", "RightUpLeg")]), [[0.2, 0, 0]])
    np.testing.assert_allclose(hd.across_vector(pos, sk, [("LeftUpLeg", "RightUpLeg")] * 2), [[0.4, 0, 0]])


def test_wrap_angle():
    np.testing.assert_allclose(hd.wrap_angle(np.array([0.0, 3 * np.pi / 2, -3 * np.pi / 2, 2 * np.pi])),
                               [0.0, -np.pi / 2, np.pi / 2, 0.0], atol=1e-15)


def test_heading_frames_hand_case_and_round_trip():
    # facing +X (theta = pi/2): a world step along +X is "forward" (+Z) in the heading frame
    theta = np.array([np.pi / 2, np.pi / 4])
    v = np.array([[1.0, 0.5, 0.0], [S2, 0.0, S2]])
    local = hd.to_heading_frame(v, theta)
    np.testing.assert_allclose(local, [[0, 0.5, 1], [0, 0, 1]], atol=1e-15)
    np.testing.assert_allclose(hd.from_heading_frame(local, theta), v, atol=1e-15)
    xz = v[:, [0, 2]]
    np.testing.assert_allclose(hd.to_heading_frame_xz(xz, theta), local[:, [0, 2]], atol=1e-15)
    np.testing.assert_allclose(hd.from_heading_frame_xz(local[:, [0, 2]], theta), xz, atol=1e-15)


def test_shortest_arc_hand_cases():
    x, y, z = np.eye(3)
    np.testing.assert_allclose(hd.shortest_arc(x, y), Rotation.from_euler("z", 90, degrees=True).as_matrix(),
                               atol=1e-15)
    np.testing.assert_allclose(hd.shortest_arc(2 * z, z), np.eye(3), atol=1e-15)  # lengths do not matter
    half = hd.shortest_arc(x, -x)  # opposite: a half turn about an axis perpendicular to x
    np.testing.assert_allclose(half @ x, -x, atol=1e-15)
    np.testing.assert_allclose(half @ half, np.eye(3), atol=1e-15)
    assert np.linalg.det(half) == pytest.approx(1.0)


def test_shortest_arc_batched_equals_scipy_one_pair_at_a_time():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(2, 50, 3))
    a[0], b[0] = [0, 0, 1.0], [0, 0, -2.0]  # one opposite pair in the batch
    r = hd.shortest_arc(a, b)
    unit = b / np.linalg.norm(b, axis=-1, keepdims=True)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", r, a / np.linalg.norm(a, axis=-1, keepdims=True)), unit,
                               atol=1e-12)
    for i in range(1, 50):  # scipy's single-pair align_vectors is the shortest rotation
        ref = Rotation.align_vectors(b[i][None], a[i][None])[0].as_matrix()
        np.testing.assert_allclose(r[i], ref, atol=1e-12)
