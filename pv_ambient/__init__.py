"""pv_ambient: ambient volume scattering for PyVista image data.

The array core (``render`` on :class:`~pv_ambient._grid.Volume`, kernels, tables, light volumes)
imports without pyvista or vtk; the PyVista accessor ``grid.ambient`` is registered through the
``pyvista.accessors`` entry point (and here, when pyvista is importable).
"""

__version__ = "0.2.0"

from .camera import Camera
from .lights import DirectionalLight, PointLight
from .render import Renderer, render
from .result import RenderResult
from .transfer import TransferFunction

__all__ = ["Camera", "DirectionalLight", "PointLight", "Renderer", "RenderResult", "TransferFunction", "render"]

try:  # the pyvista layer is optional for the array core
    from .pyvista_ext import add_ambient_volume, compare  # also registers grid.ambient
except ImportError:  # pragma: no cover - exercised by the no-pyvista test
    pass
else:
    __all__ += ["add_ambient_volume", "compare"]
