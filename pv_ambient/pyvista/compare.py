"""Pictures side by side: labelled panels of renders saved as one screenshot
(:func:`show_panels`) and VTK's own volume rendering next to pv_ambient's models
(:func:`compare`).
"""

from __future__ import annotations

from collections.abc import Mapping

import pyvista as pv

from ..inputs.camera import as_camera
from ..inputs.transfer import as_transfer_function
from ..inputs.validation import check_int, check_window_size
from ..rendering.presets import MODEL_TABLE
from ..rendering.renderer import Renderer
from .plane import add_result_plane
from .vtk_bridge import add_vtk_volume


MODEL_TITLES = {m.name: f"pv_ambient: {m.title}" for m in MODEL_TABLE if m.name != "auto"}


def show_panels(results, labels, path, *, display=None, font_size=12, off_screen=True):
    """Save renders side by side in one row, each labelled in its top-left corner.

    Each result becomes a textured plane (:func:`add_result_plane`) in its own subplot, exactly
    its ``window_size`` in pixels; the picture is saved with ``Plotter.show(screenshot=path)``.

    Parameters
    ----------
    results : sequence of RenderResult
        One panel each, left to right. All must have the same height; widths may differ.
    labels : sequence of str
        One label per result, drawn in white at the top left of its panel.
    path : str or path-like
        Where the screenshot (PNG) is written.
    display : dict or sequence of dict, optional
        Display conversion (``exposure``, ``tonemap``, ``srgb``, as :meth:`RenderResult.to_uint8`):
        one dict for every panel, or one per panel. None: each result's default (the lit
        models at ``exposure="auto"``, emission–absorption as VTK shows it: docs/display.rst).
    font_size : int, default: 12
        Label font size; labels sit ``2 * font_size`` pixels below the top of their panel.
    off_screen : bool, optional, default: True
        Passed to ``pyvista.Plotter`` (PyVista's global setting when None).

    Returns
    -------
    (int, int)
        ``(width, height)`` of the saved picture, in pixels.

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> import pyvista as pv
    >>> from pv_ambient.pyvista import show_panels
    >>> grid = pv.ImageData(dimensions=(8, 8, 8))
    >>> grid["density"] = np.linspace(0, 1, grid.n_points)
    >>> res = grid.ambient.render(window_size=(32, 24))
    >>> path = os.path.join(tempfile.mkdtemp(), "panels.png")
    >>> show_panels([res, res], ["clip", "+1 stop"], path, display=[{}, {"exposure": 1.0}], font_size=6)
    (64, 24)
    >>> os.path.isfile(path)
    True
    """
    results = list(results)
    labels = [str(label) for label in labels]
    if not results:
        raise ValueError("show_panels needs at least one result")
    if len(labels) != len(results):
        raise ValueError(f"{len(labels)} labels for {len(results)} results")
    if display is None or isinstance(display, Mapping):
        displays = [display or {}] * len(results)
    else:
        displays = [d or {} for d in display]
        if len(displays) != len(results):
            raise ValueError(f"{len(displays)} display dicts for {len(results)} results")
    font_size = check_int(font_size, "font_size", lo=1)
    sizes = [res.window_size for res in results]
    height = sizes[0][1]
    if any(h != height for _, h in sizes):
        raise ValueError(f"the panels of one row need one height, got window sizes {sizes}")
    widths = [w for w, _ in sizes]
    pl = pv.Plotter(shape=(1, len(results)), window_size=(sum(widths), height), border=False,
                    col_weights=widths, off_screen=off_screen)
    for k, (res, label, disp) in enumerate(zip(results, labels, displays)):
        pl.subplot(0, k)
        add_result_plane(pl, res, **disp)
        pl.add_text(label, position=(4, height - 2 * font_size), font_size=font_size, color="white")
    size = tuple(int(v) for v in pl.window_size)
    pl.show(screenshot=str(path))
    return size


def compare(grid, transfer_function=None, *, camera=None, models=("emission_absorption",), window_size=(400, 400),
            lights=None, scalars=None, mapper="gpu", step=None, titles=True, display=None, renderer=None,
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
    lights : sequence, optional
        As :func:`pv_ambient.render` (not given: the default light rig for the lit models).
    window_size : (int, int)
        Size of *each* panel.
    mapper : {"gpu", "fixed_point", "smart"}, default: "gpu"
        VTK's mapper for the first panel.
    titles : bool, default: True
        Label each panel.
    display : dict, optional
        Display conversion of our panels (``exposure``, ``tonemap``, ``srgb``), for all panels,
        or per model: ``{"ambient_scattering": {"exposure": 2.0}}``; each result's default when
        None (``exposure="auto"`` for the lit models, VTK's convention for emission–absorption).
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
