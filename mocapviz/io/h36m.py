"""Human3.6M in the exponential-map text form of motion-prediction papers (50 fps).

Each line holds 99 comma-separated values: 3 root-translation and 3 root-rotation values,
then 31 joints x 3 exponential-map values. In this form (Jain et al. 2016, Martinez et al.
2017) the first six values are frame-to-frame root *velocities*, not poses, and the
standard prediction protocol ignores them; the reader therefore keeps the root at the
origin with identity rotation by default and stores the raw 99 values in ``meta['expmap']``.
``root="integrated"`` integrates those velocities into a root path and rotation instead
(:func:`integrate_root`), for models such as CCNet whose frame vector carries the root.

The skeleton is the 32-joint tree with the bone lengths used by the prediction papers'
forward kinematics (in mm, converted to metres), Y up. Those codes multiply row vectors
(``offset . R_parent``), so a file's exp-map r is our column-convention rotation exp(-r).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mocapviz.errors import MocapFormatError
from mocapviz.heading import yaw_matrix
from mocapviz.io._text import parse_number_lines, read_text
from mocapviz.motion import Motion
from mocapviz.rotations import rotvec_to_matrix
from mocapviz.skeleton import Skeleton

H36M_FPS = 50.0
H36M_NAMES = (
    "Hips", "RightUpLeg", "RightLeg", "RightFoot", "RightToeBase", "RightToeEnd",
    "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase", "LeftToeEnd",
    "Spine", "Spine1", "Neck", "Head", "HeadEnd",
    "LeftShoulder", "LeftArm", "LeftForeArm", "LeftHand", "LeftHandThumb", "LeftThumbEnd",
    "LeftWristEnd", "LeftWristEndSite",
    "RightShoulder", "RightArm", "RightForeArm", "RightHand", "RightHandThumb", "RightThumbEnd",
    "RightWristEnd", "RightWristEndSite",
)
H36M_PARENTS = np.array([-1, 0, 1, 2, 3, 4, 0, 6, 7, 8, 9, 0, 11, 12, 13, 14, 12, 16, 17, 18, 19, 20, 19,
                         22, 12, 24, 25, 26, 27, 28, 27, 30])
# Bone offsets in mm, as used by the prediction papers' forward kinematics.
_H36M_OFFSETS_MM = np.array([
    [0, 0, 0], [-132.948591, 0, 0], [0, -442.894612, 0], [0, -454.206447, 0], [0, 0, 162.767078],
    [0, 0, 74.999437], [132.948826, 0, 0], [0, -442.894413, 0], [0, -454.206590, 0],
    [0, 0, 162.767426], [0, 0, 74.999948], [0, 0.1, 0], [0, 233.383263, 0], [0, 257.077681, 0],
    [0, 121.134938, 0], [0, 115.002227, 0], [0, 257.077681, 0], [0, 151.034226, 0],
    [0, 278.882773, 0], [0, 251.733451, 0], [0, 0, 0], [0, 0, 99.999627], [0, 100.000188, 0],
    [0, 0, 0], [0, 257.077681, 0], [0, 151.031437, 0], [0, 278.892924, 0], [0, 251.728680, 0],
    [0, 0, 0], [0, 0, 99.999888], [0, 137.499922, 0], [0, 0, 0],
])


def h36m_skeleton() -> Skeleton:
    return Skeleton(H36M_NAMES, H36M_PARENTS, _H36M_OFFSETS_MM / 1000.0)


def read_h36m(path: str | Path, text: str | None = None, root: str = "fixed") -> Motion:
    """Read one ``S<k>/<action>_<sub>.txt`` file into a 50 fps Motion (see :func:`h36m_motion`)."""
    text = read_text(path) if text is None else text
    values = parse_number_lines(text, 99, 1, path, sep=",")
    if len(values) == 0:
        raise MocapFormatError(path, 1, "no frames")
    return h36m_motion(values, root, name=Path(str(path)).stem, source=str(path))


def h36m_motion(values: np.ndarray, root: str = "fixed", every: int = 1, name: str = "h36m",
                source: str = "") -> Motion:
    """A Motion from rows (F, 99) of the exp-map form at 50 fps, keeping every ``every``-th
    frame from the first (2: the prediction protocol's 25 fps). ``root="fixed"``: the root stays
    at the origin with identity rotation (values 0:6 are velocities, ignored); ``"integrated"``:
    the root path and heading of :func:`integrate_root`, integrated at 50 fps before subsampling."""
    values = np.asarray(values, dtype=np.float64)
    rotations = rotvec_to_matrix(-values[::every, 3:].reshape(-1, 32, 3))
    if root == "fixed":
        rotations[:, 0] = np.eye(3)  # values 3:6 are a root rotation velocity, not a pose
        path = np.zeros((len(rotations), 3))
    elif root == "integrated":
        heading, path = integrate_root(values)
        rotations[:, 0], path = heading[::every], path[::every]
    else:
        raise ValueError(f"root must be 'fixed' or 'integrated', not {root!r}")
    meta = {"source": source, "format": "h36m-expmap", "expmap": values[::every], "length_unit": 0.001}
    return Motion(h36m_skeleton(), rotations, path, H36M_FPS / every, name=name, meta=meta)


def integrate_root(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Root rotations (F, 3, 3) (yaw only) and positions (F, 3) in metres from the root
    velocities of rows (F, 99): values 3:6 are frame n's rotation relative to frame n-1 (a
    file exp-map v, so exp(-v) in our convention, whose yaw rate is -v_y) and values 0:3 its
    displacement in mm in frame n-1's root frame.

    Only the planar part is kept: integrating the full relative rotations drifts by 10-50
    degrees of tilt over one take (measured on S1 walking and eating), so tilt, roll and the
    vertical displacement are not recoverable from this form. The root stays upright at the
    rest root height above the lowest rest point and starts at the origin facing +Z."""
    values = np.asarray(values, dtype=np.float64)
    theta = np.cumsum(-values[:, 4])                     # heading after each frame's turn
    prev = np.concatenate([[0.0], theta[:-1]])
    step = values[:, [0, 1, 2]] / 1000.0
    step[:, 1] = 0.0
    pos = np.cumsum(np.einsum("fab,fb->fa", yaw_matrix(prev), step), axis=0)
    pos[:, 1] = h36m_skeleton().configuration()[0]
    return yaw_matrix(theta), pos
