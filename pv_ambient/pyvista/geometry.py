"""Opaque geometry in front of and inside the volume: the off-screen mesh pass
(:class:`GeometryPass`: colour, coverage and depth for one camera), depth → distance along each
camera ray (:func:`ray_distance_from_depth`, the ``ray_end`` of a render) and the volume composited
over the meshes' picture (:func:`composite_over_geometry`).
"""

from __future__ import annotations

import numpy as np

from ..inputs.validation import check_rgb
from ..rendering.result import RenderResult
from .display import display_to_linear, display_values


def is_plane(actor):
    """Whether ``actor`` is one of pv_ambient's picture planes (never an occluder)."""
    return bool(getattr(actor, "_pv_ambient_plane", False))


def is_opaque_mesh(actor):
    """An actor drawn by a mapper with input data, fully opaque (our planes excluded): a mesh that
    occludes the volume."""
    if is_plane(actor) or not actor.IsA("vtkActor"):
        return False
    mapper = actor.GetMapper()
    if mapper is None or mapper.GetNumberOfInputPorts() < 1 or mapper.GetNumberOfInputConnections(0) < 1:
        return False
    prop = actor.GetProperty()
    return prop is not None and prop.GetOpacity() >= 1.0 and not actor.HasTranslucentPolygonalGeometry()


def background_image(renderer, size):
    """``(H, W, 3)`` display colour of a ``vtkRenderer``'s background at ``size`` (VTK's gradient,
    bottom colour to top colour, when the renderer has one), top row first: a read-only float32
    view of one colour per row (what every frame a plotter composites reads, never copied)."""
    w, h = size
    bottom = np.array(renderer.GetBackground(), dtype=np.float32)
    if renderer.GetGradientBackground():
        top = np.array(renderer.GetBackground2(), dtype=np.float32)
        t = ((h - 1 - np.arange(h, dtype=np.float32) + 0.5) / h)[:, None]  # 0 at the bottom row, top row first
        rows = bottom + t * (top - bottom)
        return np.broadcast_to(rows[:, None, :], (h, w, 3))
    return np.broadcast_to(bottom, (h, w, 3))


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
    >>> from pv_ambient.pyvista.geometry import composite_over_geometry
    >>> vol = RenderResult(np.full((1, 2, 3), 0.25, np.float32), np.full((1, 2), 0.5, np.float32), None)
    >>> geometry = np.array([[[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]]])   # red surface | nothing
    >>> out = composite_over_geometry(vol, geometry, np.array([[1.0, 0.0]]), background=(0, 0, 1))
    >>> out.radiance[0].tolist(), out.alpha[0].tolist()
    ([[0.75, 0.25, 0.25], [0.25, 0.25, 0.75]], [1.0, 0.5])
    """
    return composite_for_display(volume, colour, coverage, background=background, display=display)[0]


def composite_for_display(volume, colour, coverage, *, background=(0.0, 0.0, 0.0), display=None):
    """:func:`composite_over_geometry` and the uint8 picture it displays as (what
    ``to_uint8(**display)`` of the composite gives, to the rounding), in one float32 pass: a
    plotter composites every frame of a camera drag and uploads that picture as it is.
    ``coverage`` may be a number (1 where a plotter's background fills the view).

    Examples
    --------
    >>> import numpy as np
    >>> from pv_ambient.rendering.result import RenderResult
    >>> from pv_ambient.pyvista.geometry import composite_for_display
    >>> vol = RenderResult(np.full((1, 1, 3), 0.25, np.float32), np.full((1, 1), 0.5, np.float32), None)
    >>> out, image = composite_for_display(vol, np.full((1, 1, 3), 0.5), 1.0)
    >>> image[0, 0].tolist(), out.to_uint8()[0, 0].tolist()
    ([128, 128, 128], [128, 128, 128])
    """
    display = dict(display or {})
    bg = np.asarray(check_rgb(background, "background"), dtype=np.float32)
    cov = np.clip(np.asarray(coverage, dtype=np.float32), 0.0, 1.0)[..., None]
    trans = 1.0 - volume.alpha.astype(np.float32)[..., None]
    uncovered = trans * (1.0 - cov)
    shown = display_values(volume.radiance.astype(np.float32, copy=False) + uncovered * bg, **display)
    shown += trans * np.asarray(colour, dtype=np.float32)
    np.clip(shown, 0.0, 1.0, out=shown)
    radiance = display_to_linear(shown, **display).astype(np.float32, copy=False)
    alpha = np.broadcast_to(1.0 - uncovered[..., 0], trans.shape[:2]).astype(np.float32)
    result = RenderResult(radiance=radiance, alpha=alpha, camera=volume.camera, metadata=dict(volume.metadata))
    return result, np.round(shown * 255.0).astype(np.uint8)


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
    >>> from pv_ambient.pyvista.geometry import ray_distance_from_depth
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


class GeometryPass:
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
