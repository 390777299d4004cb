"""The up axis of a file, converted to the library's Y up at the reader's edge."""

from __future__ import annotations

import numpy as np

from mocapviz.motion import Motion

# Z up (Blender, 3ds Max) -> Y up, right-handed: (x, y, z) -> (x, z, -y).
Z_UP_TO_Y_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
UP_AXES = ("y", "z", "auto")


def guess_up(motion: Motion, n_samples: int = 10) -> str:
    """"y" or "z": the axis along which the body is tallest, averaged over a few frames.

    The rest pose cannot tell (Bandai's rest skeleton lies along X; its rotations stand it
    up), so this looks at posed frames: a person's head-to-toe extent (~1.7 m) exceeds the
    body's depth along the other horizontal axis in every upright pose.
    """
    frames = np.unique(np.linspace(0, motion.n_frames - 1, min(n_samples, motion.n_frames)).astype(int))
    pos = motion[frames].positions() if len(frames) < motion.n_frames else motion.positions()
    extent = (pos.max(axis=1) - pos.min(axis=1)).mean(axis=0)
    return "z" if extent[2] > extent[1] else "y"


def to_y_up(motion: Motion, up: str) -> Motion:
    """``motion`` read in a file whose up axis is ``up`` ("y", "z" or "auto"), in Y up.

    Records the file's axis in ``meta['up']`` and the conversion in ``meta['axes']``.
    """
    if up not in UP_AXES:
        raise ValueError(f"up must be one of {UP_AXES}, got {up!r}")
    if up == "auto":
        up = guess_up(motion)
    if up == "z":
        motion = motion.rotated(Z_UP_TO_Y_UP)
        motion.meta["axes"] = "file Z up -> Y up: (x, y, z) -> (x, z, -y)"
    else:
        motion.meta["axes"] = "file Y up, unchanged"
    motion.meta["up"] = up
    return motion
