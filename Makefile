# pv_ambient — the two commands of the README's quick start: `make demo` and `make test`.
# Each creates .venv if it is missing and installs the package with its extras first (test; distributed:
# dask.distributed for render_series and `pv-ambient series`; and mri:
# nilearn, whose wheel holds the MNI152 template of the MRI gallery example; every example runs in make test).
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
export PYVISTA_OFF_SCREEN := true
export VTK_DEFAULT_OPENGL_WINDOW := vtkEGLRenderWindow
# Numba's on-disk cache keys a compiled function on its own source file only: a kernel that inlines
# a callee from another module would stay compiled with the old callee after an edit there. One cache
# folder per state of the kernels' sources keeps every build consistent (make clean removes them all).
export NUMBA_CACHE_DIR := $(CURDIR)/.numba_cache/$(firstword $(shell cat pv_ambient/_kernels/*.py | cksum))
export MPLBACKEND := Agg

.PHONY: demo test test-browser install clean bench docs gallery install-check gpu-kernels

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --upgrade pip

$(STAMP): $(PY) pyproject.toml
	$(PY) -m pip install -e ".[test,mri,distributed]"
	touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/pv-ambient demo -o demo_output

test: $(STAMP)
	$(PY) -m pytest -q

# The trame views in a real browser (tests/browser, not part of make test): the jupyter extra and selenium
# into .venv, Chromium and its driver from Debian's packages when /usr/bin/chromium is missing.
# Screenshots and timings: build/test-browser.
BROWSER_STAMP := $(VENV)/.installed-browser

$(BROWSER_STAMP): $(STAMP)
	$(PY) -m pip install -e ".[jupyter]" selenium
	touch $(BROWSER_STAMP)

test-browser: $(BROWSER_STAMP)
	@if [ ! -x /usr/bin/chromium ] || [ ! -x /usr/bin/chromedriver ]; then \
	  if command -v apt-get >/dev/null && [ "$$(id -u)" = 0 ]; then \
	    apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends chromium chromium-driver; \
	  else \
	    echo "make test-browser needs Chromium and ChromeDriver: sudo apt-get install chromium chromium-driver"; exit 1; \
	  fi; \
	fi
	PV_AMBIENT_BROWSER_OUT=$(CURDIR)/build/test-browser $(PY) -m pytest -q -m browser tests/browser

bench: $(STAMP)
	$(VENV)/bin/pv-ambient bench trade

DOCS_STAMP := $(VENV)/.installed-docs

$(DOCS_STAMP): $(STAMP)
	$(PY) -m pip install -e ".[docs]"
	touch $(DOCS_STAMP)

# The documentation in one build (docs/ → build/docs): the project's pages, the API reference
# (autodoc) and the example gallery (sphinx-gallery + PyVista's scraper runs every examples/ script);
# PV_AMBIENT_EXAMPLES_FAST=1 make docs builds the gallery's small, fast variant.
docs: $(DOCS_STAMP)
	$(PY) -m sphinx -b html -d build/docs/.doctrees docs build/docs
	@echo "docs: $(CURDIR)/build/docs/index.html"

# the former name of the target (the gallery is part of the docs build)
gallery: docs

# A NON-editable install (pip install .) into a fresh venv, then a smoke run from outside the checkout:
# every model, the accessor entry point, the scene CLI (an editable install would hide a missing sub-package
# or data file).
INSTALL_CHECK := build/install-check
install-check:
	rm -rf $(INSTALL_CHECK)
	$(PYTHON) -m venv $(INSTALL_CHECK)
	$(INSTALL_CHECK)/bin/python -m pip install -q --upgrade pip
	$(INSTALL_CHECK)/bin/python -m pip install -q .
	cp tests/_install_smoke.py $(INSTALL_CHECK)/install_smoke.py  # run from outside tests/: its folders (tests/pyvista) would shadow packages
	cd $(INSTALL_CHECK) && NUMBA_CACHE_DIR=$(CURDIR)/$(INSTALL_CHECK)/numba_cache bin/python install_smoke.py

# The CUDA kernels' registers, spills and compile times, no GPU needed (benchmarks/gpu_kernels.py), in a venv
# of its own (.venv-cuda: the cuda-dev extra's numba-cuda, NVVM and ptxas; .venv, the test suite's, stays
# without them). Writes benchmarks/results/gpu_kernels.txt.
CUDA_VENV := .venv-cuda
CUDA_STAMP := $(CUDA_VENV)/.installed

$(CUDA_STAMP): pyproject.toml
	$(PYTHON) -m venv $(CUDA_VENV)
	$(CUDA_VENV)/bin/python -m pip install -q --upgrade pip
	$(CUDA_VENV)/bin/python -m pip install -e ".[cuda-dev]"
	touch $(CUDA_STAMP)

gpu-kernels: $(CUDA_STAMP)
	$(CUDA_VENV)/bin/python benchmarks/gpu_kernels.py

clean:
	rm -rf $(VENV) $(CUDA_VENV) .numba_cache demo_output build *.egg-info docs/auto_examples docs/sg_execution_times.rst
