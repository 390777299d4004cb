"""Retarget mocap (CMU BVH / HDM05 skeletons) onto a fitted anny body through the cmu_mb rig.

Both rigs share the CMU joint names and tree, but not their rest poses: anny rests in an
A-pose, the mocap skeletons in their own T-like poses (arms out, legs splayed by ~20 deg),
and zero-length joints sit in different places (CMU's Neck and clavicle roots at Spine1).

Method (global rotation transfer with a rest alignment):

1. Rest alignment ``Q_j`` (global, per anny joint): the rotation that turns anny's rest
   bone directions into the source's rest bone directions. The directions of joint j are
   the vectors from j to the first non-coincident points below it in the source tree (a
   child, or a grandchild when the child has zero length, or an end site for a leaf), and
   the same named points on anny (bone heads; a bone's tail for an end site). One
   direction (or several that are collinear in the source, like HDM05's neck and clavicle
   roots that all start straight above Spine1): the smallest rotation between them (mean
   directions); several: their Kabsch rotation. Joints
   that never rotate in the sources (:data:`STATIC_JOINTS`: hip-joint stubs, clavicle
   roots, finger tips) keep anny's own rest relation to their parent (``Q_j = Q_parent``).
2. Each frame: ``G_anny_j = G_source_j Q_j`` (global rotations), then local rotations
   ``L_j = G_anny_parent^T G_anny_j``. A rest-pose source therefore gives ``G = Q``, and
   a source that *is* anny's rest skeleton gives ``Q = I`` and anny's rest pose.
3. Root: anny's Hips head is translated so that the midpoint of its hip joints follows the
   source's hip midpoint exactly (the Hips joint itself sits ~10 cm higher in CMU than in
   anny, so matching it would lift the feet).
4. Ankles: two-bone IK (:func:`mocapviz.ik.two_bone_ik`) on each leg (hip and knee, knee plane kept, foot orientation kept)
   puts anny's ankles on the source's ankles in every frame, so leg-length differences left
   by the shape fit do not turn into foot sliding.
"""

from __future__ import annotations

import warnings

import numpy as np

from mocapviz.heading import shortest_arc
from mocapviz.ik import FEET, LEGS, foot_joints, two_bone_ik
from mocapviz.kinematics import foot_contacts, forward_kinematics, global_to_local
from mocapviz.metrics import foot_sliding, joint_position_errors
from mocapviz.motion import Motion
from mocapviz.skeleton import Skeleton

STATIC_JOINTS = ("LHipJoint", "RHipJoint", "LeftShoulder", "RightShoulder", "LeftHandIndex1",
                 "RightHandIndex1")
# Joints that mean the same anatomical point in CMU BVH, HDM05 and anny: hips, knees, ankles,
# balls of the feet, shoulders, elbows, wrists. Retargeting error is measured on these.
EVAL_JOINTS = ("LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase", "RightUpLeg", "RightLeg",
               "RightFoot", "RightToeBase", "LeftArm", "LeftForeArm", "LeftHand", "RightArm",
               "RightForeArm", "RightHand")
_EPS = 1e-4


def _targets(src: Skeleton, j: int) -> list[tuple[str, bool]]:
    """Points that give joint j's directions: (joint name, is_end_site) pairs."""
    out = []
    for c in src.children(j):
        if np.linalg.norm(src.offsets[c]) > _EPS:
            out.append((src.names[c], False))
        elif src.children(c):
            out.extend(p for p in _targets(src, c) if True)
        else:
            out.extend((src.names[c], True) for jj, off in src.end_sites
                       if jj == c and np.linalg.norm(off) > _EPS)
    if not src.children(j):
        out.extend((src.names[j], True) for jj, off in src.end_sites
                   if jj == j and np.linalg.norm(off) > _EPS)
    return out


def _point(sk: Skeleton, rest: np.ndarray, name: str, end: bool) -> np.ndarray:
    j = sk.index(name)
    if not end:
        return rest[j]
    offs = [np.asarray(off) for jj, off in sk.end_sites if jj == j]
    return rest[j] + offs[0]


def _kabsch(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation R minimising sum |R a_i - b_i|^2 over unit directions."""
    a = a / np.linalg.norm(a, axis=1, keepdims=True)
    b = b / np.linalg.norm(b, axis=1, keepdims=True)
    u, _, vt = np.linalg.svd(b.T @ a)
    d = np.sign(np.linalg.det(u @ vt))
    return u @ np.diag([1.0, 1.0, d]) @ vt


def rest_alignment(source: Skeleton, target: Skeleton, static=STATIC_JOINTS) -> np.ndarray:
    """Global rest alignment Q (J_target, 3, 3): target rest directions -> source rest directions."""
    rs, rt = source.rest_positions(), target.rest_positions()
    Q = np.zeros((target.n_joints, 3, 3))
    for j, name in enumerate(target.names):
        p = target.parents[j]
        parent_q = Q[p] if p >= 0 else np.eye(3)
        if name in static or name not in source.names:
            Q[j] = parent_q
            continue
        s = source.index(name)
        # an end site counts only where the target has one too (4 Bandai takes carry end sites on
        # joints, e.g. the hands, that are not leaves of anny's rig)
        target_ends = {target.names[jj] for jj, _ in target.end_sites}
        pts = [(n, e) for n, e in _targets(source, s) if n in target.names and (not e or n in target_ends)]
        a = [_point(target, rt, n, e) - rt[j] for n, e in pts]
        b = [_point(source, rs, n, e) - rs[s] for n, e in pts]
        keep = [i for i in range(len(pts)) if np.linalg.norm(a[i]) > _EPS]
        if not keep:
            Q[j] = parent_q
        elif len(keep) == 1:
            Q[j] = shortest_arc(a[keep[0]], b[keep[0]])
        else:
            a_k, b_k = np.array([a[i] for i in keep]), np.array([b[i] for i in keep])
            b_unit = b_k / np.linalg.norm(b_k, axis=1, keepdims=True)
            sv = np.linalg.svd(b_unit, compute_uv=False)
            if sv[1] < 0.1 * sv[0]:  # source directions (nearly) collinear: twist undefined
                Q[j] = shortest_arc(a_k.mean(0), b_k.mean(0))
            else:
                Q[j] = _kabsch(a_k, b_k)
    return Q


def hip_midpoint(skeleton: Skeleton, positions: np.ndarray) -> np.ndarray:
    return 0.5 * (positions[..., skeleton.index("LeftUpLeg"), :] + positions[..., skeleton.index("RightUpLeg"), :])


def retarget(motion: Motion, target: Skeleton, Q: np.ndarray | None = None, ik_ankles: bool = True) -> Motion:
    """``motion`` on the ``target`` skeleton (e.g. ``BodyModel.rest_skeleton(beta)``).

    Returns a Motion on ``target`` (same frames and fps) whose FK gives the anny joints;
    mesh it with ``BodyModel.mesh(beta, m.rotations, m.root_positions)``. With ``ik_ankles``
    the hips and knees are then bent (two-bone IK) so that anny's ankles follow the source
    ankles exactly: leg-length differences of a few cm would otherwise make planted feet slide.
    """
    src = motion.skeleton
    for name in STATIC_JOINTS:
        if name in src.names:
            r = motion.rotations[:, src.index(name)]
            dev = np.linalg.norm(r - r[0], axis=(-1, -2)).max()
            if dev > 0.05:  # ~3 degrees of motion
                warnings.warn(f"{motion.name}: joint {name} moves ({dev:.2f}) but is treated as static")
    if Q is None:
        Q = rest_alignment(src, target)
    src_pos, src_glob = motion.global_pose()
    idx = np.array([src.index(n) if n in src.names else -1 for n in target.names])
    glob = np.empty((motion.n_frames, target.n_joints, 3, 3))
    for j in range(target.n_joints):
        p = target.parents[j]
        if idx[j] >= 0 and target.names[j] not in STATIC_JOINTS:
            glob[:, j] = src_glob[:, idx[j]] @ Q[j]
        elif p >= 0:
            glob[:, j] = glob[:, p] @ (Q[p].T @ Q[j])
        else:  # a reference root the source lacks (Unreal's root, HumanIK's Reference): at rest
            glob[:, j] = Q[j]
    local = global_to_local(glob, target.parents)
    zero_root = forward_kinematics(local, np.zeros((motion.n_frames, 3)), target.offsets, target.parents)
    root = hip_midpoint(src, src_pos) - hip_midpoint(target, zero_root)
    if ik_ankles:
        pos = forward_kinematics(local, root, target.offsets, target.parents)
        targets = {leg[2]: src_pos[:, src.index(leg[2])] for leg in LEGS if leg[2] in src.names}
        local = global_to_local(two_bone_ik(glob, pos, target, targets), target.parents)
    out = Motion(target, local, root, motion.fps, name=motion.name, meta=dict(motion.meta))
    out.meta["retargeted_from"] = motion.name
    return out


def joint_errors(source: Motion, target: Motion, joints=EVAL_JOINTS) -> np.ndarray:
    """Per-frame, per-joint distance (F, len(joints)) in metres between corresponding joints."""
    i_s = [source.skeleton.index(n) for n in joints]
    i_t = [target.skeleton.index(n) for n in joints]
    return joint_position_errors(source.positions()[:, i_s], target.positions()[:, i_t])


def source_contacts(motion: Motion, feet=FEET) -> np.ndarray:
    """Foot contact labels (F, 2) of a motion (height and speed thresholds, per foot)."""
    return foot_contacts(motion.positions(), motion.fps, foot_joints(motion.skeleton, feet))


def retarget_report(source: Motion, target: Motion) -> dict:
    """Joint error (cm, mean over EVAL_JOINTS and frames) and foot sliding (cm/s, ankle and toe:
    :func:`mocapviz.metrics.foot_sliding`) of both, on the source's contact frames."""
    err = joint_errors(source, target)
    contacts = source_contacts(source)

    def slide(m: Motion) -> float:
        return foot_sliding(m.positions(), contacts, m.fps, foot_joints(m.skeleton))

    return {"clip": source.name, "frames": source.n_frames, "joint_err_cm": 100 * float(err.mean()),
            "joint_err_max_cm": 100 * float(err.max()),
            "slide_source_cm_s": 100 * slide(source),
            "slide_anny_cm_s": 100 * slide(target),
            "contact_frames": int(contacts.sum())}
