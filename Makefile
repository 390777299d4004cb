# Two commands for a newcomer: `make demo` (build data, run the notebooks, write figures/)
# and `make test` (unit tests plus every notebook in quick mode). Both set up .venv first.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
export VTK_DEFAULT_OPENGL_WINDOW ?= vtkEGLRenderWindow
export PYVISTA_OFF_SCREEN ?= true
export MPLBACKEND ?= Agg

.PHONY: setup demo book lab test test-unit test-fast test-notebooks train bench clean

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	# torch first, pinned to the CPU wheel, so the package's torch range is already met
	$(PY) -m pip install --quiet torch==2.13.0
	$(PY) -m pip install --quiet -e '.[dev]'
	$(PY) -m ipykernel install --sys-prefix --name python3 >/dev/null
	touch $@

setup: $(VENV)/.installed

# FULL=1 runs the notebooks at paper scale (QUICK = False): meant for a GPU or a cluster.
demo: setup
	$(PY) -m data_prep build
	$(PY) tools/run_notebooks.py $(if $(FULL),--full,--quick) $(notdir $(basename $(NOTEBOOKS)))

# The executed notebooks of `make demo` as a static site in build/book/html (docs/book.md); runs
# no notebook, fails on a missing or failed one, a broken link or image. BOOK_ALLOW_MISSING=1: partial.
book: setup
	$(PY) tools/build_book.py

# JupyterLab on the notebooks, with the project's kernel (the venv's python3, from setup).
# Jupyter refuses to run as root (containers) unless told; LAB_ARGS passes more options.
lab: setup
	$(VENV)/bin/jupyter lab notebooks/ $(if $(filter 0,$(shell id -u)),--allow-root) $(LAB_ARGS)

# The numbered notebooks: what `make test` and `make demo` execute. notebooks/appendix_* run on
# demand only (tools/run_notebooks.py appendix).
NOTEBOOKS := $(wildcard notebooks/[0-9]*.ipynb)

# CI's command (.ci/run, README): every unit test, then every numbered notebook in quick mode.
test: setup
	$(PY) -m pytest -q tests
	$(PY) -m pytest -q --nbmake --nbmake-timeout=1800 $(NOTEBOOKS)

test-unit: setup
	$(PY) -m pytest -q tests

# The unit tests without the slow ones (tests/conftest.py, SLOW): about a minute, for while you edit.
test-fast: setup
	$(PY) -m pytest -q -m "not slow" tests

# CONFIG=quick|default|paper; resumes cache/runs/$(CONFIG) if it holds a checkpoint
CONFIG ?= quick
train: setup
	$(PY) -m data_prep train --config $(CONFIG) --out cache/runs/$(CONFIG)

bench: setup
	$(PY) benchmarks/bench_io.py
	$(PY) benchmarks/bench_generation.py
	$(PY) benchmarks/bench_body.py
	$(PY) benchmarks/bench_cvae.py

clean:
	rm -rf $(VENV) cache figures/*.png
