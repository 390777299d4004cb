"""The book (``make book``, docs/book.md) in a real browser, and its build checks.

The browser tests open every page of build/book/html in headless Chromium from disk (file://,
as a reader who double-clicks index.html would), find no broken image and no notebook error
output, check that the front page reaches every chapter, the tables and the API, and save
screenshots of the front page and of one chapter under figures/ (git-ignored). They skip, with
the reason, when the book has not been built: ``make test`` does not run ``make demo``.
Needs Debian's ``chromium`` and ``chromium-driver`` (``.ci/run`` installs them) and selenium.

The check tests (no browser, no build) run the build script's checks on small fake notebooks:
a missing executed copy, an error output, a stale copy.
"""

from __future__ import annotations

import importlib.util
import json
import os
import shutil
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
BOOK = REPO / "build" / "book" / "html"
FIGURES = REPO / "figures"
CHROMIUM, DRIVER = shutil.which("chromium"), shutil.which("chromedriver")
NOT_BUILT = "the book is not built: run `make demo && make book` (build/book/html/index.html is missing)"
NO_BROWSER = "no chromium / chromedriver on this machine (apt-get install chromium chromium-driver; .ci/run does it)"


def _browser_skip() -> str | None:
    if not (BOOK / "index.html").is_file():
        return NOT_BUILT
    if not (CHROMIUM and DRIVER):
        if os.environ.get("CI"):
            raise RuntimeError(f"{NO_BROWSER}: the book is built, CI must run its browser test")
        return NO_BROWSER
    return None


_SKIP = _browser_skip()
browser_test = pytest.mark.skipif(_SKIP is not None, reason=_SKIP or "")


def _pages() -> list[Path]:
    """Every built page, front page first (theme templates under _static are not pages)."""
    pages = sorted(p for p in BOOK.rglob("*.html") if "_static" not in p.relative_to(BOOK).parts)
    return sorted(pages, key=lambda p: p != BOOK / "index.html")


def _chapters() -> list[Path]:
    return sorted((BOOK / "notebooks").glob("*.html"))


@pytest.fixture(scope="module")
def driver():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                "--window-size=1400,1000", "--allow-file-access-from-files"):
        opts.add_argument(arg)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    drv = webdriver.Chrome(service=Service(DRIVER), options=opts)  # the system driver: no download
    drv.set_page_load_timeout(60)
    yield drv
    drv.quit()


def _open(driver, page: Path) -> None:
    """Load ``page`` and wait until the document and every image have finished loading."""
    driver.get(page.as_uri())
    _wait(lambda: driver.execute_script("return document.readyState") == "complete")
    driver.execute_script("document.querySelectorAll('img[loading=lazy]').forEach(i => i.loading = 'eager')")
    _wait(lambda: driver.execute_script("return Array.from(document.images).every(i => i.complete)"), 30)


def _wait(predicate, seconds: float = 15.0):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if predicate():
            return
        time.sleep(0.05)
    raise TimeoutError("page did not finish loading in time")


BROKEN_IMAGES = """return Array.from(document.images)
    .filter(i => i.naturalWidth === 0 && i.getAttribute('src'))
    .map(i => i.getAttribute('src'));"""
ERROR_OUTPUTS = """return Array.from(document.querySelectorAll(
    '.output.traceback, .output.error, div.cell_output .highlight-ipythontb'))
    .map(e => e.innerText.slice(0, 300));"""


@browser_test
def test_every_page_has_its_images_and_no_error_output(driver):
    problems, n_images = [], 0
    driver.get_log("browser")  # drop anything logged before
    for page in _pages():
        rel = page.relative_to(BOOK).as_posix()
        _open(driver, page)
        n_images += driver.execute_script("return document.images.length")
        problems += [f"{rel}: broken image {src}" for src in driver.execute_script(BROKEN_IMAGES)]
        problems += [f"{rel}: error output: {text!r}" for text in driver.execute_script(ERROR_OUTPUTS)]
        if rel.startswith("notebooks/"):
            body = driver.find_element("tag name", "body").text
            if "Traceback (most recent call last)" in body:
                problems.append(f"{rel}: a traceback in the page text")
        problems += [f"{rel}: {e['message'][:200]}" for e in driver.get_log("browser")
                     if e["level"] == "SEVERE" and ("Failed to load" in e["message"] or "ERR_FILE" in e["message"])]
    assert not problems, "\n".join(problems)
    assert n_images > 0, "no image on any page: the figures did not make it into the book"


@browser_test
def test_front_page_reaches_every_chapter_table_and_the_api(driver):
    _open(driver, BOOK / "index.html")
    hrefs = {a.get_attribute("href").split("#")[0] for a in driver.find_elements("css selector", "a[href]")}
    wanted = [*_chapters(), BOOK / "results_tables.html", BOOK / "api.html"]
    unreachable = [p.relative_to(BOOK).as_posix() for p in wanted if p.as_uri() not in hrefs]
    assert not unreachable, f"not linked from the front page: {unreachable}"
    assert _chapters(), "the book has no chapter"
    _open(driver, BOOK / "results_tables.html")
    tables = driver.find_elements("css selector", "div.results-table table")
    rendered = list((BOOK.parent / "src" / "results").glob("*.csv"))  # results/*.csv when the book was built
    assert rendered and len(tables) == len(rendered), "one table per results/*.csv"


@browser_test
def test_screenshots_of_the_front_page_and_a_chapter(driver):
    FIGURES.mkdir(exist_ok=True)
    _open(driver, BOOK / "index.html")
    front = FIGURES / "book_front_page.png"
    assert driver.save_screenshot(str(front))
    # the first chapter with a figure, scrolled to its first figure (a chapter shows its figures)
    for page in _chapters():
        _open(driver, page)
        figures = driver.find_elements("css selector", "div.cell_output img")
        if figures:
            driver.execute_script("arguments[0].scrollIntoView({block: 'center'})", figures[0])
            time.sleep(0.3)
            shot = FIGURES / f"book_chapter_{page.stem}.png"
            assert driver.save_screenshot(str(shot))
            break
    else:
        pytest.fail("no chapter shows a figure")
    for p in (front, shot):
        assert p.stat().st_size > 10_000, f"{p} looks blank"


# --- the build script's checks, on fake notebooks (no browser, no build) ---------------------

def _build_book(monkeypatch, tmp_path):
    spec = importlib.util.spec_from_file_location("build_book", REPO / "tools" / "build_book.py")
    mod = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, "build_book", mod)  # dataclasses look their module up
    spec.loader.exec_module(mod)
    monkeypatch.setattr(mod, "NOTEBOOKS", tmp_path / "notebooks")
    monkeypatch.setattr(mod, "EXECUTED", tmp_path / "cache" / "executed")
    monkeypatch.setattr(mod, "REPO", tmp_path)
    (tmp_path / "notebooks").mkdir()
    (tmp_path / "cache" / "executed").mkdir(parents=True)
    return mod


def _notebook(path: Path, code: str, outputs: list | None = None) -> None:
    cell = {"id": "code", "cell_type": "code", "execution_count": 1, "metadata": {}, "source": code, "outputs": outputs or []}
    title = {"id": "title", "cell_type": "markdown", "metadata": {}, "source": "# A chapter"}
    path.write_text(json.dumps({"cells": [title, cell], "metadata": {}, "nbformat": 4, "nbformat_minor": 5}))


def test_a_notebook_without_executed_copy_fails_and_says_make_demo(monkeypatch, tmp_path):
    pytest.importorskip("nbformat")
    mod = _build_book(monkeypatch, tmp_path)
    for name in ("01_a", "02_b"):
        _notebook(tmp_path / "notebooks" / f"{name}.ipynb", "x = 1")
    _notebook(tmp_path / "cache" / "executed" / "01_a.ipynb", "x = 1")
    with pytest.raises(SystemExit) as err:
        mod.collect(allow_missing=False, allow_stale=False)
    assert "02_b" in str(err.value.code) and "make demo" in str(err.value.code)
    chapters, missing = mod.collect(allow_missing=True, allow_stale=False)
    assert [c.name for c in chapters] == ["01_a"] and missing == ["02_b"]


def test_an_error_output_or_a_stale_copy_fails(monkeypatch, tmp_path):
    pytest.importorskip("nbformat")
    mod = _build_book(monkeypatch, tmp_path)
    _notebook(tmp_path / "notebooks" / "01_a.ipynb", "x = 1")
    error = {"output_type": "error", "ename": "ValueError", "evalue": "boom", "traceback": []}
    _notebook(tmp_path / "cache" / "executed" / "01_a.ipynb", "x = 1", [error])
    with pytest.raises(SystemExit, match="ValueError: boom"):
        mod.collect(allow_missing=False, allow_stale=False)
    _notebook(tmp_path / "cache" / "executed" / "01_a.ipynb", "x = 2")
    with pytest.raises(SystemExit, match="stale"):
        mod.collect(allow_missing=False, allow_stale=False)
    assert [c.name for c in mod.collect(allow_missing=False, allow_stale=True)[0]] == ["01_a"]


def test_the_html_check_finds_broken_images_links_and_anchors(monkeypatch, tmp_path):
    mod = _build_book(monkeypatch, tmp_path)
    site = tmp_path / "html"
    (site / "notebooks").mkdir(parents=True)
    (site / "img.png").write_bytes(b"\x89PNG")
    (site / "index.html").write_text('<a href="notebooks/a.html#fig">a</a><a href="notebooks/b.html">b</a>'
                                     '<img src="img.png"><img src="gone.png"><a href="#top" id="top">t</a>')
    (site / "notebooks" / "a.html").write_text('<h1 id="title">A</h1><pre class="output traceback">E</pre>'
                                               '<a href="../index.html">home</a>')
    problems = mod.check_html(site)
    assert problems == ["index.html: <a> notebooks/a.html#fig: no anchor #fig in notebooks/a.html",
                        "index.html: <a> notebooks/b.html: no such file",
                        "index.html: <img> gone.png: no such file",
                        "notebooks/a.html: 1 notebook error output(s)"]
