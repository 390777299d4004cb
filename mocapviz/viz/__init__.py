"""Pictures of motion: pyvista scenes (:mod:`.scene`), matplotlib plots (:mod:`.plots`).

Geometry (bone segments, standing pose, ground track) lives in :mod:`.geometry`, so it can be
tested without rendering. ``scene`` is imported lazily: it sets the headless VTK defaults
before pyvista loads.
"""

from mocapviz.viz.colors import subject_colors
from mocapviz.viz.geometry import bone_segments, ground_track, standing_pose

__all__ = ["bone_segments", "ground_track", "standing_pose", "subject_colors"]
