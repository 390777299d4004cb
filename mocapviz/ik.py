"""Two-bone leg IK and contact-triggered foot locking (foot-sliding cleanup, CCNet paper §3.1).

One IK serves both callers: CCNet's foot locking (:func:`remove_foot_sliding`, on local
rotations) and retargeting onto anny (:func:`mocapviz.bodies.retarget.retarget`, on global
rotations). It works in world terms: bend the knee in the plane of the hip, the current knee
and the target, swing the thigh so the knee lands there, then turn the shin onto the target.
Every other joint keeps its global rotation, so the foot keeps its orientation.

Convention as everywhere: global = parent_global @ local, column vectors, metres, Y up.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from mocapviz.heading import shortest_arc
from mocapviz.kinematics import global_to_local
from mocapviz.motion import Motion
from mocapviz.skeleton import Skeleton

# The leg chains and feet of the VICON/CMU tree (and its 25-joint CCNet subset, and anny's cmu_mb rig).
LEGS = (("LeftUpLeg", "LeftLeg", "LeftFoot"), ("RightUpLeg", "RightLeg", "RightFoot"))
FEET = (("LeftFoot", "LeftToeBase"), ("RightFoot", "RightToeBase"))


def foot_joints(skeleton: Skeleton, feet=FEET) -> list[list[int]]:
    """Joint indices of each foot (``[[left ankle, left toe], [right ankle, right toe]]``)."""
    return [[skeleton.index(n) for n in foot] for foot in feet]


def two_bone_ik(global_rotations: np.ndarray, positions: np.ndarray, skeleton: Skeleton, targets: dict,
                legs=LEGS) -> np.ndarray:
    """Bend hip and knee so that each ankle reaches its target (F, 3) in metres.

    ``global_rotations`` (F, J, 3, 3) and ``positions`` (F, J, 3) are the FK of a pose on
    ``skeleton``; ``targets`` maps an ankle name of ``legs`` to its target (legs without a
    target are left alone). The hips stay where they are, the knee bends towards the side it
    already points to (forward about the thigh's x axis when the leg is straight), and every
    other global rotation is kept (the foot keeps its orientation). A target beyond the
    leg's reach is approached along the line from the hip, the leg straight (full length).
    Returns the new global rotations (F, J, 3, 3).
    """
    glob = np.array(global_rotations, dtype=np.float64, copy=True)
    for hip_n, knee_n, ankle_n in legs:
        if ankle_n not in targets:
            continue
        h, k, a = (skeleton.index(n) for n in (hip_n, knee_n, ankle_n))
        H, K, A, T = positions[:, h], positions[:, k], positions[:, a], np.asarray(targets[ankle_n])
        l1, l2 = np.linalg.norm(skeleton.offsets[k]), np.linalg.norm(skeleton.offsets[a])
        ht = T - H
        d = np.clip(np.linalg.norm(ht, axis=-1), abs(l1 - l2), l1 + l2)  # reachable hip-ankle distance
        u = ht / np.linalg.norm(ht, axis=-1, keepdims=True)
        bend = (K - H) - np.einsum("ni,ni->n", K - H, u)[:, None] * u  # pole: the current knee side
        bend_n = np.linalg.norm(bend, axis=-1, keepdims=True)
        fallback = np.cross(u, glob[:, h, :, 0])  # a straight leg: bend forward about the thigh's x axis
        bend = np.where(bend_n > 1e-6, bend / np.maximum(bend_n, 1e-12),
                        fallback / np.linalg.norm(fallback, axis=-1, keepdims=True))
        cos_a = np.clip((l1 ** 2 + d ** 2 - l2 ** 2) / (2 * l1 * d), -1.0, 1.0)  # law of cosines at the hip
        K_new = H + l1 * (cos_a[:, None] * u + np.sqrt(1 - cos_a ** 2)[:, None] * bend)
        r1 = shortest_arc(K - H, K_new - H)
        glob[:, h] = r1 @ glob[:, h]
        shin_old = np.einsum("nij,nj->ni", r1, A - K)
        r2 = shortest_arc(shin_old, H + d[:, None] * u - K_new)
        glob[:, k] = r2 @ r1 @ glob[:, k]
    return glob


def contact_segments(labels: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) runs of True in a 1-D boolean array."""
    d = np.diff(np.concatenate([[0], labels.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


# A held foot whose free trajectory drifts farther than this on the ground (m) is put down again
# where it is. In real clips the largest drift within a contact run is 0.06 m at the median and
# 0.14 m at the 99th percentile (300 dataset v4 clips, 2,808 runs; max 0.32), so real feet hardly
# ever re-plant. Why: a generated root that glides while its feet are labelled in contact (measured:
# the waving seed, 6.8x the real ground speed, both feet in contact throughout) pinned the feet
# where the run began, and the IK stretched the legs out level behind a body sitting in the air.
MAX_SLIP = 0.2


def foot_lock_targets(ankle: np.ndarray, contact: np.ndarray, blend: int = 5, max_slip: float = MAX_SLIP) -> np.ndarray:
    """Ankle targets (F, 3): held on the ground plane (X, Z) where each contact run starts (and
    again wherever the free ankle has drifted more than ``max_slip`` from the hold), the height
    left free (the heel may rise while the toes still touch), eased back to the free trajectory
    over ``blend`` frames after the run ends."""
    target = ankle.copy()
    n = len(ankle)
    for s, e in contact_segments(contact):
        hold = ankle[s, [0, 2]]
        for t in range(s, e):
            if np.hypot(*(ankle[t, [0, 2]] - hold)) > max_slip:
                hold = ankle[t, [0, 2]]
            target[t, [0, 2]] = hold
        locked = target[e - 1]
        for k in range(1, blend + 1):
            if e + k - 1 >= n or contact[min(e + k - 1, n - 1)]:
                break
            w = 1.0 - k / (blend + 1)
            target[e + k - 1] = w * locked + (1 - w) * ankle[e + k - 1]
    return target


def remove_foot_sliding(motion: Motion, contacts: np.ndarray, legs=LEGS, blend: int = 5) -> Motion:
    """Motion with each foot held still while its contact label (F, 2) is on (two-bone IK)."""
    sk = motion.skeleton
    pos, glob = motion.global_pose()
    targets = {leg[2]: foot_lock_targets(pos[:, sk.index(leg[2])], labels, blend)
               for leg, labels in zip(legs, np.asarray(contacts, dtype=bool).T)}
    rot = global_to_local(two_bone_ik(glob, pos, sk, targets, legs), sk.parents)
    # Legs whose joints carry per-frame translations keep them: the IK reads bone lengths
    # from the offsets, so a stretching leg is solved with its rest lengths (approximate).
    return replace(motion, rotations=rot, root_positions=motion.root_positions.copy(),
                   translations=dict(motion.translations), meta={**motion.meta, "foot_ik": True})
