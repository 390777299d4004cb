"""Motion files in, :class:`~mocapviz.motion.Motion` out: metres, Y up.

    from mocapviz.io import read_bvh, write_bvh, read_asf, read_amc, read_h36m

``read_bvh`` and ``read_amc`` take ``up=`` ("y", "z", "auto") for files in other axes;
``read_bvh`` guesses the length unit unless given ``length_unit=`` and can fold a reference
root (``drop_static_root=True``). Malformed files raise :class:`MocapFormatError` naming
the file and line. :func:`~mocapviz.skeleton.map_to_ccnet25` maps a file's joint names onto
the CCNet 25-joint topology.
"""

from mocapviz.errors import MocapFormatError
from mocapviz.io.asfamc import AsfSkeleton, read_amc, read_asf
from mocapviz.io.axes import to_y_up
from mocapviz.io.bvh import read_bvh, write_bvh
from mocapviz.io.h36m import read_h36m

__all__ = ["AsfSkeleton", "MocapFormatError", "read_amc", "read_asf", "read_bvh", "read_h36m", "to_y_up",
           "write_bvh"]
