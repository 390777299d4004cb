"""pyvista views of anny bodies and 4D cycles (notebook 10): shape line-ups, retargeting
overlays, time-coloured frame strips (the paper's Fig. 6 style). The matplotlib figures of
the segmentation and the dataset statistics are in :mod:`mocapviz.viz.body_plots`.

Reuses the building blocks of :mod:`mocapviz.viz.scene` (plotter, ground, camera, skeleton
tubes, screenshots); meshes come from :class:`mocapviz.bodies.BodyModel` (metres, Y up).
"""

from __future__ import annotations

import numpy as np
import pyvista as pv

from mocapviz.motion import Motion
from mocapviz.viz import geometry as geo
from mocapviz.viz.colors import time_colors
from mocapviz.viz.scene import add_ground, aim_camera, distance_to_fit, new_plotter, skeleton_mesh


def body_polydata(vertices, faces: np.ndarray) -> pv.PolyData:
    """A triangle mesh from vertices (V, 3) and faces (F, 3)."""
    v = np.asarray(vertices, dtype=np.float32)
    f = np.column_stack([np.full(len(faces), 3), np.asarray(faces)]).ravel()
    return pv.PolyData(v, f)


# ---------------------------------------------------------------- shapes
def shape_lineup(body, betas: dict, colors: dict | None = None, heights: dict | None = None,
                 gap: float = 0.15, width_px: int = 1600, title: str | None = None) -> pv.Plotter:
    """Each subject's fitted body in anny's rest pose, side by side, feet on the ground,
    coloured per subject, with its name and height written above the head.

    ``betas``: name -> beta (6,); ``heights``: name -> metres (default: anny's mesh height).
    """
    names = list(betas)
    rest = body.rest_model(np.stack([betas[n] for n in names]))["vertices"].numpy()
    widths = rest[..., 0].max(1) - rest[..., 0].min(1)
    xs = geo.lineup_offsets(widths, gap)
    if heights is None:
        h = body.measurements(np.stack([betas[n] for n in names]))["height"]
        heights = dict(zip(names, h))
    colors = colors or {}
    span = xs[-1] - xs[0] + widths.max() + 0.4
    top = float((rest[..., 1].max(1) - rest[..., 1].min(1)).max()) + 0.35
    window_size = (width_px, int(np.clip(width_px * (top + 0.3) / span, 320, 900)))
    p = new_plotter(window_size)
    labels, spots = [], []
    for k, n in enumerate(names):
        v = rest[k].copy()
        v[:, 0] += xs[k] - 0.5 * (v[:, 0].max() + v[:, 0].min())
        v[:, 1] -= v[:, 1].min()
        p.add_mesh(body_polydata(v, body.faces), color=colors.get(n, "#9ab"), smooth_shading=True, specular=0.2)
        labels.append(f"{n}\n{float(heights[n]):.2f} m")
        spots.append((xs[k], v[:, 1].max() + 0.12, 0.0))
    add_ground(p, (0, 0, 1.0), (span + 2.0, 3.0), cell=0.25)
    p.add_point_labels(np.array(spots), labels, font_size=14, text_color="black", shape_opacity=0.0,
                       show_points=False, always_visible=True, justification_horizontal="center")
    if title:
        p.add_text(title, position="upper_left", font_size=12, color="black")
    pts = np.concatenate([np.array(spots), [[xs[0] - widths[0], 0, 0], [xs[-1] + widths[-1], 0, 0]]])
    aim_camera(p, (0.0, top / 2 - 0.1, 0.0), (0, 0, -1), distance_to_fit(pts, (0.0, top / 2 - 0.1, 0.0), (0, 0, -1),
                                                                 window_size, 6.0), 6.0)
    return p


# ---------------------------------------------------------------- retargeting check
def retarget_overlay(body, beta, source: Motion, retargeted: Motion, frames, color: str = "#c9d6e8",
                     skeleton_color: str = "#d62728", window_size=(1400, 500)) -> pv.Plotter:
    """The retargeted anny mesh (translucent) with the source skeleton drawn inside it, at a
    few ``frames``, each where it is in the clip (the clip's own path on the ground)."""
    frames = list(frames)
    verts = body.mesh(beta, retargeted.rotations[frames], retargeted.root_positions[frames]).vertices.numpy()
    pos = source.positions()[frames]
    p = new_plotter(window_size)
    for k, f in enumerate(frames):
        p.add_mesh(body_polydata(verts[k], body.faces), color=color, opacity=0.35, smooth_shading=True)
        seg = geo.bone_segments(pos[k], source.skeleton.parents)
        p.add_mesh(skeleton_mesh(seg, radius=0.012), color=skeleton_color, smooth_shading=True)
    pts = verts.reshape(-1, 3)[::50]
    center = pts.mean(0)
    floor = float(pts[:, 1].min())
    add_ground(p, (center[0], 0, center[2]), (np.ptp(pts[:, 0]) + 3, np.ptp(pts[:, 2]) + 3), height=floor)
    travel = pos[-1, 0] - pos[0, 0]
    view = np.cross([0.0, 1.0, 0.0], travel) if np.linalg.norm(travel[[0, 2]]) > 0.2 else np.array([0, 0, -1.0])
    view = view / np.linalg.norm(view)
    focal = (center[0], center[1], center[2])
    aim_camera(p, focal, view, distance_to_fit(pts, focal, view, window_size, 10.0), 10.0)
    return p


# ---------------------------------------------------------------- Fig. 6 style
def cycle_strip(body, vertices, label: str = "", n: int = 8, cmap: str = "viridis",
                window_size=(1500, 420)) -> pv.Plotter:
    """One cycle as a frame strip colour-coded by time (paper Fig. 6): ``n`` of its frames
    (vertices (F, V, 3)), evenly spaced in time, dark to light, each drawn where the body is,
    seen from its left side so that travel (+Z after canonicalisation) runs left to right."""
    verts = np.asarray(vertices)
    idx = np.linspace(0, len(verts) - 1, n).round().astype(int)
    p = new_plotter(window_size)
    for c, i in zip(time_colors(n, cmap), idx):
        p.add_mesh(body_polydata(verts[i], body.faces), color=c, smooth_shading=True, specular=0.2)
    pts = verts[idx][:, ::40].reshape(-1, 3)
    center = 0.5 * (pts.min(0) + pts.max(0))
    add_ground(p, (center[0], 0, center[2]), (2.0, np.ptp(pts[:, 2]) + 3), height=float(verts[..., 1].min()),
               cell=0.25)
    if label:
        p.add_text(label, position="upper_left", font_size=11, color="black")
    view = np.array([1.0, 0.0, 0.0])
    aim_camera(p, center, view, distance_to_fit(pts, center, view, window_size, 8.0), 8.0)
    return p


def cycle_strips(body, cycles: list, labels: list | None = None, path=None, **kw) -> np.ndarray:
    """Several cycles (list of vertices (F, V, 3)) as strips stacked top to bottom, one image
    (H, W, 3); saved as PNG when ``path`` is given."""
    import imageio.v2 as imageio

    rows = []
    for k, verts in enumerate(cycles):
        p = cycle_strip(body, verts, labels[k] if labels else "", **kw)
        rows.append(p.screenshot(return_img=True))
        p.close()
    img = np.concatenate(rows, axis=0)
    if path is not None:
        imageio.imwrite(path, img)
    return img
