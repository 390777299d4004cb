"""Live interactive control in JupyterLab (paper §4.4, Fig. 8): buttons drive a CCNet session.

``LiveControl(session, skeleton, start_root, start_heading).show()`` displays buttons for the
number keys 1-5 (motion types, :data:`mocapviz.tasks.control.KEY_TYPES`), up/down (speed),
left/right (turn: held for :attr:`LiveControl.turn_frames` frames per click), a play toggle and
"export BVH", above a pyvista view (the trame backend when available, else static images):
the character, its root track and the six c^d points as green dots on the ground. Every tick
makes one frame with :class:`mocapviz.tasks.control.ControlSession`; the key events go through
the same pure :func:`mocapviz.tasks.control.plan_controls` as the scripted tests. Not run in CI
(it needs a browser); :meth:`tick` and :meth:`export_bvh` work without one.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mocapviz.features.ccnet import FPS, features_to_motion
from mocapviz.heading import from_heading_frame_xz
from mocapviz.io.bvh import write_bvh
from mocapviz.tasks.control import KEY_TYPES, ControlSession, KeyEvent, hold, plan_controls
from mocapviz.tasks.controls import path_speed
from mocapviz.viz import geometry as geo
from mocapviz.viz import scene


class LiveControl:
    turn_frames = 10     # frames a left/right click holds the key

    def __init__(self, session: ControlSession, skeleton, start_root=(0.0, 0.0, 0.0), start_heading: float = 0.0,
                 type_index: int = 0):
        self.session, self.skeleton = session, skeleton
        self.start_root, self.start_heading = np.asarray(start_root, float), float(start_heading)
        self.type_index = type_index
        self.start_speed = float(path_speed(session.predicted_traj()))
        self.events: list[KeyEvent] = []
        self.frame = 0                                  # generated frames so far
        self.p = scene.new_plotter()
        scene.add_ground(self.p, (0, 0, 0), 40.0)
        self.actor = self.dots = self.track = None
        self._draw()

    def press(self, key: str) -> None:
        """A key at the next frame (left/right: held for ``turn_frames`` frames)."""
        self.events += hold(key, self.frame, self.turn_frames) if key in ("left", "right") else [KeyEvent(self.frame, key)]

    def tick(self) -> np.ndarray:
        """One frame under the keys pressed so far; returns it raw (n_x,)."""
        n_types = len(self.session.types)
        plan = plan_controls(self.events, self.frame + 1, self.type_index, n_types, start_speed=self.start_speed)
        x = self.session.step(plan.types[-1], plan.turn[-1], plan.speed[-1])
        self.frame += 1
        self._draw()
        return x

    def motion(self):
        """The whole session (seed and generated frames) as a Motion."""
        return features_to_motion(self.session.x(), self.skeleton, self.start_root, self.start_heading, FPS,
                                  name="interactive")

    def export_bvh(self, path) -> Path:
        write_bvh(self.motion(), path)
        return Path(path)

    def _draw(self):
        """Pose, root track and c^d dots of the last frame."""
        import pyvista as pv
        path, heading = self.session.root_path(self.start_root, self.start_heading)
        # the last frame alone, integrated from the frame before it (features_to_motion's root step)
        last = features_to_motion(self.session.x()[-1:], self.skeleton, path[-2] if len(path) > 1 else self.start_root,
                                  heading[-2] if len(path) > 1 else self.start_heading, FPS)
        mesh = scene.skeleton_mesh(geo.all_segments(last)[0])
        root = path[-1]
        pts = from_heading_frame_xz(self.session.predicted_traj().reshape(6, 2), heading[-1]) + root[[0, 2]]
        dots = pv.PolyData(np.column_stack([pts[:, 0], np.full(6, 0.01), pts[:, 1]]))
        track = pv.lines_from_points(np.column_stack([path[:, 0], np.full(len(path), 0.005), path[:, 2]]))
        if self.actor is None:
            self.actor = self.p.add_mesh(mesh, color="#4c72b0", reset_camera=False)
            self.dots = self.p.add_mesh(dots, color="#2ca02c", point_size=12, render_points_as_spheres=True)
            self.track = self.p.add_mesh(track, color=scene.TRACK_COLOR, line_width=3)
        else:
            self.actor.mapper.dataset.copy_from(mesh)
            self.dots.mapper.dataset.copy_from(dots)
            self.track.mapper.dataset.copy_from(track)
        scene.aim_camera(self.p, (root[0], 0.9, root[2]), (1.0, 0.0, -1.0), 6.0)
        self.p.render()

    def show(self, bvh_path: str = "interactive.bvh"):
        """The buttons and the view (call in a JupyterLab cell)."""
        import ipywidgets as w
        from IPython.display import display

        def button(label, key):
            b = w.Button(description=label, layout=w.Layout(width="auto"))
            b.on_click(lambda _: self.press(key))
            return b

        types = [button(f"{k}: {v}", k) for k, v in KEY_TYPES.items()]
        arrows = [button(s, k) for s, k in (("←", "left"), ("↑ faster", "up"), ("↓ slower", "down"), ("→", "right"))]
        play = w.Play(interval=int(1000 / 30), max=10 ** 9, description="run")
        play.observe(lambda _: self.tick(), names="value")
        out = w.Output()
        export = w.Button(description="export BVH")

        def do_export(_):
            with out:
                print(f"wrote {self.export_bvh(bvh_path)} ({self.frame} generated frames)")
        export.on_click(do_export)
        display(w.VBox([w.HBox(types), w.HBox(arrows + [play, export]), out]))
        return self.p.show(return_viewer=True)
