"""CCNet's motion-type vocabulary (the meaning of the c^t one-hot) and the one one-hot.

Which source class maps to which type (the HDM05/CMU class-merge table) is dataset knowledge
and lives in :mod:`data_prep.motion_types`.
"""

from __future__ import annotations

import numpy as np

MOTION_TYPES = ("walk", "jog", "sneak", "hop", "kick", "punch", "deposit_floor", "elbow_to_knee",
                "grab_high", "lie_down_floor", "rotate_arms", "squat", "throw_basketball")


def one_hot(indices, n: int) -> np.ndarray:
    """float32 one-hot rows (*indices.shape, n) of integer ``indices`` (any shape) over ``n`` classes."""
    indices = np.asarray(indices, dtype=np.int64)
    return np.eye(n, dtype=np.float32)[indices]
