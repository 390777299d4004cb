"""CCNet's motion-type vocabulary (the meaning of the c^t one-hot) and the one one-hot.

Which source class maps to which type (the HDM05/CMU class-merge table) is dataset knowledge
and lives in :mod:`data_prep.motion_types`.
"""

from __future__ import annotations

import numpy as np

# Append-only: a checkpoint trained on the first n types (its ``cfg.n_types``; ``ccnet_default``
# has the first 13, dataset v3) reads index i as MOTION_TYPES[i] for every later vocabulary.
MOTION_TYPES = ("walk", "jog", "sneak", "hop", "kick", "punch", "deposit_floor", "elbow_to_knee",
                "grab_high", "lie_down_floor", "rotate_arms", "squat", "throw_basketball",
                # dataset v4 (Bandai)
                "dash", "walk_back", "side_step", "wave", "raise_hand", "gesture", "slash", "dance")


def vocabulary(n_types: int, stored=None) -> tuple[str, ...]:
    """The type names of a model or dataset with ``n_types`` one-hot columns: its ``stored``
    list (checkpoint or dataset metadata ``motion_types``) when it has one, else the first
    ``n_types`` of :data:`MOTION_TYPES`. Raises if a stored list contradicts the
    append-only vocabulary (an index would change meaning)."""
    names = tuple(stored) if stored else MOTION_TYPES[:n_types]
    if len(names) != n_types or names != MOTION_TYPES[:n_types]:
        raise ValueError(f"type vocabulary {names} ({n_types} columns) is not the first {n_types} of "
                         f"MOTION_TYPES {MOTION_TYPES}")
    return names


def one_hot(indices, n: int) -> np.ndarray:
    """float32 one-hot rows (*indices.shape, n) of integer ``indices`` (any shape) over ``n`` classes."""
    indices = np.asarray(indices, dtype=np.int64)
    return np.eye(n, dtype=np.float32)[indices]
