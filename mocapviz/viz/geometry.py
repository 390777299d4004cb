"""Geometry for drawing skeletons: bone segments, a standing pose, line-ups, ground tracks.

Pure numpy, no rendering, so that every number a picture shows can be tested. Metres, Y up.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mocapviz.heading import shortest_arc
from mocapviz.ik import LEGS
from mocapviz.motion import Motion
from mocapviz.rotations import rotvec_to_matrix
from mocapviz.skeleton import Skeleton

UP = np.array([0.0, 1.0, 0.0])


def bone_segments(positions: np.ndarray, parents) -> np.ndarray:
    """Segments (..., J-1, 2, 3) from each non-root joint's parent to the joint.

    ``positions`` is (..., J, 3) (one pose or a whole clip); segment ``k`` belongs to joint
    ``k + 1`` (joints are in topological order, the root first). Zero-length bones (VICON
    trees have several, e.g. LHipJoint) are kept so that indices stay aligned.
    """
    positions = np.asarray(positions, dtype=np.float64)
    parents = np.asarray(parents)
    if positions.shape[-2] != len(parents) or positions.shape[-1] != 3:
        raise ValueError(f"positions {positions.shape} do not match {len(parents)} joints")
    child = np.arange(1, len(parents))
    return np.stack([positions[..., parents[child], :], positions[..., child, :]], axis=-2)


def end_site_segments(motion: Motion) -> np.ndarray:
    """Segments (F, E, 2, 3) from each end site's joint to the end site (head top, toe tips)."""
    sk = motion.skeleton
    if not sk.end_sites:
        return np.zeros((motion.n_frames, 0, 2, 3))
    pos, rot = motion.global_pose()
    joints = np.array([j for j, _ in sk.end_sites])
    offs = np.array([off for _, off in sk.end_sites], dtype=np.float64)
    tips = pos[:, joints] + np.einsum("fekl,el->fek", rot[:, joints], offs)
    return np.stack([pos[:, joints], tips], axis=-2)


def all_segments(motion: Motion, end_sites: bool = True) -> np.ndarray:
    """Bone segments (F, S, 2, 3) of every frame, with end-site segments appended."""
    segs = bone_segments(motion.positions(), motion.skeleton.parents)
    if end_sites:
        segs = np.concatenate([segs, end_site_segments(motion)], axis=1)
    return segs


def nonzero_segments(segments: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    """Drop segments shorter than ``eps`` (a tube of zero length cannot be drawn)."""
    lengths = np.linalg.norm(segments[..., 1, :] - segments[..., 0, :], axis=-1)
    return segments[lengths > eps]


def _chain_joint(sk: Skeleton, *candidates: str) -> int | None:
    for name in candidates:
        if name in sk.names:
            return sk.index(name)
    return None


def standing_pose(skeleton: Skeleton, arm_drop_deg: float = 65.0) -> Motion:
    """A one-frame standing pose built from the rest pose, feet on the floor (y = 0).

    Starting from the identity-rotation rest pose (what CCNet's skeleton configuration
    encodes), the thighs are turned to hang straight down (VICON rest poses splay the legs
    by about 20 degrees) and the upper arms are lowered by ``arm_drop_deg`` from the
    horizontal T-pose (0 keeps the T-pose). Works on the VICON/CMU joint names; joints that
    are missing are left alone.
    """
    sk = skeleton
    rot = np.tile(np.eye(3), (1, sk.n_joints, 1, 1))
    for hip, knee, ankle in LEGS:
        j_hip, j_knee, j_ankle = (_chain_joint(sk, n) for n in (hip, knee, ankle))
        if None in (j_hip, j_knee, j_ankle):
            continue
        thigh = sk.offsets[j_knee] + sk.offsets[j_ankle]  # hip -> ankle in the hip's frame
        rot[0, j_hip] = shortest_arc(thigh, -UP)
    for shoulder, elbow, sign in (("LeftArm", "LeftForeArm", -1.0), ("RightArm", "RightForeArm", 1.0)):
        j_sh, j_el = _chain_joint(sk, shoulder), _chain_joint(sk, elbow)
        if None in (j_sh, j_el) or arm_drop_deg == 0:
            continue
        # lower the arm about the body's forward axis (+Z), outward arm goes down
        rot[0, j_sh] = rotvec_to_matrix(np.array([0.0, 0.0, sign * np.deg2rad(arm_drop_deg)]))
    pose = Motion(sk, rot, np.zeros((1, 3)), fps=1.0, name="standing")
    lowest = lowest_point(pose)[0]
    pose.root_positions[:, 1] -= lowest
    return pose


def lowest_point(motion: Motion) -> np.ndarray:
    """Lowest height (F,) of any joint or end site in each frame."""
    low = motion.positions()[..., 1].min(axis=-1)
    ends = end_site_segments(motion)
    if ends.shape[1]:
        low = np.minimum(low, ends[:, :, 1, 1].min(axis=-1))
    return low


def highest_point(motion: Motion) -> np.ndarray:
    """Highest height (F,) of any joint or end site in each frame."""
    high = motion.positions()[..., 1].max(axis=-1)
    ends = end_site_segments(motion)
    if ends.shape[1]:
        high = np.maximum(high, ends[:, :, 1, 1].max(axis=-1))
    return high


def lineup_offsets(widths, gap: float = 0.25) -> np.ndarray:
    """X positions that put bodies of the given widths side by side, centred on x = 0."""
    widths = np.asarray(widths, dtype=np.float64)
    right_edges = np.cumsum(widths + gap) - gap
    centres = right_edges - widths / 2
    return centres - (right_edges[-1] / 2 if len(widths) else 0.0)


@dataclass
class LineupEntry:
    """One body of a line-up: its standing pose (already shifted to x), label and label spot."""

    name: str
    pose: Motion
    x: float
    height: float
    label: str
    label_at: np.ndarray


def lineup(skeletons: dict, heights: dict | None = None, arm_drop_deg: float = 75.0,
           gap: float = 0.3) -> list[LineupEntry]:
    """Standing poses side by side along X (left to right in dict order), feet at y = 0.

    ``heights`` (name -> metres) defaults to :meth:`Skeleton.standing_height`; each label
    reads ``"<name>\\n<height> m"`` and sits 10 cm above the body's highest point.
    """
    names = list(skeletons)
    poses = [standing_pose(skeletons[n], arm_drop_deg) for n in names]
    xs = lineup_offsets([pose_width(p) for p in poses], gap)
    out = []
    for n, pose, x in zip(names, poses, xs):
        h = float(skeletons[n].standing_height() if heights is None else heights[n])
        seg_x = all_segments(pose)[..., 0]
        pose.root_positions[:, 0] += x - (seg_x.min() + seg_x.max()) / 2  # centre its extent on x
        top = np.array([x, highest_point(pose)[0] + 0.1, 0.0])
        out.append(LineupEntry(n, pose, float(x), h, f"{n}\n{h:.2f} m", top))
    return out


def pose_width(motion: Motion) -> float:
    """Extent along X of the first frame, end sites included."""
    segs = all_segments(motion[0])
    return float(np.ptp(segs[..., 0].ravel()))


def floor_height(motion: Motion, percentile: float = 1.0) -> float:
    """Ground height of a clip: a low percentile of the per-frame lowest points."""
    return float(np.percentile(lowest_point(motion), percentile))


def body_root_positions(motion: Motion) -> np.ndarray:
    """(F, 3) world positions of the joint that carries the body: the root, unless the root stays
    put over the whole clip while a child of it moves (Bandai's files keep ``joint_Root`` at the
    origin and put the translation on the hips); then the first such child."""
    root = np.asarray(motion.root_positions, dtype=np.float64)
    if len(root) < 2 or np.ptp(root, axis=0).max() > 1e-6:
        return root
    pos = motion.positions()
    moving = [c for c in motion.skeleton.children(0) if np.ptp(pos[:, c], axis=0).max() > 1e-6]
    return root if not moving else pos[:, moving[0]]


def ground_track(motion: Motion, floor: float | None = None) -> np.ndarray:
    """The body's trajectory (F, 3; :func:`body_root_positions`) projected onto the ground plane y = ``floor``."""
    track = body_root_positions(motion).copy()
    track[:, 1] = floor_height(motion) if floor is None else floor
    return track


def travel_direction(motion: Motion) -> np.ndarray:
    """Unit horizontal direction of the body's main travel (principal axis of
    :func:`body_root_positions`), +X if none."""
    xz = body_root_positions(motion)[:, [0, 2]]
    xz = xz - xz.mean(axis=0)
    if len(xz) < 2 or np.abs(xz).max() < 1e-3:
        return np.array([1.0, 0.0, 0.0])
    _, _, vt = np.linalg.svd(xz, full_matrices=False)
    d = np.array([vt[0, 0], 0.0, vt[0, 1]])
    return d / np.linalg.norm(d)


def joint_tracks(motion: Motion, joints) -> np.ndarray:
    """World positions (F, len(joints), 3) of the named joints over the clip (e.g. hands, toes)."""
    idx = [motion.skeleton.index(j) for j in joints]
    return motion.positions()[:, idx]
