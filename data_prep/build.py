"""Dataset builds run by ``python -m data_prep build [target ...]`` (``make demo`` runs it first).

A target is a function ``fn(data_dir, quick) -> str`` (a one-line report) registered by name:

    from data_prep.build import register_build

    @register_build("ccnet", help="CCNet training windows")
    def build_ccnet(data_dir=None, quick=False): ...

Modules named in :data:`PLUGIN_MODULES` are imported (when they exist) so that their targets
register themselves; ``build`` without targets runs every target with ``default=True``.
"""

from __future__ import annotations

import importlib
import time
from dataclasses import dataclass
from typing import Callable

# Add your module here (e.g. "data_prep.ccnet"); a module that does not exist yet is skipped.
PLUGIN_MODULES = ("data_prep.ccnet", "data_prep.body4d")


@dataclass
class Target:
    name: str
    fn: Callable
    help: str
    default: bool


BUILDERS: dict[str, Target] = {}


def register_build(name: str, help: str = "", default: bool = True):
    def deco(fn):
        if name in BUILDERS and BUILDERS[name].fn is not fn:
            raise ValueError(f"build target {name!r} registered twice")
        BUILDERS[name] = Target(name, fn, help or (fn.__doc__ or "").strip().split("\n")[0], default)
        return fn
    return deco


def load_plugins() -> dict[str, Target]:
    for mod in PLUGIN_MODULES:
        try:
            importlib.import_module(mod)
        except ModuleNotFoundError as e:
            if e.name != mod:  # the module exists but one of its imports is missing
                raise
    return BUILDERS


@register_build("catalog", help="scan the data folder and cache the catalog (cache/catalog-*.pkl)")
def build_catalog_target(data_dir=None, quick=False) -> str:
    from data_prep.catalog import build_catalog
    t = time.perf_counter()
    cat = build_catalog(data_dir)
    return (f"{len(cat)} clips from {cat.attrs['data_dir']} ({cat.attrs['cache']} of "
            f"{cat.attrs['cache_path']}, {time.perf_counter() - t:.2f} s)")


def run_builds(names=(), data_dir=None, quick=False, echo=print) -> None:
    targets = load_plugins()
    unknown = [n for n in names if n not in targets]
    if unknown:
        raise KeyError(f"unknown build target(s) {', '.join(unknown)}; known: {', '.join(targets)}")
    for name in names or [n for n, t in targets.items() if t.default]:
        echo(f"build {name}: {targets[name].fn(data_dir=data_dir, quick=quick)}")
