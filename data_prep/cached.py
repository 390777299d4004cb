"""Load a built dataset from its cache file, or build it and write the cache."""

from __future__ import annotations

from pathlib import Path
from typing import Callable, TypeVar

T = TypeVar("T")


def load_or_build(path: Path, load: Callable[[Path], T], build: Callable[[], T],
                  save: Callable[[T, Path], None], cache: bool = True) -> T:
    """``load(path)`` when a cache file exists and reads; else ``build()``, saved when ``cache``.

    An unreadable file (truncated by a crash, or from an older layout) is reported and rebuilt;
    the path itself is keyed by config, inputs and code, so a stale build is never loaded.
    """
    if cache and path.is_file():
        try:
            return load(path)
        except Exception as e:  # noqa: BLE001 - any unreadable cache is rebuilt
            print(f"ignoring unreadable dataset cache {path}: {e}")
    built = build()
    if cache:
        save(built, path)
    return built
