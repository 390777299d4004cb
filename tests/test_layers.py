"""One-way layers: the library never imports the dataset builders (data_prep)."""

import ast
import subprocess
import sys
from pathlib import Path

import mocapviz

LIBRARY = Path(mocapviz.__file__).resolve().parent


def imported_modules(path: Path) -> set[str]:
    """Every module named by an import statement anywhere in the file (also inside functions)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module)
    return names


def test_the_walk_sees_imports_inside_functions(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("import os\n\ndef f():\n    from data_prep.zoo import load\n    import data_prep.sources as s\n")
    assert {"data_prep.zoo", "data_prep.sources", "os"} <= imported_modules(f)


def test_no_library_module_imports_data_prep():
    files = sorted(LIBRARY.rglob("*.py"))
    assert len(files) > 30
    offenders = {str(f.relative_to(LIBRARY)): sorted(m for m in imported_modules(f)
                                                     if m == "data_prep" or m.startswith("data_prep."))
                 for f in files}
    assert {f: m for f, m in offenders.items() if m} == {}


def test_importing_every_library_module_loads_no_data_prep():
    # a fresh interpreter: import mocapviz and all its submodules, then look at sys.modules
    code = ("import importlib, pkgutil, sys, mocapviz\n"
            "for m in pkgutil.walk_packages(mocapviz.__path__, 'mocapviz.'):\n"
            "    importlib.import_module(m.name)\n"
            "print(len([m for m in sys.modules if m.startswith('mocapviz.')]))\n"
            "print(sorted(m for m in sys.modules if m == 'data_prep' or m.startswith('data_prep.')))\n")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                         cwd=LIBRARY.parent)
    assert res.returncode == 0, res.stderr[-3000:]
    n_loaded, loaded_data_prep = res.stdout.strip().splitlines()[-2:]
    assert int(n_loaded) > 30 and loaded_data_prep == "[]"


def test_no_library_module_finds_the_repository_from_its_file():
    # data_prep knows the repository's paths (cache/, models/zoo/); the library is handed them
    for f in sorted(LIBRARY.rglob("*.py")):
        text = f.read_text()
        assert "REPO_ROOT" not in text and '"models" / "zoo"' not in text and '"cache"' not in text, f
