"""The VTK transfer-function bridge: VTK's own volume mapper with *our* classification.

:func:`optics_volume_property` turns pv_ambient's optics into a ``vtkVolumeProperty`` that
classifies exactly like them; :func:`add_vtk_volume` adds a grid to a plotter with VTK's mapper,
that property, linear interpolation and a matched sample distance — the reference panel of
:func:`pv_ambient.compare` and of the VTK agreement tests and benchmarks.
"""

from __future__ import annotations

import numpy as np

from ..inputs.transfer import MODE_GRID
from ..inputs.validation import check_choice
from ..rendering.renderer import Renderer


def optics_volume_property(optics, unit_distance=1.0):
    """A ``vtkVolumeProperty`` that classifies exactly like ``optics`` (emission–absorption).

    Opacity for a slab ``unit_distance`` thick is ``1 − exp(−σt·unit_distance)``, colour is
    the TF colour; both use every table entry as a node, with linear interpolation. A physical
    TF (σt given per voxel) maps the σt scalar through the identity with a white colour.
    """
    from vtkmodules.vtkCommonDataModel import vtkPiecewiseFunction
    from vtkmodules.vtkRenderingCore import vtkColorTransferFunction, vtkVolumeProperty

    ctf = vtkColorTransferFunction()
    otf = vtkPiecewiseFunction()
    if optics.mode == MODE_GRID:
        smax = max(float(optics.sigma_max), 1e-12)
        values = np.linspace(0.0, smax, 1024)
        sig = values
        col = np.ones((values.size, 3))
    else:
        n = optics.table.shape[0]
        values = optics.lut_lo + np.arange(n) / (optics.lut_inv if optics.lut_inv > 0 else 1.0)
        sig = optics.table[:, 0].astype(np.float64)
        col = optics.table[:, 7:10].astype(np.float64)
    alpha = -np.expm1(-sig * unit_distance)
    for v, a, c in zip(values, alpha, col):
        ctf.AddRGBPoint(float(v), *(float(x) for x in c))
        otf.AddPoint(float(v), float(a))
    prop = vtkVolumeProperty()
    prop.SetColor(ctf)
    prop.SetScalarOpacity(otf)
    prop.SetScalarOpacityUnitDistance(unit_distance)
    prop.SetInterpolationTypeToLinear()
    prop.ShadeOff()
    return prop


def add_vtk_volume(plotter, grid, renderer: Renderer, *, step, mapper="gpu", scalars=None):
    """Add ``grid`` with VTK's own mapper and *our* classification, linear interpolation and a
    matched sample distance (PyVista's defaults are nearest and 1.0). Returns the actor."""
    check_choice(mapper, "mapper", ("gpu", "fixed_point", "smart"))
    optics = renderer.optics
    if optics.mode == MODE_GRID:
        tf = renderer.transfer_function
        scalars = tf.physical_arrays[0] if tf.kind == "physical" else None
        if scalars is None:
            raise ValueError("the VTK panel needs a scalar array; a baked (nan_policy='vacuum') TF has none")
    image = grid
    if scalars is None:
        scalars = renderer.volume.active
    actor = plotter.add_volume(image, scalars=scalars, mapper=mapper, show_scalar_bar=False,
                               preference=renderer.volume.association)
    actor.SetProperty(optics_volume_property(optics, unit_distance=float(step)))
    m = actor.mapper
    m.SetAutoAdjustSampleDistances(False)
    m.SetSampleDistance(float(step))
    if mapper == "fixed_point":
        m.SetInteractiveSampleDistance(float(step))
        m.SetImageSampleDistance(1.0)
        m.SetMinimumImageSampleDistance(1.0)
        m.SetMaximumImageSampleDistance(1.0)
    elif hasattr(m, "SetLockSampleDistanceToInputSpacing"):
        m.SetLockSampleDistanceToInputSpacing(False)
    return actor
