"""Motion metrics as pure numpy functions of joint positions (metres, Y up, frames at ``fps``).

A flat module: each function states its array shapes and units, and has a hand-computed
test case in ``tests/test_metrics.py`` (pose level: ``tests/test_metrics_pose.py``). Motions
enter as positions (``Motion.positions()``), never as objects, so that generated, retargeted and
captured motion are measured alike.

The pose-level metrics of generated motion (activity, jitter, freezing share) read *poses*:
:func:`local_positions`, joint positions relative to the root joint in each frame's heading
frame, so a body that glides along its path as a statue has constant local positions while a
real walk does not. They never read the network's frame vector: a model can predict a constant
non-zero velocity block while the pose it outputs is frozen. Each is compared with real clips
of the same motion type by :func:`ratio`.

Activity and jitter cannot tell a walk from a body tumbling at a walk's pace: :class:`PoseBank`
measures how far each pose is from the nearest real pose (plausibility).
"""

from __future__ import annotations

import numpy as np

from mocapviz.features.ccnet import heading_angles
from mocapviz.heading import to_heading_frame

# A window is frozen when its mean local joint speed is under this (m/s). Measured on the 245
# clips of dataset v3 that are at least 1 s long (1 s windows): the slowest window of any clip
# is 0.017 m/s (lying still on the floor), of a jog 0.022 (standing before the start), of a
# walk 0.15, of a sneak 0.20; typical windows are 0.15-0.7 m/s. No real window goes under
# 0.01 m/s (1 cm/s mean joint speed), while a held pose sits at ~0.
FROZEN_SPEED = 0.01


def joint_position_errors(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Euclidean distance (..., J) in metres between corresponding joints of ``a`` and ``b``
    (both (..., J, 3))."""
    return np.linalg.norm(np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64), axis=-1)


def mean_joint_error(a: np.ndarray, b: np.ndarray) -> float:
    """Mean per-joint position error (MPJPE) in metres: :func:`joint_position_errors` of
    ``a`` and ``b`` (..., J, 3) averaged over every frame and joint."""
    return float(joint_position_errors(a, b).mean())


def rel_p(pred: np.ndarray, true: np.ndarray) -> float:
    """CCNet §4.6's relative prediction error: the mean over frames of |x̂_n - x_n| / |x_n|
    (Euclidean norms of whole frame vectors ``pred`` and ``true`` (N, D), no IK). The vectors
    are the motion representation itself (the continuous part of CCNet's x, raw units), not
    joint positions. 0 for a perfect prediction; 1 for predicting zeros."""
    return float(rel_p_frames(pred, true).mean())


def rel_p_frames(pred: np.ndarray, true: np.ndarray) -> np.ndarray:
    """(N,) the per-frame terms |x̂_n - x_n| / |x_n| of :func:`rel_p` (for its spread)."""
    pred, true = np.asarray(pred, dtype=np.float64), np.asarray(true, dtype=np.float64)
    if pred.shape != true.shape or pred.ndim != 2:
        raise ValueError(f"rel_p needs two (N, D) arrays of one shape, got {pred.shape} and {true.shape}")
    return np.linalg.norm(pred - true, axis=1) / np.linalg.norm(true, axis=1)


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


def local_positions(positions: np.ndarray, skeleton) -> np.ndarray:
    """(F, J, 3) joint positions minus the root joint's, turned into each frame's heading frame
    (m); ``positions`` (F, J, 3) world positions of ``skeleton``'s joints (the heading needs its
    hips and shoulders)."""
    positions = np.asarray(positions, dtype=np.float64)
    return to_heading_frame(positions - positions[:, :1], heading_angles(positions, skeleton))


def forward_lean(positions: np.ndarray, skeleton, lower: str = "Hips", upper: str = "Neck") -> np.ndarray:
    """(F,) forward lean (degrees, + forward) of the ``lower`` -> ``upper`` joint vector in each
    frame's heading frame (its side-to-side tilt left out), from the same vector in the
    skeleton's rest pose (Y up). Why from the rest: where an exporter puts the spine and neck
    joints tilts that vector at rest (-2.3 degrees on a Mixamo skeleton, -0.7 to -7.9 on the
    VICON ones, 0 on Bandai's), so its angle from vertical compares joint placements, not postures."""
    local = local_positions(positions, skeleton)
    v = local[:, skeleton.index(upper)] - local[:, skeleton.index(lower)]
    rest = skeleton.rest_positions()
    r = rest[skeleton.index(upper)] - rest[skeleton.index(lower)]
    return np.degrees(np.arctan2(v[:, 2], v[:, 1])) - float(np.degrees(np.arctan2(r[2], r[1])))


def pose_speed(local: np.ndarray, fps: float) -> np.ndarray:
    """(F-1,) mean over joints of |p_{n+1} - p_n| * fps for local positions (F, J, 3): m/s."""
    return np.linalg.norm(np.diff(local, axis=0), axis=-1).mean(axis=-1) * fps


def activity(local: np.ndarray, fps: float) -> float:
    """Mean pose change per second (m/s) of local positions (F, J, 3): the mean of :func:`pose_speed`."""
    return float(pose_speed(local, fps).mean())


def jitter(local: np.ndarray, fps: float) -> float:
    """Mean over frames and joints of |p_{n+1} - 2 p_n + p_{n-1}| * fps^2 (m/s^2), local (F, J, 3)."""
    d2 = local[2:] - 2 * local[1:-1] + local[:-2]
    return float(np.linalg.norm(d2, axis=-1).mean() * fps ** 2)


def window_speeds(local: np.ndarray, fps: float, seconds: float = 1.0) -> np.ndarray:
    """(W,) mean :func:`pose_speed` of consecutive non-overlapping windows of ``seconds`` (m/s);
    a trailing partial window is dropped."""
    n = round(seconds * fps)
    v = pose_speed(local, fps)
    w = len(v) // n
    return v[:w * n].reshape(w, n).mean(axis=1)


def freezing_share(local: np.ndarray, fps: float, seconds: float = 1.0, threshold: float = FROZEN_SPEED) -> float:
    """Share of ``seconds``-long windows of local positions (F, J, 3) whose mean joint speed is
    under ``threshold`` (m/s); NaN if any pose is not finite (a diverged generation is not "moving")."""
    w = window_speeds(local, fps, seconds)
    if not len(w):
        raise ValueError(f"need at least {seconds} s of frames")
    if not np.isfinite(w).all():
        return float("nan")
    return float((w < threshold).mean())


def root_speed(root_positions: np.ndarray, fps: float) -> float:
    """Mean horizontal speed (m/s) of root positions (F, 3), Y up: a body that glides faster or
    slower than its gait carries it shows here, which the root-relative pose metrics cannot see."""
    ground = np.asarray(root_positions, dtype=np.float64)[:, [0, 2]]
    return float(np.linalg.norm(np.diff(ground, axis=0), axis=-1).mean() * fps)


def ratio(value: float, real_values) -> float:
    """``value`` over the mean of the same metric on real clips (e.g. of the same motion type)."""
    return float(value / np.mean(real_values))


def ground_penetration(positions: np.ndarray, floor: float = 0.0) -> float:
    """Mean depth (m) of the lowest joint under the floor height, over frames (0 above it);
    ``positions`` (F, J, 3) world joint positions."""
    low = np.asarray(positions)[..., 1].min(axis=-1)
    return float(np.maximum(floor - low, 0.0).mean())


def pose_metrics(positions: np.ndarray, skeleton, fps: float, floor: float = 0.0) -> dict[str, float]:
    """Activity (m/s), jitter (m/s^2), freezing share and ground penetration (m) of world joint
    positions (F, J, 3) of ``skeleton`` at ``fps``."""
    local = local_positions(positions, skeleton)
    return dict(activity=activity(local, fps), jitter=jitter(local, fps), freezing_share=freezing_share(local, fps),
                ground_penetration=ground_penetration(positions, floor))


class PoseBank:
    """Real poses to measure plausibility against: local positions (:func:`local_positions`)
    divided by the body's standing root height, so that bodies of different size compare.

    ``poses`` (N, J, 3) in root heights. :meth:`distance` gives, per frame, the root-mean-square
    joint distance to the nearest pose of the bank (in root heights; x100 reads as % of it). A
    real held-out walk sits a few % from its nearest training pose; a body tumbling through
    impossible poses sits tens of % away. Nearest neighbours by brute force as matrix products
    (|q|^2 + |b|^2 - 2 q.b, BLAS): in 75 dimensions scipy's KD-tree was slower than that.
    """

    def __init__(self, poses: np.ndarray):
        poses = np.asarray(poses, dtype=np.float64)
        self.n_joints = poses.shape[1]
        self.poses = poses.reshape(len(poses), -1)
        self._sq = (self.poses ** 2).sum(axis=1)

    def __len__(self) -> int:
        return len(self.poses)

    def distance(self, local: np.ndarray, root_height: float) -> np.ndarray:
        """(F,) RMS joint distance (root heights) of local positions (F, J, 3) in metres of a
        body whose standing root height is ``root_height`` (m) to the nearest bank pose."""
        q = np.asarray(local, dtype=np.float64) / root_height
        if q.shape[1] != self.n_joints:
            raise ValueError(f"poses of {q.shape[1]} joints against a bank of {self.n_joints}")
        q = q.reshape(len(q), -1)
        d2 = np.concatenate([(c ** 2).sum(1)[:, None] + self._sq[None] - 2 * c @ self.poses.T
                             for c in np.array_split(q, max(1, len(q) // 256))]).min(axis=1)
        return np.sqrt(np.maximum(d2, 0.0) / self.n_joints)
