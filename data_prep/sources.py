"""Where the real motion data lives.

Search order: an explicit path, ``$MOCAPVIZ_DATA_DIR``, ``../shared/data`` beside the
checkout, then ``data/raw`` (filled by ``python -m data_prep download``).
"""

from __future__ import annotations

import os
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
SOURCES = ("hdm05", "cmu", "h36m", "bandai")
# Length unit of each source's files, in metres per file unit (what load_motion passes on).
# HDM05's ASF files state theirs (``:units length 0.45``: one unit is 1/0.45 inch); CMU's
# BVH conversion keeps that ASF unit; H3.6M bone lengths are millimetres; Bandai is cm.
SOURCE_LENGTH_UNITS = {"hdm05": "stated by each ASF file (1/0.45 inch)", "cmu": 0.0254 / 0.45,
                       "h36m": 0.001, "bandai": 0.01}


class DataNotFoundError(FileNotFoundError):
    pass


def candidate_dirs(explicit: str | Path | None = None) -> list[Path]:
    return [d for _, d in _labelled_candidates(explicit) if d is not None]


def _labelled_candidates(explicit) -> list[tuple[str, Path | None]]:
    env = os.environ.get("MOCAPVIZ_DATA_DIR")
    return [("the path you passed", Path(explicit) if explicit is not None else None),
            ("$MOCAPVIZ_DATA_DIR", Path(env) if env else None),
            ("../shared/data beside the checkout", REPO_ROOT.parent / "shared" / "data"),
            ("data/raw in the checkout", REPO_ROOT / "data" / "raw")]


def search_order(explicit: str | Path | None = None) -> str:
    """The search order as text, for error messages (unset candidates say so)."""
    return "; ".join(f"{i}. {label}: {d if d is not None else '(not set)'}"
                     for i, (label, d) in enumerate(_labelled_candidates(explicit), 1))


def find_data_dir(explicit: str | Path | None = None, source: str | None = None) -> Path:
    """The first candidate folder that holds ``source`` (or any source when None).

    An explicit path that does not exist is an error rather than silently skipped.
    """
    if explicit is not None and not Path(explicit).is_dir():
        raise DataNotFoundError(f"data folder {explicit} does not exist (pass an existing folder, "
                                "or none to search $MOCAPVIZ_DATA_DIR, ../shared/data, data/raw)")
    wanted = [source] if source else list(SOURCES)
    for d in candidate_dirs(explicit):
        if any((d / s).is_dir() for s in wanted):
            return d
    raise DataNotFoundError(
        f"no motion data ({'/'.join(wanted)} folders) found. Searched, in order: "
        f"{search_order(explicit)}. Set MOCAPVIZ_DATA_DIR, pass a path, or run "
        "`python -m data_prep download`.")
