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
4. Ankles: two-bone IK on each leg (hip and knee, knee plane kept, foot orientation kept)
   puts anny's ankles on the source's ankles in every frame, so leg-length differences left
   by the shape fit do not turn into foot sliding.
"""

from __future__ import annotations

import warnings

import numpy as np

from mocapviz.bodies.anny_model import BodyModel
from mocapviz.heading import shortest_arc
from mocapviz.kinematics import foot_contacts, forward_kinematics
from mocapviz.motion import Motion
from mocapviz.skeleton import Skeleton

STATIC_JOINTS = ("LHipJoint", "RHipJoint", "LeftShoulder", "RightShoulder", "LeftHandIndex1",
                 "RightHandIndex1")
# Joints that mean the same anatomical point in CMU BVH, HDM05 and anny: hips, knees, ankles,
# balls of the feet, shoulders, elbows, wrists. Retargeting error is measured on these.
EVAL_JOINTS = ("LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase", "RightUpLeg", "RightLeg",
               "RightFoot", "RightToeBase", "LeftArm", "LeftForeArm", "LeftHand", "RightArm",
               "RightForeArm", "RightHand")
FEET = (("LeftFoot", "LeftToeBase"), ("RightFoot", "RightToeBase"))
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
        pts = [(n, e) for n, e in _targets(source, s) if n in target.names]
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


LEGS = (("LeftUpLeg", "LeftLeg", "LeftFoot"), ("RightUpLeg", "RightLeg", "RightFoot"))


def two_bone_ik(glob: np.ndarray, pos: np.ndarray, skeleton: Skeleton, targets: dict) -> np.ndarray:
    """Bend hip and knee so that each ankle reaches its target (F, 3), keeping the hips
    where they are, the knee's bending plane, and every other global rotation (the foot keeps
    its orientation). ``glob``/``pos``: global rotations (F, J, 3, 3) and positions (F, J, 3).
    Returns the new global rotations; unreachable targets are approached along the leg line."""
    glob = glob.copy()
    for hip_n, knee_n, ankle_n in LEGS:
        if ankle_n not in targets:
            continue
        h, k, a = (skeleton.index(n) for n in (hip_n, knee_n, ankle_n))
        H, K, A, T = pos[:, h], pos[:, k], pos[:, a], targets[ankle_n]
        l1, l2 = np.linalg.norm(skeleton.offsets[k]), np.linalg.norm(skeleton.offsets[a])
        ht = T - H
        d = np.clip(np.linalg.norm(ht, axis=-1), abs(l1 - l2) + 1e-4, l1 + l2 - 1e-4)
        u = ht / np.linalg.norm(ht, axis=-1, keepdims=True)
        bend = (K - H) - np.einsum("ni,ni->n", K - H, u)[:, None] * u  # pole: the current knee side
        bend_n = np.linalg.norm(bend, axis=-1, keepdims=True)
        fallback = np.cross(u, glob[:, h, :, 0])  # a straight leg: bend forward about the thigh's x axis
        bend = np.where(bend_n > 1e-6, bend / np.maximum(bend_n, 1e-12), fallback / np.linalg.norm(fallback, axis=-1, keepdims=True))
        cos_a = np.clip((l1 ** 2 + d ** 2 - l2 ** 2) / (2 * l1 * d), -1.0, 1.0)
        K_new = H + l1 * (cos_a[:, None] * u + np.sqrt(1 - cos_a ** 2)[:, None] * bend)
        r1 = shortest_arc(K - H, K_new - H)
        glob[:, h] = r1 @ glob[:, h]
        shin_old = np.einsum("nij,nj->ni", r1, A - K)
        r2 = shortest_arc(shin_old, H + d[:, None] * u - K_new)
        glob[:, k] = r2 @ r1 @ glob[:, k]
    return glob


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
    src_pos, src_glob = forward_kinematics(motion.rotations, motion.root_positions, src.offsets,
                                           src.parents, return_rotations=True)
    idx = np.array([src.index(n) if n in src.names else -1 for n in target.names])
    glob = np.empty((motion.n_frames, target.n_joints, 3, 3))
    for j in range(target.n_joints):
        if idx[j] >= 0 and target.names[j] not in STATIC_JOINTS:
            glob[:, j] = src_glob[:, idx[j]] @ Q[j]
        else:
            glob[:, j] = glob[:, target.parents[j]] @ (Q[target.parents[j]].T @ Q[j])
    local = np.empty_like(glob)
    local[:, 0] = glob[:, 0]
    local[:, 1:] = np.swapaxes(glob[:, target.parents[1:]], -1, -2) @ glob[:, 1:]
    zero_root = forward_kinematics(local, np.zeros((motion.n_frames, 3)), target.offsets, target.parents)
    root = hip_midpoint(src, src_pos) - hip_midpoint(target, zero_root)
    if ik_ankles:
        pos = forward_kinematics(local, root, target.offsets, target.parents)
        targets = {leg[2]: src_pos[:, src.index(leg[2])] for leg in LEGS if leg[2] in src.names}
        glob = two_bone_ik(glob, pos, target, targets)
        local[:, 1:] = np.swapaxes(glob[:, target.parents[1:]], -1, -2) @ glob[:, 1:]
    out = Motion(target, local, root, motion.fps, name=motion.name, meta=dict(motion.meta))
    out.meta["retargeted_from"] = motion.name
    return out


def retarget_to_body(motion: Motion, body: BodyModel, beta) -> Motion:
    return retarget(motion, body.rest_skeleton(beta))


def joint_errors(source: Motion, target: Motion, joints=EVAL_JOINTS) -> np.ndarray:
    """Per-frame, per-joint distance (F, len(joints)) in metres between corresponding joints."""
    ps, pt = source.positions(), target.positions()
    i_s = [source.skeleton.index(n) for n in joints]
    i_t = [target.skeleton.index(n) for n in joints]
    return np.linalg.norm(ps[:, i_s] - pt[:, i_t], axis=-1)


def foot_sliding(motion: Motion, contacts: np.ndarray, feet=FEET) -> float:
    """Mean horizontal speed (m/s) of feet during contact frames (``contacts`` (F, 2)).

    A foot's speed is the mean of its ankle and toe joints' ground-plane speeds.
    """
    pos = motion.positions()
    speeds = []
    for i, names in enumerate(feet):
        idx = [motion.skeleton.index(n) for n in names]
        p = pos[:, idx][..., [0, 2]].mean(1)
        v = np.linalg.norm(np.gradient(p, axis=0), axis=-1) * motion.fps
        speeds.append(v[contacts[:, i]])
    speeds = np.concatenate(speeds)
    return float(speeds.mean()) if len(speeds) else float("nan")


def source_contacts(motion: Motion, feet=FEET) -> np.ndarray:
    """Foot contact labels (F, 2) of a motion (height and speed thresholds, per foot)."""
    idx = [[motion.skeleton.index(n) for n in names] for names in feet]
    return foot_contacts(motion.positions(), motion.fps, idx)


def retarget_report(source: Motion, target: Motion) -> dict:
    """Joint error (cm, mean over EVAL_JOINTS and frames) and foot sliding (cm/s) of both."""
    err = joint_errors(source, target)
    contacts = source_contacts(source)
    return {"clip": source.name, "frames": source.n_frames, "joint_err_cm": 100 * float(err.mean()),
            "joint_err_max_cm": 100 * float(err.max()),
            "slide_source_cm_s": 100 * foot_sliding(source, contacts),
            "slide_anny_cm_s": 100 * foot_sliding(target, contacts),
            "contact_frames": int(contacts.sum())}
