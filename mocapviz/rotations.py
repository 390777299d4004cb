"""Rotation conversions on numpy arrays.

Convention everywhere in mocapviz: rotation matrices act on column vectors, and a joint's
global rotation is ``parent_global @ local``.

Conversions between rotation vectors, matrices, quaternions and the 6-D form go through
``roma`` (torch); Euler angles from files go through ``scipy.spatial.transform`` whose
intrinsic upper-case sequences ("ZYX") mean exactly BVH's channel order R = Rz @ Ry @ Rx.
"""

from __future__ import annotations

import warnings

import numpy as np
import roma
import torch
from scipy.spatial.transform import Rotation


def _t(x: np.ndarray) -> torch.Tensor:
    return torch.from_numpy(np.ascontiguousarray(x, dtype=np.float64))


def euler_to_matrix(angles_deg: np.ndarray, order: str) -> np.ndarray:
    """Angles (..., 3) in degrees, applied as R = R_order[0] @ R_order[1] @ R_order[2]."""
    angles_deg = np.asarray(angles_deg, dtype=np.float64)
    flat = angles_deg.reshape(-1, 3)
    mats = Rotation.from_euler(order.upper(), flat, degrees=True).as_matrix()
    return mats.reshape(angles_deg.shape[:-1] + (3, 3))


def matrix_to_euler(mats: np.ndarray, order: str) -> np.ndarray:
    """Inverse of :func:`euler_to_matrix` (angles in degrees, middle angle in [-90, 90])."""
    mats = np.asarray(mats, dtype=np.float64)
    flat = mats.reshape(-1, 3, 3)
    with warnings.catch_warnings():  # gimbal lock: scipy warns but returns a valid solution
        warnings.simplefilter("ignore", UserWarning)
        angles = Rotation.from_matrix(flat).as_euler(order.upper(), degrees=True)
    return angles.reshape(mats.shape[:-2] + (3,))


def rotvec_to_matrix(rotvec: np.ndarray) -> np.ndarray:
    return roma.rotvec_to_rotmat(_t(rotvec)).numpy()


def matrix_to_rotvec(mats: np.ndarray) -> np.ndarray:
    return roma.rotmat_to_rotvec(_t(mats)).numpy()


def matrix_to_quat(mats: np.ndarray) -> np.ndarray:
    """Unit quaternions (..., 4) in roma's XYZW order."""
    return roma.rotmat_to_unitquat(_t(mats)).numpy()


def quat_to_matrix(quats: np.ndarray) -> np.ndarray:
    return roma.unitquat_to_rotmat(_t(quats)).numpy()


def matrix_to_6d(mats: np.ndarray) -> np.ndarray:
    """Continuous 6-D form (Zhou et al. 2019): the first two columns, column-major flattened."""
    mats = np.asarray(mats)
    return np.concatenate([mats[..., :, 0], mats[..., :, 1]], axis=-1)


def sixd_to_matrix(sixd: np.ndarray) -> np.ndarray:
    sixd = _t(sixd)
    return roma.special_gramschmidt(torch.stack([sixd[..., :3], sixd[..., 3:]], dim=-1)).numpy()


def slerp_matrices(r0: np.ndarray, r1: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Element-wise geodesic interpolation R0 exp(alpha log(R0^T R1)); alpha broadcasts."""
    r0 = np.asarray(r0, dtype=np.float64)
    delta = matrix_to_rotvec(np.swapaxes(r0, -1, -2) @ r1)
    alpha = np.asarray(alpha, dtype=np.float64)[..., None]
    return r0 @ rotvec_to_matrix(delta * alpha)
