"""Side-by-side videos of two clips for a two-alternative forced-choice question.

Both clips are resampled to the same frame rate and cut to the same length, drawn with the same
colour, camera distance and ground by :class:`mocapviz.viz.scene.ClipScene` (pyvista, off screen),
and their frames are put next to each other with a white gap. Nothing on screen says which model
made which side: the panels are captioned only "Left" and "Right".
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mocapviz.motion import Motion
from mocapviz.viz.scene import ClipScene, aim_camera, save_frames

PANEL_SIZE = (360, 300)   # (width, height) pixels of each side; even, as H.264 wants
GAP = 8                   # white pixels between the panels (even: the total width stays even)
COLOR = "#4c72b0"


def pair_frames(left: Motion, right: Motion, fps: float = 30.0, seconds: float | None = None,
                panel_size=PANEL_SIZE, gap: int = GAP) -> np.ndarray:
    """RGB frames (T, H, 2 W + gap, 3) uint8 of ``left`` and ``right`` side by side.

    Both clips are resampled to ``fps`` (:meth:`Motion.resample`); T is the shorter clip's frame
    count, at most ``seconds * fps`` (default: the whole shorter clip).
    """
    clips = [m.resample(fps) for m in (left, right)]
    n = min(m.n_frames for m in clips)
    if seconds is not None:
        n = min(n, round(seconds * fps))
    scenes = [ClipScene(m[:n], color=COLOR, window_size=panel_size, label=caption)
              for m, caption in zip(clips, ("Left", "Right"))]
    # One camera distance for both (the larger of the two fits), so that a body of the same
    # size looks the same size on either side: the scale must not tell the clips apart.
    distance = max(np.linalg.norm(np.subtract(s.p.camera.position, s.p.camera.focal_point)) for s in scenes)
    for s in scenes:
        aim_camera(s.p, s.p.camera.focal_point, s.view_dir, distance, s.elevation)
    panels = []
    for s in scenes:
        panels.append([s.image(i) for i in range(n)])
        s.close()
    white = np.full((panel_size[1], gap, 3), 255, dtype=np.uint8)
    return np.stack([np.concatenate([a[..., :3], white, b[..., :3]], axis=1) for a, b in zip(*panels)])


def render_pair(left: Motion, right: Motion, paths, fps: float = 30.0, seconds: float | None = None,
                panel_size=PANEL_SIZE) -> list[Path]:
    """Write the side-by-side video of :func:`pair_frames` to each of ``paths`` (.mp4 and/or .gif)."""
    return save_frames(pair_frames(left, right, fps, seconds, panel_size), paths, fps)
