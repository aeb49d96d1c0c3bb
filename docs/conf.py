"""Sphinx configuration of pv_ambient's documentation: ``make docs`` → ``build/docs``.

One build makes three things:

* the project's own pages (``docs/*.rst``: conventions, models, the method, architecture);
* the API reference (``api.rst``, autodoc + autosummary over the public names; NumPy-style
  docstrings through napoleon);
* the example gallery: sphinx-gallery runs every ``examples/<section>/*.py`` (each section folder
  has a ``README.txt``) and PyVista's scraper captures the plotters each script shows
  (matplotlib's, its figures). The scripts also save their own pictures, to
  ``PV_AMBIENT_EXAMPLES_OUT`` (here ``build/gallery_images`` unless set).

``PV_AMBIENT_EXAMPLES_FAST=1 make docs`` builds the gallery's small, fast variant.
"""

import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))  # the package from this checkout, installed or not

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
os.environ.setdefault("PYVISTA_BUILDING_GALLERY", "true")
os.environ.setdefault("MPLBACKEND", "Agg")
# sphinx-gallery runs each script in its own folder: keep their own PNGs out of the source tree
Path(os.environ.setdefault("PV_AMBIENT_EXAMPLES_OUT", str(ROOT / "build" / "gallery_images"))).mkdir(
    parents=True, exist_ok=True)

import pyvista  # noqa: E402

import pv_ambient  # noqa: E402

pyvista.BUILDING_GALLERY = True
pyvista.OFF_SCREEN = True

project = "pv_ambient"
author = "pv_ambient contributors"
release = version = pv_ambient.__version__
extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx_gallery.gen_gallery",
]
html_theme = "alabaster"
html_title = f"pv_ambient {release}"
exclude_patterns = ["_build", "_citations.txt", "auto_examples/*.ipynb"]
default_role = "code"

# API reference: members in source order, type hints in the description, no stub files
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"members": True, "show-inheritance": False}
autosummary_generate = False
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_rtype = False
napoleon_use_ivar = True  # "Attributes" sections as fields: no duplicate of the documented properties

sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples"),  # examples/: its README.txt and one folder per section
    "gallery_dirs": "auto_examples",          # generated inside docs/ (git-ignored)
    "filename_pattern": r"\.py$",             # execute every example, not only plot_*.py
    "ignore_pattern": r"(__init__|conf)\.py$",
    "image_scrapers": ("pyvista", "matplotlib"),
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
}
