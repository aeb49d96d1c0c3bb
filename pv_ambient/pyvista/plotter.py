"""A pv_ambient volume inside a PyVista plotter: :func:`add_ambient_volume` and the
:class:`AmbientVolume` it returns — the picture as a textured plane following the plotter's camera
(interactive mode), occluded by the plotter's opaque meshes, and progressive refinement of a path
traced picture while the camera rests.
"""

from __future__ import annotations

import math
import time
import warnings

import numpy as np
import pyvista as pv

from ..inputs.camera import Camera
from ..inputs.validation import check_int, check_real, check_window_size
from ..rendering.renderer import Renderer
from ..rendering.request import warn_unused_lights
from ..rendering.result import DISPLAY_KEYS, RenderResult, unknown_display_keys
from .drag import MOVING_RATE, STEP_GROW, STEP_SHRINK, DragStep, drag_multisamples  # noqa: F401
from .geometry import (GeometryPass, background_image, composite_for_display, is_opaque_mesh,
                       ray_distance_from_depth)
from .plane import add_result_plane, write_texture
from .refinement import Refinement


#: The models whose picture refines while the camera rests (samples accumulated by :meth:`AmbientVolume.refine`).
MONTE_CARLO = ("path_traced", "progressive")


def _camera_key(cam):
    return (cam.position, cam.focal_point, cam.view_up, cam.view_angle, cam.parallel_projection, cam.parallel_scale)


class AmbientVolume(DragStep):
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
                 window_size=None, interactive_samples=4, refine_interval=100, interactive=False,
                 interactive_resolution=0.5, interactive_step=16):
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
        self.interactive_resolution = float(interactive_resolution)
        self.interactive_step = int(interactive_step)
        self.step_factor = 1  # the drag frames' ray step, in resting steps (a power of two)
        self.rest_seconds = None  # the last resting picture's ray cast, seconds (predicts the first drag's step)
        self.dragged = False  # whether a drag has set the step (a later drag starts at the step it ended on)
        # A callable taking a function to call once the view's size has settled (debounced), or None:
        # a size change then renders at once. The trame views set it (pv_ambient.pyvista.jupyter).
        self.defer_resize = None
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
        self._multisamples = None  # the window's multisampling, held back while a drag renders without it
        # path tracing in interactive mode: the samples so far, and the view they are taken with
        self._refinement = Refinement(model, self.options, interactive_samples, self._render_volume)

    def __iter__(self):
        yield self.actor
        yield self.result

    def __repr__(self):
        return (f"AmbientVolume(model={self.model!r}, window_size={self.result.window_size}, "
                f"occluders={len(self.occluders)}, interactive={self.observer is not None})")

    # -- the view and the scene ----------------------------------------------------------------
    @property
    def moving(self) -> bool:
        """Whether the camera is being moved: in interactive mode, while the render window asks
        for an interactive frame rate (``GetDesiredUpdateRate() >= MOVING_RATE``; VTK's
        interactors ask for 15 fps during a drag and 0.0001 at rest), as VTK's own mappers decide."""
        ren_win = self.plotter.ren_win
        return self.interactive and ren_win is not None and ren_win.GetDesiredUpdateRate() >= MOVING_RATE

    def _view(self):
        ren = self.vtk_renderer
        cam = Camera.from_vtk(ren.GetActiveCamera())
        if self.window_size is not None:
            size = self.window_size
        else:
            x0, y0, x1, y1 = ren.GetViewport()
            w, h = self.plotter.window_size
            size = (max(1, int(round((x1 - x0) * w))), max(1, int(round((y1 - y0) * h))))
        if self.moving:  # reduced resolution while the camera moves: the full one when it rests
            f = self.interactive_resolution
            size = (max(1, math.ceil(size[0] * f)), max(1, math.ceil(size[1] * f)))
        return cam, size

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
            if a is None or not is_opaque_mesh(a):
                continue
            if id(a) in hidden or a.GetVisibility():
                found.append(a)
        for a in found:
            a.SetVisibility(False)
        self.occluders = found
        return found

    def _state(self, cam, size):
        return (_camera_key(cam), tuple(size), tuple((id(a), a.GetRedrawMTime()) for a in self.occluders),
                self._moving_step())

    @property
    def _own_background(self):
        """Whether ``background=`` was given (a radiance painted behind the volume); otherwise
        the volume is composited over the plotter's own background colour."""
        return "background" in self.options

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
        if self._step_adapts and not self.dragged:
            self._first_drag_step()
            state = self._state(cam, size)
        t = time.perf_counter()
        self._draw(cam, size, occluders)
        self._key = self._state(*self._view())  # after the plane set the camera (VTK normalises it)
        seconds = time.perf_counter() - t
        if self.moving:
            self._adapt_step(seconds, self.volume_result.metadata.get("time_render"))
        else:  # the ray cast alone: the first picture's time also holds the per-scene stages
            self.rest_seconds = self.volume_result.metadata.get("time_render", seconds)
        return True

    def _resizing(self):
        """Whether this frame only resizes the view while ``defer_resize`` is set: a page settling its
        layout resizes it several times in a second; the picture is rendered once, when the size has
        held (``defer_resize`` calls :meth:`settle`), the last one shown meanwhile."""
        if self.defer_resize is None or self._key is None or self.moving:
            return False
        cam, size = self._view()
        key = self._key
        if tuple(size) == key[1] or _camera_key(cam) != key[0]:
            return False
        self.defer_resize(self.settle)
        return True

    def settle(self):
        """Render at the view's present size if it changed (what a deferred resize calls); returns
        whether it rendered."""
        try:
            return self.update()
        except Exception as exc:  # called from an event loop: report, never raise into it
            self.error = exc
            warnings.warn(f"pv_ambient: interactive update failed: {exc!r}", RuntimeWarning, stacklevel=2)
            return False

    def _render_volume(self, cam, size, **extra):
        opts = dict(self.options)
        step = self._moving_step()
        if step is not None:
            opts["step"] = step
            # a long step marched from the same place on every ray bands thin layers (wood grain)
            # and shifts the picture's mean; jittered starts turn that into fine noise
            # (docs/guide.rst, "In a plotter")
            opts.setdefault("jitter", True)
        if self.moving:  # a drag frame takes a fraction of a second: no delayed progress bar (its thread)
            opts.setdefault("progress_bar", False)
            # the volume and its lighting on every other data sample (docs/guide.rst, "In a plotter")
            opts.setdefault("draft", True)
        opts.update(extra)
        return self.renderer.render(camera=cam, window_size=size, model=self.model, **opts)

    def _draw(self, cam, size, occluders):
        t0 = time.perf_counter()
        ray_end = rgba = image = None
        if occluders:
            if self.model in MONTE_CARLO:
                raise ValueError(f"opaque geometry in the plotter cannot occlude a {self.model} volume (ray_end is "
                                 "supported by the ray-cast models); use a ray-cast model or occlusion=False")
            if self._pass is None:
                self._pass = GeometryPass(self._multisamples or self.plotter.ren_win.GetMultiSamples())
            rgba, z, (near, far) = self._pass.run(self.vtk_renderer, occluders, cam, size)
            ray_end = ray_distance_from_depth(z, near, far, cam, size)
            t_geometry = time.perf_counter() - t0
            volume = self._render_volume(cam, size, background=(0.0, 0.0, 0.0), ray_end=ray_end)
            if "exposure" not in self.display:
                self.display["exposure"] = volume.display_exposure()
            colour, coverage = rgba[..., :3], rgba[..., 3]
            if not self._own_background:  # the plotter's background behind the meshes
                colour = colour + (1.0 - coverage)[..., None] * background_image(self.vtk_renderer, size)
                coverage = np.ones_like(coverage)
            shown, image = composite_for_display(volume, colour, coverage,
                                                 background=self.options.get("background", (0.0, 0.0, 0.0)),
                                                 display=self.display)
            shown.metadata.update(occluders=len(occluders), time_geometry=t_geometry)
        elif self.model == "progressive" and self.interactive and self.moving:
            # the camera moves: the base model's noise-free picture (no samples); they follow at rest
            self._refinement.reset()
            shown = volume = self._render_volume(cam, size, samples_per_pixel=0)
        elif self.model in MONTE_CARLO and self.interactive:
            shown = volume = self._first_pass(cam, size)
        else:
            shown = volume = self._render_volume(cam, size, **({} if self._own_background else
                                                               {"background": (0.0, 0.0, 0.0)}))
        if "exposure" not in self.display:  # "auto" resolved once, on the first picture: no flicker
            self.display["exposure"] = volume.display_exposure()
        if not occluders and not self._own_background:
            shown, image = composite_for_display(volume, background_image(self.vtk_renderer, size), 1.0,
                                                 display=self.display)
        self.volume_result, self.result, self.ray_end, self.geometry_image = volume, shown, ray_end, rgba
        self._show(shown, image)
        self.renders += 1

    def _show(self, result, image=None):
        """Put ``result`` on the picture plane: ``image``, where the caller has its displayed uint8
        already (a composite), else ``result.to_uint8(**display)``; the first picture builds the
        plane (and its to_uint8 warns of a black picture at an explicit exposure)."""
        if self.actor is None:
            actor = add_result_plane(self.plotter, result, **self.display)
            pv.set_new_attribute(actor, "_pv_ambient_plane", True)
            self.actor = actor
            return
        data = pv.wrap(self.actor.GetMapper().GetInputDataObject(0, 0))
        data.points = result.plane_corners()  # the texture is written in place: no new one is built
        write_texture(self.actor.GetTexture(), result.to_uint8(**self.display) if image is None else image)
        self.vtk_renderer.ResetCameraClippingRange()

    def new_plane(self):
        """Show the picture on a new plane actor (``actor``); the old one stays in the renderer,
        its corners collapsed to one point so that it draws nothing, and is returned. A viewer that
        keeps what it uploaded per actor — vtk.js in the browser keeps a texture's first image —
        then shows the new picture (:mod:`pv_ambient.pyvista.jupyter`, client rendering)."""
        old = self.actor
        if old is not None:
            plane = pv.wrap(old.GetMapper().GetInputDataObject(0, 0))
            plane.points = np.repeat(plane.points[:1], plane.n_points, axis=0)
            self.actor = None
        if self.result is not None:
            self._show(self.result)
        return old

    # -- path tracing: progressive refinement ----------------------------------------------------------
    def _first_pass(self, cam, size):
        self._refinement.reset()
        return self._refinement.add_pass(cam, size)

    def refine(self, render=True):
        """Path tracing in interactive mode: add ``interactive_samples`` samples per pixel (the
        next seed) to the picture of the current camera, averaged with the samples so far, until
        ``samples_per_pixel`` are reached (or the relative error ``target_error``). Returns
        whether it added samples; a no-op for the other models and outside interactive mode
        (where the one picture already has all its samples). ``render`` re-renders the plotter
        (only when samples were added). The interactive timer calls it; call it yourself where
        there is no event loop."""
        ref = self._refinement
        if self.model not in MONTE_CARLO or ref.passes is None:
            if self.model == "progressive" and self.interactive and self.result is not None and not self.moving:
                self.update(force=True)  # the camera came to rest after a drag: the first samples
                if render:
                    self.plotter.render()
                return True
            return False
        if ref.done(self.result):
            return False
        res = ref.add_pass(*ref.view)
        self.volume_result = self.result = res
        size, image = ref.view[1], None
        if not self._own_background:
            self.result, image = composite_for_display(res, background_image(self.vtk_renderer, size), 1.0,
                                                       display=self.display)
        self._show(self.result, image)
        self.renders += 1
        if render:
            self.plotter.render()
        return True

    # -- interactive mode ---------------------------------------------------------------------------
    def _on_start(self, obj=None, event=None):
        try:
            self._multisamples = drag_multisamples(self.plotter.ren_win, self.moving, self._multisamples)
            if self._resizing():
                return
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
        if self.model not in MONTE_CARLO or self.observer is None or self._timer is not None:
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
            if self.model in MONTE_CARLO and self._refinement.passes is None:
                self.update(force=True)
            self._ensure_timer()
        return self.observer

    def remove_observer(self):
        """Leave interactive mode: remove the render-window observer (and the refinement timer).
        The picture stays as it is."""
        if self.observer is not None:
            if self.plotter.ren_win is not None:
                self.plotter.ren_win.RemoveObserver(self.observer)
                if self._multisamples is not None:  # left in a drag: the window's own back
                    self.plotter.ren_win.SetMultiSamples(self._multisamples)
            self._multisamples = None
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


def add_ambient_volume(plotter, grid=None, *, model="emission_absorption", transfer_function=None, lights=None,
                       scalars=None, display=None, interactive=False, occlusion=True, renderer=None,
                       interactive_samples=4, refine_interval=100, interactive_resolution=0.5, interactive_step=16,
                       **render_options):
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
        As :func:`pv_ambient.render` (``lights`` not given: the default light rig for the lit
        models, placed from the plotter's camera at the first picture and kept).
    display : dict, optional
        Keywords for :meth:`RenderResult.to_uint8` (``exposure``, ``tonemap``, ``srgb``). An
        exposure not given (``"auto"`` for the lit models, 0 otherwise) is resolved on the first
        picture and then kept (``display["exposure"]``), so camera moves do not flicker.
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
        :meth:`AmbientVolume.refine` yourself. ``model="progressive"`` (docs/progressive.rst)
        draws its base model's noise-free picture while the camera moves and, once it rests,
        refines it the same way (residual samples). While the camera is being dragged (the render window
        asks for an interactive frame rate, :attr:`AmbientVolume.moving`) the picture is rendered
        at ``interactive_resolution`` of the window per axis and, while frames are slower than the
        rate the window asks for, with a longer ray step (doubled per slow frame, up to
        ``interactive_step`` times the resting one, halved again when frames are fast; VTK's
        ``AutoAdjustSampleDistances`` does the same) and then jittered ray starts (``jitter=True``
        unless the options say otherwise: fine noise instead of the bands a long step leaves on
        thin layers); the frame drawn when the camera rests is the full-resolution render at the
        resting step.
    occlusion : bool, default: True
        Let the plotter's opaque meshes occlude the volume (above). False leaves them alone
        (the plane then hides whatever lies behind the focal plane).
    renderer : pv_ambient.Renderer, optional
        Render with this renderer (its volume, transfer function and lights, and its caches)
        instead of building one from ``grid``, ``transfer_function``, ``scalars``, ``lights``.
    interactive_samples : int, default: 4
        Path tracing (and ``progressive``) in interactive mode: samples per pixel per pass (≥ 2).
    refine_interval : int, default: 100
        Path tracing in interactive mode: milliseconds between refinement passes.
    interactive_resolution : float, default: 0.5
        Interactive mode: the picture's resolution per axis while the camera moves, as a fraction
        of the window's, in [0.5, 1] (1: always full resolution).
    interactive_step : int, default: 16
        Interactive mode: the largest ray step while the camera moves, in resting steps (a power
        of two ≥ 1; 1 keeps the resting step). Ignored by ``path_traced``. A drag frame at a longer
        step is an approximation (the volume sampled more coarsely, its fine detail aliased — as
        noise, its ray starts jittered): a preview while the camera moves, never the picture it
        rests on (docs/display.rst).
    **render_options
        As :meth:`pv_ambient.Renderer.render`. Without ``background`` the volume is composited
        over the plotter's own background (its colour, or its gradient), as VTK's ``add_volume``
        is, so a theme's white background stays white; ``background=`` instead paints that
        radiance where there is neither volume nor geometry.

    Returns
    -------
    AmbientVolume
        Unpacks as ``actor, result`` (the plane's actor and the :class:`RenderResult` shown);
        ``.volume_result``, ``.ray_end``, ``.occluders``, ``.observer``, ``.update()``,
        ``.refine()``, ``.remove_observer()``, ``.remove()``.

    Raises
    ------
    ValueError
        ``model="path_traced"`` or ``"progressive"`` with opaque meshes in the renderer and
        ``occlusion=True``.

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
        warn_unused_lights(lights, model)
        renderer = Renderer(grid, transfer_function=transfer_function, scalars=scalars, lights=lights)
    elif not isinstance(renderer, Renderer):
        raise TypeError(f"renderer must be a pv_ambient.Renderer, got {type(renderer).__name__}")
    display = dict(display or {})
    unknown = unknown_display_keys(display)
    if unknown:
        raise TypeError(f"display has unknown keys {unknown}; allowed: {list(DISPLAY_KEYS)}")
    interactive_samples = check_int(interactive_samples, "interactive_samples", lo=2)
    refine_interval = check_int(refine_interval, "refine_interval", lo=1)
    interactive_resolution = check_real(interactive_resolution, "interactive_resolution", lo=0.5, hi=1.0)
    interactive_step = check_int(interactive_step, "interactive_step", lo=1)
    if interactive_step & (interactive_step - 1):
        raise ValueError(f"interactive_step must be a power of two (1, 2, 4, …), got {interactive_step!r}")
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
                        refine_interval=refine_interval, interactive=interactive,
                        interactive_resolution=interactive_resolution, interactive_step=interactive_step)
    try:
        vol.update(force=True)
    except BaseException:
        vol.remove()  # show any mesh it hid
        raise
    if interactive:
        vol.start()
        from .jupyter import register  # the trame views find the plotter's volumes (docs/jupyter.rst)

        register(vol)
    return vol
