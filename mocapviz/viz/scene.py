"""pyvista scenes: skeleton line-ups, clips with ground and root track, gif/mp4, stills.

Headless machines: importing this module sets ``VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow``
(if unset and there is no display) before pyvista loads, and renders off screen, so nobody
needs an X server. Geometry comes from :mod:`mocapviz.viz.geometry`; this file only draws.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path


def _headless() -> bool:
    return sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


if _headless():  # must happen before VTK creates its first render window
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")

import imageio.v2 as imageio  # noqa: E402
import numpy as np  # noqa: E402
import pyvista as pv  # noqa: E402
from tqdm.auto import tqdm  # noqa: E402

from mocapviz.motion import Motion  # noqa: E402
from mocapviz.viz import geometry as geo  # noqa: E402

if _headless():
    pv.OFF_SCREEN = True

WINDOW_SIZE = (800, 450)
BACKGROUND = "white"
GROUND_COLOR = "#e6e6e6"
GROUND_LINES = "#c8c8c8"
TRACK_COLOR = "#1f77b4"


# ---------------------------------------------------------------- notebook backend
def _in_ci() -> bool:
    return any(os.environ.get(k) for k in ("CI", "GITHUB_ACTIONS", "GITLAB_CI"))


def _trame_available() -> bool:
    """pyvista's trame backend needs trame-pyvista (pyvista >= 0.47) or trame-vtk (older)."""
    from importlib.util import find_spec

    return find_spec("trame") is not None and (find_spec("trame_pyvista") is not None
                                                or find_spec("trame_vtk") is not None)


def choose_notebook_backend(quick: bool = True) -> str:
    """``static`` (PNGs embedded in the notebook) or ``trame`` (interactive, JupyterLab).

    ``MOCAPVIZ_PYVISTA_BACKEND`` overrides. Otherwise static in quick mode, in CI and when
    trame is not installed; trame when a person runs the full notebook.
    """
    forced = os.environ.get("MOCAPVIZ_PYVISTA_BACKEND")
    if forced:
        return forced
    if quick or _in_ci() or not _trame_available():
        return "static"
    return "trame"


def set_notebook_backend(quick: bool = True) -> str:
    """Set pyvista's Jupyter backend (see :func:`choose_notebook_backend`) and return it."""
    backend = choose_notebook_backend(quick)
    try:
        pv.set_jupyter_backend(backend)
    except ImportError as e:  # e.g. trame installed without pyvista's jupyter extra
        print(f"pyvista backend {backend!r} unavailable ({e}); using static images")
        backend = "static"
        pv.set_jupyter_backend(backend)
    return backend


# ---------------------------------------------------------------- building blocks
def new_plotter(window_size=WINDOW_SIZE, aa: str = "ssaa") -> pv.Plotter:
    """An off-screen-safe plotter of ``window_size`` (width, height) pixels, white, anti-aliased."""
    p = pv.Plotter(off_screen=pv.OFF_SCREEN or _headless(), window_size=list(window_size))
    p.set_background(BACKGROUND)
    p.enable_anti_aliasing(aa)
    return p


def skeleton_mesh(segments: np.ndarray, radius: float = 0.018, joint_radius: float | None = None) -> pv.PolyData:
    """Tubes for bones and spheres for joints from segments (S, 2, 3); one PolyData."""
    segs = geo.nonzero_segments(np.asarray(segments).reshape(-1, 2, 3))
    joint_radius = radius * 1.6 if joint_radius is None else joint_radius
    n = len(segs)
    points = segs.reshape(-1, 3)
    lines = np.column_stack([np.full(n, 2), np.arange(0, 2 * n, 2), np.arange(1, 2 * n, 2)]).ravel()
    bones = pv.PolyData(points, lines=lines).tube(radius=radius, n_sides=10, capping=True)
    joints = np.unique(np.round(points, 6), axis=0)
    balls = pv.PolyData(joints).glyph(geom=pv.Sphere(radius=joint_radius, theta_resolution=10,
                                                     phi_resolution=10), scale=False, orient=False)
    return bones.merge(balls)


def add_ground(p: pv.Plotter, center, size: float | tuple[float, float], height: float = 0.0,
               cell: float = 0.5) -> None:
    """A grey ground plane at ``height`` with grid lines every ``cell`` metres."""
    sx, sz = (size, size) if np.isscalar(size) else size
    nx, nz = max(1, int(round(sx / cell))), max(1, int(round(sz / cell)))
    # with direction +Y, pyvista's i axis runs along Z and j along X
    plane = pv.Plane(center=(center[0], height - 1e-3, center[2]), direction=(0, 1, 0),
                     i_size=nz * cell, j_size=nx * cell, i_resolution=nz, j_resolution=nx)
    p.add_mesh(plane, color=GROUND_COLOR, show_edges=True, edge_color=GROUND_LINES, lighting=False)


def aim_camera(p: pv.Plotter, focal, view_dir, distance: float, elevation_deg: float = 12.0):
    """Camera at ``distance`` from ``focal``, looking along horizontal ``view_dir``, Y up."""
    view_dir = np.asarray(view_dir, dtype=np.float64)
    view_dir = view_dir / np.linalg.norm(view_dir)
    el = np.deg2rad(elevation_deg)
    back = -view_dir * np.cos(el) + geo.UP * np.sin(el)
    p.camera.focal_point = tuple(focal)
    p.camera.position = tuple(np.asarray(focal) + back * distance)
    p.camera.up = (0.0, 1.0, 0.0)
    p.camera.view_angle = 30.0
    p.renderer.ResetCameraClippingRange()  # else a moved camera clips the scene away


def distance_to_fit(points: np.ndarray, focal, view_dir, window_size, elevation_deg: float,
                view_angle: float = 30.0, margin: float = 1.08) -> float:
    """Smallest camera distance (camera as in :func:`aim_camera`) that keeps every point in view."""
    view_dir = np.asarray(view_dir, dtype=np.float64) / np.linalg.norm(view_dir)
    el = np.deg2rad(elevation_deg)
    back = -view_dir * np.cos(el) + geo.UP * np.sin(el)
    right = np.cross(-back, geo.UP)
    right /= np.linalg.norm(right)
    up = np.cross(right, -back)
    q = np.asarray(points, dtype=np.float64).reshape(-1, 3) - np.asarray(focal)
    x, y, z = q @ right, q @ up, q @ back
    tan_v = np.tan(np.deg2rad(view_angle) / 2) / margin
    tan_h = tan_v * window_size[0] / window_size[1]
    return float(max(np.max(np.abs(x) / tan_h + z), np.max(np.abs(y) / tan_v + z), 0.5))


def _fit_distance(width: float, height: float, window_size, view_angle: float = 30.0, margin=1.1) -> float:
    """Camera distance so that a width x height box fills the window (perspective)."""
    half_v = np.deg2rad(view_angle) / 2
    aspect = window_size[0] / window_size[1]
    half_h = np.arctan(np.tan(half_v) * aspect)
    return margin * max(height / 2 / np.tan(half_v), width / 2 / np.tan(half_h))


def save_screenshot(p: pv.Plotter, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    p.screenshot(str(path))
    return path


# ---------------------------------------------------------------- skeleton line-up
def skeleton_lineup(skeletons: dict, colors: dict | None = None, heights: dict | None = None,
                    arm_drop_deg: float = 75.0, gap: float = 0.3, width_px: int = 1600,
                    title: str | None = None) -> pv.Plotter:
    """Every skeleton side by side in a standing pose, coloured, with its height written above.

    ``skeletons``: name -> Skeleton, drawn left to right in that order. ``heights``: name ->
    metres to print (default :meth:`Skeleton.standing_height`). Returns an unshown plotter.
    """
    entries = geo.lineup(skeletons, heights, arm_drop_deg, gap)
    colors = colors or {}
    span = entries[-1].x - entries[0].x + 1.0
    h = max(e.label_at[1] for e in entries) + 0.45  # room for the two-line labels
    window_size = (width_px, int(np.clip(width_px * (h + 0.4) / span, 340, 900)))
    p = new_plotter(window_size)
    for e in entries:
        p.add_mesh(skeleton_mesh(geo.all_segments(e.pose)[0], radius=0.016),
                   color=colors.get(e.name, "#4c72b0"), smooth_shading=True, specular=0.3)
    add_ground(p, (0, 0, 2.5), (span + 4.0, 6.0), cell=0.25)  # reaches towards the camera
    p.add_point_labels(np.array([e.label_at for e in entries]), [e.label for e in entries], font_size=16,
                       text_color="black", shape_opacity=0.0, show_points=False, always_visible=True,
                       justification_horizontal="center")
    if title:
        p.add_text(title, position="upper_left", font_size=12, color="black")
    aim_camera(p, (0.0, h / 2 - 0.15, 0.0), (0, 0, -1), _fit_distance(span, h, window_size, margin=1.05), 8.0)
    pv.set_new_attribute(p, "lineup", entries)  # what was drawn, for captions and tests
    return p


# ---------------------------------------------------------------- clips
class ClipScene:
    """A clip on a ground plane with its root track; call :meth:`frame` to pose it."""

    def __init__(self, motion: Motion, color: str = "#4c72b0", window_size=WINDOW_SIZE,
                 follow: bool = False, show_track: bool = True, label: str | None = None):
        self.motion = motion
        self.body_track = geo.body_root_positions(motion)  # what follow=True keeps in view
        self.segments = geo.all_segments(motion)  # (F, S, 2, 3)
        self.floor = geo.floor_height(motion)
        self.color = color
        self.follow = follow
        self.window_size = window_size
        pts = self.segments.reshape(-1, 3)
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        self.center = (lo + hi) / 2
        travel = geo.travel_direction(motion)
        self.view_dir = np.cross(geo.UP, travel)  # look across the main direction of travel
        self.view_dir = -self.view_dir if self.view_dir[2] > 0 else self.view_dir  # from +Z side
        extent_h = float(np.abs((hi - lo)[[0, 2]] @ np.abs(travel[[0, 2]]))) if not follow else 1.6
        self.height = hi[1] - self.floor
        self.p = new_plotter(window_size)
        ground = max(hi[0] - lo[0], hi[2] - lo[2]) + 10.0
        add_ground(self.p, self.center, ground, self.floor)
        if show_track and len(motion.root_positions) > 1:
            track = geo.ground_track(motion, self.floor + 2e-3)
            self.p.add_mesh(pv.lines_from_points(track), color=TRACK_COLOR, line_width=4, lighting=False)
        if label:
            self.p.add_text(label, position="upper_left", font_size=11, color="black")
        self.actor = None
        self.elevation = 15.0
        self._extent = max(extent_h, 1.2) + 0.6
        if not follow:
            self._aim(self.center)

    def _aim(self, focal):
        focal = np.array([focal[0], self.floor + self.height * 0.45, focal[2]])
        if self.follow:  # a 2.2 m wide window around the body
            d = _fit_distance(self._extent, self.height + 0.3, self.window_size, margin=1.0)
        else:  # every pose of the clip in view
            pts = self.segments.reshape(-1, 3)
            pts = pts[:: max(1, len(pts) // 4000)]
            d = distance_to_fit(pts, focal, self.view_dir, self.window_size, self.elevation)
        aim_camera(self.p, focal, self.view_dir, d, elevation_deg=self.elevation)

    def frame(self, i: int) -> pv.Plotter:
        mesh = skeleton_mesh(self.segments[i])  # tubes and spheres carry their own normals
        if self.actor is None:
            self.actor = self.p.add_mesh(mesh, color=self.color, specular=0.3, reset_camera=False)
        else:
            self.actor.mapper.dataset.copy_from(mesh)
        if self.follow:
            self._aim(self.body_track[i])
        return self.p

    def image(self, i: int) -> np.ndarray:
        self.frame(i)
        self.p.render()
        return self.p.screenshot(return_img=True)

    def close(self):
        self.p.close()


def _frame_indices(motion: Motion, fps: float | None, max_frames: int | None) -> np.ndarray:
    step = 1 if not fps else max(1, int(round(motion.fps / fps)))
    idx = np.arange(0, motion.n_frames, step)
    if max_frames is not None and len(idx) > max_frames:
        idx = idx[:max_frames]
    return idx


def render_clip(motion: Motion, paths, fps: float = 30.0, max_frames: int | None = None,
                color: str = "#4c72b0", window_size=WINDOW_SIZE, label: str | None = None,
                progress: bool = True) -> list[Path]:
    """Render ``motion`` at ``fps`` to each of ``paths`` (.gif and/or .mp4); returns the paths.

    Frames are taken every ``round(motion.fps / fps)`` source frames, at most ``max_frames``.
    """
    paths = [Path(x) for x in ([paths] if isinstance(paths, (str, Path)) else paths)]
    idx = _frame_indices(motion, fps, max_frames)
    real_fps = motion.fps / (idx[1] - idx[0]) if len(idx) > 1 else fps
    scene = ClipScene(motion, color=color, window_size=window_size, label=label or motion.name)
    frames = [scene.image(int(i)) for i in tqdm(idx, desc=f"render {motion.name}", disable=not progress,
                                                 leave=False)]
    scene.close()
    return save_frames(frames, paths, real_fps)


def save_frames(frames, paths, fps: float) -> list[Path]:
    """Write RGB frames (T, H, W, 3) uint8 at ``fps`` to each of ``paths`` (.gif and/or .mp4:
    H.264, yuv420p, so browsers play it)."""
    paths = [Path(x) for x in ([paths] if isinstance(paths, (str, Path)) else paths)]
    for path in paths:
        path.parent.mkdir(parents=True, exist_ok=True)
        if path.suffix == ".gif":
            imageio.mimsave(path, frames, duration=1000.0 / fps, loop=0)
        elif path.suffix == ".mp4":
            imageio.mimsave(path, frames, fps=fps, macro_block_size=1, codec="libx264",
                            quality=7, pixelformat="yuv420p")
        else:
            raise ValueError(f"{path}: only .gif and .mp4 are written")
    return paths


def frame_strip(motion: Motion, path: str | Path | None = None, n: int = 6, color: str = "#4c72b0",
                panel_size=(220, 400)) -> np.ndarray:
    """``n`` evenly spaced frames side by side (camera following the root), as one image.

    Each panel keeps the same orientation and ground, so the strip reads like film; the
    time of each frame is written in its panel. Saves a PNG if ``path`` is given.
    """
    idx = np.linspace(0, motion.n_frames - 1, n).round().astype(int)
    scene = ClipScene(motion, color=color, window_size=panel_size, follow=True, show_track=True)
    panels = []
    for i in idx:
        scene.frame(int(i))
        text = scene.p.add_text(f"t = {i / motion.fps:.2f} s", position="upper_left", font_size=9,
                                color="black", name="time")
        scene.p.render()
        panels.append(scene.p.screenshot(return_img=True))
        scene.p.remove_actor(text)
    scene.close()
    sep = np.full((panel_size[1], 3, 3), 255, dtype=np.uint8)
    strip = np.concatenate([x for pnl in panels for x in (pnl, sep)][:-1], axis=1)
    if path is not None:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        imageio.imwrite(path, strip)
    return strip


# ---------------------------------------------------------------- notebooks
def show(p: pv.Plotter, path: str | Path | None = None, close: bool = True):
    """Save a screenshot to ``path`` (if given) and show the scene in the notebook.

    With the ``static`` backend the saved PNG itself is displayed (no second render);
    otherwise ``p.show()`` opens the interactive (trame) view.
    """
    from IPython.display import Image, display

    if path is not None:
        path = save_screenshot(p, path)
    if pv.global_theme.jupyter_backend != "static":
        return p.show()
    img = Image(filename=str(path)) if path is not None else Image(data=_png_bytes(p))
    if close:
        p.close()
    display(img)
    return None


def _png_bytes(p: pv.Plotter) -> bytes:
    import io

    buf = io.BytesIO()
    imageio.imwrite(buf, p.screenshot(return_img=True), format="png")
    return buf.getvalue()
