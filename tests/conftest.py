"""Shared fixtures: the real data folder (found like the library finds it) and file lists.

CI clones the repo to a fresh folder with ``../shared`` beside it, so the folder is located
with :func:`data_prep.sources.find_data_dir`, never by an absolute path. Tests that need
real data skip, with the reason, only when no data folder exists at all.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from data_prep.sources import DataNotFoundError, find_data_dir

NO_DATA_REASON = ("no real motion data: none of ../shared/data, $MOCAPVIZ_DATA_DIR or data/raw exists "
                  "(run `python -m data_prep download`)")


def _find() -> Path | None:
    try:
        return find_data_dir()
    except DataNotFoundError:
        return None


DATA_DIR = _find()


def _files(source: str, pattern: str) -> list[Path]:
    if DATA_DIR is None or not (DATA_DIR / source).is_dir():
        return []
    return sorted((DATA_DIR / source).glob(pattern))


CMU_FILES = _files("cmu", "*/*.bvh")
HDM05_FILES = _files("hdm05", "*/*.amc")
H36M_FILES = _files("h36m", "S*/*.txt")


@pytest.fixture(scope="session")
def data_dir() -> Path:
    if DATA_DIR is None:
        pytest.skip(NO_DATA_REASON)
    return DATA_DIR


def _need(files: list[Path], source: str) -> list[Path]:
    if DATA_DIR is None:
        pytest.skip(NO_DATA_REASON)
    if not files:
        pytest.fail(f"data folder {DATA_DIR} has no {source} files")
    return files


@pytest.fixture(scope="session")
def cmu_files() -> list[Path]:
    return _need(CMU_FILES, "cmu")


@pytest.fixture(scope="session")
def hdm05_files() -> list[Path]:
    return _need(HDM05_FILES, "hdm05")


@pytest.fixture(scope="session")
def h36m_files() -> list[Path]:
    return _need(H36M_FILES, "h36m")


@pytest.fixture(scope="session")
def catalog(data_dir):
    from data_prep.catalog import build_catalog
    return build_catalog(data_dir, cache=False)


@pytest.fixture(scope="session")
def hdm05_asf():
    """ASF of an HDM05 actor, read once: ``hdm05_asf(amc_path)``."""
    from mocapviz.io.asfamc import read_asf
    cache = {}

    def get(amc: Path):
        actor = Path(amc).parent.name
        if actor not in cache:
            cache[actor] = read_asf(Path(amc).parent / f"HDM_{actor}.asf")
        return cache[actor]
    return get
