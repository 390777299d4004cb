"""tools/run_notebooks.py: parameters reach the notebook, failures name notebook and cell."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import nbformat
import pytest

RUNNER = Path(__file__).resolve().parent.parent / "tools" / "run_notebooks.py"


def _notebook(folder: Path, name: str, cells: list[str]) -> Path:
    nb = nbformat.v4.new_notebook()
    first = nbformat.v4.new_code_cell("QUICK = True")
    first.metadata["tags"] = ["parameters"]
    nb.cells = [first] + [nbformat.v4.new_code_cell(c) for c in cells]
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    path = folder / f"{name}.ipynb"
    nbformat.write(nb, path)
    return path


def _run(*args):
    return subprocess.run([sys.executable, str(RUNNER), *map(str, args)], capture_output=True, text=True)


@pytest.mark.slow
def test_quick_flag_and_failure_report(tmp_path):
    nbs, out = tmp_path / "nbs", tmp_path / "out"
    nbs.mkdir()
    _notebook(nbs, "01_ok", ["open('mode.txt', 'w').write(str(QUICK))"])
    _notebook(nbs, "02_bad", ["x = 1", "assert not QUICK, 'needs full mode'"])
    res = _run("--notebooks-dir", nbs, "--out", out)
    assert res.returncode == 1
    assert (nbs / "mode.txt").read_text() == "True"  # ran in the notebook's folder, quick
    assert "FAILED" in res.stderr and "02_bad.ipynb, cell 3" in res.stderr
    assert "AssertionError: needs full mode" in res.stderr and "01_ok" not in res.stderr
    assert (out / "01_ok.ipynb").is_file() and (out / "02_bad.ipynb").is_file()

    res = _run("--notebooks-dir", nbs, "--out", out, "--full", "02")
    assert res.returncode == 0, res.stderr
    assert (nbs / "mode.txt").read_text() == "True"  # 01 was not selected this time
    executed = nbformat.read(out / "02_bad.ipynb", as_version=4)
    injected = [c for c in executed.cells if "injected-parameters" in c.metadata.get("tags", [])]
    assert "QUICK = False" in injected[0].source


def test_unknown_name_is_a_clear_error(tmp_path):
    (tmp_path / "nbs").mkdir()
    _notebook(tmp_path / "nbs", "01_ok", [])
    res = _run("--notebooks-dir", tmp_path / "nbs", "99_missing")
    assert res.returncode != 0 and "no notebook" in res.stderr and "99_missing" in res.stderr
