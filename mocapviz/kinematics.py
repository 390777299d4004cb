"""Forward kinematics, velocities and foot contacts (numpy or torch, batched)."""

from __future__ import annotations

import numpy as np
import torch


def forward_kinematics(local_rotations, root_positions, offsets, parents, return_rotations=False,
                       translations=None):
    """Global joint positions from local rotations.

    local_rotations: (..., J, 3, 3); root_positions: (..., 3); offsets: (J, 3); parents: (J,)
    with parents[j] < j. ``translations`` (optional) maps a joint index to its per-frame
    local position (..., 3), replacing ``offsets[j]`` (BVH position channels below the root);
    joints not in it use their rest offset. Works on numpy arrays or torch tensors
    (differentiable) alike. Returns positions (..., J, 3) and, if asked, global rotations
    (..., J, 3, 3).
    """
    xp = torch if isinstance(local_rotations, torch.Tensor) else np
    if xp is torch:
        def as_array(x):
            return torch.as_tensor(x, dtype=local_rotations.dtype, device=local_rotations.device)
    else:
        def as_array(x):
            return np.asarray(x, dtype=local_rotations.dtype)
    offsets = as_array(offsets)
    moving = {int(j): as_array(t)[..., :, None] for j, t in (translations or {}).items()}
    n_joints = local_rotations.shape[-3]
    glob_rot = [local_rotations[..., 0, :, :]]
    glob_pos = [root_positions + offsets[0]]
    for j in range(1, n_joints):
        p = int(parents[j])
        local = moving[j] if j in moving else offsets[j][:, None]
        glob_pos.append(glob_pos[p] + (glob_rot[p] @ local)[..., 0])
        glob_rot.append(glob_rot[p] @ local_rotations[..., j, :, :])
    positions = xp.stack(glob_pos, -2) if xp is torch else np.stack(glob_pos, axis=-2)
    if not return_rotations:
        return positions
    rotations = xp.stack(glob_rot, -3) if xp is torch else np.stack(glob_rot, axis=-3)
    return positions, rotations


def velocities(positions: np.ndarray, fps: float) -> np.ndarray:
    """Finite-difference velocity per frame (first frame copies the second), units/s."""
    vel = np.diff(positions, axis=0) * fps
    return np.concatenate([vel[:1], vel], axis=0) if len(vel) else np.zeros_like(positions)


def foot_contacts(positions: np.ndarray, fps: float, feet: list[list[int]], up_axis: int = 1,
                  height_threshold: float = 0.05, speed_threshold: float = 0.5,
                  floor: float | None = None) -> np.ndarray:
    """Binary contact labels (F, len(feet)) from joint height and speed thresholds.

    ``feet`` lists the joints of each foot (e.g. [[LeftFoot, LeftToeBase], [RightFoot, ...]]).
    A foot touches the ground in a frame when any of its joints is within
    ``height_threshold`` metres of that joint's own lowest height over the clip (the ankle
    sits higher than the toes) and moves slower than ``speed_threshold`` m/s. ``floor``
    replaces those per-joint lowest heights by one known ground height.
    """
    speed = np.linalg.norm(velocities(positions, fps), axis=-1)
    height = positions[..., up_axis]
    labels = np.zeros((positions.shape[0], len(feet)), dtype=bool)
    for i, joints in enumerate(feet):
        for j in joints:
            ground = np.percentile(height[:, j], 2) if floor is None else floor
            labels[:, i] |= (height[:, j] - ground < height_threshold) & (speed[:, j] < speed_threshold)
    return labels


def global_to_local(global_rotations: np.ndarray, parents) -> np.ndarray:
    """Local rotations (..., J, 3, 3) from global ones (the inverse of FK's rotation part)."""
    parents = np.asarray(parents)
    local = np.array(global_rotations, copy=True)
    local[..., 1:, :, :] = np.swapaxes(global_rotations[..., parents[1:], :, :], -1, -2) @ global_rotations[..., 1:, :, :]
    return local
