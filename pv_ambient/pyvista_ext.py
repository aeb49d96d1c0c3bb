"""PyVista integration: the ``grid.ambient`` accessor, textured planes in plotters, and the
side-by-side comparison with VTK's own volume rendering.

This is the only module that imports ``pyvista.plotting``. It is the target of the
``pyvista.accessors`` entry point, so ``grid.ambient`` works without importing pv_ambient.
"""

from __future__ import annotations

import numpy as np
import pyvista as pv

from ._validation import check_choice, check_window_size
from .camera import as_camera
from .render import Renderer
from .transfer import MODE_GRID, as_transfer_function

MODEL_TITLES = {
    "emission_absorption": "pv_ambient: emission-absorption",
    "ambient_occlusion": "pv_ambient: ambient occlusion",
    "single_scattering": "pv_ambient: single scattering",
    "ambient_scattering": "pv_ambient: ambient scattering",
    "diffusion": "pv_ambient: diffusion",
    "path_traced": "pv_ambient: path traced",
}


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
        scalars = renderer.transfer_function._physical[0] if renderer.transfer_function.kind == "physical" else None
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


def add_result_plane(plotter, result, *, name=None, **display):
    """Add ``result.to_plane()`` to the active renderer, unlit, with its texture, and put the
    result's camera on that renderer. Returns the actor."""
    plane = result.to_plane(**display)
    actor = plotter.add_mesh(plane, texture=plane.ambient_texture, lighting=False, name=name,
                             reset_camera=False, show_scalar_bar=False)
    result.camera.to_vtk(plotter.camera)
    plotter.renderer.ResetCameraClippingRange()
    return actor


def add_ambient_volume(plotter, grid, *, model="emission_absorption", transfer_function=None, lights=(),
                       scalars=None, display=None, **render_options):
    """Render ``grid`` with the plotter's camera and window size and add it as a textured plane.

    In a plotter with subplots the active subplot's camera and size (its share of the window)
    are used; ``window_size=`` overrides the size.

    Parameters
    ----------
    plotter : pyvista.Plotter
    grid : pyvista.ImageData
    model, transfer_function, lights, scalars
        As :func:`pv_ambient.render`.
    display : dict, optional
        Keywords for :meth:`RenderResult.to_uint8` (exposure, tonemap, srgb).
    **render_options
        As :meth:`pv_ambient.Renderer.render`.

    Returns
    -------
    tuple of (pyvista.Actor, RenderResult)

    Examples
    --------
    >>> import pyvista as pv
    >>> import pv_ambient
    >>> from pv_ambient import datasets
    >>> grid = datasets.cloud(n=24)
    >>> pl = pv.Plotter(off_screen=True, window_size=(64, 48))
    >>> actor, res = pv_ambient.add_ambient_volume(pl, grid)
    >>> res.window_size
    (64, 48)
    """
    r = Renderer(grid, transfer_function=transfer_function, scalars=scalars, lights=lights)
    if not plotter.camera_set:
        plotter.renderer.reset_camera(bounds=r.bounds)
        plotter.camera_position = "iso"
        plotter.renderer.reset_camera(bounds=r.bounds)
        plotter.camera_set = True
    cam, size = as_camera(plotter, window_size=render_options.pop("window_size", None), bounds=r.bounds)
    res = r.render(camera=cam, window_size=size, model=model, **render_options)
    actor = add_result_plane(plotter, res, **(display or {}))
    return actor, res


def compare(grid, transfer_function=None, *, camera=None, models=("emission_absorption",), window_size=(400, 400),
            lights=(), scalars=None, mapper="gpu", step=None, titles=True, display=None, renderer=None,
            off_screen=None, **render_options):
    """Side by side: VTK's ``add_volume`` with the same TF, then our render(s), one per subplot.

    The VTK panel uses our classification (same colours and opacities), linear interpolation
    and the same sample distance as our ray marcher. Our images are pixel-exact textured planes.

    Parameters
    ----------
    grid : pyvista.ImageData
    transfer_function : TransferFunction, dict, vtkVolumeProperty or actor, optional
    camera : optional
        Any camera :func:`pv_ambient.render` accepts; PyVista's default view when None.
    models : sequence of str
        Our models, one panel each.
    window_size : (int, int)
        Size of *each* panel.
    mapper : {"gpu", "fixed_point", "smart"}, default: "gpu"
        VTK's mapper for the first panel.
    titles : bool, default: True
        Label each panel.
    display : dict, optional
        Display conversion of our panels (``exposure``, ``tonemap``, ``srgb``), for all panels,
        or per model: ``{"ambient_scattering": {"exposure": 2.0}}``.
    off_screen : bool, optional
        Passed to ``pyvista.Plotter`` (PyVista's global setting when None).

    Returns
    -------
    pyvista.Plotter
        Off-screen when PyVista is (``pv.OFF_SCREEN``); call ``.screenshot(path)`` or ``.show()``.
        The plotter's ``results`` attribute maps each model to its :class:`RenderResult`.

    Examples
    --------
    >>> import pv_ambient
    >>> from pv_ambient import datasets
    >>> pl = pv_ambient.compare(datasets.supernova(n=24), window_size=(64, 64))
    >>> pl.shape
    (1, 2)
    """
    w, h = check_window_size(window_size)
    models = tuple(models)
    r = renderer or Renderer(grid, transfer_function=as_transfer_function(transfer_function), scalars=scalars,
                             lights=lights)
    cam, _ = as_camera(camera, window_size=(w, h), bounds=r.bounds)
    step = r.default_step() if step is None else float(step)
    pl = pv.Plotter(shape=(1, 1 + len(models)), window_size=(w * (1 + len(models)), h), border=False,
                    off_screen=off_screen)
    pl.set_background("black")
    pl.subplot(0, 0)
    add_vtk_volume(pl, grid, r, step=step, mapper=mapper)
    cam.to_vtk(pl.camera)
    pl.renderer.ResetCameraClippingRange()
    pl.camera_set = True
    if titles:
        pl.add_text(f"VTK add_volume ({mapper})", font_size=9, color="white")
    pv.set_new_attribute(pl, "results", {})
    for k, model in enumerate(models, start=1):
        pl.subplot(0, k)
        res = r.render(camera=cam, window_size=(w, h), model=model, step=step, **render_options)
        pl.results[model] = res
        disp = display or {}
        if any(k in MODEL_TITLES for k in disp):
            disp = disp.get(model, {})
        add_result_plane(pl, res, **disp)
        pl.camera_set = True
        if titles:
            pl.add_text(MODEL_TITLES.get(model, model), font_size=9, color="white")
    return pl


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
        from .render import render

        return render(self._grid, **kwargs)

    def plane(self, **kwargs):
        """Render and return the textured plane (:meth:`RenderResult.to_plane`)."""
        display = kwargs.pop("display", None) or {}
        return self.render(**kwargs).to_plane(**display)

    def compare(self, **kwargs):
        """:func:`pv_ambient.compare` on this grid."""
        return compare(self._grid, **kwargs)
