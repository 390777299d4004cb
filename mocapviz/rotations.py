"""Rotation conversions on numpy arrays.

Convention everywhere in mocapviz: rotation matrices act on column vectors, and a joint's
global rotation is ``parent_global @ local``. Quaternions: no public function here takes or
returns one; the private helpers below are scalar-first (W, X, Y, Z), while ``roma``
(and so anny) is scalar-last (X, Y, Z, W) -- convert explicitly if one ever crosses over.
Rotation vectors are axis * angle in radians; the 6-D form is the first two matrix columns.

Matrix -> rotation vector, quaternion and 6-D Gram-Schmidt go through ``roma`` (torch).
Two conversions on the file-reading path are written in plain numpy because they run on
every frame of every joint of a file and roma/scipy cost more in call and tensor overhead
than the arithmetic: Euler angles (any intrinsic order, BVH's "ZYX" = Rz @ Ry @ Rx) and
rotation vector -> matrix. Tests check both against scipy and roma; matrix -> Euler (for
writing BVH) uses scipy.
"""

from __future__ import annotations

import warnings

import numpy as np
import roma
import torch
from scipy.spatial.transform import Rotation


def _t(x: np.ndarray) -> torch.Tensor:
    return torch.from_numpy(np.ascontiguousarray(x, dtype=np.float64))


def _quat_mul(a, b):
    """Hamilton product of two (W, X, Y, Z) quaternions given as 4-tuples of arrays."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw)


def _wxyz_to_matrix(w, x, y, z) -> np.ndarray:
    out = np.empty(np.shape(w) + (3, 3))
    xx, yy, zz, xy, xz, yz, wx, wy, wz = x * x, y * y, z * z, x * y, x * z, y * z, w * x, w * y, w * z
    out[..., 0, 0] = 1 - 2 * (yy + zz)
    out[..., 0, 1] = 2 * (xy - wz)
    out[..., 0, 2] = 2 * (xz + wy)
    out[..., 1, 0] = 2 * (xy + wz)
    out[..., 1, 1] = 1 - 2 * (xx + zz)
    out[..., 1, 2] = 2 * (yz - wx)
    out[..., 2, 0] = 2 * (xz - wy)
    out[..., 2, 1] = 2 * (yz + wx)
    out[..., 2, 2] = 1 - 2 * (xx + yy)
    return out


def euler_to_matrix(angles_deg: np.ndarray, order: str, axes: np.ndarray | None = None) -> np.ndarray:
    """Angles (..., 3) in degrees, applied as R = R_order[0] @ R_order[1] @ R_order[2].

    ``order`` is intrinsic (BVH channel order, scipy's upper-case sequences; proper Euler
    orders like "ZXZ" work too). With ``axes`` (broadcasting against ``angles[..., 0]``,
    shape (..., 3, 3)) returns ``axes @ R @ axes.T``: the same rotation expressed in the
    frame ``axes`` (ASF bone axes), computed by rotating the quaternion's vector part.
    Plain numpy, batched over every leading axis: scipy's ``from_euler`` costs ~1 ms a
    call, which dominated reading files with one call per joint; scipy is the reference in
    tests/test_motion_core.py.
    """
    angles = np.asarray(angles_deg, dtype=np.float64)
    order = order.upper()
    if angles.shape[-1:] != (3,) or len(order) != 3 or set(order) - set("XYZ") or order[1] in (order[0], order[2]):
        raise ValueError(f"need (..., 3) angles and an Euler order like 'ZYX', got {order!r}")
    half = np.radians(angles) * 0.5
    c, s = np.cos(half), np.sin(half)
    quats = []
    for i, axis in enumerate(order):
        zero = np.zeros_like(c[..., i])
        q = [c[..., i], zero, zero, zero]
        q[1 + "XYZ".index(axis)] = s[..., i]
        quats.append(q)
    w, x, y, z = _quat_mul(_quat_mul(quats[0], quats[1]), quats[2])
    if axes is not None:
        a = np.asarray(axes, dtype=np.float64)
        x, y, z = (a[..., 0, 0] * x + a[..., 0, 1] * y + a[..., 0, 2] * z,
                   a[..., 1, 0] * x + a[..., 1, 1] * y + a[..., 1, 2] * z,
                   a[..., 2, 0] * x + a[..., 2, 1] * y + a[..., 2, 2] * z)
    return _wxyz_to_matrix(w, x, y, z)


def matrix_to_euler(mats: np.ndarray, order: str) -> np.ndarray:
    """Inverse of :func:`euler_to_matrix` (angles in degrees, middle angle in [-90, 90])."""
    mats = np.asarray(mats, dtype=np.float64)
    flat = mats.reshape(-1, 3, 3)
    with warnings.catch_warnings():  # gimbal lock: scipy warns but returns a valid solution
        warnings.simplefilter("ignore", UserWarning)
        angles = Rotation.from_matrix(flat).as_euler(order.upper(), degrees=True)
    return angles.reshape(mats.shape[:-2] + (3,))


def rotvec_to_matrix(rotvec: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., 3) (axis * angle in radians) to matrices, in plain numpy.

    Same result as ``roma.rotvec_to_rotmat`` (checked in tests) at a fraction of the cost
    on large arrays, since H3.6M files hold ~10^5 rotation vectors each.
    """
    rotvec = np.asarray(rotvec, dtype=np.float64)
    theta = np.linalg.norm(rotvec, axis=-1)
    small = theta < 1e-8
    half = 0.5 * theta
    # sin(theta/2)/theta, with its Taylor series near 0
    k = np.where(small, 0.5 - theta ** 2 / 48.0, np.sin(half) / np.where(small, 1.0, theta))
    v = rotvec * k[..., None]
    return _wxyz_to_matrix(np.cos(half), v[..., 0], v[..., 1], v[..., 2])


def matrix_to_rotvec(mats: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) to rotation vectors (..., 3), radians (roma)."""
    return roma.rotmat_to_rotvec(_t(mats)).numpy()


def matrix_to_sixd(mats: np.ndarray) -> np.ndarray:
    """Matrices (..., 3, 3) to the continuous 6-D form (..., 6) of Zhou et al. 2019: the first
    two columns, column-major flattened. Inverse: :func:`sixd_to_matrix`."""
    mats = np.asarray(mats)
    return np.concatenate([mats[..., :, 0], mats[..., :, 1]], axis=-1)


def sixd_to_matrix(sixd: np.ndarray) -> np.ndarray:
    """6-D forms (..., 6) to rotation matrices (..., 3, 3) by Gram-Schmidt (roma); any two
    independent columns give a rotation. Inverse of :func:`matrix_to_sixd` on rotations."""
    sixd = _t(sixd)
    return roma.special_gramschmidt(torch.stack([sixd[..., :3], sixd[..., 3:]], dim=-1)).numpy()


def slerp_matrices(r0: np.ndarray, r1: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Element-wise geodesic interpolation R0 exp(alpha log(R0^T R1)); alpha broadcasts."""
    r0 = np.asarray(r0, dtype=np.float64)
    delta = matrix_to_rotvec(np.swapaxes(r0, -1, -2) @ r1)
    alpha = np.asarray(alpha, dtype=np.float64)[..., None]
    return r0 @ rotvec_to_matrix(delta * alpha)
