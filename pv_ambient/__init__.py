"""pv_ambient: ambient volume scattering for PyVista image data.

The array core (``render`` on :class:`~pv_ambient.inputs.grid.Volume`, kernels, tables, light volumes)
imports without pyvista or vtk; the PyVista accessor ``grid.ambient`` is registered through the
``pyvista.accessors`` entry point (and here, when pyvista is importable).
"""

__version__ = "0.4.0"

from ._kernels.cpu_features import apply_load_policy

apply_load_policy()  # before Numba is imported: it reads the CPU's features once (docs/performance.rst)

from .inputs.camera import Camera, orbit  # noqa: E402
from .inputs.lights import DirectionalLight, PointLight  # noqa: E402
from .rendering.renderer import Renderer, render  # noqa: E402
from .rendering.result import RenderResult  # noqa: E402
from .inputs.transfer import TransferFunction  # noqa: E402
from .series import render_series  # noqa: E402

__all__ = ["Camera", "DirectionalLight", "PointLight", "Renderer", "RenderResult", "TransferFunction", "orbit", "render",
           "render_series"]

try:  # the pyvista layer is optional for the array core
    from .pyvista import add_ambient_volume, compare  # also registers grid.ambient
except ImportError:  # pragma: no cover - exercised by the no-pyvista test
    pass
else:
    __all__ += ["add_ambient_volume", "compare"]
