"""Sphinx configuration of the book (``make book``; see docs/book.md).

The source tree Sphinx reads is *staged* by ``tools/build_book.py`` under ``build/book/src``
(the executed notebooks from ``cache/executed/``, the README as front page, the docs, the
generated results and API pages); this file is passed with ``-c docs/book``. Notebooks are
never executed here (``nb_execution_mode = "off"``): the book shows what ``make demo`` ran.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))  # mocapviz and data_prep, for autodoc, without an install

project = "mocapviz"
author = "mocapviz contributors"
copyright = "mocapviz contributors, MIT licence"

extensions = [
    "myst_nb",  # MyST markdown and .ipynb pages (myst_parser comes with it)
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.viewcode",
    "sphinx-mathjax-offline",  # MathJax 3 copied into _static/: the math renders offline (no CDN)
]

# --- notebooks: render the executed copies as they are, never run them -------------------
nb_execution_mode = "off"
nb_merge_streams = True
nb_render_markdown_format = "myst"
# live widgets (tqdm progress bars) are dropped by the staging step; an unknown mime type
# left over would be a warning, and -W makes it an error
myst_enable_extensions = ["colon_fence", "dollarmath", "amsmath", "deflist"]
myst_heading_anchors = 3
myst_dmath_double_inline = True

# --- autodoc: the public facades --------------------------------------------------------
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"members": True, "undoc-members": True, "show-inheritance": True}
# the body extra (anny, dtaidistance) is mocked for autodoc only where it is not installed
autodoc_mock_imports = [m for m in ("anny", "dtaidistance") if importlib.util.find_spec(m) is None]

# --- html -------------------------------------------------------------------------------
html_theme = "sphinx_book_theme"
html_title = "mocapviz: CCNet and the 4D motion CVAE, executed"
html_static_path = ["_static"]
html_css_files = ["book.css"]
html_theme_options = {
    "show_toc_level": 2,
    "use_download_button": False,
    "use_fullscreen_button": False,
    "use_repository_button": False,
    "home_page_in_toc": True,
}
html_show_sourcelink = False
html_copy_source = False
html_last_updated_fmt = None

exclude_patterns = ["_build", "**.ipynb_checkpoints"]
# the docs' own heading levels are theirs (docs/generate.md starts at ###): not a book error
suppress_warnings = ["myst.header"]


def _escape_bars(app, what, name, obj, options, lines):
    """Docstrings write norms as |x| (mocapviz.metrics); reST would read a substitution.
    Escape the bars of prose lines (lines starting with | or + may be tables: left alone)."""
    for i, line in enumerate(lines):
        if "|" in line and not line.lstrip().startswith(("|", "+")):
            lines[i] = line.replace("|", r"\|")


def setup(app):
    app.connect("autodoc-process-docstring", _escape_bars)
