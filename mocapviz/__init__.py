"""mocapviz: reference implementation of CCNet and the multi-frame 4D motion CVAE on real mocap."""

from mocapviz.errors import MocapFormatError
from mocapviz.motion import Motion
from mocapviz.skeleton import Skeleton

__all__ = ["Motion", "Skeleton", "MocapFormatError"]
__version__ = "0.1.0"
