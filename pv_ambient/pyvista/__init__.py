"""The face inside PyVista: ``grid.ambient``, :func:`add_ambient_volume` and its interactive
:class:`AmbientVolume`, :func:`compare`, side-by-side panels and depth compositing with meshes.

The only part of pv_ambient that imports ``pyvista.plotting``.
"""

from .plotter import (
    AmbientAccessor,
    AmbientVolume,
    add_ambient_volume,
    add_result_plane,
    add_vtk_volume,
    compare,
    show_panels,
)

__all__ = ["AmbientAccessor", "AmbientVolume", "add_ambient_volume", "add_result_plane", "add_vtk_volume", "compare",
           "show_panels"]
