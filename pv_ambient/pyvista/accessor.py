"""``grid.ambient``: the ``pyvista.ImageData`` accessor.

This module is the target of the ``pyvista.accessors`` entry point, so ``grid.ambient`` works
without importing pv_ambient; importing it registers the accessor.
"""

from __future__ import annotations

import pyvista as pv

from .compare import compare


@pv.register_dataset_accessor("ambient", pv.ImageData)
class AmbientAccessor:
    """``grid.ambient``: pv_ambient's filters on a ``pyvista.ImageData``.

    Examples
    --------
    >>> import pyvista as pv
    >>> import numpy as np
    >>> grid = pv.ImageData(dimensions=(8, 8, 8))
    >>> grid["density"] = np.linspace(0, 1, grid.n_points)
    >>> res = grid.ambient.render(window_size=(16, 16))
    >>> res.radiance.shape
    (16, 16, 3)
    """

    def __init__(self, dataset):
        self._grid = dataset

    def render(self, **kwargs):
        """:func:`pv_ambient.render` on this grid (keyword-only options)."""
        from ..rendering.renderer import render

        return render(self._grid, **kwargs)

    def plane(self, **kwargs):
        """Render and return the textured plane (:meth:`RenderResult.to_plane`)."""
        display = kwargs.pop("display", None) or {}
        return self.render(**kwargs).to_plane(**display)

    def compare(self, **kwargs):
        """:func:`pv_ambient.compare` on this grid."""
        return compare(self._grid, **kwargs)
