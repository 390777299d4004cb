"""Joint world positions of a BVH file as Blender imports it (run inside Blender).

    blender -b --factory-startup --python tools/blender_positions.py -- IN.bvh OUT.json [--scale S] FRAMES...

FRAMES are 0-based BVH frame indices. OUT.json holds ``{"blender": version, "settings": the
import settings, "frames": {"<frame>": {"<bone name>": [x, y, z], ...}, ...}}``: each bone's head
(``armature.matrix_world @ pose_bone.head``) in Blender's world axes (Z up) and units (the
file's length unit times ``--scale``; pass the file's metres per unit to get metres).

Import settings (File > Import > Motion Capture (.bvh) in the UI), chosen so that the joints
land where the BVH says and the frames map one to one:

- ``global_scale`` (Scale): ``--scale``, default 1.0 (file units kept).
- ``axis_forward="-Z"``, ``axis_up="Y"`` (Forward -Z, Up Y, the importer's defaults): the file
  is Y up, as every file mocapviz writes; Blender is Z up, so a file point (x, y, z) lands at
  (x, -z, y).
- ``rotate_mode="NATIVE"`` (Rotation: Native): each bone keeps the file's Euler order. Any
  mode gives the same pose on a keyed frame; Native keeps the curves as written.
- ``use_fps_scale=False`` (Scale FPS off): BVH frame i is keyed on scene frame
  ``frame_start + i`` exactly, no resampling.
- ``update_scene_fps=True``, ``update_scene_duration=True``: the scene plays at the file's
  rate (60 fps for the generate command) over all its frames.
- ``frame_start=1`` (Start Frame): BVH frame i is scene frame i + 1.

Debian's blender 3.4.1 runs the importer on the system Python 3.11, which refuses the
importer's ``open(path, 'rU')`` (``ValueError: invalid mode: 'rU'``, on every file; the 'U' mode
was removed in Python 3.11, and blender.org builds of 3.x bundle Python 3.10). This script gives
the importer module an ``open`` that drops the 'U' (universal newlines are Python 3's default
anyway), so the file is read exactly as intended.

Names: the importer joins a joint name that holds spaces with underscores; bone names are as
in the file otherwise.
"""

from __future__ import annotations

import json
import sys

import bpy

SETTINGS = dict(axis_forward="-Z", axis_up="Y", rotate_mode="NATIVE", use_fps_scale=False,
                update_scene_fps=True, update_scene_duration=True, frame_start=1)


def _patch_importer_open() -> None:
    """Let Blender's BVH importer open files on Python 3.11+ (it asks for mode 'rU')."""
    import builtins

    from io_anim_bvh import import_bvh

    def open_without_u(file, mode="r", *args, **kwargs):
        return builtins.open(file, mode.replace("U", ""), *args, **kwargs)
    import_bvh.open = open_without_u  # a module global shadows the builtin for the importer only


def main(argv: list[str]) -> None:
    args = argv[argv.index("--") + 1:] if "--" in argv else []
    scale = 1.0
    if "--scale" in args:
        i = args.index("--scale")
        scale = float(args[i + 1])
        del args[i:i + 2]
    if len(args) < 3:
        raise SystemExit("usage: blender -b --factory-startup --python tools/blender_positions.py -- "
                         "IN.bvh OUT.json [--scale S] FRAME...")
    src, out, frames = args[0], args[1], [int(f) for f in args[2:]]
    settings = dict(SETTINGS, global_scale=scale)
    _patch_importer_open()
    bpy.ops.import_anim.bvh(filepath=src, **settings)
    arm = next(ob for ob in bpy.context.scene.objects if ob.type == "ARMATURE")
    scene = bpy.context.scene
    result = {}
    for f in frames:
        scene.frame_set(settings["frame_start"] + f)
        bpy.context.view_layer.update()
        mw = arm.matrix_world
        result[str(f)] = {pb.name: list(mw @ pb.head) for pb in arm.pose.bones}
    with open(out, "w") as fh:
        json.dump({"blender": bpy.app.version_string, "settings": settings, "fps": scene.render.fps / scene.render.fps_base,
                   "frame_end": scene.frame_end, "frames": result}, fh)


if __name__ == "__main__":
    main(sys.argv)
