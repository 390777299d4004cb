"""Dataset builds run by ``python -m data_prep build [target ...]`` (``make demo`` runs it first).

A target is a function ``fn(data_dir, quick) -> str`` (a one-line report) registered by name:

    from data_prep.build import register_build

    @register_build("ccnet", help="CCNet training windows")
    def build_ccnet(data_dir=None, quick=False): ...

Every ``data_prep/*_dataset.py`` module (e.g. ``data_prep.ccnet_dataset``) and the modules named
in :data:`PLUGIN_MODULES` are imported so that their targets register themselves; ``build``
without targets runs every target with ``default=True``, catalog first.
"""

from __future__ import annotations

import importlib
import time
from dataclasses import dataclass
from typing import Callable

# Extra modules that register targets (``*_dataset`` modules are found on their own); a module
# that does not exist is skipped.
PLUGIN_MODULES: tuple[str, ...] = ()


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
    import pkgutil

    import data_prep
    found = [f"data_prep.{m.name}" for m in pkgutil.iter_modules(data_prep.__path__)
             if m.name.endswith("_dataset")]
    for mod in sorted(found) + list(PLUGIN_MODULES):
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
    # importing the plugins can be slow (torch): skip it when only built-in targets are asked for
    targets = BUILDERS if names and all(n in BUILDERS for n in names) else load_plugins()
    unknown = [n for n in names if n not in targets]
    if unknown:
        raise KeyError(f"unknown build target(s) {', '.join(unknown)}; known: {', '.join(targets)}")
    for name in names or [n for n, t in targets.items() if t.default]:
        echo(f"build {name}: {targets[name].fn(data_dir=data_dir, quick=quick)}")
