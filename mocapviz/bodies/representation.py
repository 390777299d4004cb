"""The multi-frame representation chi = [Theta, Gamma, Phi] with body shape beta (§3.1, §4.2).

Per cycle: ``N_FRAMES`` = 100 time-stamped frames (uniform resampling of the cycle), each

- Theta: local rotations of the kept anny joints (:data:`CHI_JOINTS`, the root first) in
  the continuous 6-D form (first two matrix columns), with the identity's
  [1, 0, 0, 0, 1, 0] subtracted (centred, not z-scored, as in the paper);
- Gamma: the root (Hips head) translation with the first frame at 0, divided per axis by
  the dataset's ``gamma_scale`` (max absolute value over the training cycles) so training
  cycles lie in [-1, 1];
- Phi: the time since the cycle's first frame divided by ``PHI_SCALE`` = 3 s (the longest
  cycle kept), so it lies in [0, 1] and still tells a 0.6 s run from a 1.2 s walk.

The whole cycle is first turned about the vertical so that the root's initial heading is
the identity in the ground plane (facing +Z). Dropped joints (:data:`DROPPED_JOINTS`) carry
no information: the hip-joint stubs, clavicle roots and finger tips never rotate in CMU or
HDM05, and the hands are not modelled (as in the paper, which ignores SMPL-H's hands);
decoding sets them to anny's rest relation (identity).
"""

from __future__ import annotations

import numpy as np
import torch

from mocapviz.bodies.anny_model import BodyModel
from mocapviz.bodies.retarget import STATIC_JOINTS
from mocapviz.features.cycles import MAX_CYCLE_S
from mocapviz.heading import rotation_heading, yaw_matrix
from mocapviz.kinematics import global_to_local
from mocapviz.rotations import matrix_to_sixd, sixd_to_matrix

N_FRAMES = 100
PHI_SCALE = MAX_CYCLE_S
HAND_JOINTS = ("LThumb", "LeftFingerBase", "RThumb", "RightFingerBase")
DROPPED_JOINTS = tuple(STATIC_JOINTS) + HAND_JOINTS
IDENTITY_6D = np.array([1.0, 0.0, 0.0, 0.0, 1.0, 0.0])


def chi_joint_indices(body_joint_names) -> np.ndarray:
    """Indices (into the body's joints) of the joints kept in Theta, in body order."""
    return np.array([j for j, n in enumerate(body_joint_names) if n not in DROPPED_JOINTS])


def split_chi(chi: np.ndarray, n_kept: int):
    """Views (Theta (..., K, 6), Gamma (..., 3), Phi (...)) of chi (..., 6K + 4)."""
    theta = chi[..., :6 * n_kept].reshape(chi.shape[:-1] + (n_kept, 6))
    return theta, chi[..., 6 * n_kept:6 * n_kept + 3], chi[..., -1]


def canonicalise(rotations: np.ndarray, root: np.ndarray):
    """Turn a cycle about +Y so the root's first heading faces +Z; zero the first root position.

    Returns (rotations, root translation relative to frame 0, the removed yaw, the first
    root position after turning (its height puts the body back on the ground)).
    """
    yaw = float(rotation_heading(rotations[0, 0]))  # the root's +Z axis on the ground plane
    turn = yaw_matrix(-yaw)
    rot = rotations.copy()
    rot[:, 0] = turn @ rotations[:, 0]
    rel = (root - root[0]) @ turn.T
    return rot, rel, yaw, turn @ root[0]


def encode(rotations: np.ndarray, root: np.ndarray, times: np.ndarray, kept: np.ndarray,
           gamma_scale) -> np.ndarray:
    """chi (N, 6K + 4) of a resampled cycle: local rotations (N, J, 3, 3) of the body's
    joints, root (N, 3), times (N,) in seconds from the cycle start."""
    rot, rel, _, _ = canonicalise(rotations, root)
    theta = matrix_to_sixd(rot[:, kept]) - IDENTITY_6D
    gamma = rel / np.asarray(gamma_scale)
    phi = (times - times[0]) / PHI_SCALE
    return np.concatenate([theta.reshape(len(theta), -1), gamma, phi[:, None]], axis=1).astype(np.float32)


def decode(chi: np.ndarray, kept: np.ndarray, n_joints: int, gamma_scale):
    """Inverse of :func:`encode`: (rotations (N, J, 3, 3), root (N, 3) from the first
    frame's root, times (N,) in seconds). Dropped joints get identity rotations."""
    chi = np.asarray(chi, dtype=np.float64)
    theta, gamma, phi = split_chi(chi, len(kept))
    rot = np.tile(np.eye(3), (chi.shape[0], n_joints, 1, 1))
    rot[:, kept] = sixd_to_matrix(theta + IDENTITY_6D)
    return rot, gamma * np.asarray(gamma_scale), phi * PHI_SCALE


def mesh_chi(body: BodyModel, beta, chi: np.ndarray, gamma_scale, root0=(0.0, 0.0, 0.0)):
    """Vertices (N, V, 3) of a cycle given by chi and beta; ``root0`` places the first frame."""
    kept = chi_joint_indices(body.joint_names)
    rot, root, _ = decode(chi, kept, body.n_joints, gamma_scale)
    return body.mesh(beta, rot, root + np.asarray(root0)).vertices


def bone_rotations_from_mesh(body: BodyModel, beta, vertices) -> tuple[np.ndarray, np.ndarray]:
    """Global bone rotations (N, J, 3, 3) and root positions (N, 3) that produced a mesh
    sequence (N, V, 3) of known shape beta, by inverting linear blend skinning exactly.

    LBS is linear in the bone transforms: v' = sum_c w_vc (A_c v + t_c). With the rest
    vertices and weights known, one least-squares solve (a pseudo-inverse shared by all
    frames) recovers every A_c, t_c; A_c is then projected onto the nearest rotation.
    Bones that skin no vertex are undetermined (NaN) -- none of the kept joints.
    """
    rest = body.rest_model(beta)
    vr = rest["vertices"][0].double()
    n_v, n_j = vr.shape[0], body.n_joints
    w = torch.zeros(n_v, n_j, dtype=torch.float64)
    w.scatter_add_(1, body.anny.vertex_bone_indices.long(), body.anny.vertex_bone_weights.double())
    design = torch.cat([w[:, :, None] * vr[:, None, :], w[:, :, None]], dim=2).reshape(n_v, 4 * n_j)
    used = design.abs().sum(0) > 0
    pinv = torch.linalg.pinv(design[:, used])
    x = torch.zeros(vertices.shape[0], 4 * n_j, 3, dtype=torch.float64)
    x[:, used] = torch.einsum("uv,fvk->fuk", pinv, torch.as_tensor(vertices).double())
    x = x.reshape(-1, n_j, 4, 3)
    lin = x[:, :, :3, :].transpose(-1, -2)  # A_c[k, i]
    u, _, vt = torch.linalg.svd(lin)
    d = torch.sign(torch.det(u @ vt))
    rot = u @ torch.diag_embed(torch.stack([torch.ones_like(d), torch.ones_like(d), d], -1)) @ vt
    skinned = used.reshape(n_j, 4).any(1)
    rot[:, ~skinned] = float("nan")
    root = (lin[:, 0] @ rest["joints"][0, 0].double()) + x[:, 0, 3, :]
    return rot.numpy(), root.numpy()


def chi_from_mesh(body: BodyModel, beta, vertices, times: np.ndarray, gamma_scale) -> np.ndarray:
    """Recover chi from a mesh sequence (N, V, 3) of known shape beta: exact LBS inversion
    (:func:`bone_rotations_from_mesh`) to global rotations, local rotations for the kept
    joints (dropped joints have identity local rotation by construction), then :func:`encode`.
    """
    glob, root = bone_rotations_from_mesh(body, beta, vertices)
    parents = body.parents
    kept = chi_joint_indices(body.joint_names)
    # a dropped joint's global rotation is its parent's (identity local rotation)
    for j in range(1, body.n_joints):
        if j not in kept:
            glob[:, j] = glob[:, parents[j]]
    return encode(global_to_local(glob, parents), root, times, kept, gamma_scale)
