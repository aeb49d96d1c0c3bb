# pv_ambient — the two commands of the README's quick start: `make demo` and `make test`.
# Each creates .venv if it is missing and installs the package with its extras first (test, and mri:
# nilearn, whose wheel holds the MNI152 template of the MRI gallery example; every example runs in make test).
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
export PYVISTA_OFF_SCREEN := true
export VTK_DEFAULT_OPENGL_WINDOW := vtkEGLRenderWindow
export NUMBA_CACHE_DIR := $(CURDIR)/.numba_cache
export MPLBACKEND := Agg

.PHONY: demo test install clean bench gallery

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --upgrade pip

$(STAMP): $(PY) pyproject.toml
	$(PY) -m pip install -e ".[test,mri]"
	touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/pv-ambient demo -o demo_output

test: $(STAMP)
	$(PY) -m pytest -q

bench: $(STAMP)
	$(VENV)/bin/pv-ambient bench trade

DOCS_STAMP := $(VENV)/.installed-docs

$(DOCS_STAMP): $(STAMP)
	$(PY) -m pip install -e ".[docs]"
	touch $(DOCS_STAMP)

# The example gallery (sphinx-gallery + PyVista's scraper) from examples/_sphinx into build/gallery;
# PV_AMBIENT_EXAMPLES_FAST=1 make gallery builds the small, fast variant.
gallery: $(DOCS_STAMP)
	$(PY) -m sphinx -b html -d build/gallery/.doctrees examples/_sphinx build/gallery
	@echo "gallery: $(CURDIR)/build/gallery/index.html"

clean:
	rm -rf $(VENV) .numba_cache demo_output build *.egg-info
