"""Where the real motion data lives.

Search order: an explicit path, ``$MOCAPVIZ_DATA_DIR``, ``../shared/data`` beside the
checkout, then ``data/raw`` (filled by ``python -m data_prep download``).
"""

from __future__ import annotations

import os
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
SOURCES = ("hdm05", "cmu", "h36m")


class DataNotFoundError(FileNotFoundError):
    pass


def candidate_dirs(explicit: str | Path | None = None) -> list[Path]:
    out = []
    if explicit is not None:
        out.append(Path(explicit))
    if os.environ.get("MOCAPVIZ_DATA_DIR"):
        out.append(Path(os.environ["MOCAPVIZ_DATA_DIR"]))
    out.append(REPO_ROOT.parent / "shared" / "data")
    out.append(REPO_ROOT / "data" / "raw")
    return out


def find_data_dir(explicit: str | Path | None = None, source: str | None = None) -> Path:
    """The first candidate folder that holds ``source`` (or any source when None).

    An explicit path that does not exist is an error rather than silently skipped.
    """
    if explicit is not None and not Path(explicit).is_dir():
        raise DataNotFoundError(f"data folder {explicit} does not exist")
    wanted = [source] if source else list(SOURCES)
    for d in candidate_dirs(explicit):
        if any((d / s).is_dir() for s in wanted):
            return d
    tried = ", ".join(str(d) for d in candidate_dirs(explicit))
    raise DataNotFoundError(
        f"no motion data ({'/'.join(wanted)}) found in: {tried}. Set MOCAPVIZ_DATA_DIR, pass a "
        "path, or run `python -m data_prep download`.")
