"""Retargeting onto anny: rest-pose identities, joint error and foot sliding on real clips."""

from __future__ import annotations

import numpy as np
import pytest

from mocapviz.bodies.anny_model import NEUTRAL_BETA, body_model
from mocapviz.bodies.retarget import STATIC_JOINTS, rest_alignment, retarget, retarget_report
from mocapviz.motion import Motion


@pytest.fixture(scope="session")
def body():
    return body_model()


@pytest.fixture(scope="session")
def clips(data_dir):
    from data_prep.catalog import build_catalog, load_motion
    cat = build_catalog(data_dir)
    return {c: load_motion(cat[cat["clip"] == c].iloc[0]) for c in ("07_01", "HDM_bd_sneak2StepsLStart_001_120")}


def _rest_motion(skeleton, n=2):
    return Motion(skeleton, np.tile(np.eye(3), (n, skeleton.n_joints, 1, 1)), np.zeros((n, 3)), 120.0, name="rest")


def test_anny_rest_pose_retargets_to_anny_rest_pose(body):
    sk = body.rest_skeleton(NEUTRAL_BETA)
    np.testing.assert_allclose(rest_alignment(sk, sk), np.tile(np.eye(3), (sk.n_joints, 1, 1)), atol=1e-9)
    rest = body.rest_model(NEUTRAL_BETA)
    src = _rest_motion(sk)
    src.root_positions[:] = rest["joints"][0, 0].numpy()
    out = retarget(src, sk)
    np.testing.assert_allclose(out.rotations, src.rotations, atol=1e-9)
    mesh = body.mesh(NEUTRAL_BETA, out.rotations, out.root_positions)
    np.testing.assert_allclose(mesh.vertices[0].numpy(), rest["vertices"][0].numpy(), atol=1e-5)


@pytest.mark.parametrize("clip", ["07_01", "HDM_bd_sneak2StepsLStart_001_120"])
def test_source_rest_pose_gives_source_bone_directions(body, clips, clip):
    """A mocap rest pose (T-like) on anny's A-pose body: every moving bone points the same way."""
    src_sk = clips[clip].skeleton
    tgt = body.rest_skeleton(NEUTRAL_BETA)
    out = retarget(_rest_motion(src_sk), tgt, ik_ankles=False)  # the rest alignment alone
    ps, pt = _rest_motion(src_sk).positions()[0], out.positions()[0]
    checked = 0
    for j, name in enumerate(tgt.names):
        p = tgt.parents[j]
        if p < 0 or tgt.names[p] in STATIC_JOINTS or name not in src_sk.names:
            continue
        a = ps[src_sk.index(name)] - ps[src_sk.index(tgt.names[p])]
        b = pt[j] - pt[p]
        if np.linalg.norm(a) < 1e-3 or np.linalg.norm(b) < 1e-3 or len(src_sk.children(src_sk.index(tgt.names[p]))) > 1:
            continue
        assert np.dot(a, b) / np.linalg.norm(a) / np.linalg.norm(b) > 0.999, name
        checked += 1
    assert checked >= 12  # legs, arms, spine, neck


@pytest.mark.parametrize("clip", ["07_01", "HDM_bd_sneak2StepsLStart_001_120"])
def test_real_clip_joint_error_and_foot_sliding(body, clips, clip):
    from mocapviz.bodies.shape_fit import fit_shapes
    m = clips[clip]
    beta = fit_shapes(body, {"s": m.skeleton}, steps=40).beta[0]
    rep = retarget_report(m, retarget(m, body.rest_skeleton(beta)))
    assert rep["joint_err_cm"] < 6.5, rep
    assert rep["contact_frames"] > 50
    assert rep["slide_anny_cm_s"] <= rep["slide_source_cm_s"] * 1.05, rep


def test_ankles_follow_the_source_with_ik(body, clips):
    """Two-bone IK: anny's ankles land on the source ankles; hips and foot orientation unchanged."""
    from mocapviz.kinematics import forward_kinematics
    m = clips["07_01"]
    tgt = body.rest_skeleton(NEUTRAL_BETA)
    with_ik, without = retarget(m, tgt), retarget(m, tgt, ik_ankles=False)
    ps, pa, p0 = m.positions(), with_ik.positions(), without.positions()
    for name in ("LeftFoot", "RightFoot"):
        np.testing.assert_allclose(pa[:, tgt.index(name)], ps[:, m.skeleton.index(name)], atol=1e-6)
        assert np.abs(p0[:, tgt.index(name)] - ps[:, m.skeleton.index(name)]).max() > 0.01  # IK did something
    for name in ("LeftUpLeg", "RightUpLeg", "Head", "LeftHand"):
        np.testing.assert_allclose(pa[:, tgt.index(name)], p0[:, tgt.index(name)], atol=1e-9)
    _, g_ik = forward_kinematics(with_ik.rotations, with_ik.root_positions, tgt.offsets, tgt.parents, True)
    _, g_0 = forward_kinematics(without.rotations, without.root_positions, tgt.offsets, tgt.parents, True)
    np.testing.assert_allclose(g_ik[:, tgt.index("LeftFoot")], g_0[:, tgt.index("LeftFoot")], atol=1e-9)


def test_a_reference_root_above_the_hips_stays_at_rest(clips):
    """A target with a root the source lacks (Unreal's ``root``, HumanIK's ``Reference``) above
    the hips: the reference stays at rest and every other joint lands where it lands on the same
    skeleton without it. Its global rotation used to be read from an unfilled array (any
    matrix, often not a rotation)."""
    from mocapviz.skeleton import Skeleton

    clip = clips["07_01"][:30]
    sk = clip.skeleton
    with_ref = Skeleton(("Reference",) + tuple(sk.names), np.concatenate([[-1], np.where(sk.parents >= 0, sk.parents + 1, 0)]),
                        np.concatenate([np.zeros((1, 3)), sk.offsets]), tuple((j + 1, off) for j, off in sk.end_sites))
    plain, ref = retarget(clip, sk), retarget(clip, with_ref)
    np.testing.assert_allclose(ref.rotations[:, 0], np.tile(np.eye(3), (30, 1, 1)), atol=1e-9)
    np.testing.assert_allclose(np.linalg.det(ref.rotations), 1.0, atol=1e-9)
    np.testing.assert_allclose(ref.positions()[:, 1:], plain.positions(), atol=1e-9)
