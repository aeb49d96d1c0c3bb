"""``render(grid, ...)`` and the :class:`Renderer`: a volume, its transfer function and lights,
with the per-scene stages that survive camera moves.

Data flows one way (docs/architecture.rst): ImageData → arrays (:mod:`pv_ambient.inputs.grid`) →
optical properties (:mod:`pv_ambient.inputs.transfer`) → per-light / per-radius volumes and solves
(:mod:`pv_ambient.stages`, kept by the renderer's
:class:`~pv_ambient.rendering.scene_stages.SceneStages`) → image (:mod:`pv_ambient.backend`). A
render's arguments are checked once into a frozen :class:`RenderRequest`; ``auto`` is decided in
:meth:`Renderer.choose_model`; the model's own module renders it — the camera-pass models
(:mod:`.camera_pass`), the path tracer (:mod:`.path_traced`), the progressive model
(:mod:`.progressive`). So moving the camera re-runs only the ray cast.
"""

from __future__ import annotations

import copy
import inspect
import time

import numpy as np

from ..backend import blas_on_demand, blas_one_thread, check_backend, resolve_backend
from ..inputs.grid import Volume, volume_from_image
from ..inputs.lights import as_lights, needs_camera
from ..inputs.transfer import as_transfer_function
from ..inputs.validation import check_choice, check_window_size
from .camera_pass import render_camera_pass
from .path_traced import path_trace, render_path_traced
from .presets import ACCURATE_DIFFUSION, BALANCED_DIFFUSION, BALANCED_SWEEP_SAMPLES, BUDGET_MAX_SPP, \
    DEFAULT_PROPAGATION, DEFAULT_SPP, ERT, MAJORANT_BLOCK, MODEL_SPECS, step_for
from .progressive import render_progressive
from ..stages.reference import RR_DEPTH
from .request import (RenderRequest, build_request, check_image_memory, check_thickness, compile_notice, stage_bar,
                      warn_black, warn_unused_lights, warn_unused_options)
from .result import RenderResult
from .scene_stages import SceneStages


class Renderer:
    """A volume, its transfer function and lights, with caches that survive camera moves.

    Parameters
    ----------
    grid : pyvista.ImageData, vtkImageData or pv_ambient.inputs.grid.Volume
        The volume. Never modified. It needs a thickness: a 2-D grid (one point along an axis)
        or a single point is a ValueError that says how to give it one.
    transfer_function : TransferFunction, dict, vtkVolumeProperty or volume actor, optional
        How scalars become optical properties; PyVista's defaults when None.
    scalars : str, optional
        Array to classify (the active scalars when None).
    component : int, optional
        Component of a multi-component array (magnitude when None).
    lights : sequence of PointLight, DirectionalLight, pyvista.Light or dict, optional
        None (not given): the lit models get the default light rig (docs/lights.rst), placed
        from the camera of the first lit render and kept (a camera move does not relight);
        ``()``: no light (lit models render black, with a warning). ``lights`` holds the
        lights in use (empty until a rig or a pyvista head/camera light is placed).
    preference : {"point", "cell"}, default: "point"
        Which data to use when both exist.
    nan_policy : {"raise", "vacuum"}, default: "raise"
        Non-finite scalars are an error, or empty space (see :mod:`pv_ambient.inputs.transfer`).
    backend : {"auto", "cpu", "cuda"}, default: "auto"
        Where the kernels run (:mod:`pv_ambient.backend`); a render's ``backend`` overrides it.

    Attributes
    ----------
    stages : SceneStages
        The per-scene stages (light volumes, ball grid, tables, diffusion fields) and their cache.

    Examples
    --------
    >>> import pv_ambient
    >>> from pv_ambient import datasets
    >>> r = pv_ambient.Renderer(datasets.cloud(n=24))
    >>> res = r.render(window_size=(32, 24))
    >>> res.radiance.shape
    (24, 32, 3)
    """

    def __init__(self, grid, *, transfer_function=None, scalars=None, component=None, lights=None,
                 preference="point", nan_policy="raise", backend="auto"):
        check_choice(preference, "preference", ("point", "cell"))
        self.backend = check_backend(backend)
        self.volume = grid if isinstance(grid, Volume) else volume_from_image(grid, preference=preference)
        check_thickness(self.volume.geometry, getattr(grid, "dimensions", None))
        self.transfer_function = as_transfer_function(transfer_function)
        t = time.perf_counter()
        with stage_bar(None, "classify"):
            optics = self.transfer_function.resolve(self.volume, scalars=scalars, component=component,
                                                    nan_policy=nan_policy)
        self.stages = SceneStages(optics, self.volume.geometry)
        self.stages.timings["classify"] = time.perf_counter() - t
        self.set_lights(lights)

    def with_optics(self, optics) -> "Renderer":
        """A renderer of the same volume, lights and backend with other optical properties
        (``pv_ambient.inputs.transfer.Optics``) of the same σt: it starts from this renderer's
        σt-only cache entries (majorant, light grids, optical depths) and shares its GPU cache."""
        other = copy.copy(self)
        other.stages = self.stages.with_optics(optics)
        return other

    @property
    def optics(self):
        """The classified medium (``pv_ambient.inputs.transfer.Optics``)."""
        return self.stages.optics

    @property
    def cache(self):
        """The :class:`~pv_ambient.rendering.cache.SceneCache` of :attr:`stages`."""
        return self.stages.cache

    @property
    def timings(self) -> dict:
        """Seconds of the last computation of each stage."""
        return self.stages.timings

    @property
    def device_cache(self):
        """The :class:`pv_ambient.backend.DeviceCache` of the CUDA backend (created on first use)."""
        return self.stages.device_cache

    @property
    def geometry(self):
        return self.volume.geometry

    @property
    def bounds(self):
        return self.geometry.bounds

    def default_step(self, quality="balanced") -> float:
        """The ray step of a quality preset (world units)."""
        return step_for(quality, np.min(self.geometry.spacing))

    # -- lights ------------------------------------------------------------------------------
    def set_lights(self, lights):
        """Replace the lights; cached volumes of lights that stay are kept (a relight). None: the
        default rig, placed at the next lit render from its camera (as pyvista head and camera
        lights are)."""
        self.light_rig = "default" if lights is None else "given"
        self._lights_pending = needs_camera(lights)
        self._light_spec = lights if self._lights_pending else None
        self.lights = () if self._lights_pending else as_lights(lights, center=self._center())
        if not self._lights_pending:
            self.stages.keep_lights(self.lights)

    def place_lights(self, camera):
        """Place lights that wait for a camera (the default rig, pyvista head/camera lights) with
        ``camera``, once; returns :attr:`lights`. Every lit render calls it with its camera."""
        if self._lights_pending:
            self.lights = as_lights(self._light_spec, center=self._center(), camera=camera)
            self._lights_pending, self._light_spec = False, None
            self.stages.keep_lights(self.lights)
        return self.lights

    def _center(self):
        return np.reshape(np.asarray(self.bounds, dtype=float), (3, 2)).mean(axis=1)

    # -- a render ----------------------------------------------------------------------------
    def choose_model(self, request) -> tuple:
        """The model a request renders and the options the choice adds: ``auto``'s rules (listed in
        :meth:`render`) decided in this one place; any other model stands for itself."""
        if request.model != "auto":
            return request.model, {}
        grid = self.stages.light_grid(request.light_resolution)
        if request.time_budget is not None:
            return self._budget_choice(request, grid)
        if not self.stages.active_lights(self.lights, grid, request.backend):
            model = "single_scattering"  # nothing scatters, or no light reaches what does: no light volume is kept
        else:
            model = "ambient_scattering" if request.quality == "preview" else "diffusion"
        sweeps = None
        if model == "diffusion" and request.quality == "accurate":
            sweeps = ACCURATE_DIFFUSION
        elif (model == "diffusion" and request.quality == "balanced"
              and int(np.prod(self.geometry.shape)) <= BALANCED_SWEEP_SAMPLES):
            sweeps = BALANCED_DIFFUSION
        if sweeps is None:
            return model, {}
        return model, {k: request.options.get(k, v) for k, v in sweeps.items()}  # the caller's options first

    def _budget_choice(self, request, grid) -> tuple:
        """``auto`` with a time budget (rule 5 of :meth:`render`): the path tracer, unless nothing
        scatters or no light has power — rules 1 and 3 by the checks that need no light volume. A
        light behind an opaque wall (rule 2) is not looked for: finding it takes a light sweep per
        light, a large share of a budget of a fraction of a second, where the path tracer's shadow
        rays find it dark at a cost that grows with the samples (docs/trade.rst, "At a time
        budget")."""
        from ..stages.denoise import available

        if not (self.stages.scatters(grid) and any(max(lt.power) > 0.0 for lt in self.lights)):
            return "single_scattering", {}
        extra = {"time_limit": request.time_budget, "denoise": request.options.get("denoise", available())}
        if "samples_per_pixel" not in request.explicit:
            extra["samples_per_pixel"] = BUDGET_MAX_SPP
        return "path_traced", extra

    def render(self, *, camera=None, window_size=None, model="emission_absorption", quality="balanced", step=None,
               jitter=False, seed=0, background=(0.0, 0.0, 0.0), early_termination=ERT, phase=None,
               progress_bar=None, radius=None, light_resolution=None, ambient_radiance=1.0,
               propagation=DEFAULT_PROPAGATION, table_quality=None, ray_end=None, backend=None, draft=False,
               **model_options) -> RenderResult:
        """Render one image.

        Parameters
        ----------
        camera : Camera, pyvista.Camera, pyvista.Plotter, dict, list or str, optional
            PyVista's default isometric view of the volume when None; ``"iso"``, ``"xy"``,
            ``"xz"``, ``"yz"``, ``"yx"``, ``"zx"``, ``"zy"`` as ``Plotter.camera_position``.
        window_size : (int, int), optional
            ``(width, height)``; the plotter's when a plotter is given, else (512, 512). A size
            whose buffers would not fit in the available memory is a ``MemoryError`` before
            any work.
        model : str, default: "emission_absorption"
            One of (docs/models.rst; the lit models use :attr:`lights`):

            * ``"emission_absorption"`` — VTK's ``add_volume``, no lights;
            * ``"ambient_occlusion"`` — options ``radius`` (4 voxels), ``ambient_radiance`` (1.0);
            * ``"single_scattering"`` — lit;
            * ``"ambient_scattering"`` — lit; ``radius`` (8 voxels), ``propagation``
              ("beer_lambert"), ``table_quality`` (the preset's);
            * ``"diffusion"`` — lit; ``flux_limited`` (False), ``sweep_orders`` (0: the first
              scattering orders by transport sweeps, docs/diffusion.rst §5);
            * ``"path_traced"`` — lit, the Monte Carlo reference
              (:func:`pv_ambient.stages.reference.path_trace`); ``samples_per_pixel`` (the
              preset's: 16 / 64 / 256), ``target_error`` (None; a warning gives the error reached
              when the cap comes first), ``max_depth`` (None), ``denoise`` (False);
            * ``"progressive"`` — lit: the noise-free ``base_model``'s picture ("diffusion", with
              8 transport sweeps and flux limiting except at quality "preview";
              "single_scattering", "ambient_scattering") refined by residual path samples that
              use it as a control variate (docs/progressive.rst): noise-free at
              ``samples_per_pixel=0``, then (from 16 samples per pixel) the base plus the part of
              the samples' correction that stands out of its noise — the path tracer's answer as
              samples accumulate
              (``unbiased=True``: the whole correction, unbiased at every count;
              ``denoise=True``, with ``pyoidn``: that picture or the unbiased one denoised by
              OIDN, whichever held-out halves of the samples find closer); the base's options,
              ``samples_per_pixel``, ``target_error``, ``max_depth``, ``unbiased``, ``denoise``;
            * ``"auto"`` — lit; ``time_budget`` (None).

            An option given to a model that does not use it earns a warning. ``auto`` picks the
            model the trade benchmark measured best for the quality preset, and builds nothing
            the scene does not need, by these rules (each tested):

            1. no scattering (albedo 0 wherever σt > 0): ``single_scattering`` with no light
               volume built — emission and absorption only;
            2. lights with zero intensity, or whose optical depth exceeds 700 at every sample
               that scatters (behind an opaque wall), are dropped (by every model);
            3. no light left: ``single_scattering`` (emission and absorption only);
            4. otherwise ``diffusion``, with ``quality="accurate"`` its first
               ``AUTO_SWEEP_ORDERS`` (8) scattering orders by transport sweeps and flux-limited
               diffusion for the rest, with ``quality="balanced"`` its first
               ``BALANCED_SWEEP_ORDERS`` (4) so on volumes of at most ``BALANCED_SWEEP_SAMPLES``
               (64³) samples, where they fit in the first-frame budget plain diffusion has on a
               256³ volume (docs/trade.rst, "What auto renders"), and with ``quality="preview"``
               ``ambient_scattering`` (an isotropic phase function uses a 1D table slice: D does
               not depend on θ).
               Diffusion has the lower error at a similar camera-move cost, ambient
               scattering's "preview" the cheapest first frame that carries multiply scattered
               light, the sweeps the lowest error of the noise-free models (block error ≤ 0.14
               on six scenes against 0.35 flux-limited alone, docs/diffusion.rst §5; first
               frame 2–4× flux-limited diffusion's);
            5. with ``time_budget=SECONDS`` (a still image): ``path_traced`` with as many samples
               per pixel as fit in the budget (``samples_per_pixel`` is then the cap, default
               4096), denoised when ``pyoidn`` is installed — at a still image's budget the
               denoised path tracer usually reaches a noise-free model's error sooner than that
               model's first frame (docs/trade.rst). The denoiser's time (one
               emission–absorption frame for its guide, then OIDN) comes on top of the budget.
               Of rules 1–3 only those that need no light volume apply (nothing scatters, or no
               light has power: ``single_scattering``); a light behind an opaque wall is not
               swept for. For the best picture at a budget install the ``denoise`` extra.
        quality : {"preview", "balanced", "accurate"}, default: "balanced"
            Preset for the knobs not given explicitly (``QUALITY_PRESETS``): ray step 1, ½, ¼ of
            the smallest grid spacing; light grid 1×, docs/ambient_scattering.rst §3's default, ≥ 2× the data
            resolution; table effort preview, balanced, balanced; ``path_traced`` 16, 64, 256
            samples per pixel.
        step : float, optional
            Ray-marching step in world units (overrides ``quality``).
        jitter : bool, default: False
            Shift each ray's sample grid by a seeded random fraction of a step.
        seed : int, default: 0
        background : RGB, default: (0, 0, 0)
            Constant background radiance seen through the volume (not a light).
        early_termination : float, default: 1e-5
            Stop a ray once its transmittance falls below this (0 disables).
        phase : PhaseFunction, float or dict, optional
            Phase function of the scattering models (isotropic when None).
        radius : float, optional
            Ambient radius r in world units (ambient occlusion / scattering); default 8 data
            spacings for ambient scattering (closest to the path-traced reference, docs/trade.rst)
            and 4 for ambient occlusion (``radius_voxels`` of the model table). A string like ``"4 voxels"`` gives it in units of the largest spacing.
        light_resolution : float, optional
            Light-grid nodes per data spacing (the preset's when None).
        ambient_radiance : float, default: 1.0
            Uniform ambient radiance of ``ambient_occlusion``.
        propagation : {"beer_lambert", "tube"}, default: "beer_lambert"
            How ``ambient_scattering`` attenuates the light front arriving at each ball
            (docs/ambient_scattering.rst §3): Beer–Lambert transmittance to the ball's entry point, or the paper's
            tube march through balls (soft shadows). The default is the one measured closer to
            the path-traced reference.
        table_quality : {"preview", "balanced", "accurate"}, optional
            Monte Carlo effort of the preintegrated table slice (computed once, cached on disk);
            the preset's when None.
        progress_bar : bool, optional
            One tqdm bar per stage, named: light volumes, preintegrated table, diffusion solve,
            ray cast (over image tiles), path-traced samples. True shows them at once, False
            never; None (the default) shows a stage's bar only once it has run 2 s, and never
            under pytest.
        ray_end : numpy.ndarray, optional
            ``(H, W)`` world distance along each pixel's camera ray at which opaque geometry
            stops it (``inf`` where there is none); the radiance then holds only the volume in
            front of the geometry (plus ``T·background``), for compositing over the geometry
            with ``alpha`` — what :func:`pv_ambient.add_ambient_volume` does with the plotter's
            depth buffer. Ray-cast models only.
        backend : {"auto", "cpu", "cuda"}, optional
            Where the kernels run (:mod:`pv_ambient.backend`); the renderer's ``backend`` when
            None. ``auto`` takes CUDA when numba-cuda and a GPU are there, and falls back to the
            CPU with a warning when the scene does not fit in the GPU's free memory;
            ``metadata["backend"]`` says which ran and ``metadata["device_memory"]`` the bytes
            the scene holds on the GPU.
        draft : bool, default: False
            A quick preview for interaction (what ``add_ambient_volume(..., interactive=True)``
            renders while the camera moves): the volume, its colours and a lit model's lighting
            on every other data sample per axis, shaded there once and interpolated between
            (docs/guide.rst, "In a plotter"). Ray-cast models of a
            table transfer function on the CPU (a lit model with baked in-scattering); elsewhere
            the full frame. ``metadata["draft"]`` says which was rendered.
        **model_options
            Knobs of other models (see ``MODEL_OPTIONS``); unknown names are an error, and an
            option that needs an optional package (``denoise=True``: ``pyoidn``) raises its
            ImportError before any work.

        Notes
        -----
        A point light's fall-off ``I/d²`` is clamped at ``d = step/4`` (a sample closer than a
        quarter step to the light cannot resolve the singularity).
        """
        # the keywords are render()'s own: checked by build_request, without binding them to the
        # signature again as request() must (a frame's host work: docs/performance.rst)
        args = {k: v for k, v in locals().items() if k not in ("self", "model_options", "__class__")}
        return self.render_request(build_request(self, **args, model_options=model_options))

    def request(self, **arguments) -> RenderRequest:
        """Check :meth:`render`'s arguments (the same keywords, the same defaults) once into a
        frozen :class:`~pv_ambient.rendering.request.RenderRequest`."""
        bound = _RENDER_SIGNATURE.bind(self, **arguments)
        bound.apply_defaults()
        args = dict(bound.arguments)
        del args["self"]
        return build_request(self, **args)

    def render_request(self, req: RenderRequest) -> RenderResult:
        """Render a checked :class:`RenderRequest` (what :meth:`render` does after checking)."""
        if MODEL_SPECS[req.model].lit:
            self.place_lights(req.camera)
        model, extra = self.choose_model(req)
        compile_notice(model)
        warn_unused_options(req, model)
        options = {**req.options, **extra}
        # no spinning BLAS workers beside the Numba kernels (backend.py); on the GPU only once a
        # stage runs on the CPU
        with blas_one_thread() if req.backend == "cpu" else blas_on_demand():
            if model == "path_traced":
                res = render_path_traced(self, req, options)
            elif model == "progressive":
                res = render_progressive(self, req, options)
            else:
                res = render_camera_pass(self, req, model, options)
        if MODEL_SPECS[req.model].lit:
            res.metadata["light_rig"] = self.light_rig
            # its causes (lights, transfer function) do not move with the camera: decided once per
            # light set and model, not at every frame
            key = (tuple(self.lights), res.metadata["model"])
            if key not in self.stages.black_checked and warn_black(self, res, req.background):
                self.stages.black_checked.add(key)
        return res

    def path_trace(self, camera=None, window_size=None, *, phase=None, samples_per_pixel=DEFAULT_SPP,
                   target_error=None, max_depth=None, seed=0, background=(0.0, 0.0, 0.0), progress_bar=False,
                   batch=16, light_clamp=None, majorant_block=MAJORANT_BLOCK, rr_depth=RR_DEPTH, backend=None,
                   time_limit=None, equiangular=True, first_sample=0) -> RenderResult:
        """Render the unbiased path-traced reference of this scene (no denoising; ``render(model=
        "path_traced")`` is the same with the quality presets and the denoiser).

        Parameters
        ----------
        camera : Camera, pyvista.Camera, pyvista.Plotter, dict or list, optional
            PyVista's default isometric view of the volume when None.
        window_size : (int, int), optional
            ``(width, height)``; as :meth:`render`.
        majorant_block : int, default: 8
            Samples per majorant block (smaller: tighter majorants, more block crossings).

        backend : {"auto", "cpu", "cuda"}, optional
            The renderer's ``backend`` when None.
        **others
            As :func:`pv_ambient.stages.reference.path_trace` (``phase``, ``samples_per_pixel``,
            ``target_error``, ``max_depth``, ``seed``, ``background``, ``progress_bar``, ``batch``,
            ``light_clamp``, ``rr_depth``, ``time_limit``, ``equiangular``, ``first_sample``: with
            one seed, ``samples_per_pixel=n2, first_sample=n1`` continues a render of ``n1``).

        Returns
        -------
        RenderResult
            ``radiance`` the per-pixel mean, ``alpha`` the fraction of primary rays that collided,
            ``std_error`` the per-pixel standard error of the mean (``(H, W, 3)``; ``inf`` after a
            single sample), and ``metadata`` with ``spp``, ``time``, ``seed``, ``max_depth``,
            ``relative_error`` and the options.

        Examples
        --------
        >>> import pv_ambient
        >>> from pv_ambient import datasets
        >>> r = pv_ambient.Renderer(datasets.cloud(n=16), lights=[pv_ambient.PointLight((2, 2, 2), 5.0)])
        >>> res = r.path_trace(window_size=(8, 6), samples_per_pixel=4)
        >>> res.radiance.shape, res.std_error.shape, res.metadata["spp"]
        ((6, 8, 3), (6, 8, 3), 4)
        """
        backend = resolve_backend(self.backend if backend is None else check_backend(backend))
        return path_trace(self, camera, window_size, backend=backend, block=majorant_block, phase=phase,
                          samples_per_pixel=samples_per_pixel, target_error=target_error, max_depth=max_depth,
                          seed=seed, background=background, progress_bar=progress_bar, batch=batch,
                          light_clamp=light_clamp, rr_depth=rr_depth,
                          time_limit=time_limit, equiangular=equiangular, first_sample=first_sample)

    def albedo_guide(self, camera, window_size, *, step=None) -> np.ndarray:
        """The albedo guide of :func:`pv_ambient.stages.denoise.denoise_radiance`: (H, W, 3) float32 in [0, 1].

        The expected single-scattering albedo at each camera ray's first collision, premultiplied
        by the ray's coverage, ``∫ T(t) σt(t) a(t) dt``: this scene's emission–absorption image
        with its colour replaced by the scattering albedo (one ray cast on the renderer's backend with
        ``step``, the ``"balanced"`` one when None; no background). This renderer's own cached
        volumes are not touched. Noise-free, so OIDN takes it as a clean guide.
        """
        guide = self.with_optics(self.optics.albedo_as_colour())
        res = guide.render(camera=camera, window_size=window_size, model="emission_absorption",
                           step=self.default_step() if step is None else step, background=(0.0, 0.0, 0.0))
        return np.clip(np.nan_to_num(res.radiance, nan=0.0), 0.0, 1.0).astype(np.float32)


#: The keywords of :meth:`Renderer.render`, read once: :meth:`Renderer.request` checks the same.
_RENDER_SIGNATURE = inspect.signature(Renderer.render)


def render(grid, *, transfer_function=None, camera=None, window_size=None, lights=None, model="emission_absorption",
           scalars=None, component=None, preference="point", nan_policy="raise", **options) -> RenderResult:
    """Render a volume: the one-call entry point.

    Parameters
    ----------
    grid : pyvista.ImageData or vtkImageData
        The volume (never modified). A 2-D grid (one point along an axis) or a single point
        has no thickness: a ValueError says how to give it one.
    transfer_function : TransferFunction, dict, vtkVolumeProperty or volume actor, optional
        PyVista's defaults (theme colormap, linear opacity, default unit distance) when None.
    camera : pyvista.Camera, pyvista.Plotter, Camera, dict, list or str, optional
        PyVista's default isometric view when None; ``"iso"``, ``"xy"``, ``"xz"``, ``"yz"``,
        ``"yx"``, ``"zx"``, ``"zy"`` as ``Plotter.camera_position`` takes them.
    window_size : (int, int), optional
        ``(width, height)``, default (512, 512) (a plotter's when ``camera`` is a plotter).
    lights : sequence of PointLight, DirectionalLight, pyvista.Light or dict, optional
        Used by the lit models. None (not given): a default light rig placed from the camera
        and the bounds, bright in any world unit (docs/lights.rst); ``()``: no light (a lit
        model then renders black, with a warning). Lights given to a model that ignores them
        earn a warning.
    model : str, default: "emission_absorption"
        ``"emission_absorption"`` (VTK's ``add_volume``: no lights), ``"ambient_occlusion"``
        (options ``radius`` = 4 voxels, ``ambient_radiance`` = 1.0), ``"single_scattering"``,
        ``"ambient_scattering"`` (``radius`` = 8 voxels, ``propagation`` = "beer_lambert",
        ``table_quality`` = the preset's), ``"diffusion"`` (``flux_limited`` = False,
        ``sweep_orders`` = 0),
        ``"path_traced"`` (``samples_per_pixel`` = 16 / 64 / 256 by ``quality``,
        ``target_error`` = None, ``max_depth`` = None, ``denoise`` = False), ``"progressive"``
        (``base_model`` = "diffusion", refined by residual path samples; ``unbiased`` = False;
        docs/progressive.rst) or ``"auto"``
        (``time_budget`` = None; rules in :meth:`Renderer.render`). The lit models also take
        ``phase`` (isotropic) and ``light_resolution`` (the preset's). docs/models.rst
        describes each; an option the chosen model does not use earns a warning.
    scalars : str, optional
        Array to classify (the active scalars when None).
    component : int, optional
        Component of a multi-component array (the magnitude when None).
    preference : {"point", "cell"}, default: "point"
        Which data to use when both exist.
    nan_policy : {"raise", "vacuum"}, default: "raise"
        Non-finite scalars are an error, or empty space.
    **options
        Every other keyword of :meth:`Renderer.render`, with its defaults: ``quality="balanced"``,
        ``step=None`` (½ the smallest spacing), ``jitter=False``, ``seed=0``,
        ``background=(0, 0, 0)``, ``early_termination=1e-5``, ``progress_bar=None`` (a named
        bar per stage that runs longer than 2 s; never under pytest), ``ray_end=None``,
        ``backend=None`` ("auto"), and the model options above.

    Returns
    -------
    RenderResult
        Linear float32 radiance and alpha; ``save("x.png")`` shows the lit models at
        ``exposure="auto"`` (docs/display.rst).

    Examples
    --------
    >>> import pv_ambient
    >>> from pv_ambient import datasets
    >>> grid = datasets.supernova(n=24)
    >>> res = pv_ambient.render(grid, window_size=(40, 30))
    >>> res.radiance.shape, res.alpha.shape
    ((30, 40, 3), (30, 40))

    A lit model with no light argument gets the default light rig:

    >>> res = pv_ambient.render(grid, window_size=(40, 30), model="single_scattering")
    >>> res.metadata["lights"], res.metadata["light_rig"]
    (2, 'default')
    """
    if window_size is not None:
        check_image_memory(check_window_size(window_size), model if isinstance(model, str) else "")
    warn_unused_lights(lights, model)
    r = Renderer(grid, transfer_function=transfer_function, scalars=scalars, component=component,
                 lights=lights, preference=preference, nan_policy=nan_policy)
    return r.render(camera=camera, window_size=window_size, model=model, **options)
