"""pyvista renders of CCNet's applications (paper Figs. 4-7).

- :func:`denoising_render` (Fig. 4(a-b)): one panel per version of a clip (noisy, denoised,
  clean), each with the body at one frame and the paths of both hands and both toes over the clip;
- :func:`completion_render` (Fig. 4(c-d)): bodies at a few frames over the truth (grey), one
  panel per version (corrupted input, completion);
- :func:`following_render` (Figs. 5-7): seen from above at an angle, the target path (green),
  the achieved root path (yellow) and the generated body at a few frames, one panel per run.

The panels of one figure share one camera, so that they compare. Each function returns the
RGB image (H, W, 3) uint8 (panels side by side, 3 white pixels apart) and writes a PNG when
given ``path``. Geometry comes from :mod:`mocapviz.viz.geometry`; this file only draws.
"""

from __future__ import annotations

from pathlib import Path

import imageio.v2 as imageio
import numpy as np
import pyvista as pv

from mocapviz.motion import Motion
from mocapviz.viz import geometry as geo
from mocapviz.viz.scene import add_ground, aim_camera, distance_to_fit, new_plotter, skeleton_mesh

EFFECTORS = ("LeftHand", "RightHand", "LeftToeBase", "RightToeBase")
EFFECTOR_COLORS = ("#ff7f0e", "#d62728", "#17becf", "#1f77b4")   # hands warm, toes cool
BODY_COLOR = "#4c72b0"
TRUTH_COLOR = "#a0a0a0"
TARGET_COLOR = "#2ca02c"      # the paper's green target path
ACHIEVED_COLOR = "#f5c400"    # and its yellow achieved path
PANEL_SIZE = (360, 300)


# ---------------------------------------------------------------- building blocks
def _tube(points: np.ndarray, radius: float) -> pv.PolyData:
    return pv.lines_from_points(np.asarray(points, dtype=np.float64)).tube(radius=radius, n_sides=8)


def _pixels(n: float, distance: float, panel_size, view_angle: float = 30.0) -> float:
    """Metres that ``n`` pixels span at the focal point: tracks keep their width on screen."""
    return n * 2 * np.tan(np.deg2rad(view_angle) / 2) * distance / panel_size[1]


def _add_poses(p: pv.Plotter, motion: Motion, frames, color: str, opacity: float = 1.0, radius: float = 0.018):
    segments = geo.all_segments(motion[np.asarray(frames, dtype=int)])   # (n, S, 2, 3)
    p.add_mesh(skeleton_mesh(segments, radius=radius), color=color, opacity=opacity, specular=0.3,
               smooth_shading=True, reset_camera=False)


def _snap(p: pv.Plotter, focal, view_dir, distance: float, elevation: float, title: str | None) -> np.ndarray:
    if title:
        p.add_text(title, position="upper_left", font_size=9, color="black")
    aim_camera(p, focal, view_dir, distance, elevation_deg=elevation)
    p.render()
    img = p.screenshot(return_img=True)
    p.close()
    return np.asarray(img)[..., :3]


def _camera(points: np.ndarray, view_dir, panel_size, elevation: float):
    """Focal point and distance that keep ``points`` (N, 3) in view in every panel, with room
    for the panel's title."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    focal = (lo + hi) / 2
    return focal, distance_to_fit(points, focal, view_dir, panel_size, elevation, margin=1.3)


def _side_view(motion: Motion) -> np.ndarray:
    """Horizontal view direction across the clip's main direction of travel (as ClipScene's)."""
    v = np.cross(geo.UP, geo.travel_direction(motion))
    return -v if v[2] > 0 else v


def _join(panels: list[np.ndarray], path: str | Path | None) -> np.ndarray:
    sep = np.full((panels[0].shape[0], 3, 3), 255, dtype=np.uint8)
    img = np.concatenate([x for pnl in panels for x in (pnl, sep)][:-1], axis=1)
    if path is not None:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        imageio.imwrite(path, img)
    return img


def _ground_size(points: np.ndarray, margin: float) -> tuple[float, float]:
    ext = points.max(axis=0) - points.min(axis=0)
    return float(ext[0] + 2 * margin), float(ext[2] + 2 * margin)


# ---------------------------------------------------------------- Fig. 4(a-b)
def denoising_render(motions: dict[str, Motion], frame: int, joints=EFFECTORS, path: str | Path | None = None,
                     panel_size=PANEL_SIZE, elevation: float = 12.0) -> np.ndarray:
    """One panel per ``motions`` entry (label -> Motion, e.g. noisy / denoised / clean versions
    of one clip): the body at ``frame`` and the paths of ``joints`` over every frame, in the
    colours of :data:`EFFECTOR_COLORS`; seen from the side of the first motion's travel."""
    first = next(iter(motions.values()))
    tracks = {k: geo.joint_tracks(m, joints) for k, m in motions.items()}          # (F, J, 3) each
    pts = np.concatenate([t.reshape(-1, 3) for t in tracks.values()]
                         + [geo.all_segments(m[[frame]]).reshape(-1, 3) for m in motions.values()])
    floor = geo.floor_height(first)
    view = _side_view(first)
    focal, dist = _camera(pts, view, panel_size, elevation)
    panels = []
    for label, m in motions.items():
        p = new_plotter(panel_size)
        add_ground(p, focal, _ground_size(pts, 3.0), floor, cell=0.5)
        _add_poses(p, m, [frame], BODY_COLOR)
        for j in range(len(joints)):
            p.add_mesh(_tube(tracks[label][:, j], _pixels(1.2, dist, panel_size)),
                       color=EFFECTOR_COLORS[j % len(EFFECTOR_COLORS)], lighting=False, reset_camera=False)
        panels.append(_snap(p, focal, view, dist, elevation, label))
    return _join(panels, path)


# ---------------------------------------------------------------- Fig. 4(c-d)
def completion_render(truth: Motion, versions: dict[str, Motion], frames, path: str | Path | None = None,
                      panel_size=PANEL_SIZE, colors=None, elevation: float = 12.0) -> np.ndarray:
    """One panel per ``versions`` entry (label -> Motion of the same frames as ``truth``): its
    bodies at ``frames`` (coloured) over the truth's at the same frames (grey, translucent)."""
    colors = colors or ["#d62728", BODY_COLOR, "#9467bd"]
    frames = np.asarray(frames, dtype=int)
    pts = np.concatenate([geo.all_segments(m[frames]).reshape(-1, 3) for m in (truth, *versions.values())])
    view = _side_view(truth)
    focal, dist = _camera(pts, view, panel_size, elevation)
    panels = []
    for (label, m), color in zip(versions.items(), colors):
        p = new_plotter(panel_size)
        add_ground(p, focal, _ground_size(pts, 3.0), geo.floor_height(truth), cell=0.5)
        _add_poses(p, truth, frames, TRUTH_COLOR, opacity=0.45)
        _add_poses(p, m, frames, color)
        panels.append(_snap(p, focal, view, dist, elevation, label))
    return _join(panels, path)


# ---------------------------------------------------------------- Figs. 5-7
def following_render(runs: dict[str, tuple], n_poses: int = 4, path: str | Path | None = None,
                     panel_size=PANEL_SIZE, elevation: float = 55.0) -> np.ndarray:
    """One panel per ``runs`` entry, label -> (target (P, 2), achieved (N, 2), motion): the
    target path in green, the achieved root path in yellow (ground X/Z, metres) and, if
    ``motion`` (the generated frames, N of them, in the same world frame) is not None, the body
    at ``n_poses`` frames spread over the run. All panels share the camera that fits every path."""
    def lift(xz, y):
        xz = np.asarray(xz, dtype=np.float64)
        return np.column_stack([xz[:, 0], np.full(len(xz), y), xz[:, 1]])

    floors = [geo.floor_height(m) for _, _, m in runs.values() if m is not None]
    floor = float(np.median(floors)) if floors else 0.0
    flat = np.concatenate([lift(np.concatenate([t, a]), floor) for t, a, _ in runs.values()])
    pts = np.concatenate([flat, flat + [0.0, 1.8, 0.0]])   # room for a standing body anywhere on the paths
    view = np.array([0.0, 0.0, -1.0])                     # from +Z towards -Z, seen from above
    focal, dist = _camera(pts, view, panel_size, elevation)
    radius = _pixels(2.0, dist, panel_size)               # paths stay visible from far away
    panels = []
    for label, (target, achieved, motion) in runs.items():
        p = new_plotter(panel_size)
        add_ground(p, focal, _ground_size(flat, 1.5), floor, cell=1.0)
        p.add_mesh(_tube(lift(target, floor + 0.01), radius), color=TARGET_COLOR, lighting=False,
                   reset_camera=False)
        p.add_mesh(_tube(lift(achieved, floor + 0.02), radius * 0.8), color=ACHIEVED_COLOR, lighting=False,
                   reset_camera=False)
        if motion is not None and n_poses:
            idx = np.linspace(0, motion.n_frames - 1, n_poses).round().astype(int)
            _add_poses(p, motion, idx, BODY_COLOR, radius=max(0.018, radius * 0.5))
        panels.append(_snap(p, focal, view, dist, elevation, label))
    return _join(panels, path)
