"""The face inside PyVista: ``grid.ambient``, :func:`add_ambient_volume` and its interactive
:class:`AmbientVolume`, :func:`compare`, side-by-side panels and depth compositing with meshes.

The only part of pv_ambient that imports ``pyvista.plotting``. One concept a module:

* :mod:`.accessor` — ``grid.ambient`` (the target of the ``pyvista.accessors`` entry point)
* :mod:`.plotter` — :func:`add_ambient_volume` and :class:`AmbientVolume`
* :mod:`.drag` — the ray step of an interactive drag
* :mod:`.jupyter` — the volumes in PyVista's Jupyter (trame) views: ``show``, ``ambient_ui``
* :mod:`.compare` — :func:`show_panels` and :func:`compare` (VTK's volume beside ours)
* :mod:`.plane` — a render as a textured plane in a plotter (:func:`add_result_plane`)
* :mod:`.geometry` — the opaque-mesh pass, depth → ray distance, compositing over meshes
* :mod:`.vtk_bridge` — our classification as a ``vtkVolumeProperty`` (:func:`add_vtk_volume`)
* :mod:`.display` — the display conversion and its inverse
* :mod:`.nifti` — a NIfTI image (nibabel, nilearn) as an ``ImageData`` placed by its affine
"""

from .accessor import AmbientAccessor
from .compare import compare, show_panels
from .display import display_to_linear
from .geometry import composite_over_geometry, ray_distance_from_depth
from .nifti import nifti_to_image_data
from .plane import add_result_plane, texture_image
from .plotter import AmbientVolume, add_ambient_volume
from .vtk_bridge import add_vtk_volume, optics_volume_property

__all__ = ["AmbientAccessor", "AmbientVolume", "add_ambient_volume", "add_result_plane", "add_vtk_volume", "compare",
           "composite_over_geometry", "display_to_linear", "nifti_to_image_data", "optics_volume_property",
           "ray_distance_from_depth", "show_panels", "texture_image"]
