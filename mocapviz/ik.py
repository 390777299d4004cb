"""Two-bone leg IK and contact-triggered foot locking (foot-sliding cleanup, paper §3.1).

Convention as everywhere: local rotations, global = parent_global @ local, column vectors.
"""

from __future__ import annotations

import numpy as np

from mocapviz.kinematics import forward_kinematics
from mocapviz.motion import Motion
from mocapviz.rotations import rotvec_to_matrix

LEGS = (("LeftUpLeg", "LeftLeg", "LeftFoot"), ("RightUpLeg", "RightLeg", "RightFoot"))


def _unit(v):
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def _angle(u, v):
    return np.arccos(np.clip(np.sum(_unit(u) * _unit(v), axis=-1), -1.0, 1.0))


def two_bone_ik(local_rot: np.ndarray, global_rot: np.ndarray, pos: np.ndarray, chain, target: np.ndarray,
                eps: float = 1e-4) -> np.ndarray:
    """Local rotations (F, J, 3, 3) with the chain (hip a, knee b, ankle c) bent so c reaches
    ``target`` (F, 3) as far as the bone lengths allow (Holden's analytic two-joint IK).

    ``global_rot``/``pos`` are the FK of ``local_rot``. Only joints a and b change.
    """
    a_i, b_i, c_i = chain
    a, b, c = pos[:, a_i], pos[:, b_i], pos[:, c_i]
    lab = np.linalg.norm(b - a, axis=-1)
    lcb = np.linalg.norm(c - b, axis=-1)
    lat = np.clip(np.linalg.norm(target - a, axis=-1), eps, lab + lcb - eps)
    ac_ab_0 = _angle(c - a, b - a)
    ba_bc_0 = _angle(a - b, c - b)
    ac_at_0 = _angle(c - a, target - a)
    ac_ab_1 = np.arccos(np.clip((lcb ** 2 - lab ** 2 - lat ** 2) / (-2 * lab * lat), -1, 1))
    ba_bc_1 = np.arccos(np.clip((lat ** 2 - lab ** 2 - lcb ** 2) / (-2 * lab * lcb), -1, 1))
    axis0 = _unit(np.cross(c - a, b - a))
    axis1 = _unit(np.cross(c - a, target - a))
    a_gr, b_gr = global_rot[:, a_i], global_rot[:, b_i]
    a_inv, b_inv = np.swapaxes(a_gr, -1, -2), np.swapaxes(b_gr, -1, -2)
    r0 = rotvec_to_matrix(np.einsum("fab,fb->fa", a_inv, axis0) * (ac_ab_1 - ac_ab_0)[:, None])
    r1 = rotvec_to_matrix(np.einsum("fab,fb->fa", b_inv, axis0) * (ba_bc_1 - ba_bc_0)[:, None])
    r2 = rotvec_to_matrix(np.einsum("fab,fb->fa", a_inv, axis1) * ac_at_0[:, None])
    out = local_rot.copy()
    out[:, a_i] = local_rot[:, a_i] @ r0 @ r2
    out[:, b_i] = local_rot[:, b_i] @ r1
    return out


def contact_segments(labels: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) runs of True in a 1-D boolean array."""
    d = np.diff(np.concatenate([[0], labels.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


def foot_lock_targets(ankle: np.ndarray, contact: np.ndarray, blend: int = 5) -> np.ndarray:
    """Ankle targets (F, 3): held on the ground plane (X, Z) where each contact run starts, the
    height left free (the heel may rise while the toes still touch), eased back to the free
    trajectory over ``blend`` frames after the run ends."""
    target = ankle.copy()
    n = len(ankle)
    for s, e in contact_segments(contact):
        locked = np.broadcast_to(ankle[s], (e - s, 3)).copy()
        locked[:, 1] = ankle[s:e, 1]
        target[s:e] = locked
        locked = locked[-1]
        for k in range(1, blend + 1):
            if e + k - 1 >= n or contact[min(e + k - 1, n - 1)]:
                break
            w = 1.0 - k / (blend + 1)
            target[e + k - 1] = w * locked + (1 - w) * ankle[e + k - 1]
    return target


def remove_foot_sliding(motion: Motion, contacts: np.ndarray, legs=LEGS, blend: int = 5) -> Motion:
    """Motion with each foot held still while its contact label (F, 2) is on (two-bone IK)."""
    sk = motion.skeleton
    rot = motion.rotations.copy()
    for leg, labels in zip(legs, np.asarray(contacts, dtype=bool).T):
        chain = [sk.index(n) for n in leg]
        pos, grot = forward_kinematics(rot, motion.root_positions, sk.offsets, sk.parents, return_rotations=True)
        target = foot_lock_targets(pos[:, chain[2]], labels, blend)
        rot = two_bone_ik(rot, grot, pos, chain, target)
    out = Motion(sk, rot, motion.root_positions.copy(), motion.fps, name=motion.name, meta=dict(motion.meta))
    out.meta["foot_ik"] = True
    return out


def foot_slide(motion: Motion, contacts: np.ndarray, legs=LEGS) -> float:
    """Mean horizontal ankle speed (m/s) over frames where that foot's contact label is on."""
    pos = motion.positions()
    speeds = []
    for leg, labels in zip(legs, np.asarray(contacts, dtype=bool).T):
        p = pos[:, motion.skeleton.index(leg[2])][:, [0, 2]]
        v = np.linalg.norm(np.diff(p, axis=0), axis=-1) * motion.fps
        on = labels[1:] & labels[:-1]
        if on.any():
            speeds.append(v[on])
    return float(np.concatenate(speeds).mean()) if speeds else 0.0
