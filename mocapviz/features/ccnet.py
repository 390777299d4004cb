"""CCNet's frame vector x_n, control signal c_n, and normalisation (paper §3.1).

Frame vector x_n (60 fps, J joints; all vectors in the *previous* frame's heading frame,
a Y-up frame at the previous root's ground projection, turned by its heading angle):

=============  =====  ===============================================================
block          size   meaning
=============  =====  ===============================================================
``rot``        3J     local joint rotations as exponential maps; the root's is relative
                      to its own heading frame (so it holds tilt and roll, not heading)
``angvel``     3J     local angular velocities log(R_{n-1}^T R_n) * fps, rad/s
``pos``        3J     joint positions relative to the previous frame's root frame, m
``vel``        3J     joint linear velocities (p_n - p_{n-1}) * fps, m/s
``root``       4      root planar velocity (vx, vz) m/s, heading rate rad/s, root height m
``contact``    2      left / right foot contact labels (0/1)
=============  =====  ===============================================================

The first five blocks are continuous (modelled by the Gaussian); ``root`` is what generation
integrates into the path. Control c_n = (c^s, c^d, c^t): skeleton configuration (root height
and root-relative rest positions, 3J-2), the 12-D trajectory (root ground positions 10, 20,
..., 60 frames ahead in frame n's heading frame; past a clip's end the path is extrapolated
at the clip's last 0.25 s mean velocity), and the motion-type one-hot over
:data:`mocapviz.features.motion_types.MOTION_TYPES`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from mocapviz.features.ccnet_joints import complete_ccnet25
from mocapviz.features.motion_types import MOTION_TYPES
from mocapviz.heading import (across_vector, facing_direction, from_heading_frame, heading_of, to_heading_frame,
                              wrap_angle, yaw_matrix)
from mocapviz.ik import FEET
from mocapviz.kinematics import foot_contacts
from mocapviz.motion import Motion
from mocapviz.rotations import matrix_to_rotvec, rotvec_to_matrix
from mocapviz.skeleton import CCNET_25_JOINTS, Skeleton

FPS = 60.0
TRAJ_STEPS = (10, 20, 30, 40, 50, 60)  # frames ahead sampled by c^d (one second at 60 fps)
ACROSS = (("LeftUpLeg", "RightUpLeg"), ("LeftShoulder", "RightShoulder"))


@dataclass(frozen=True)
class FeatureLayout:
    """Where each block sits in x_n and c_n, for ``n_joints`` joints and ``n_types`` types."""

    n_joints: int
    n_types: int = len(MOTION_TYPES)

    @property
    def x_blocks(self) -> dict[str, slice]:
        j3 = 3 * self.n_joints
        sizes = [("rot", j3), ("angvel", j3), ("pos", j3), ("vel", j3), ("root", 4), ("contact", 2)]
        out, at = {}, 0
        for name, n in sizes:
            out[name] = slice(at, at + n)
            at += n
        return out

    @property
    def n_x(self) -> int:
        return 12 * self.n_joints + 6

    @classmethod
    def of_model(cls, cfg) -> "FeatureLayout":
        """The layout of a model config's frame vector (``cfg.n_x``, ``cfg.n_types``)."""
        return cls((cfg.n_x - 6) // 12, cfg.n_types)

    @property
    def length_channels(self) -> np.ndarray:
        """(n_x,) bool: the channels of x in m or m/s (``pos``, ``vel``, the root's vx, vz and
        height), the ones that grow with the body (the rest are angles, rates and contacts)."""
        b, out = self.x_blocks, np.zeros(self.n_x, bool)
        out[b["pos"]] = out[b["vel"]] = True
        out[b["root"].start + np.array([0, 1, 3])] = True
        return out

    @property
    def n_continuous(self) -> int:
        """Continuous part of x (everything but the contact labels)."""
        return 12 * self.n_joints + 4

    @property
    def n_skel(self) -> int:
        return 3 * self.n_joints - 2

    n_traj: int = len(TRAJ_STEPS) * 2

    def table(self) -> list[tuple[str, int, int, str]]:
        """(block, start, stop, unit) rows for display."""
        units = dict(rot="rad (exp map)", angvel="rad/s", pos="m", vel="m/s",
                     root="m/s, m/s, rad/s, m", contact="0/1")
        rows = [(k, s.start, s.stop, units[k]) for k, s in self.x_blocks.items()]
        at = 0
        for name, n, unit in (("c^s skeleton", self.n_skel, "m"), ("c^d trajectory", self.n_traj, "m"),
                              ("c^t type", self.n_types, "one-hot")):
            rows.append((name, at, at + n, unit))
            at += n
        return rows


def heading_angles(positions: np.ndarray, skeleton: Skeleton) -> np.ndarray:
    """Facing angle (F,) per frame of positions (F, J, 3): forward = across x up, with across =
    hips + shoulders (left - right); R_y(theta) maps +Z onto the facing direction."""
    return heading_of(facing_direction(across_vector(positions, skeleton, ACROSS)))


def trajectory_control(root: np.ndarray, theta: np.ndarray, fps: float = FPS) -> np.ndarray:
    """c^d per frame (F, 12): future root ground positions in the frame's heading frame."""
    n = len(root)
    tail = max(2, int(round(0.25 * fps)))
    first = max(0, n - 1 - tail)
    v = (root[-1] - root[first]) / max(1, n - 1 - first)
    extra = root[-1] + v[None] * np.arange(1, TRAJ_STEPS[-1] + 1)[:, None]
    path = np.concatenate([root, extra])
    out = []
    for k in TRAJ_STEPS:
        d = path[np.arange(n) + k] - root
        d[:, 1] = 0.0
        out.append(to_heading_frame(d, theta)[:, [0, 2]])
    return np.concatenate(out, axis=1).astype(np.float32)


@dataclass
class ClipFeatures:
    """Features of one clip at 60 fps: x (F-1, n_x) for frames 1..F-1, controls aligned to x."""

    x: np.ndarray
    traj: np.ndarray          # c^d (F-1, 12)
    skel: np.ndarray          # c^s (3J-2,)
    start_root: np.ndarray    # root position at frame 0 (3,)
    start_heading: float      # heading angle at frame 0


def motion_features(motion: Motion, fps: float = FPS) -> ClipFeatures:
    """x_n and the per-frame controls of a Motion already at ``fps`` with CCNet's joints."""
    if abs(motion.fps - fps) > 1e-6:
        raise ValueError(f"motion is at {motion.fps} fps; resample to {fps} first")
    if motion.n_frames < 3:
        raise ValueError(f"{motion.name}: need at least 3 frames, got {motion.n_frames}")
    sk = motion.skeleton
    pos = motion.positions()
    theta = heading_angles(pos, sk)
    rot = motion.rotations.copy()
    rot[:, 0] = np.swapaxes(yaw_matrix(theta), -1, -2) @ rot[:, 0]  # root relative to its heading
    rotvec = matrix_to_rotvec(rot)
    angvel = matrix_to_rotvec(np.swapaxes(rot[:-1], -1, -2) @ rot[1:]) * fps
    origin = motion.root_positions[:-1].copy()
    origin[:, 1] = 0.0
    rel = to_heading_frame(pos[1:] - origin[:, None], theta[:-1])
    vel = to_heading_frame(pos[1:] - pos[:-1], theta[:-1]) * fps
    dtheta = wrap_angle(np.diff(theta)) * fps
    root = np.stack([vel[:, 0, 0], vel[:, 0, 2], dtheta, motion.root_positions[1:, 1]], axis=1)
    feet = [[sk.index(n) for n in foot] for foot in FEET]
    contact = foot_contacts(pos, fps, feet)[1:].astype(np.float64)
    f1 = motion.n_frames - 1
    x = np.concatenate([rotvec[1:].reshape(f1, -1), angvel.reshape(f1, -1), rel.reshape(f1, -1),
                        vel.reshape(f1, -1), root, contact], axis=1).astype(np.float32)
    traj = trajectory_control(motion.root_positions, theta, fps)[1:]
    return ClipFeatures(x=x, traj=traj, skel=sk.configuration().astype(np.float32),
                        start_root=motion.root_positions[0].copy(), start_heading=float(theta[0]))


def integrate_root(root_block: np.ndarray, start_root, start_heading: float, fps: float = FPS):
    """Root ground path and heading from the ``root`` block (F, 4): returns (F, 3), (F,).

    Displacement of frame n is expressed in frame n-1's heading frame, so it is turned by
    the heading before it is accumulated; the root height is taken as is.
    """
    root_block = np.asarray(root_block, dtype=np.float64)
    theta = start_heading + np.cumsum(root_block[:, 2]) / fps
    prev_theta = np.concatenate([[start_heading], theta[:-1]])
    local = np.stack([root_block[:, 0], np.zeros(len(root_block)), root_block[:, 1]], axis=1) / fps
    step = from_heading_frame(local, prev_theta)
    path = np.asarray(start_root, dtype=np.float64)[None] + np.cumsum(step, axis=0)
    path[:, 1] = root_block[:, 3]
    return path, theta


def features_to_motion(x: np.ndarray, skeleton: Skeleton, start_root=(0.0, 0.0, 0.0),
                       start_heading: float = 0.0, fps: float = FPS, name: str = "generated") -> Motion:
    """Poses back from frame vectors (F, n_x): exp maps through FK, integrated root path."""
    layout = FeatureLayout(skeleton.n_joints)
    b = layout.x_blocks
    x = np.asarray(x, dtype=np.float64)
    path, theta = integrate_root(x[:, b["root"]], start_root, start_heading, fps)
    rot = rotvec_to_matrix(x[:, b["rot"]].reshape(len(x), -1, 3))
    rot[:, 0] = yaw_matrix(theta) @ rot[:, 0]
    meta = {"contacts": (x[:, b["contact"]] > 0.5)}
    return Motion(skeleton, rot, path, fps, name=name, meta=meta)


def joint_speed(x: np.ndarray, layout: FeatureLayout) -> np.ndarray:
    """Mean joint speed per frame (m/s) from the ``vel`` block of x (F, n_x)."""
    v = np.asarray(x)[:, layout.x_blocks["vel"]].reshape(len(x), -1, 3)
    return np.linalg.norm(v, axis=-1).mean(axis=1)


@dataclass
class Normaliser:
    """Per-channel mean/std for the continuous part of x, c^s and c^d (from training data)."""

    x_mean: np.ndarray
    x_std: np.ndarray
    skel_mean: np.ndarray
    skel_std: np.ndarray
    traj_mean: np.ndarray
    traj_std: np.ndarray

    @staticmethod
    def _std(a: np.ndarray) -> np.ndarray:
        return Normaliser._floored(a.std(axis=0))

    @staticmethod
    def _floored(s: np.ndarray) -> np.ndarray:
        return np.where(s < 1e-4, 1.0, s).astype(np.float32)  # constant channels stay unscaled

    @classmethod
    def fit(cls, x: np.ndarray, skel: np.ndarray, traj: np.ndarray, n_continuous: int) -> "Normaliser":
        xc = x[:, :n_continuous].astype(np.float64)
        return cls(xc.mean(0).astype(np.float32), cls._std(xc), skel.mean(0).astype(np.float32),
                   cls._std(skel), traj.mean(0).astype(np.float32), cls._std(traj))

    def constant_channels(self) -> np.ndarray:
        """(n_continuous,) bool: channels constant in the training data (``fit`` stores std 1 for
        them; their normalised value is always 0). A varying channel whose std is exactly 1.0 would be
        marked too: the saved normaliser keeps only mean and std (checkpoints stay as they are)."""
        return self.x_std == 1.0

    def body_scaled(self, lo: float, hi: float) -> "Normaliser":
        """This normaliser with c^s's mean and std those of s c^s, s ~ U(lo, hi) drawn
        independently of c^s: the bodies training sees with ``TrainConfig.body_scale``
        (E[s c] = E[s] E[c], E[(s c)^2] = E[s^2] E[c^2]; a constant channel, stored with std 1,
        has variance 0)."""
        m1, m2 = (lo + hi) / 2, (lo * lo + lo * hi + hi * hi) / 3
        mean = self.skel_mean.astype(np.float64)
        var = np.where(self.skel_std == 1.0, 0.0, self.skel_std.astype(np.float64) ** 2)
        std = np.sqrt(np.maximum(m2 * (var + mean ** 2) - (m1 * mean) ** 2, 0.0))
        return replace(self, skel_mean=(m1 * mean).astype(np.float32), skel_std=self._floored(std))

    def norm_x(self, x):
        n = len(self.x_mean)
        out = np.array(x, dtype=np.float32, copy=True)
        out[..., :n] = (out[..., :n] - self.x_mean) / self.x_std
        return out

    def denorm_x(self, x):
        n = len(self.x_mean)
        out = np.array(x, dtype=np.float64, copy=True)
        out[..., :n] = out[..., :n] * self.x_std + self.x_mean
        return out

    def norm_skel(self, s):
        return ((np.asarray(s) - self.skel_mean) / self.skel_std).astype(np.float32)

    def norm_traj(self, t):
        return ((np.asarray(t) - self.traj_mean) / self.traj_std).astype(np.float32)

    def denorm_traj(self, t):
        """Raw c^d ground points (..., 12) of normalised c^d (..., >= 12: a phase model's phase
        columns follow the points, unnormalised, and are left out)."""
        return (np.asarray(t)[..., :len(self.traj_mean)] * self.traj_std + self.traj_mean).astype(np.float32)

    def state_dict(self) -> dict[str, np.ndarray]:
        return {k: np.asarray(v, dtype=np.float32) for k, v in self.__dict__.items()}

    @classmethod
    def from_state_dict(cls, d) -> "Normaliser":
        return cls(**{k: np.asarray(d[k], dtype=np.float32) for k in cls.__dataclass_fields__})


def prepare_motion(motion: Motion, fps: float = FPS) -> Motion:
    """The 25 CCNet joints at ``fps`` (no-op parts are skipped); joints a skeleton lacks
    (Bandai's hip stubs, LowerBack, Neck1) are filled in by :func:`complete_ccnet25`."""
    names = motion.skeleton.names
    if set(names) != set(CCNET_25_JOINTS):
        present = [n for n in CCNET_25_JOINTS if n in names]
        motion = motion.keep_joints(present) if len(present) < len(names) else motion
        motion = complete_ccnet25(motion) if len(present) < len(CCNET_25_JOINTS) else motion
    if abs(motion.fps - fps) > 1e-6:
        motion = motion.resample(fps)
    return motion
