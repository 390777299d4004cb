"""Build the book: the executed notebooks as a static site (what `make book` runs).

    python tools/build_book.py                      # build/book/html, fails on any problem
    BOOK_ALLOW_MISSING=1 python tools/build_book.py # skip notebooks with no executed copy
    python tools/build_book.py --check-only         # the checks on cache/executed/, no build

Sphinx + myst-nb renders the executed copies that `make demo` wrote to cache/executed/; it never
executes a notebook. Steps:

1. checks the executed copies: every notebooks/*.ipynb must have one (else: run `make demo`),
   its code must be the committed notebook's code (else it is stale: run `make demo`), and it
   must hold no error output and no empty image;
2. stages a source tree under build/book/src: the README as front page (paper-map names linked
   to their chapters and tables), one chapter per notebook in the papers' order, docs/*.md,
   models/README.md, results/README.md, a page of the results/*.csv tables, the API page;
   every relative link and image in those pages must name a file;
3. runs ``sphinx-build -W --keep-going`` (a warning, e.g. a missing image or a broken link
   between pages, fails the build) into build/book/html;
4. checks the built HTML: every local link, image, script and stylesheet resolves to a file,
   every #anchor of a local link exists, and no page shows a notebook error.

The result is plain static files: serve build/book/html as is (see docs/book.md).
Environment (for local previews; the default fails on each of these): BOOK_ALLOW_MISSING=1
skips notebooks without an executed copy, BOOK_ALLOW_STALE=1 builds stale copies as they are,
BOOK_ALLOW_BROKEN_LINKS=1 shows a link to a missing page as plain text (a warning each).
"""

from __future__ import annotations

import argparse
import base64
import csv
import html.parser
import os
import re
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import unquote, urlsplit

REPO = Path(__file__).resolve().parent.parent
NOTEBOOKS = REPO / "notebooks"
EXECUTED = REPO / "cache" / "executed"
CONF_DIR = REPO / "docs" / "book"
BUILD = REPO / "build" / "book"
SRC, HTML = BUILD / "src", BUILD / "html"

PAPERS = [  # (caption, notebooks whose number is in range): the README's paper map order
    ("CCNet (Hou et al. 2023)", range(0, 10)),
    ("Multi-frame 4D motion CVAE (Marsot et al. 2021)", range(10, 100)),
]
DOC_ORDER = ["method", "data", "experiments", "generate", "your_own_file", "benchmarks", "gpu", "book"]
WIDGET_MIME = "application/vnd.jupyter.widget-view+json"
RUN_DEMO = "run `make demo` first (it executes every notebook into cache/executed/)"


class BookError(SystemExit):
    pass


def _env_flag(name: str) -> bool:
    return os.environ.get(name, "").strip().lower() not in ("", "0", "false", "no")


# --- 1. the executed copies -----------------------------------------------------------------

@dataclass
class Chapter:
    name: str                    # "01_dataset"
    source: Path                 # notebooks/01_dataset.ipynb
    executed: Path               # cache/executed/01_dataset.ipynb
    problems: list[str] = field(default_factory=list)
    stale: bool = False
    mode: str = "?"              # quick / full, from papermill's parameters


def _code(nb) -> list[str]:
    return [c.source.strip() for c in nb.cells
            if c.cell_type == "code" and "injected-parameters" not in c.metadata.get("tags", [])]


def check_chapter(ch: Chapter) -> None:
    """Fill ``ch.problems`` (errors, empty images) and ``ch.stale`` from the executed copy."""
    import nbformat

    nb = nbformat.read(str(ch.executed), as_version=4)
    params = nb.metadata.get("papermill", {}).get("parameters", {})
    if "QUICK" in params:
        ch.mode = "quick" if params["QUICK"] else "full"
    ch.stale = _code(nb) != _code(nbformat.read(str(ch.source), as_version=4))
    n = 0
    for cell in nb.cells:
        if cell.cell_type != "code":
            continue
        n += "injected-parameters" not in cell.metadata.get("tags", [])
        where = f"{ch.executed.relative_to(REPO)}, code cell {n}"
        pm = cell.metadata.get("papermill", {})
        if pm.get("exception"):
            ch.problems.append(f"{where}: the cell raised when it ran")
        elif pm.get("status", "completed") != "completed":
            ch.problems.append(f"{where}: not run to the end (papermill status {pm.get('status')!r}: "
                               "a run still going, or one that was stopped)")
        for out in cell.get("outputs", []):
            if out.get("output_type") == "error":
                ch.problems.append(f"{where}: error output {out.get('ename')}: {out.get('evalue')}")
            for mime, data in out.get("data", {}).items():
                if mime.startswith("image/") and mime != "image/svg+xml":
                    raw = "".join(data) if isinstance(data, list) else data
                    if not raw or not base64.b64decode(raw, validate=False):
                        ch.problems.append(f"{where}: an empty {mime} figure")
    if nb.metadata.get("papermill", {}).get("exception") and not ch.problems:
        ch.problems.append(f"{ch.executed.relative_to(REPO)}: papermill recorded an exception")


def collect(allow_missing: bool, allow_stale: bool) -> tuple[list[Chapter], list[str]]:
    """The chapters to build, in the papers' order; raises BookError listing every problem."""
    sources = sorted(p for p in NOTEBOOKS.glob("[0-9][0-9]_*.ipynb") if not p.name.endswith(".out.ipynb"))
    if not sources:
        raise BookError(f"book: no notebooks in {NOTEBOOKS}")
    chapters, missing, errors, stale = [], [], [], []
    for src in sources:
        ch = Chapter(src.stem, src, EXECUTED / src.name)
        if not ch.executed.is_file():
            missing.append(ch.name)
            continue
        check_chapter(ch)
        errors += ch.problems
        if ch.stale:
            stale.append(ch.name)
        chapters.append(ch)
    lines = []
    if missing:
        msg = (f"{len(missing)} of {len(sources)} notebooks have no executed copy in "
               f"{EXECUTED.relative_to(REPO)}/: {', '.join(missing)}")
        if allow_missing:
            print(f"book: WARNING: {msg}; skipped (BOOK_ALLOW_MISSING=1), the book is incomplete", flush=True)
        else:
            lines.append(f"{msg}.\n    {RUN_DEMO}; BOOK_ALLOW_MISSING=1 builds a partial book without them")
    if stale:
        msg = (f"executed copies older than their notebook's code (stale): {', '.join(stale)}")
        if allow_stale:
            print(f"book: WARNING: {msg}; built anyway (BOOK_ALLOW_STALE=1)", flush=True)
        else:
            lines.append(f"{msg}.\n    {RUN_DEMO} again; BOOK_ALLOW_STALE=1 builds them as they are")
    if errors:
        lines.append("notebook errors in the executed copies (fix the notebook, then `make demo`):\n    "
                     + "\n    ".join(errors))
    if lines:
        raise BookError("book: FAILED\n  " + "\n  ".join(lines))
    return chapters, missing


# --- 2. the staged source tree --------------------------------------------------------------

def _clean_notebook(src: Path, dst: Path) -> None:
    """Copy an executed notebook for the book: drop live-widget outputs (tqdm bars, which have
    no static form), put the title cell before papermill's parameter cells."""
    import nbformat

    nb = nbformat.read(str(src), as_version=4)
    for cell in nb.cells:
        if cell.cell_type == "code":
            cell.outputs = [o for o in cell.get("outputs", []) if WIDGET_MIME not in o.get("data", {})]
    lead = 0
    while lead < len(nb.cells) and nb.cells[lead].cell_type == "code" and \
            {"parameters", "injected-parameters"} & set(nb.cells[lead].metadata.get("tags", [])):
        lead += 1
    if lead and lead < len(nb.cells) and nb.cells[lead].cell_type == "markdown":
        nb.cells.insert(0, nb.cells.pop(lead))
    nb.metadata.pop("widgets", None)
    dst.parent.mkdir(parents=True, exist_ok=True)
    nbformat.write(nb, str(dst))


def _readme_front_page(chapters: list[Chapter], missing: list[str], tables: list[str]) -> str:
    """README.md with the paper map's notebook and results-file names linked into the book."""
    text = (REPO / "README.md").read_text(encoding="utf-8")
    names = {ch.name for ch in chapters}
    by_number = {}
    for ch in chapters:
        by_number.setdefault(ch.name[:2], []).append(ch.name)

    def notebook_link(m: re.Match) -> str:
        token = m.group(1)
        name = token if token in names else (by_number[token][0] if len(by_number.get(token, [])) == 1 else None)
        return f"[`{token}`](notebooks/{name}.ipynb)" if name else m.group(0)

    def table_link(m: re.Match) -> str:
        stem = m.group(1)
        return f"[`{stem}.csv`](results_tables.md#{_anchor(stem)})" if stem in tables else m.group(0)

    start = text.find("\n## Paper map")
    end = text.find("\n## ", start + 1) if start >= 0 else -1
    if start >= 0:
        end = len(text) if end < 0 else end
        part = re.sub(r"(?<!\[)`(\d\d(?:_[a-z0-9_]+)?)`", notebook_link, text[start:end])
        part = re.sub(r"(?<!\[)`([a-z0-9_]+)\.csv`", table_link, part)
        text = text[:start] + part + text[end:]
    when = sorted(t for t in (_run_time(ch.executed) for ch in chapters) if t)
    modes = sorted({ch.mode for ch in chapters})
    note = [
        "",
        "```{note}",
        "This book shows the notebooks as `make demo` executed them "
        f"({'/'.join(modes)} mode{', ' + when[0][:10] if when else ''}"
        f"{' to ' + when[-1][:10] if len(when) > 1 and when[-1][:10] != when[0][:10] else ''}), "
        "from `cache/executed/`; `make book` renders them without running them again.",
        "```",
    ]
    if missing:
        note += ["", "```{warning}",
                 f"Partial build (BOOK_ALLOW_MISSING=1): no executed copy of {', '.join(missing)}; "
                 "run `make demo` for the whole book.", "```"]
    lines = text.splitlines()
    title = next(i for i, ln in enumerate(lines) if ln.startswith("# "))
    lines[title + 1:title + 1] = note
    out = "\n".join(lines).rstrip() + "\n\n## Contents\n"
    for caption, numbers in PAPERS:
        entries = [f"notebooks/{ch.name}" for ch in chapters if int(ch.name[:2]) in numbers]
        if entries:
            out += _toctree(caption, entries)
    out += _toctree("Results and reference", ["results_tables", "api"])
    docs = [f"docs/{d}" for d in DOC_ORDER if (REPO / "docs" / f"{d}.md").is_file()]
    docs += sorted(f"docs/{p.stem}" for p in (REPO / "docs").glob("*.md") if p.stem not in DOC_ORDER)
    out += _toctree("Documentation", docs + ["models/README", "results/README"])
    return out


def _toctree(caption: str, entries: list[str]) -> str:
    return "\n```{toctree}\n:caption: " + caption + "\n:maxdepth: 1\n\n" + "\n".join(entries) + "\n```\n"


def _anchor(stem: str) -> str:
    return "table-" + stem.replace("_", "-")


def _run_time(executed: Path) -> str | None:
    import json

    try:
        return json.loads(executed.read_text(encoding="utf-8"))["metadata"]["papermill"]["end_time"]
    except (KeyError, ValueError, OSError):
        return None


def _results_descriptions() -> dict[str, tuple[str, str]]:
    """results/README.md's table: file stem -> (what, made by)."""
    out = {}
    for line in (REPO / "results" / "README.md").read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split(" | ")]
        m = re.fullmatch(r"`([a-z0-9_]+)\.csv`", cells[0]) if len(cells) >= 3 else None
        if m:
            out[m.group(1)] = (cells[1], cells[2])
    return out


def _results_page(csvs: list[Path]) -> str:
    about = _results_descriptions()
    parts = ["# Results tables", "",
             "Every `results/*.csv` of the repository, rendered from the committed file at build time "
             "(the notebooks and commands named below write them). What each column means, and the mode "
             "each was computed in: [results/README.md](results/README.md).", ""]
    for group, key in (("CCNet (Hou et al. 2023)", "ccnet"), ("Multi-frame 4D motion CVAE (Marsot et al. 2021)", "cvae4d")):
        chosen = [p for p in csvs if key in p.stem]
        if chosen:
            parts += [f"## {group}", ""]
        for p in chosen:
            parts += _table_section(p, about.get(p.stem))
    rest = [p for p in csvs if "ccnet" not in p.stem and "cvae4d" not in p.stem]
    if rest:
        parts += ["## Other tables", ""]
        for p in rest:
            parts += _table_section(p, about.get(p.stem))
    return "\n".join(parts) + "\n"


def _table_section(p: Path, about: tuple[str, str] | None) -> list[str]:
    with p.open(newline="", encoding="utf-8") as f:
        n_rows = sum(1 for _ in csv.reader(f)) - 1
    out = [f"({_anchor(p.stem)})=", f"### `{p.name}`", ""]
    if about:
        out += [about[0], "", f"Made by: {about[1]}", ""]
    out += [f"{n_rows} rows; {{download}}`download the CSV <results/{p.name}>`.", "",
            ":::{container} results-table", f"```{{csv-table}}", f":file: results/{p.name}", ":header-rows: 1", "```",
            ":::", ""]
    return out


def _generate_help() -> str:
    """``mocapviz generate --help``, as the installed command prints it."""
    env = dict(os.environ, COLUMNS="88")
    res = subprocess.run([sys.executable, "-m", "mocapviz", "generate", "--help"], capture_output=True,
                         text=True, cwd=REPO, env=env, timeout=300)
    if res.returncode != 0:
        raise BookError(f"book: FAILED: `mocapviz generate --help` exited {res.returncode}:\n{res.stderr}")
    return res.stdout


def stage(chapters: list[Chapter], missing: list[str]) -> None:
    if SRC.exists():
        shutil.rmtree(SRC)
    SRC.mkdir(parents=True)
    for p in CONF_DIR.iterdir():  # the hand-written pages (api.md, ...); conf.py is read with -c
        if p.suffix == ".md":
            shutil.copy2(p, SRC / p.name)
    for ch in chapters:
        _clean_notebook(ch.executed, SRC / "notebooks" / f"{ch.name}.ipynb")
    shutil.copytree(REPO / "docs", SRC / "docs", ignore=shutil.ignore_patterns("book", "*.py"))
    (SRC / "models").mkdir()
    shutil.copy2(REPO / "models" / "README.md", SRC / "models" / "README.md")
    (SRC / "results").mkdir()
    csvs = sorted((REPO / "results").glob("*.csv"))
    for p in [*csvs, REPO / "results" / "README.md"]:
        shutil.copy2(p, SRC / "results" / p.name)
    (SRC / "results_tables.md").write_text(_results_page(csvs), encoding="utf-8")
    (SRC / "generate_help.txt").write_text(_generate_help(), encoding="utf-8")
    (SRC / "index.md").write_text(_readme_front_page(chapters, missing, [p.stem for p in csvs]), encoding="utf-8")


LINK = re.compile(r"(!?)\[((?:[^\[\]]|\[[^\]]*\])*)\]\(([^)\s]+)\)")


def _origin(staged: Path) -> str:
    rel = staged.relative_to(SRC).as_posix()
    return {"index.md": "README.md", "api.md": "docs/book/api.md",
            "results_tables.md": "results/*.csv (generated page)"}.get(rel, rel)


def check_links(allow_broken: bool) -> None:
    """Every relative link and image of the staged markdown pages must name a file of the book:
    a link to a page that is not there fails (unlinked with a warning under
    BOOK_ALLOW_BROKEN_LINKS=1); a missing image always fails."""
    errors, unlinked = [], []
    for md in sorted(SRC.rglob("*.md")):
        lines, fenced, changed = md.read_text(encoding="utf-8").splitlines(), False, False
        for i, line in enumerate(lines):
            if line.lstrip().startswith(("```", "~~~")):
                fenced = not fenced
            if fenced:
                continue

            def visit(m: re.Match) -> str:
                nonlocal changed
                bang, text, url = m.groups()
                parts = urlsplit(url)
                if parts.scheme or parts.netloc or not parts.path:
                    return m.group(0)
                if (md.parent / unquote(parts.path)).exists():
                    return m.group(0)
                where = f"{_origin(md)}:{i + 1}: {'image' if bang else 'link'} {url}: no such file"
                if bang or not allow_broken:
                    errors.append(where)
                    return m.group(0)
                unlinked.append(where)
                changed = True
                return text

            lines[i] = LINK.sub(visit, line)
        if changed:
            md.write_text("\n".join(lines) + "\n", encoding="utf-8")
    for w in unlinked:
        print(f"book: WARNING: {w} (shown as plain text: BOOK_ALLOW_BROKEN_LINKS=1)", flush=True)
    if errors:
        raise BookError("book: FAILED: broken links or missing figures in the pages' sources:\n  "
                        + "\n  ".join(errors) + "\n  (BOOK_ALLOW_BROKEN_LINKS=1 previews the book with "
                        "broken page links as plain text)")


# --- 3. sphinx -------------------------------------------------------------------------------

def sphinx(jobs: str) -> None:
    if HTML.exists():
        shutil.rmtree(HTML)
    cmd = [sys.executable, "-m", "sphinx", "-b", "html", "-W", "--keep-going", "-q", "-j", jobs,
           "-c", str(CONF_DIR), "-d", str(BUILD / "doctrees"), str(SRC), str(HTML)]
    print("book: " + " ".join(str(c).replace(str(REPO) + "/", "") for c in cmd), flush=True)
    env = dict(os.environ, MPLBACKEND="Agg", PYVISTA_OFF_SCREEN="true")
    if subprocess.run(cmd, cwd=REPO, env=env).returncode != 0:
        raise BookError("book: FAILED: sphinx reported warnings or errors (above); -W treats each as an error")


# --- 4. the built html -----------------------------------------------------------------------

class _Page(html.parser.HTMLParser):
    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.ids: set[str] = set()
        self.refs: list[tuple[str, str]] = []  # (tag, url)
        self.error_outputs = 0

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if a.get("id"):
            self.ids.add(a["id"])
        if tag == "a" and a.get("name"):
            self.ids.add(a["name"])
        for key in ("href", "src"):
            if a.get(key) and tag in ("a", "img", "script", "link", "source", "video", "iframe"):
                self.refs.append((tag, a[key]))
        classes = set((a.get("class") or "").split())
        if {"output", "traceback"} <= classes or "stderr-error" in classes:
            self.error_outputs += 1


def check_html(root: Path = HTML) -> list[str]:
    """Broken local links, images and anchors, and error outputs, in every built page."""
    pages = {p: _Page() for p in root.rglob("*.html") if "_static" not in p.relative_to(root).parts}
    for p, parser in pages.items():
        parser.feed(p.read_text(encoding="utf-8", errors="replace"))
    problems = []
    for p, parser in pages.items():
        rel = p.relative_to(root)
        if parser.error_outputs:
            problems.append(f"{rel}: {parser.error_outputs} notebook error output(s)")
        for tag, url in parser.refs:
            parts = urlsplit(url)
            if parts.scheme or parts.netloc or url.startswith(("data:", "mailto:", "javascript:")):
                continue
            target = (p.parent / unquote(parts.path)).resolve() if parts.path else p
            if parts.path.endswith("/") or (target.is_dir() and parts.path):
                target = target / "index.html"
            if not target.is_file():
                problems.append(f"{rel}: <{tag}> {url}: no such file")
            elif tag == "img" and target.stat().st_size == 0:
                problems.append(f"{rel}: <img> {url}: empty file")
            elif parts.fragment and target.suffix == ".html" and tag == "a":
                ids = pages[target].ids if target in pages else set()
                if unquote(parts.fragment) not in ids:
                    problems.append(f"{rel}: <a> {url}: no anchor #{parts.fragment} in {target.relative_to(root)}")
    return sorted(set(problems))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--check-only", action="store_true", help="check cache/executed/ only, build nothing")
    ap.add_argument("-j", "--jobs", default="1", help="sphinx-build -j (default 1)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    try:
        chapters, missing = collect(_env_flag("BOOK_ALLOW_MISSING"), _env_flag("BOOK_ALLOW_STALE"))
        print(f"book: {len(chapters)} executed notebooks checked: {', '.join(ch.name for ch in chapters)}", flush=True)
        if args.check_only:
            return 0
        if not chapters:
            raise BookError(f"book: FAILED: no executed notebook to build; {RUN_DEMO}")
        stage(chapters, missing)
        check_links(_env_flag("BOOK_ALLOW_BROKEN_LINKS"))
        sphinx(args.jobs)
        problems = check_html()
        if problems:
            raise BookError("book: FAILED: the built site has broken links or error outputs:\n  " + "\n  ".join(problems))
    except BookError as e:
        print(e.code, file=sys.stderr, flush=True)
        return 1
    n_pages = sum(1 for _ in HTML.rglob("*.html"))
    print(f"book: {len(chapters)} chapters, {n_pages} pages in {time.perf_counter() - t0:.0f} s; "
          f"open {(HTML / 'index.html').relative_to(REPO)} "
          f"(or: python -m http.server -d {HTML.relative_to(REPO)} 8000)"
          + (f"; INCOMPLETE: {len(missing)} notebooks missing" if missing else ""), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
