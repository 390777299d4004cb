"""Pictures of motion, one import away: ``from mocapviz.viz import render_clip, plot_controls``.

- :mod:`.geometry`: bone segments, standing pose, ground track (numpy only, testable);
- :mod:`.scene` (pyvista): plotters, camera, skeleton line-ups, clips, gif/mp4, notebook display;
- :mod:`.body_scene` (pyvista): anny bodies, retargeting overlays, time-coloured cycle strips;
- :mod:`.apps_scene` (pyvista): CCNet's applications: denoising, completion, trajectory following;
- :mod:`.plots`, :mod:`.ccnet`, :mod:`.body_plots` (matplotlib): dataset, CCNet and 4D figures;
- :mod:`.figures` (save/show a matplotlib figure), :mod:`.colors` (per subject, over time).

Names load lazily (PEP 562): importing this package pulls in neither pyvista nor torch, and
:mod:`.scene` sets the headless VTK defaults before pyvista loads.
"""

from importlib import import_module

_HOMES = {
    "geometry": ("bone_segments", "ground_track", "joint_tracks", "standing_pose"),
    "colors": ("subject_colors", "time_colors"),
    "figures": ("save_figure", "show_figure"),
    "plots": ("VICON_BONE_NAMES", "bone_length_table", "plot_bone_lengths", "plot_dataset_minutes"),
    "ccnet": ("plot_controls", "plot_training_curves"),
    "body_plots": ("plot_counts", "plot_durations", "plot_segmentation"),
    "scene": ("ClipScene", "add_ground", "aim_camera", "choose_notebook_backend", "distance_to_fit",
              "frame_strip", "new_plotter", "render_clip", "save_frames", "save_screenshot", "set_notebook_backend",
              "show", "skeleton_lineup", "skeleton_mesh"),
    "apps_scene": ("completion_render", "denoising_render", "following_render"),
    "body_scene": ("body_polydata", "cycle_strip", "cycle_strips", "retarget_overlay", "shape_lineup"),
}
_MODULE_OF = {name: module for module, names in _HOMES.items() for name in names}
__all__ = sorted(_MODULE_OF)


def __getattr__(name: str):
    if name not in _MODULE_OF:
        raise AttributeError(f"module 'mocapviz.viz' has no attribute {name!r}")
    return getattr(import_module(f"mocapviz.viz.{_MODULE_OF[name]}"), name)


def __dir__():
    return __all__
