"""PyVista integration: the ``grid.ambient`` accessor, textured planes in plotters, labelled
panels of renders saved side by side, and the side-by-side comparison with VTK's own volume
rendering.

This is the only module that imports ``pyvista.plotting``. It is the target of the
``pyvista.accessors`` entry point, so ``grid.ambient`` works without importing pv_ambient.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Mapping

import numpy as np
import pyvista as pv

from ..inputs.validation import check_choice, check_int, check_real, check_rgb, check_window_size
from ..inputs.camera import Camera, as_camera
from ..rendering.renderer import Renderer
from ..rendering.result import TONEMAPS, RenderResult, srgb_encode, tonemap_values
from ..inputs.transfer import MODE_GRID, as_transfer_function

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
        one dict for every panel, or one per panel. None: VTK's convention (no exposure, clipped).
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
    >>> from pv_ambient.pyvista.plotter import show_panels
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


#: Keywords of :meth:`RenderResult.to_uint8` that ``display=`` may hold.
DISPLAY_KEYS = ("exposure", "tonemap", "srgb")


def display_to_linear(values, *, exposure=0.0, tonemap="clip", srgb=False):
    """Invert :meth:`RenderResult.to_uint8`'s display conversion: display values → linear radiance.

    ``to_uint8(exposure, tonemap, srgb)`` applied to the returned radiance gives ``values`` back
    (to the uint8 rounding): the sRGB curve is decoded, the tone map inverted (``clip`` is the
    identity on [0, 1]; ``reinhard`` ``y/(1 − y)``, display 1 read as 1 − ¼/255; ``aces``
    numerically) and the exposure undone.

    Parameters
    ----------
    values : array_like
        Display values in [0, 1] (uint8 / 255).
    exposure, tonemap, srgb
        As :meth:`RenderResult.to_uint8`.

    Returns
    -------
    numpy.ndarray
        float64 linear radiance.

    Examples
    --------
    >>> from pv_ambient.pyvista.plotter import display_to_linear
    >>> display_to_linear([0.0, 0.5, 1.0]).tolist()
    [0.0, 0.5, 1.0]
    >>> round(float(display_to_linear(0.5, tonemap="reinhard", exposure=1.0)), 6)
    0.5
    """
    exposure = check_real(exposure, "exposure")
    check_choice(tonemap, "tonemap", TONEMAPS)
    x = np.clip(np.asarray(values, dtype=np.float64), 0.0, 1.0)
    if srgb:
        x = np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)
    if tonemap == "reinhard":
        x = np.minimum(x, 1.0 - 0.25 / 255.0)  # the map reaches 1 only at infinity
        x = x / (1.0 - x)
    elif tonemap == "aces":
        knots = np.concatenate([[0.0], np.geomspace(1e-7, 1e3, 8192)])
        y = tonemap_values(knots, "aces")
        top = int(np.argmax(y >= 1.0)) + 1 if (y >= 1.0).any() else y.size
        x = np.interp(x, y[:top], knots[:top])
    return x / 2.0 ** exposure


def _display_values(x, *, exposure=0.0, tonemap="clip", srgb=False):
    """:meth:`RenderResult.to_uint8`'s conversion without the rounding: linear → display [0, 1]."""
    x = tonemap_values(np.asarray(x, dtype=np.float64) * 2.0 ** check_real(exposure, "exposure"), tonemap)
    return srgb_encode(x) if srgb else x


def composite_over_geometry(volume, colour, coverage, *, background=(0.0, 0.0, 0.0), display=None):
    """Composite a volume render that stopped at opaque geometry over that geometry's picture.

    The composite is formed in display space, as VTK's frame buffer does::

        shown = D(L + T·(1 − c)·bg) + T·G

    ``L`` the volume's radiance in front of the geometry (rendered over black with
    ``ray_end``), ``T = 1 − alpha``, ``c`` the geometry's coverage of the pixel, ``bg`` the
    background radiance, ``D`` the display conversion of :meth:`RenderResult.to_uint8`
    (``display``) and ``G`` the geometry's colour as VTK drew it (premultiplied by ``c``). Why
    display space: VTK writes a surface's shaded colour to the frame buffer as it is and blends
    the volume's colour over it, ``C_vol + (1 − α)·C_geom``; with the default display (VTK's
    convention, ``D`` the identity on [0, 1]) the formula above *is* that blend, so the picture
    matches VTK's own volume+geometry render. With an exposure, tone map or sRGB the display
    transform applies to the volume's radiance (and the background), never again to VTK's
    already displayed surface colours: a surface keeps its VTK colour where no volume covers
    it. (Compositing in linear radiance instead would need the surface's colour taken back
    through the inverse display transform, which sends a saturated channel of a tone-mapped
    display to near-infinite radiance that no volume in front can dim.)

    Parameters
    ----------
    volume : RenderResult
        The volume over a black background, rays ended at the geometry.
    colour : numpy.ndarray
        ``(H, W, 3)`` display values in [0, 1] of the geometry over a transparent black
        background, premultiplied by ``coverage`` (what an anti-aliased frame buffer holds).
    coverage : numpy.ndarray
        ``(H, W)`` fraction of each pixel the geometry covers (its frame-buffer alpha).
    background : RGB, default: (0, 0, 0)
        Linear radiance where there is no geometry.
    display : dict, optional
        The display conversion the picture is shown with (``exposure``, ``tonemap``, ``srgb``).

    Returns
    -------
    RenderResult
        ``radiance`` the linear values that display as ``shown`` (:func:`display_to_linear`;
        ``to_uint8(**display)`` gives the composite), ``alpha = 1 − T·(1 − c)``, the metadata
        of ``volume``.

    Examples
    --------
    >>> import numpy as np
    >>> from pv_ambient.rendering.result import RenderResult
    >>> from pv_ambient.pyvista.plotter import composite_over_geometry
    >>> vol = RenderResult(np.full((1, 2, 3), 0.25, np.float32), np.full((1, 2), 0.5, np.float32), None)
    >>> geometry = np.array([[[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]]])   # red surface | nothing
    >>> out = composite_over_geometry(vol, geometry, np.array([[1.0, 0.0]]), background=(0, 0, 1))
    >>> out.radiance[0].tolist(), out.alpha[0].tolist()
    ([[0.75, 0.25, 0.25], [0.25, 0.25, 0.75]], [1.0, 0.5])
    """
    display = dict(display or {})
    bg = check_rgb(background, "background")
    cov = np.clip(np.asarray(coverage, dtype=np.float64), 0.0, 1.0)[..., None]
    trans = 1.0 - volume.alpha.astype(np.float64)[..., None]
    base = volume.radiance.astype(np.float64) + trans * (1.0 - cov) * bg
    shown = np.clip(_display_values(base, **display) + trans * np.asarray(colour, dtype=np.float64), 0.0, 1.0)
    radiance = display_to_linear(shown, **display)
    alpha = 1.0 - trans[..., 0] * (1.0 - cov[..., 0])
    return RenderResult(radiance=radiance.astype(np.float32), alpha=alpha.astype(np.float32), camera=volume.camera,
                        metadata=dict(volume.metadata))


def ray_distance_from_depth(zbuffer, near, far, camera, window_size):
    """World distance along each pixel's camera ray from a VTK depth buffer.

    Parameters
    ----------
    zbuffer : numpy.ndarray
        ``(H, W)`` window depth in [0, 1], **top row first** (VTK reads bottom row first: flip
        it), 1 where nothing was drawn.
    near, far : float
        The clipping range the depth was rendered with.
    camera : pv_ambient.Camera
        The camera it was rendered with (our rays: :meth:`Camera.rays`).
    window_size : (int, int)

    Returns
    -------
    numpy.ndarray
        ``(H, W)`` float64 distances, ``inf`` where the depth is 1 — the ``ray_end`` of
        :meth:`pv_ambient.Renderer.render`.

    Notes
    -----
    A perspective depth is the distance along the *view axis*,
    ``d = 2nf / ((f + n) − (2z − 1)(f − n))``; our ``t`` is along the pixel's ray, so
    ``t = d / (ω · fwd)``. A parallel projection's depth is linear, ``d = n + z (f − n)``, and
    its rays run along the view axis from the camera plane, so ``t = d``.

    Examples
    --------
    >>> import numpy as np
    >>> from pv_ambient import Camera
    >>> from pv_ambient.pyvista.plotter import ray_distance_from_depth
    >>> cam = Camera((0, -4, 0), (0, 0, 0), (0, 0, 1))
    >>> near, far = 2.0, 6.0
    >>> [ray_distance_from_depth([[z]], near, far, cam, (1, 1)).item() for z in (0.0, 0.5, 1.0)]
    [2.0, 3.0, inf]
    """
    z = np.asarray(zbuffer, dtype=np.float64)
    near, far = float(near), float(far)
    hit = z < 1.0
    if camera.parallel_projection:
        t = near + z * (far - near)
    else:
        depth = 2.0 * near * far / ((far + near) - (2.0 * z - 1.0) * (far - near))
        _, dirs = camera.rays(window_size)
        t = depth / (dirs @ camera.basis()[0])
    return np.where(hit, np.maximum(t, 0.0), np.inf)


def _is_plane(actor):
    return bool(getattr(actor, "_pv_ambient_plane", False))


def _is_opaque_mesh(actor):
    """An actor drawn by a mapper with input data, fully opaque (our planes excluded)."""
    if _is_plane(actor) or not actor.IsA("vtkActor"):
        return False
    mapper = actor.GetMapper()
    if mapper is None or mapper.GetNumberOfInputPorts() < 1 or mapper.GetNumberOfInputConnections(0) < 1:
        return False
    prop = actor.GetProperty()
    return prop is not None and prop.GetOpacity() >= 1.0 and not actor.HasTranslucentPolygonalGeometry()


class _GeometryPass:
    """Draws a plotter renderer's opaque meshes in a private off-screen window: colour, coverage
    and depth for one camera.

    The meshes are shallow copies of the plotter's actors (the same property, transform and
    input data; their own mapper and texture, since OpenGL resources belong to one window),
    lit by the plotter renderer's own lights, with its two-sided lighting, ambient and FXAA
    settings and its window's multisampling — so a surface gets the colour the plotter would
    give it. Re-synchronised on every pass.
    """

    def __init__(self, multisamples=0):
        from vtkmodules.vtkRenderingCore import vtkRenderer, vtkRenderWindow

        self.window = vtkRenderWindow()
        self.window.SetOffScreenRendering(True)
        self.window.SetAlphaBitPlanes(True)
        self.multisamples = int(multisamples)
        self.renderer = vtkRenderer()
        self.renderer.SetBackground(0.0, 0.0, 0.0)
        self.renderer.SetBackgroundAlpha(0.0)
        self.renderer.SetAutomaticLightCreation(False)
        self.window.AddRenderer(self.renderer)
        self._copies = {}

    def _sync(self, source, entry):
        from vtkmodules.vtkRenderingCore import vtkTexture

        copy, mapper, texture = entry
        copy.ShallowCopy(source)  # property, transform, visibility, ... (and mapper/texture, replaced below)
        src_mapper = source.GetMapper()
        mapper.ShallowCopy(src_mapper)  # scalar colouring, lookup table, ...
        mapper.SetInputConnection(src_mapper.GetInputConnection(0, 0))
        copy.SetMapper(mapper)
        src_tex = source.GetTexture()
        if src_tex is not None and src_tex.GetNumberOfInputConnections(0) > 0:
            if texture is None:
                texture = vtkTexture()
            texture.SetInputConnection(src_tex.GetInputConnection(0, 0))
            for flag in ("Interpolate", "Repeat", "EdgeClamp", "Mipmap", "ColorMode", "UseSRGBColorSpace",
                         "PremultipliedAlpha"):
                getattr(texture, "Set" + flag)(getattr(src_tex, "Get" + flag)())
            copy.SetTexture(texture)
        copy.SetVisibility(True)
        return copy, mapper, texture

    def run(self, source_renderer, actors, camera, window_size):
        """Render ``actors`` with ``camera``; returns ``(rgba, z, (near, far))``, top row first:
        ``rgba`` (H, W, 4) float64 (colour premultiplied by coverage), ``z`` (H, W) float64."""
        from vtkmodules.util.numpy_support import vtk_to_numpy
        from vtkmodules.vtkCommonCore import vtkFloatArray
        from vtkmodules.vtkRenderingCore import vtkActor

        ren = self.renderer
        kept = {}
        for a in actors:
            key = id(a)
            old = self._copies.get(key)
            if old is not None and old[0] is a:
                entry = old[1]
            else:
                copy = vtkActor()
                entry = (copy, a.GetMapper().NewInstance(), None)
                ren.AddActor(copy)
            kept[key] = (a, self._sync(a, entry))
        for key, (a, entry) in self._copies.items():
            if key not in kept:
                ren.RemoveActor(entry[0])
        self._copies = kept
        ren.RemoveAllLights()
        lights = source_renderer.GetLights()
        lights.InitTraversal()
        for _ in range(lights.GetNumberOfItems()):
            ren.AddLight(lights.GetNextItem())
        ren.SetTwoSidedLighting(source_renderer.GetTwoSidedLighting())
        ren.SetLightFollowCamera(source_renderer.GetLightFollowCamera())
        ren.SetAmbient(source_renderer.GetAmbient())
        ren.SetUseFXAA(source_renderer.GetUseFXAA())
        camera.to_vtk(ren.GetActiveCamera())
        ren.ResetCameraClippingRange()
        w, h = window_size
        win = self.window
        win.SetSize(w, h)
        # Depth from a single-sample render: a multisampled depth buffer resolves to one sample
        # off the pixel centre (measured: a bias of 6e-4 world units on a tilted plane at
        # distance 4.5). Colour with the plotter's multisampling, as the plotter draws it.
        win.SetMultiSamples(0)
        win.Render()
        depth = vtkFloatArray()
        win.GetZbufferData(0, 0, w - 1, h - 1, depth)
        if self.multisamples > 0:
            win.SetMultiSamples(self.multisamples)
            win.Render()
        rgba = vtkFloatArray()
        win.GetRGBAPixelData(0, 0, w - 1, h - 1, 0, rgba)
        rgba = vtk_to_numpy(rgba).reshape(h, w, 4)[::-1].astype(np.float64)
        z = vtk_to_numpy(depth).reshape(h, w)[::-1].astype(np.float64)
        return rgba, z, ren.GetActiveCamera().GetClippingRange()

    def release(self):
        self.renderer.RemoveAllViewProps()
        self._copies = {}
        self.window.Finalize()


def _write_texture(texture, image):
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
    >>> from pv_ambient.pyvista.plotter import texture_image
    >>> img = np.arange(24, dtype=np.uint8).reshape(2, 4, 3)
    >>> bool((texture_image(pv.Texture(img)) == img).all())
    True
    """
    from vtkmodules.util.numpy_support import vtk_to_numpy

    data = texture.GetInput()
    w, h, _ = data.GetDimensions()
    scalars = data.GetPointData().GetScalars()
    return vtk_to_numpy(scalars).reshape(h, w, scalars.GetNumberOfComponents())[::-1].copy()


def _camera_key(cam):
    return (cam.position, cam.focal_point, cam.view_up, cam.view_angle, cam.parallel_projection, cam.parallel_scale)


class AmbientVolume:
    """A pv_ambient volume shown in a plotter: what :func:`add_ambient_volume` returns.

    Unpacks as ``actor, result = add_ambient_volume(...)`` (the form of earlier versions).

    Attributes
    ----------
    plotter : pyvista.Plotter
    vtk_renderer : vtkRenderer
        The plotter's renderer (subplot) the volume lives in.
    renderer : pv_ambient.Renderer
        The volume's renderer (its caches make a camera move re-run only the ray cast).
    actor : pyvista.Actor
        The textured plane showing the picture.
    result : RenderResult
        What the plane shows: the volume composited over the opaque geometry (the volume render
        itself when there is none).
    volume_result : RenderResult
        The volume alone: over black and ended at the geometry when there is geometry.
    ray_end : numpy.ndarray or None
        ``(H, W)`` world distance along each pixel's ray to the opaque geometry (``inf`` where
        none); None without geometry.
    geometry_image : numpy.ndarray or None
        ``(H, W, 4)`` the meshes' picture as drawn for the composite: display colour
        premultiplied by coverage, and coverage; None without geometry.
    occluders : list of pyvista.Actor
        The plotter's opaque meshes drawn into the picture; hidden in the plotter while the
        volume is shown (:meth:`remove` shows them again).
    observer : int or None
        The render window's ``StartEvent`` observer of interactive mode.
    renders : int
        How many pictures were rendered (first render, camera moves, refinements).
    error : Exception or None
        The last exception raised inside an interactive update (also issued as a warning).

    Examples
    --------
    >>> import pyvista as pv
    >>> import pv_ambient
    >>> from pv_ambient import datasets
    >>> pl = pv.Plotter(off_screen=True, window_size=(48, 32))
    >>> vol = pv_ambient.add_ambient_volume(pl, datasets.cloud(n=16), interactive=True)
    >>> vol
    AmbientVolume(model='emission_absorption', window_size=(48, 32), occluders=0, interactive=True)
    >>> vol.remove_observer()   # a still picture from now on
    >>> vol.observer is None
    True
    """

    def __init__(self, plotter, renderer, *, model="emission_absorption", display=None, options=None, occlusion=True,
                 window_size=None, interactive_samples=4, refine_interval=100, interactive=False):
        self.plotter = plotter
        self.vtk_renderer = plotter.renderer
        self.renderer = renderer
        self.model = model
        self.display = dict(display or {})
        self.options = dict(options or {})
        self.occlusion = bool(occlusion)
        self.window_size = window_size
        self.interactive_samples = interactive_samples
        self.refine_interval = refine_interval
        self.interactive = bool(interactive)
        self.actor = None
        self.result = None
        self.volume_result = None
        self.ray_end = None
        self.geometry_image = None
        self.occluders = []
        self.observer = None
        self.renders = 0
        self.error = None
        self._key = None
        self._pass = None
        self._timer = None
        self._sums = None

    def __iter__(self):
        yield self.actor
        yield self.result

    def __repr__(self):
        return (f"AmbientVolume(model={self.model!r}, window_size={self.result.window_size}, "
                f"occluders={len(self.occluders)}, interactive={self.observer is not None})")

    # -- the view and the scene ----------------------------------------------------------------
    def _view(self):
        ren = self.vtk_renderer
        cam = Camera.from_vtk(ren.GetActiveCamera())
        if self.window_size is not None:
            return cam, self.window_size
        x0, y0, x1, y1 = ren.GetViewport()
        w, h = self.plotter.window_size
        return cam, (max(1, int(round((x1 - x0) * w))), max(1, int(round((y1 - y0) * h))))

    def _scan(self):
        """The opaque meshes of the renderer (hiding newly added ones)."""
        if not self.occlusion:
            return []
        ren = self.vtk_renderer
        actors = ren.GetActors()
        actors.InitTraversal()
        hidden = {id(a) for a in self.occluders}
        found = []
        for _ in range(actors.GetNumberOfItems()):
            a = actors.GetNextActor()
            if a is None or not _is_opaque_mesh(a):
                continue
            if id(a) in hidden or a.GetVisibility():
                found.append(a)
        for a in found:
            a.SetVisibility(False)
        self.occluders = found
        return found

    def _state(self, cam, size):
        return (_camera_key(cam), tuple(size), tuple((id(a), a.GetRedrawMTime()) for a in self.occluders))

    # -- rendering -------------------------------------------------------------------------------
    def update(self, force=False):
        """Re-render if the camera, the viewport size or the opaque geometry changed since the last
        picture (always with ``force``); returns whether it rendered. Interactive mode calls it
        at the start of every frame."""
        cam, size = self._view()
        occluders = self._scan()
        state = self._state(cam, size)
        if not force and state == self._key:
            return False
        self._draw(cam, size, occluders)
        self._key = self._state(*self._view())  # after the plane set the camera (VTK normalises it)
        return True

    def _render_volume(self, cam, size, **extra):
        opts = dict(self.options)
        opts.update(extra)
        return self.renderer.render(camera=cam, window_size=size, model=self.model, **opts)

    def _draw(self, cam, size, occluders):
        t0 = time.perf_counter()
        ray_end = rgba = None
        if occluders:
            if self.model == "path_traced":
                raise ValueError("opaque geometry in the plotter cannot occlude a path_traced volume (ray_end is "
                                 "supported by the ray-cast models); use a ray-cast model or occlusion=False")
            if self._pass is None:
                self._pass = _GeometryPass(self.plotter.ren_win.GetMultiSamples())
            rgba, z, (near, far) = self._pass.run(self.vtk_renderer, occluders, cam, size)
            ray_end = ray_distance_from_depth(z, near, far, cam, size)
            t_geometry = time.perf_counter() - t0
            volume = self._render_volume(cam, size, background=(0.0, 0.0, 0.0), ray_end=ray_end)
            shown = composite_over_geometry(volume, rgba[..., :3], rgba[..., 3],
                                            background=self.options.get("background", (0.0, 0.0, 0.0)),
                                            display=self.display)
            shown.metadata.update(occluders=len(occluders), time_geometry=t_geometry)
        elif self.model == "path_traced" and self.interactive:
            shown = volume = self._first_pass(cam, size)
        else:
            shown = volume = self._render_volume(cam, size)
        self.volume_result, self.result, self.ray_end, self.geometry_image = volume, shown, ray_end, rgba
        self._show(shown)
        self.renders += 1

    def _show(self, result):
        if self.actor is None:
            actor = add_result_plane(self.plotter, result, **self.display)
            pv.set_new_attribute(actor, "_pv_ambient_plane", True)
            self.actor = actor
            return
        plane = result.to_plane(**self.display)
        data = pv.wrap(self.actor.GetMapper().GetInputDataObject(0, 0))
        data.points = plane.points
        _write_texture(self.actor.GetTexture(), result.to_uint8(**self.display))
        self.vtk_renderer.ResetCameraClippingRange()

    # -- path tracing: progressive refinement ----------------------------------------------------------
    def _first_pass(self, cam, size):
        self._sums = None
        return self._accumulate(cam, size)

    def _accumulate(self, cam, size):
        from ..stages.reference import _moments, relative_error

        k = 0 if self._sums is None else self._sums["passes"]
        done = 0 if self._sums is None else self._sums["n"]
        total = int(self.options.get("samples_per_pixel", 64))
        n = max(2, min(self.interactive_samples, total - done))
        res = self._render_volume(cam, size, samples_per_pixel=n, seed=int(self.options.get("seed", 0)) + k,
                                  target_error=None)
        mean = res.radiance.astype(np.float64)
        se = res.std_error.astype(np.float64)
        var_n = np.where(np.isfinite(se), se * se * n, 0.0)  # sample variance
        s1, s2, hit = n * mean, (n - 1) * var_n + n * mean * mean, n * res.alpha.astype(np.float64)
        if self._sums is None:
            self._sums = {"s1": s1, "s2": s2, "hit": hit, "n": n, "passes": 1, "camera": cam, "size": size}
        else:
            s = self._sums
            s["s1"] += s1
            s["s2"] += s2
            s["hit"] += hit
            s["n"] += n
            s["passes"] += 1
        s = self._sums
        if s["passes"] == 1:
            res.metadata["passes"] = 1
            return res
        mean, se = _moments(s["s1"], s["s2"], s["n"])
        alpha = s["hit"] / s["n"]
        meta = dict(res.metadata, spp=s["n"], passes=s["passes"], relative_error=relative_error(mean, se, alpha))
        return RenderResult(radiance=mean.astype(np.float32), alpha=alpha.astype(np.float32), camera=cam,
                            metadata=meta, std_error=se.astype(np.float32))

    def refine(self, render=True):
        """Path tracing in interactive mode: add ``interactive_samples`` samples per pixel (the
        next seed) to the picture of the current camera, averaged with the samples so far, until
        ``samples_per_pixel`` are reached (or the relative error ``target_error``). Returns
        whether it added samples; a no-op for the other models and outside interactive mode
        (where the one picture already has all its samples). ``render`` re-renders the plotter
        (only when samples were added). The interactive timer calls it; call it yourself where
        there is no event loop."""
        if self.model != "path_traced" or self._sums is None:
            return False
        s = self._sums
        target = self.options.get("target_error")
        if s["n"] >= int(self.options.get("samples_per_pixel", 64)):
            return False
        if target is not None and s["passes"] > 1 and self.result.metadata.get("relative_error", np.inf) <= target:
            return False
        res = self._accumulate(s["camera"], s["size"])
        self.volume_result = self.result = res
        self._show(res)
        self.renders += 1
        if render:
            self.plotter.render()
        return True

    # -- interactive mode ---------------------------------------------------------------------------
    def _on_start(self, obj=None, event=None):
        try:
            self.update()
            self._ensure_timer()
        except Exception as exc:  # an exception must not escape into VTK's render loop
            self.error = exc
            warnings.warn(f"pv_ambient: interactive update failed: {exc!r}", RuntimeWarning, stacklevel=2)

    def _on_timer(self, obj=None, event=None):
        try:
            self.refine()
        except Exception as exc:
            self.error = exc
            warnings.warn(f"pv_ambient: refinement failed: {exc!r}", RuntimeWarning, stacklevel=2)

    def _ensure_timer(self, interval_ms=None):
        """Path tracing in interactive mode: a repeating timer on the plotter's interactor that
        calls :meth:`refine` while the camera rests (its events arrive once the interactor's
        event loop runs, i.e. after ``show()``)."""
        if self.model != "path_traced" or self.observer is None or self._timer is not None:
            return
        iren = getattr(self.plotter, "iren", None)
        if iren is None or getattr(iren, "interactor", None) is None:
            return
        tid = iren.interactor.CreateRepeatingTimer(int(interval_ms or self.refine_interval))
        oid = iren.interactor.AddObserver("TimerEvent", self._on_timer)
        self._timer = (iren.interactor, tid, oid)

    def start(self):
        """Interactive mode: re-render whenever the plotter renders a frame whose camera (or
        viewport size, or opaque geometry) changed. Returns the observer id."""
        if self.observer is None:
            self.interactive = True
            self.observer = self.plotter.ren_win.AddObserver("StartEvent", self._on_start)
            if self.model == "path_traced" and self._sums is None:
                self.update(force=True)
            self._ensure_timer()
        return self.observer

    def remove_observer(self):
        """Leave interactive mode: remove the render-window observer (and the refinement timer).
        The picture stays as it is."""
        if self.observer is not None:
            if self.plotter.ren_win is not None:
                self.plotter.ren_win.RemoveObserver(self.observer)
            self.observer = None
        self.interactive = False
        if self._timer is not None:
            iren, tid, oid = self._timer
            iren.DestroyTimer(tid)
            iren.RemoveObserver(oid)
            self._timer = None

    def remove(self):
        """Remove the volume from the plotter: the observer, the plane, and show the hidden opaque
        meshes again."""
        self.remove_observer()
        if self.actor is not None:
            self.vtk_renderer.RemoveActor(self.actor)
            self.actor = None
        for a in self.occluders:
            a.SetVisibility(True)
        self.occluders = []
        if self._pass is not None:
            self._pass.release()
            self._pass = None


def add_ambient_volume(plotter, grid=None, *, model="emission_absorption", transfer_function=None, lights=(),
                       scalars=None, display=None, interactive=False, occlusion=True, renderer=None,
                       interactive_samples=4, refine_interval=100, **render_options):
    """Render ``grid`` with the plotter's camera and window size and show it in the plotter, in
    front of or behind the plotter's opaque meshes.

    The picture is a textured plane at the focal plane that fills the view (pixel-exact:
    a screenshot of the plotter shows the rendered pixels). In a plotter with subplots the
    active subplot's camera and size (its share of the window) are used; ``window_size=``
    overrides the size.

    **Opaque geometry.** When the renderer (subplot) holds opaque meshes — visible actors with
    a mapper, opacity 1 and no translucent colours or textures; our own planes excluded — at the
    time of the call (in interactive mode: at every update, so meshes added later join), they
    occlude the volume: the meshes are drawn with the same camera, lights and multisampling in
    a private off-screen window, each pixel's depth becomes the distance along its camera ray
    (:func:`ray_distance_from_depth`), the volume is ray cast up to that distance
    (``ray_end``, ray-cast models only) over black, and composited over the meshes' picture
    (:func:`composite_over_geometry`: ``L + T·G`` in display space, VTK's own frame-buffer
    blend; with ``display`` options the meshes keep their VTK colours). The plane
    then shows volume and meshes together, so the meshes themselves are hidden in the plotter
    (``occluders``; :meth:`AmbientVolume.remove` shows them again). The volume's ray ends
    exactly at the surface, where VTK's GPU mapper lets it run on for one to two sample steps
    (it takes ⌈M⌉ + 1 whole steps for a surface M steps away), so in front of a surface VTK's
    volume is slightly denser than ours at a coarse ``step``; the two agree as the step shrinks.
    Translucent actors and props that are not meshes (text, axes, scalar bars) are left to VTK:
    they are drawn over the plane, depth-tested against the focal plane. Image-based lighting,
    shadows, SSAO and other render passes of the plotter are not reproduced in the mesh pass.

    Parameters
    ----------
    plotter : pyvista.Plotter
    grid : pyvista.ImageData, optional
        The volume (never modified); may be omitted when ``renderer`` is given.
    model, transfer_function, lights, scalars
        As :func:`pv_ambient.render`.
    display : dict, optional
        Keywords for :meth:`RenderResult.to_uint8` (``exposure``, ``tonemap``, ``srgb``).
    interactive : bool, default: False
        Re-render whenever the plotter draws a frame whose camera, viewport size or opaque
        meshes changed since the last picture (an observer on the render window's
        ``StartEvent``; unchanged frames cost one comparison). The plane's texture is updated in
        place and the plane moved to the new focal plane. Stop it with
        :meth:`AmbientVolume.remove_observer` (or :meth:`AmbientVolume.remove`). With
        ``model="path_traced"`` a camera move renders ``interactive_samples`` samples per pixel,
        and while the camera rests a repeating timer on the plotter's interactor (once it is
        shown) adds as many again every ``refine_interval`` ms, averaging, up to
        ``samples_per_pixel`` (or ``target_error``); without an event loop (off-screen) call
        :meth:`AmbientVolume.refine` yourself.
    occlusion : bool, default: True
        Let the plotter's opaque meshes occlude the volume (above). False leaves them alone
        (the plane then hides whatever lies behind the focal plane).
    renderer : pv_ambient.Renderer, optional
        Render with this renderer (its volume, transfer function and lights, and its caches)
        instead of building one from ``grid``, ``transfer_function``, ``scalars``, ``lights``.
    interactive_samples : int, default: 4
        Path tracing in interactive mode: samples per pixel per pass (≥ 2).
    refine_interval : int, default: 100
        Path tracing in interactive mode: milliseconds between refinement passes.
    **render_options
        As :meth:`pv_ambient.Renderer.render` (``background`` is the radiance where there is
        neither volume nor geometry).

    Returns
    -------
    AmbientVolume
        Unpacks as ``actor, result`` (the plane's actor and the :class:`RenderResult` shown);
        ``.volume_result``, ``.ray_end``, ``.occluders``, ``.observer``, ``.update()``,
        ``.refine()``, ``.remove_observer()``, ``.remove()``.

    Raises
    ------
    ValueError
        ``model="path_traced"`` with opaque meshes in the renderer and ``occlusion=True``.

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

    An opaque sphere inside the cloud, and a picture that follows the camera:

    >>> pl = pv.Plotter(off_screen=True, window_size=(64, 48))
    >>> sphere = pl.add_mesh(pv.Sphere(radius=0.3), color="orange")
    >>> vol = pv_ambient.add_ambient_volume(pl, grid, interactive=True)
    >>> len(vol.occluders), bool(vol.ray_end.min() < 10)
    (1, True)
    >>> pl.show(auto_close=False)
    >>> pl.camera.azimuth += 30
    >>> pl.render()
    >>> vol.renders
    2
    >>> vol.remove()
    >>> bool(sphere.visibility)
    True
    """
    if renderer is None:
        if grid is None:
            raise TypeError("add_ambient_volume needs a grid (or a pv_ambient.Renderer as renderer=)")
        renderer = Renderer(grid, transfer_function=transfer_function, scalars=scalars, lights=lights)
    elif not isinstance(renderer, Renderer):
        raise TypeError(f"renderer must be a pv_ambient.Renderer, got {type(renderer).__name__}")
    display = dict(display or {})
    unknown = set(display) - set(DISPLAY_KEYS)
    if unknown:
        raise TypeError(f"display has unknown keys {sorted(unknown)}; allowed: {list(DISPLAY_KEYS)}")
    interactive_samples = check_int(interactive_samples, "interactive_samples", lo=2)
    refine_interval = check_int(refine_interval, "refine_interval", lo=1)
    window_size = render_options.pop("window_size", None)
    if window_size is not None:
        window_size = check_window_size(window_size)
    if not plotter.camera_set:
        plotter.renderer.reset_camera(bounds=renderer.bounds)
        plotter.camera_position = "iso"
        plotter.renderer.reset_camera(bounds=renderer.bounds)
        plotter.camera_set = True
    vol = AmbientVolume(plotter, renderer, model=model, display=display, options=render_options,
                        occlusion=occlusion, window_size=window_size, interactive_samples=interactive_samples,
                        refine_interval=refine_interval, interactive=interactive)
    try:
        vol.update(force=True)
    except BaseException:
        vol.remove()  # show any mesh it hid
        raise
    if interactive:
        vol.start()
    return vol


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
        from ..rendering.renderer import render

        return render(self._grid, **kwargs)

    def plane(self, **kwargs):
        """Render and return the textured plane (:meth:`RenderResult.to_plane`)."""
        display = kwargs.pop("display", None) or {}
        return self.render(**kwargs).to_plane(**display)

    def compare(self, **kwargs):
        """:func:`pv_ambient.compare` on this grid."""
        return compare(self._grid, **kwargs)
