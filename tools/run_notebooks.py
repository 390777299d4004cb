"""Execute the notebooks with papermill (what `make demo` runs).

    python tools/run_notebooks.py                 # every notebooks/*.ipynb, quick mode
    python tools/run_notebooks.py --full          # paper scale (QUICK = False)
    python tools/run_notebooks.py 01 03_denoising # only notebooks whose name starts so

Executed copies (with outputs) go to cache/executed/ (git-ignored); the notebooks in
notebooks/ stay output-free. Figures are written by the notebooks themselves to figures/.
A failing cell stops that notebook; the run continues with the next one and ends with a
summary naming each failed notebook and cell, exit status 1.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
NOTEBOOKS = REPO / "notebooks"
OUT = REPO / "cache" / "executed"


def find_notebooks(names: list[str], folder: Path = NOTEBOOKS) -> list[Path]:
    """Notebooks in ``folder`` (sorted), restricted to names starting with one of ``names``."""
    found = sorted(p for p in folder.glob("*.ipynb") if not p.name.endswith(".out.ipynb"))
    if not names:
        return found
    chosen = [p for p in found if any(p.stem.startswith(n.removesuffix(".ipynb")) for n in names)]
    missing = [n for n in names if not any(p.stem.startswith(n.removesuffix(".ipynb")) for p in found)]
    if missing:
        raise SystemExit(f"no notebook in {folder} matches: {', '.join(missing)}")
    return chosen


def _headless_env() -> None:
    """Rendering defaults for the kernels (inherited through the environment)."""
    if not os.environ.get("DISPLAY"):
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
        os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
    os.environ.setdefault("MPLBACKEND", "Agg")
    os.environ.setdefault("MOCAPVIZ_PYVISTA_BACKEND", "static")  # executed copies embed PNGs


def _injected_before(executed: Path, cell_index: int) -> int:
    """How many cells papermill injected before ``cell_index`` of the executed copy."""
    try:
        import nbformat

        cells = nbformat.read(str(executed), as_version=4).cells[:cell_index]
    except Exception:
        return 0
    return sum("injected-parameters" in c.get("metadata", {}).get("tags", []) for c in cells)


def describe_failure(nb: Path, out: Path, err: Exception) -> str:
    """One readable paragraph: notebook, cell number, error, the cell's first lines."""
    cell = getattr(err, "cell_index", None)
    ename, evalue = getattr(err, "ename", type(err).__name__), getattr(err, "evalue", str(err))
    if cell is not None:
        cell -= _injected_before(out, cell)  # papermill adds a parameters cell to the copy
    where = f"cell {cell + 1}" if cell is not None else "before any cell ran"
    exec_count = getattr(err, "exec_count", None)
    if exec_count:
        where += f" (In [{exec_count}])"
    lines = [f"FAILED {nb.relative_to(REPO) if nb.is_relative_to(REPO) else nb}, {where}: {ename}: {evalue}"]
    source = getattr(err, "source", "") or ""
    if source:
        lines += ["    | " + ln for ln in source.splitlines()[:8]]
    lines.append(f"    full traceback in {out}")
    return "\n".join(lines)


def run(notebooks: list[Path], quick: bool, out_dir: Path, timeout: int | None, kernel: str) -> list[str]:
    import papermill as pm

    out_dir.mkdir(parents=True, exist_ok=True)
    failures = []
    for i, nb in enumerate(notebooks, 1):
        out = out_dir / nb.name
        print(f"[{i}/{len(notebooks)}] {nb.name} ({'quick' if quick else 'full'}) -> {out}", flush=True)
        t0 = time.perf_counter()
        try:
            pm.execute_notebook(str(nb), str(out), parameters={"QUICK": quick}, cwd=str(nb.parent),
                                kernel_name=kernel, progress_bar=True, execution_timeout=timeout,
                                request_save_on_cell_execute=True)
        except Exception as err:  # PapermillExecutionError, timeouts, a dead kernel
            msg = describe_failure(nb, out, err)
            print(msg, file=sys.stderr, flush=True)
            failures.append(msg)
            continue
        print(f"    ok in {time.perf_counter() - t0:.0f} s", flush=True)
    return failures


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("names", nargs="*", help="notebook name prefixes (default: all)")
    ap.add_argument("--all", action="store_true", help="every notebook (the default without names)")
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--quick", dest="quick", action="store_true", default=True, help="QUICK = True (default)")
    mode.add_argument("--full", dest="quick", action="store_false", help="QUICK = False: paper scale")
    ap.add_argument("--out", type=Path, default=OUT, help=f"executed copies (default {OUT.relative_to(REPO)})")
    ap.add_argument("--timeout", type=int, default=None, help="seconds per cell (default none)")
    ap.add_argument("--kernel", default="python3")
    ap.add_argument("--notebooks-dir", type=Path, default=NOTEBOOKS, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    notebooks = find_notebooks([] if args.all else args.names, args.notebooks_dir)
    if not notebooks:
        print(f"no notebooks in {args.notebooks_dir}", file=sys.stderr)
        return 1
    _headless_env()
    t0 = time.perf_counter()
    failures = run(notebooks, args.quick, args.out, args.timeout, args.kernel)
    total = time.perf_counter() - t0
    if failures:
        print(f"\n{len(failures)} of {len(notebooks)} notebooks failed ({total:.0f} s):", file=sys.stderr)
        print("\n".join(failures), file=sys.stderr)
        return 1
    print(f"all {len(notebooks)} notebooks ran in {total:.0f} s; executed copies in {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
