"""anny wrapper: conventions (Y up, metres, FK = mesh joints), float32, batching, subsets."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mocapviz.bodies.anny_model import BETA_LABELS, NEUTRAL_BETA, body_model
from mocapviz.kinematics import forward_kinematics


@pytest.fixture(scope="session")
def body():
    return body_model()  # created once per process (anny's cache build, if any, is logged)


@pytest.fixture(scope="session")
def walk(data_dir):
    from data_prep.catalog import build_catalog, load_motion
    cat = build_catalog(data_dir)
    return load_motion(cat[cat["clip"] == "07_01"].iloc[0])


def test_float32_and_sizes(body):
    assert body.anny.dtype == torch.float32
    assert body.n_vertices == 13718 and body.n_joints == 31
    assert "LeftHandIndex1" in body.joint_names and "LeftHandFinger1" not in body.joint_names


def test_identity_pose_is_rest_mesh_y_up(body):
    rest = body.rest_model(NEUTRAL_BETA)
    rot = np.tile(np.eye(3), (1, body.n_joints, 1, 1))
    out = body.mesh(NEUTRAL_BETA, rot, rest["joints"][0, :1].numpy())
    assert torch.allclose(out.vertices[0], rest["vertices"][0], atol=1e-5)
    v = rest["vertices"][0].numpy()
    head, toe = body.index("Head"), body.index("LeftToeBase")
    j = rest["joints"][0].numpy()
    assert j[head, 1] - j[toe, 1] > 1.3  # Y is up
    assert j[toe, 2] > j[body.index("LeftFoot"), 2]  # toes point to +Z: the body faces +Z
    height = float(body.measurements(NEUTRAL_BETA)["height"][0])
    assert abs((v[:, 1].max() - v[:, 1].min()) - height) < 1e-4  # anny's height (Z) is our Y extent


def test_mesh_joints_equal_our_fk_on_a_real_retargeted_clip(body, walk):
    from mocapviz.bodies.retarget import retarget
    sk = body.rest_skeleton(NEUTRAL_BETA)
    m = retarget(walk[:100], sk)
    out = body.mesh(NEUTRAL_BETA, m.rotations, m.root_positions, joints=True)
    fk = forward_kinematics(m.rotations, m.root_positions, sk.offsets, sk.parents)
    assert out.vertices.shape == (100, body.n_vertices, 3)
    np.testing.assert_allclose(out.joints.numpy(), fk, atol=2e-5)


def test_pose_parameters_round_trip(body, walk):
    from mocapviz.bodies.retarget import retarget
    m = retarget(walk[:10], body.rest_skeleton(NEUTRAL_BETA))
    rot, root = body.rotations_from_pose_parameters(body.pose_parameters(m.rotations, m.root_positions))
    np.testing.assert_allclose(rot, m.rotations, atol=1e-6)
    np.testing.assert_allclose(root, m.root_positions, atol=1e-6)


def test_beta_shape_changes_height_and_is_checked(body):
    tall = NEUTRAL_BETA.copy()
    tall[BETA_LABELS.index("height")] = 1.0
    h = body.measurements(np.stack([NEUTRAL_BETA, tall]))["height"]
    assert h[1] > h[0] + 0.05
    with pytest.raises(ValueError, match="beta must have 6"):
        body.rest_joints(np.zeros(5))


def test_vertex_subset_is_fixed_and_spread(body):
    s = body.vertex_subset()
    assert len(s) == 1024 and len(np.unique(s)) == 1024
    np.testing.assert_array_equal(s[:4], [0, 13029, 9686, 2426])


def test_mesh_cycles_batch_equals_one_by_one(body, walk):
    from mocapviz.bodies.retarget import retarget
    tall = NEUTRAL_BETA.copy()
    tall[BETA_LABELS.index("height")] = 0.9
    betas = np.stack([NEUTRAL_BETA, tall])
    ms = [retarget(walk[i:i + 5], body.rest_skeleton(b)) for i, b in zip((0, 50), betas)]
    batch = body.mesh_cycles(betas, np.stack([m.rotations for m in ms]), np.stack([m.root_positions for m in ms]))
    for k, (m, b) in enumerate(zip(ms, betas)):
        one = body.mesh(b, m.rotations, m.root_positions).vertices
        assert torch.allclose(batch[k], one, atol=1e-5)
