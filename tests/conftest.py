"""Shared pytest set-up: headless VTK, deterministic seeds."""
import os

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
os.environ.setdefault("MPLBACKEND", "Agg")
# Preintegrated table slices computed by the tests are cached inside the checkout (ignored by
# git), never in the user's cache directory.
os.environ.setdefault("PV_AMBIENT_CACHE", os.path.join(os.path.dirname(os.path.dirname(__file__)), ".cache", "tables"))
# OpenMP worker threads that spin while waiting slow the light-volume sweeps (one parallel region
# per layer) badly when the 2 CI cores are shared; passive waiting costs nothing measurable here.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
