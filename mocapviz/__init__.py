"""mocapviz: reference implementation of CCNet and the multi-frame 4D motion CVAE on real mocap."""

__all__ = ["Motion", "Skeleton", "MocapFormatError"]
__version__ = "0.1.0"

_EXPORTS = {"Motion": "mocapviz.motion", "Skeleton": "mocapviz.skeleton", "MocapFormatError": "mocapviz.errors"}


def __getattr__(name):
    # Lazy, so that light modules (mocapviz.atomic, mocapviz.errors) do not import torch.
    if name in _EXPORTS:
        import importlib

        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'mocapviz' has no attribute {name!r}")
