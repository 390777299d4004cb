"""Yaw about +Y, facing (heading) angles, heading frames, and shortest-arc rotations.

The one home of these ideas. Conventions: Y up, right-handed, column vectors, radians. A
heading angle theta is the yaw that turns +Z onto the facing direction: R_y(theta) maps
(0, 0, 1) to (sin theta, 0, cos theta). A *heading frame* is the world turned by R_y(theta);
a vector v is expressed in it as R_y(theta)^T v.
"""

from __future__ import annotations

import numpy as np

UP = np.array([0.0, 1.0, 0.0])


def yaw_matrix(theta) -> np.ndarray:
    """Rotations (..., 3, 3) by ``theta`` (...) radians about +Y."""
    c, s = np.cos(theta), np.sin(theta)
    out = np.zeros(np.shape(theta) + (3, 3))
    out[..., 0, 0] = c
    out[..., 0, 2] = s
    out[..., 1, 1] = 1.0
    out[..., 2, 0] = -s
    out[..., 2, 2] = c
    return out


def wrap_angle(a) -> np.ndarray:
    """Angles mapped to [-pi, pi)."""
    return (a + np.pi) % (2 * np.pi) - np.pi


def heading_of(direction: np.ndarray) -> np.ndarray:
    """Heading angle (...) of directions (..., 3); only their ground-plane (X, Z) part counts."""
    direction = np.asarray(direction)
    return np.arctan2(direction[..., 0], direction[..., 2])


def across_vector(positions: np.ndarray, skeleton, pairs) -> np.ndarray:
    """Left-minus-right vector (..., 3) of positions (..., J, 3): the sum over the (left, right)
    joint-name ``pairs`` of ``skeleton`` (e.g. hips and shoulders) of left - right."""
    return sum(positions[..., skeleton.index(a), :] - positions[..., skeleton.index(b), :] for a, b in pairs)


def facing_direction(across: np.ndarray) -> np.ndarray:
    """Horizontal forward direction (..., 3), not normalised, of a body whose left-minus-right
    vector is ``across`` (..., 3): across x up (a body facing +Z has its left side at +X)."""
    return np.cross(across, UP)


def rotation_heading(rotation: np.ndarray) -> np.ndarray:
    """Heading angle (...) of rotations (..., 3, 3): where they turn the +Z axis to."""
    return heading_of(np.asarray(rotation)[..., :, 2])


def to_heading_frame(vec: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """World vectors (F, ..., 3) expressed in per-frame heading frames theta (F,): R_y(theta)^T v."""
    r_t = np.swapaxes(yaw_matrix(theta), -1, -2)
    return np.einsum("fab,f...b->f...a", r_t, vec)


def from_heading_frame(vec: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Heading-frame vectors (F, 3) back in the world: R_y(theta) v, theta (F,)."""
    return np.einsum("fab,fb->fa", yaw_matrix(theta), vec)


def to_heading_frame_xz(xz: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Ground vectors (..., 2) as (X, Z) in heading frames theta (broadcast against ``xz[..., 0]``):
    the X/Z rows of R_y(theta)^T (x, 0, z), i.e. (c x - s z, s x + c z)."""
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([c * xz[..., 0] - s * xz[..., 1], s * xz[..., 0] + c * xz[..., 1]], axis=-1)


def from_heading_frame_xz(xz: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Inverse of :func:`to_heading_frame_xz`: R_y(theta) (x, 0, z) = (c x + s z, -s x + c z)."""
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([c * xz[..., 0] + s * xz[..., 1], -s * xz[..., 0] + c * xz[..., 1]], axis=-1)


def shortest_arc(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Smallest rotations R (..., 3, 3) with R a parallel to b, for directions a, b (..., 3).

    Rodrigues' form I + [v]x + [v]x^2 / (1 + c), v = a x b, c = a . b (unit a, b). Opposite
    directions have no unique smallest rotation: they get the half turn about an axis
    perpendicular to a. Hand-written because scipy's ``Rotation.align_vectors`` aligns one set
    of vectors per call (a Python loop over frames) and roma has no vector-to-vector rotation.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    v = np.cross(a, b)
    c = np.sum(a * b, axis=-1)
    vx = np.zeros(v.shape[:-1] + (3, 3))
    vx[..., 0, 1], vx[..., 0, 2], vx[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    vx[..., 1, 0], vx[..., 2, 0], vx[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    opposite = c < -1 + 1e-9
    out = np.eye(3) + vx + vx @ vx / np.where(opposite, 1.0, 1 + c)[..., None, None]
    if np.any(opposite):
        a_o = a[opposite]
        helper = np.where(np.abs(a_o[:, :1]) < 0.9, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
        axis = np.cross(a_o, helper)
        axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
        out[opposite] = 2 * axis[:, :, None] * axis[:, None, :] - np.eye(3)
    return out
