"""A render shown in a plotter: the pixel-exact textured plane of :meth:`RenderResult.to_plane`
added to a plotter (:func:`add_result_plane`), and its texture's image written in place and read
back.
"""

from __future__ import annotations

import numpy as np
import pyvista as pv


def add_result_plane(plotter, result, *, name=None, **display):
    """Add ``result.to_plane()`` to the active renderer, unlit, with its texture, and put the
    result's camera on that renderer. Returns the actor."""
    plane = result.to_plane(**display)
    actor = plotter.add_mesh(plane, texture=plane.ambient_texture, lighting=False, name=name,
                             reset_camera=False, show_scalar_bar=False)
    result.camera.to_vtk(plotter.camera)
    plotter.renderer.ResetCameraClippingRange()
    return actor


def write_texture(texture, image):
    """Replace a ``vtkTexture``'s image by ``image`` ((H, W, C) uint8, top row first) in place."""
    from vtkmodules.util.numpy_support import vtk_to_numpy

    h, w, c = image.shape
    data = texture.GetInput()
    scalars = None if data is None else data.GetPointData().GetScalars()
    flat = np.ascontiguousarray(image[::-1]).reshape(-1, c)  # VTK images are bottom row first
    if (scalars is not None and tuple(data.GetDimensions()) == (w, h, 1)
            and scalars.GetNumberOfComponents() == c and scalars.GetDataType() == 3):  # VTK_UNSIGNED_CHAR
        vtk_to_numpy(scalars).reshape(-1, c)[:] = flat
        scalars.Modified()
        data.Modified()
    else:
        img = pv.ImageData(dimensions=(w, h, 1))
        img.point_data["Image"] = flat
        img.set_active_scalars("Image")
        texture.SetInputDataObject(img)
    texture.Modified()


def texture_image(texture):
    """The ``(H, W, C)`` uint8 image a ``vtkTexture`` holds, top row first (as screenshots).

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> from pv_ambient.pyvista.plane import texture_image
    >>> img = np.arange(24, dtype=np.uint8).reshape(2, 4, 3)
    >>> bool((texture_image(pv.Texture(img)) == img).all())
    True
    """
    from vtkmodules.util.numpy_support import vtk_to_numpy

    data = texture.GetInput()
    w, h, _ = data.GetDimensions()
    scalars = data.GetPointData().GetScalars()
    return vtk_to_numpy(scalars).reshape(h, w, scalars.GetNumberOfComponents())[::-1].copy()
