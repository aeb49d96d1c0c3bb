"""Minimal Sphinx project that builds the example gallery: ``make gallery`` → ``build/gallery``.

sphinx-gallery runs every ``examples/<section>/*.py`` (each section folder has a ``README.txt``)
and PyVista's scraper captures the plotters each script shows (matplotlib's, its figures). The
scripts also save their own pictures, to ``PV_AMBIENT_EXAMPLES_OUT`` (here ``build/gallery_images``
unless set). ``PV_AMBIENT_EXAMPLES_FAST=1 make gallery`` builds the small, fast variant.
"""

import os
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
os.environ.setdefault("PYVISTA_BUILDING_GALLERY", "true")
os.environ.setdefault("MPLBACKEND", "Agg")
# sphinx-gallery runs each script in its own folder: keep their own PNGs out of the source tree
Path(os.environ.setdefault("PV_AMBIENT_EXAMPLES_OUT", str(ROOT / "build" / "gallery_images"))).mkdir(
    parents=True, exist_ok=True)

import pyvista  # noqa: E402

pyvista.BUILDING_GALLERY = True
pyvista.OFF_SCREEN = True

project = "pv_ambient"
author = "pv_ambient contributors"
extensions = ["sphinx_gallery.gen_gallery"]
html_theme = "alabaster"
html_title = "pv_ambient gallery"
exclude_patterns = ["_build"]

sphinx_gallery_conf = {
    "examples_dirs": str(HERE.parent),  # examples/: its README.txt and one folder per section
    "gallery_dirs": "auto_examples",    # generated here, inside this Sphinx source folder (git-ignored)
    "filename_pattern": r"\.py$",       # execute every example, not only plot_*.py
    "ignore_pattern": r"(__init__|conf)\.py$",
    "image_scrapers": ("pyvista", "matplotlib"),
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
}
