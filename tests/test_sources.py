"""Data discovery: explicit path, $MOCAPVIZ_DATA_DIR, ../shared/data beside the checkout, data/raw."""

from __future__ import annotations

from pathlib import Path

import pytest

from data_prep import cli, sources
from data_prep.sources import DataNotFoundError, find_data_dir

try:
    REAL = find_data_dir()
except DataNotFoundError as e:
    pytest.skip(str(e), allow_module_level=True)


def _data_folder(path: Path, *names: str) -> Path:
    """A data folder holding symlinks to the real source folders ``names``."""
    path.mkdir(parents=True)
    for n in names:
        (path / n).symlink_to(REAL / n, target_is_directory=True)
    return path


@pytest.fixture
def layout(tmp_path, monkeypatch):
    """A fake checkout at tmp/checkout with every candidate folder holding real data."""
    checkout = tmp_path / "checkout"
    checkout.mkdir()
    monkeypatch.setattr(sources, "REPO_ROOT", checkout)
    monkeypatch.delenv("MOCAPVIZ_DATA_DIR", raising=False)
    return dict(explicit=_data_folder(tmp_path / "mine", "cmu"),
                env=_data_folder(tmp_path / "env", "cmu"),
                shared=_data_folder(tmp_path / "shared" / "data", "hdm05", "cmu"),
                raw=_data_folder(checkout / "data" / "raw", "h36m"),
                checkout=checkout, monkeypatch=monkeypatch)


def test_search_order(layout):
    mp = layout["monkeypatch"]
    mp.setenv("MOCAPVIZ_DATA_DIR", str(layout["env"]))
    assert find_data_dir(layout["explicit"]) == layout["explicit"]
    assert find_data_dir() == layout["env"]
    mp.delenv("MOCAPVIZ_DATA_DIR")
    assert find_data_dir() == layout["shared"]  # ../shared/data beside the checkout
    assert find_data_dir(source="h36m") == layout["raw"]  # the first folder that has that source
    (layout["shared"] / "hdm05").unlink()
    (layout["shared"] / "cmu").unlink()
    assert find_data_dir() == layout["raw"]
    assert sources.candidate_dirs() == [layout["shared"], layout["raw"]]


def test_env_without_wanted_source_falls_through(layout):
    layout["monkeypatch"].setenv("MOCAPVIZ_DATA_DIR", str(layout["env"]))  # holds only cmu
    assert find_data_dir(source="hdm05") == layout["shared"]


def test_missing_everywhere_lists_search_order(tmp_path, monkeypatch):
    monkeypatch.setattr(sources, "REPO_ROOT", tmp_path / "checkout")
    monkeypatch.setenv("MOCAPVIZ_DATA_DIR", str(tmp_path / "nothing"))
    with pytest.raises(DataNotFoundError) as e:
        find_data_dir()
    msg = str(e.value)
    order = [msg.index(s) for s in ("$MOCAPVIZ_DATA_DIR", str(tmp_path / "shared" / "data"),
                                    str(tmp_path / "checkout" / "data" / "raw"), "data_prep download")]
    assert order == sorted(order)


def test_explicit_path_must_exist(tmp_path):
    with pytest.raises(DataNotFoundError, match="does not exist"):
        find_data_dir(tmp_path / "absent")


def test_cli_reports_missing_data_without_traceback(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(sources, "REPO_ROOT", tmp_path / "checkout")
    monkeypatch.delenv("MOCAPVIZ_DATA_DIR", raising=False)
    assert cli.main(["catalog", "--csv", str(tmp_path / "c.csv")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: no motion data") and "Traceback" not in err
    assert "1. the path you passed" in err and "4. data/raw" in err
    assert not (tmp_path / "c.csv").exists()
    assert cli.main(["build", "--data-dir", str(tmp_path / "absent")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_cli_catalog_and_build(tmp_path, monkeypatch, capsys):
    from data_prep import build, catalog
    monkeypatch.setattr(catalog, "CACHE_DIR", tmp_path / "cache")
    data = _data_folder(tmp_path / "data", "cmu")
    assert cli.main(["catalog", "--data-dir", str(data), "--csv", str(tmp_path / "c.csv")]) == 0
    out = capsys.readouterr().out
    assert "cmu: clips/frames/seconds" in out and "1/316/2.6s" in out  # 07_01: 316 frames
    assert "15 clips, 3384 frames" in out and "4 too short" in out
    import pandas as pd
    assert len(pd.read_csv(tmp_path / "c.csv")) == 15
    assert cli.main(["build", "catalog", "--data-dir", str(data)]) == 0
    assert "build catalog: 15 clips" in capsys.readouterr().out
    assert cli.main(["build", "nope"]) == 2 and "unknown build target" in capsys.readouterr().err
    assert "catalog" in build.load_plugins()


def test_register_build_target(monkeypatch, capsys):
    from data_prep import build
    monkeypatch.setattr(build, "BUILDERS", dict(build.BUILDERS))
    calls = []

    @build.register_build("probe", help="records its call", default=False)
    def probe(data_dir=None, quick=False):
        calls.append((data_dir, quick))
        return "ok"

    build.run_builds(["probe"], data_dir="x", quick=True)
    assert calls == [("x", True)] and "build probe: ok" in capsys.readouterr().out
    with pytest.raises(ValueError, match="twice"):
        build.register_build("probe")(lambda **kw: "other")
