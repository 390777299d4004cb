"""Motion metrics as pure numpy functions of joint positions (metres, Y up, frames at ``fps``).

A flat module: each function states its array shapes and units, and has a hand-computed
test case in ``tests/test_metrics.py``. Motions enter as positions (``Motion.positions()``),
never as objects, so that generated, retargeted and captured motion are measured alike.
"""

from __future__ import annotations

import numpy as np


def joint_position_errors(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Euclidean distance (..., J) in metres between corresponding joints of ``a`` and ``b``
    (both (..., J, 3))."""
    return np.linalg.norm(np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64), axis=-1)


def mean_joint_error(a: np.ndarray, b: np.ndarray) -> float:
    """Mean per-joint position error (MPJPE) in metres: :func:`joint_position_errors` of
    ``a`` and ``b`` (..., J, 3) averaged over every frame and joint."""
    return float(joint_position_errors(a, b).mean())


def foot_sliding(positions: np.ndarray, contacts: np.ndarray, fps: float, feet) -> float:
    """Mean horizontal speed (m/s) of the feet while they touch the ground.

    ``positions`` (F, J, 3); ``contacts`` (F, K) booleans, one column per foot; ``feet`` K
    lists of joint indices (ankle and toe: :func:`mocapviz.ik.foot_joints`). Between frames
    n and n+1 where a foot is in contact in both, its speed is that of its slowest joint on
    the ground plane (X, Z), by forward difference ``|p[n+1] - p[n]| * fps``: a planted foot
    pivots about its heel or its toes (the other end may move), so it slides only when no
    joint of it stays put. Returns the mean over those frame pairs of all feet; NaN when
    there are none (no contact is not "no sliding").
    """
    positions = np.asarray(positions, dtype=np.float64)
    contacts = np.asarray(contacts, dtype=bool)
    speeds = []
    for k, joints in enumerate(feet):
        ground = positions[:, list(joints)][..., [0, 2]]  # (F, joints, 2)
        v = np.linalg.norm(np.diff(ground, axis=0), axis=-1).min(axis=1) * fps
        speeds.append(v[contacts[1:, k] & contacts[:-1, k]])
    speeds = np.concatenate(speeds)
    return float(speeds.mean()) if len(speeds) else float("nan")
