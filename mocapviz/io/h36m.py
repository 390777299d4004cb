"""Human3.6M in the exponential-map text form of motion-prediction papers (50 fps).

Each line holds 99 comma-separated values: 3 root-translation and 3 root-rotation values,
then 31 joints x 3 exponential-map values. In this form (Jain et al. 2016, Martinez et al.
2017) the first six values are frame-to-frame root *velocities*, not poses, and the
standard prediction protocol ignores them; the reader therefore keeps the root at the
origin with identity rotation and stores the raw 99 values in ``meta['expmap']``.

The skeleton is the 32-joint tree with the bone lengths used by the prediction papers'
forward kinematics (in mm, converted to metres), Y up. Those codes multiply row vectors
(``offset . R_parent``), so a file's exp-map r is our column-convention rotation exp(-r).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mocapviz.errors import MocapFormatError
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


def read_h36m(path: str | Path, text: str | None = None) -> Motion:
    """Read one ``S<k>/<action>_<sub>.txt`` file into a 50 fps Motion (root fixed)."""
    text = read_text(path) if text is None else text
    values = parse_number_lines(text, 99, 1, path, sep=",")
    if len(values) == 0:
        raise MocapFormatError(path, 1, "no frames")
    expmap = values[:, 3:].reshape(-1, 32, 3)
    rotations = rotvec_to_matrix(-expmap)
    rotations[:, 0] = np.eye(3)  # values 3:6 are a root rotation velocity, not a pose
    meta = {"source": str(path), "format": "h36m-expmap", "expmap": values, "length_unit": 0.001}
    return Motion(h36m_skeleton(), rotations, np.zeros((len(values), 3)), H36M_FPS,
                  name=Path(str(path)).stem, meta=meta)
