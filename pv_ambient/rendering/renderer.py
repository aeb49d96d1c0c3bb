"""``render(grid, ...)`` and the :class:`Renderer` that keeps per-scene caches.

Data flows one way (docs/architecture.rst): ImageData → arrays (:mod:`pv_ambient.inputs.grid`) →
optical properties (:mod:`pv_ambient.inputs.transfer`) → per-light / per-radius volumes and solves
(:mod:`pv_ambient.stages`, cached in the renderer's :class:`~pv_ambient.rendering.cache.SceneCache`)
→ image (:mod:`pv_ambient.backend`). A render's arguments are checked once into a frozen
:class:`RenderRequest`; ``auto`` is decided in :meth:`Renderer.choose_model`; so moving the camera
re-runs only the ray cast.
"""

from __future__ import annotations

import copy
import math
import time
import warnings

import numpy as np

from ..backend import BACKENDS, blas_one_thread, resolve_backend, run_raycast
from ..inputs.camera import as_camera
from ..inputs.grid import Volume, volume_from_image
from ..inputs.lights import POINT, as_lights, needs_camera, pack_lights
from ..inputs.transfer import as_transfer_function
from .._kernels import records as K
from ..inputs.validation import check_bool, check_choice, check_int, check_real, check_rgb, check_window_size
from ..stages.reference import EQ_RADIUS, RR_DEPTH, Accumulator, relative_error
from ..stages.refine import held_out_z, threshold_correction
from .cache import SceneCache
from .presets import (
    ALL_MODELS,
    ACCURATE_DIFFUSION,
    BUDGET_MAX_SPP,
    CONTROL_STEP_FRACTION,
    DEFAULT_PROGRESSIVE_BASE,
    DEFAULT_PROPAGATION,
    DEFAULT_SPP,
    ERT,
    MAJORANT_BLOCK,
    MODEL_OPTIONS,
    MODEL_SPECS,
    MODEL_TABLE,
    PROGRESSIVE_BASES,
    PROPAGATION_MODES,
    QUALITIES,
    QUALITY_PRESETS,
    step_for,
)
from .request import (RenderRequest, check_image_memory, check_ray_end, check_thickness, compile_notice, given_options,
                      stage_bar, warn_black, warn_unused_lights, warn_unused_options)
from .result import RenderResult
from .stages import NO_GRID, SceneStages

#: The ray-cast models' kernel ids (from the model table).
MODEL_IDS = {m.name: m.kernel_id for m in MODEL_TABLE if m.kernel_id is not None}


class Renderer(SceneStages):
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
        check_choice(backend, "backend", BACKENDS)
        self.backend = backend
        self.volume = grid if isinstance(grid, Volume) else volume_from_image(grid, preference=preference)
        check_thickness(self.volume.geometry, getattr(grid, "dimensions", None))
        self.transfer_function = as_transfer_function(transfer_function)
        t = time.perf_counter()
        with stage_bar(None, "classify"):
            self.optics = self.transfer_function.resolve(self.volume, scalars=scalars, component=component,
                                                         nan_policy=nan_policy)
        self.timings = {"classify": time.perf_counter() - t}
        self.set_lights(lights)
        self.cache = SceneCache()
        self._device = None  # backend.DeviceCache once the CUDA backend has run

    def __getstate__(self):
        # the GPU-resident copies stay behind: a renderer sent to another process (a Dask worker)
        # uploads what it needs there
        state = self.__dict__.copy()
        state["_device"] = None
        return state

    def with_optics(self, optics) -> "Renderer":
        """A renderer of the same volume, lights and backend with other optical properties
        (``pv_ambient.inputs.transfer.Optics``) of the same σt: it starts from this renderer's
        σt-only cache entries (majorant, light grids, optical depths) and shares its GPU cache."""
        other = copy.copy(self)
        other.optics = optics
        other.cache = self.cache.with_sigma_only()
        other.timings = {}
        return other

    @property
    def device_cache(self):
        """The :class:`pv_ambient.backend.DeviceCache` of the CUDA backend (created on first use)."""
        if self._device is None:
            from ..backend import DeviceCache

            self._device = DeviceCache()
        return self._device

    @property
    def geometry(self):
        return self.volume.geometry

    @property
    def bounds(self):
        return self.geometry.bounds

    def default_step(self, quality="balanced") -> float:
        """The ray step of a quality preset (world units)."""
        return step_for(quality, np.min(self.geometry.spacing))

    def set_lights(self, lights):
        """Replace the lights; cached volumes of lights that stay are kept (a relight). None: the
        default rig, placed at the next lit render from its camera (as pyvista head and camera
        lights are)."""
        self.light_rig = "default" if lights is None else "given"
        self._lights_pending = needs_camera(lights)
        self._light_spec = lights if self._lights_pending else None
        self.lights = () if self._lights_pending else as_lights(lights, center=self._center())

    def place_lights(self, camera):
        """Place lights that wait for a camera (the default rig, pyvista head/camera lights) with
        ``camera``, once; returns :attr:`lights`. Every lit render calls it with its camera."""
        if self._lights_pending:
            self.lights = as_lights(self._light_spec, center=self._center(), camera=camera)
            self._lights_pending, self._light_spec = False, None
        return self.lights

    def _center(self):
        return np.reshape(np.asarray(self.bounds, dtype=float), (3, 2)).mean(axis=1)

    def choose_model(self, request) -> tuple:
        """The model a request renders and the options the choice adds: ``auto``'s rules (listed in
        :meth:`render`) decided in this one place; any other model stands for itself."""
        if request.model != "auto":
            return request.model, {}
        grid = self.light_grid(request.light_resolution)
        if not self.optics.has_scattering:
            model = "single_scattering"  # emission only: no light volumes are built (no scattering)
        elif not self.active_lights(grid, request.backend):
            model = "single_scattering"
        else:
            model = "ambient_scattering" if request.quality == "preview" else "diffusion"
        if request.time_budget is not None and model != "single_scattering":
            from ..stages.denoise import available

            extra = {"time_limit": request.time_budget, "denoise": request.options.get("denoise", available())}
            if "samples_per_pixel" not in request.explicit:
                extra["samples_per_pixel"] = BUDGET_MAX_SPP
            return "path_traced", extra
        if model == "diffusion" and request.quality == "accurate":
            return model, {k: request.options.get(k, v) for k, v in ACCURATE_DIFFUSION.items()}
        return model, {}

    def render(self, *, camera=None, window_size=None, model="emission_absorption", quality="balanced", step=None,
               jitter=False, seed=0, background=(0.0, 0.0, 0.0), early_termination=ERT, phase=None,
               progress_bar=None, radius=None, light_resolution=None, ambient_radiance=1.0,
               propagation=DEFAULT_PROPAGATION, table_quality=None, ray_end=None, backend=None,
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
               diffusion for the rest, and with ``quality="preview"`` ``ambient_scattering`` (an
               isotropic phase function uses a 1D table slice: D does not depend on θ).
               Diffusion has the lower error at a similar camera-move cost, ambient
               scattering's "preview" the cheapest first frame that carries multiply scattered
               light, the sweeps the lowest error of the noise-free models (block error ≤ 0.14
               on six scenes against 0.35 flux-limited alone, docs/diffusion.rst §5; first
               frame 2–4× flux-limited diffusion's);
            5. with ``time_budget=SECONDS`` (a still image): ``path_traced`` with as many samples
               per pixel as fit in the budget (``samples_per_pixel`` is then the cap, default
               4096), denoised when ``pyoidn`` is installed — the path tracer reaches a
               noise-free model's error in less time than that model's first frame on all but
               two rows of the trade benchmark (README, "The trade"). The denoiser's time (one emission–absorption frame for its
               guide, then OIDN) comes on top of the budget.
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
            spacings for ambient scattering (the measured best, ``DEFAULT_RADIUS_VOXELS``) and 4
            for ambient occlusion. A string like ``"4 voxels"`` gives it in units of the largest spacing.
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
        **model_options
            Knobs of other models (see ``MODEL_OPTIONS``); unknown names are an error.

        Notes
        -----
        A point light's fall-off ``I/d²`` is clamped at ``d = step/4`` (a sample closer than a
        quarter step to the light cannot resolve the singularity).
        """
        req = self.request(camera=camera, window_size=window_size, model=model, quality=quality, step=step,
                           jitter=jitter, seed=seed, background=background, early_termination=early_termination,
                           phase=phase, progress_bar=progress_bar, radius=radius, light_resolution=light_resolution,
                           ambient_radiance=ambient_radiance, propagation=propagation, table_quality=table_quality,
                           ray_end=ray_end, backend=backend, **model_options)
        return self.render_request(req)

    def request(self, *, camera=None, window_size=None, model="emission_absorption", quality="balanced", step=None,
                jitter=False, seed=0, background=(0.0, 0.0, 0.0), early_termination=ERT, phase=None,
                progress_bar=None, radius=None, light_resolution=None, ambient_radiance=1.0,
                propagation=DEFAULT_PROPAGATION, table_quality=None, ray_end=None, backend=None,
                **model_options) -> "RenderRequest":
        """Check :meth:`render`'s arguments once into a frozen :class:`RenderRequest` (same parameters)."""
        from ..inputs.phase import as_phase
        from ..stages.propagation import default_factor

        cam, size = as_camera(camera, window_size=window_size, bounds=self.bounds)
        check_choice(model, "model", ALL_MODELS)
        check_image_memory(size, model)
        given = given_options(radius=radius, propagation=propagation, ambient_radiance=ambient_radiance)
        check_choice(quality, "quality", QUALITIES)
        check_choice(propagation, "propagation", PROPAGATION_MODES)
        preset = QUALITY_PRESETS[quality]
        if table_quality is None:
            table_quality = preset["table_quality"]
        check_choice(table_quality, "table_quality", QUALITIES)
        if light_resolution is None and preset["light_resolution"] is not None:
            light_resolution = max(preset["light_resolution"],
                                   default_factor(self.optics, self.geometry) if quality == "accurate" else 0.0)
        explicit = frozenset(model_options) | given
        model_options.setdefault("samples_per_pixel", preset["samples_per_pixel"])
        unknown = set(model_options) - MODEL_OPTIONS
        if unknown:
            raise TypeError(f"render() got unknown options {sorted(unknown)}; model options are {sorted(MODEL_OPTIONS)}")
        if step is None:
            step = step_for(quality, np.min(self.geometry.spacing))
        else:
            step = check_real(step, "step", lo=0.0, lo_open=True)
        asked = self.backend if backend is None else check_choice(backend, "backend", BACKENDS)
        budget = model_options.pop("time_budget", None)
        if budget is not None:
            budget = check_real(budget, "time_budget", lo=0.0, lo_open=True)
            if model != "auto":
                raise ValueError(f"time_budget chooses the model: use it with model='auto', not {model!r}")
        for flag in ("denoise", "unbiased"):  # a bool, not 0/1 or a string that happens to compare equal
            if flag in model_options:
                model_options[flag] = check_bool(model_options[flag], flag)
        if "sweep_orders" in model_options:
            check_int(model_options["sweep_orders"], "sweep_orders", lo=0)
        if model in ("path_traced", "progressive") and ray_end is not None:
            raise ValueError(f"ray_end (opaque geometry) is supported by the ray-cast models, not by {model}")
        if "base_model" in model_options:
            check_choice(model_options["base_model"], "base_model", PROGRESSIVE_BASES)
        return RenderRequest(
            camera=cam, window_size=size, model=model, quality=quality, step=step, jitter=bool(jitter),
            seed=check_int(seed, "seed", lo=0), background=check_rgb(background, "background"),
            early_termination=check_real(early_termination, "early_termination", lo=0.0, hi=1.0),
            ambient_radiance=check_real(ambient_radiance, "ambient_radiance", lo=0.0), phase=as_phase(phase),
            radius=self._radius(radius, model), t_end=check_ray_end(ray_end, size), light_resolution=light_resolution,
            table_quality=table_quality, propagation=propagation, bake_lights=bool(preset["bake_lights"]), asked=asked,
            progress_bar=None if progress_bar is None else bool(progress_bar),
            backend=resolve_backend(asked), time_budget=budget, options=dict(model_options), explicit=explicit)

    def render_request(self, req: "RenderRequest") -> RenderResult:
        """Render a checked :class:`RenderRequest` (what :meth:`render` does after checking)."""
        if MODEL_SPECS[req.model].lit:
            self.place_lights(req.camera)
        model, extra = self.choose_model(req)
        compile_notice(model)
        warn_unused_options(req, model)
        options = {**req.options, **extra}
        with blas_one_thread():  # no spinning BLAS workers beside the Numba kernels (backend.py)
            if model == "path_traced":
                res = self._path_trace(req, options)
            elif model == "progressive":
                res = self._progressive(req, options)
            else:
                res = self._render(req, model, options)
        if MODEL_SPECS[req.model].lit:
            res.metadata["light_rig"] = self.light_rig
            warn_black(self, res, req.background)
        return res

    def _render(self, req, model, model_options, records=None):
        """A ray-cast model's picture; ``records``: a list to receive the kernel's records (the
        model id and the records after it), when there is a medium to march."""
        t_start = time.perf_counter()
        cam, size, step, radius, ph = req.camera, req.window_size, req.step, req.radius, req.phase
        backend, progress_bar = req.backend, req.progress_bar
        grid = self.light_grid(req.light_resolution) if model != "emission_absorption" else None
        w, h = size
        rad = np.zeros((h, w, 3), np.float32)
        alpha = np.zeros((h, w), np.float32)
        lit = MODEL_SPECS[model].lit and bool(self.lights)
        # the optical-depth volumes are computed (and cached) while the active lights are sorted out
        with stage_bar(progress_bar if lit else False, f"light volumes ({len(self.lights)} lights)") as bar:
            lights = self.active_lights(grid, backend) if lit else ()
            if model in ("single_scattering", "diffusion") and not self.optics.has_scattering:
                lights = ()
            taus = [self.optical_depth(lt, grid, backend) for lt in lights]
            bar.update()
        inner = progress_bar is True  # the stages' own bars (table nodes, solver iterations)
        ball = self.ball_grid(radius) if MODEL_SPECS[model].ball else K.NONE4
        D, a_nodes, lo_log, dlog = K.NONE3, K.NONE1, 0.0, 1.0
        phi = K.NONE4
        if model == "ambient_scattering" and lights:
            with stage_bar(progress_bar if not inner else False, "preintegrated table"):
                tab = self.table(ph, radius, quality=req.table_quality, progress_bar=inner)
            D, F_diff, a_nodes, lo_log, dlog = tab.lookup_args()
            if req.propagation == "tube":
                phi = self.stacked("front_stack", lights, grid,
                                   [self.front_depth(lt, grid, radius, ph, req.table_quality) for lt in lights],
                                   extra=(float(radius), self._table_key(ph, radius, req.table_quality)))
            else:
                phi = None  # the τ grids themselves, read at the ball's entry point
        diff = K.NONE12
        if model == "diffusion" and lights:
            with stage_bar(progress_bar, "diffusion solve") as bar:
                diff = self.diffusion(lights, grid, ph, flux_limited=model_options.get("flux_limited", False),
                                      progress_bar=inner, backend=backend,
                                      sweep_orders=model_options.get("sweep_orders", 0))
                info = getattr(self, "_diffusion_info", None) or {}
                if "residual" in info:
                    bar.set_postfix_str(f"{info['iterations']} iterations, residual {info['residual']:.2g}")
                bar.update()
        seed, bg, ert, amb, t_end, jitter, asked = (req.seed, req.background, req.early_termination,
                                                    req.ambient_radiance, req.t_end, req.jitter, req.asked)
        d2min = (0.25 * step) ** 2
        # isotropic phase: the lights' in-scattering does not depend on the view; bake it once
        bake = bool(req.bake_lights and lights and ph.canonical()[2])
        t_prep = time.perf_counter() - t_start
        if not self.geometry.is_empty:
            tau = self.stacked("tau_stack", lights, grid, taus) if taus else K.NONE4
            lg = grid if grid is not None else NO_GRID
            lrec = K.lights_of(pack_lights(lights), ph, d2min)
            grec = K.LightGrid(lg.lo, lg.inv_step, tau, tau if phi is None else phi, K.NONE4, 0)
            arec = K.Ambient(radius, ball, amb, D, a_nodes, lo_log, dlog)
            kernel_model = MODEL_IDS[model]
            if bake:
                tkey = self._table_key(ph, radius, req.table_quality) if model == "ambient_scattering" else None
                # diffusion's φ/4π joins the bake where the light-grid nodes are the data samples
                # (then exactly: trilinear interpolation is linear); the march is single scattering's
                fold = model == "diffusion" and grid.on_samples(self.optics.field.shape)
                dkey = ((bool(model_options.get("flux_limited", False)), fold)
                        + ((int(model_options["sweep_orders"]),) if model_options.get("sweep_orders", 0) else ())
                        if model == "diffusion" else None)
                with stage_bar(progress_bar, "baked in-scattering") as bar:
                    inc = self.incident(MODEL_IDS[model], lights, grid, (lrec, grec, arec),
                                        (model, d2min, radius, tkey, req.propagation, ph.canonical(), dkey),
                                        diffusion=diff if fold else None)
                    bar.update()
                grec = grec._replace(inc=inc[0], baked=inc[1])
                if fold:
                    kernel_model = MODEL_IDS["single_scattering"]
            t_prep = time.perf_counter() - t_start
            # the kernel's records (pv_ambient._kernels.records), after the model id
            args = (kernel_model,
                    K.view_of(cam, size, self.geometry),
                    K.March(step, bool(jitter), seed, ert, bg, t_end),
                    K.medium_of(self.optics, self.majorant(), MAJORANT_BLOCK),
                    lrec, grec, arec,
                    K.Diffusion(diff, float(ph.mean_cosine)))
            if records is not None:
                records.append(args)
            with stage_bar(progress_bar if not inner else False, f"ray cast ({model})"):
                backend = run_raycast(args, rad, alpha, backend=backend, asked=asked,
                                      device_cache=self.device_cache if backend == "cuda" else None,
                                      progress_bar=inner, name=f"ray cast ({model})")
        else:
            rad[:] = bg
        meta = {"model": model, "requested_model": req.model, "quality": req.quality, "step": step,
                "window_size": size, "jitter": jitter, "seed": seed, "backend": backend,
                "device_memory": self._device.nbytes if backend == "cuda" else 0,
                "lights": len(lights), "radius": radius, "phase": repr(ph),
                "propagation": req.propagation if model == "ambient_scattering" else None,
                "baked_lights": bake,
                "flux_limited": bool(model_options.get("flux_limited", False)) if model == "diffusion" else None,
                "sweep_orders": int(model_options.get("sweep_orders", 0)) if model == "diffusion" else None,
                "diffusion_solver": getattr(self, "_diffusion_info", None) if model == "diffusion" else None,
                "light_grid": None if grid is None else grid.shape,
                "time_prepare": t_prep, "time_render": time.perf_counter() - t_start - t_prep,
                "early_termination": ert}
        return RenderResult(radiance=rad, alpha=alpha, camera=cam, metadata=meta)

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
        from ..stages.reference import path_trace

        cam, size = as_camera(camera, window_size=window_size, bounds=self.bounds)
        check_image_memory(size, "path_traced")
        self.place_lights(cam)
        block = check_int(majorant_block, "majorant_block", lo=1)
        asked = self.backend if backend is None else check_choice(backend, "backend", BACKENDS)
        backend = resolve_backend(asked)
        out = path_trace(self.geometry, self.optics, self.majorant(block), self.lights, cam, size, block=block,
                         phase=phase, samples_per_pixel=samples_per_pixel, target_error=target_error,
                         max_depth=max_depth, seed=seed, background=background, progress_bar=progress_bar,
                         batch=batch, light_clamp=light_clamp, rr_depth=rr_depth, backend=backend,
                         time_limit=time_limit, device_cache=self.device_cache if backend == "cuda" else None,
                         equiangular=equiangular, first_sample=first_sample)
        reached, target = out.metadata.get("relative_error"), out.metadata.get("target_error")
        if target is not None and time_limit is None and not reached <= target:
            warnings.warn(f"target_error={target:g} was not reached: the relative error is {reached:.3g} after "
                          f"{out.metadata['spp']} samples per pixel (samples_per_pixel={samples_per_pixel} is the "
                          f"cap; the error falls as 1/√samples, so about "
                          f"{int(np.ceil(out.metadata['spp'] * (reached / target) ** 2))} would reach it)",
                          UserWarning, stacklevel=2)
        return RenderResult(radiance=out.radiance, alpha=out.alpha, camera=cam, metadata=out.metadata,
                            std_error=out.std_error)

    def _path_trace(self, req, options):
        denoise = options.get("denoise", False)
        if denoise:
            from ..stages.denoise import denoise_radiance, require

            require()  # the ImportError that names the extra
        with stage_bar(False if req.progress_bar else req.progress_bar, "path-traced samples"):
            res = self.path_trace(req.camera, req.window_size, phase=req.phase,
                                  samples_per_pixel=options.get("samples_per_pixel", DEFAULT_SPP),
                                  target_error=options.get("target_error"), max_depth=options.get("max_depth"),
                                  seed=req.seed, background=req.background, progress_bar=req.progress_bar is True,
                                  light_clamp=0.25 * req.step, backend=req.backend,
                                  time_limit=options.get("time_limit"))
        if "time_limit" in options:
            res.metadata["requested_model"] = "auto"
            res.metadata["time_budget"] = options["time_limit"]
        res.metadata.setdefault("time_prepare", 0.0)
        res.metadata.setdefault("time_render", res.metadata.get("time", 0.0))
        res.metadata["denoised"] = bool(denoise)
        if denoise:
            t = time.perf_counter()
            # albedo guide (first-collision albedo × coverage, noise-free) and mean preservation:
            # measured in pv_ambient.stages.denoise; std_error stays the un-denoised one
            res.radiance = denoise_radiance(res.radiance, albedo=self.albedo_guide(req.camera, req.window_size,
                                                                                   step=req.step))
            res.metadata["denoise_guide"] = "albedo"
            res.metadata["time_denoise"] = time.perf_counter() - t
            res.metadata["time_render"] += res.metadata["time_denoise"]
        return res

    def _progressive(self, req, options):
        """The ``progressive`` model (docs/progressive.rst): the noise-free ``base_model``'s picture
        at zero samples; after that, the same model marched at ``CONTROL_STEP_FRACTION`` of the step
        plus the mean of ``samples_per_pixel`` residual path samples, that model's source at each
        path's first collision as a control variate (:mod:`pv_ambient._kernels.residual`). Both
        pictures of a view are cached (the interactive mode's refinement passes add samples to
        one view without marching it again)."""
        from ..stages.reference import path_trace

        t_start = time.perf_counter()
        base = options.get("base_model", DEFAULT_PROGRESSIVE_BASE)
        base_options = {k: options[k] for k in ("flux_limited", "sweep_orders") if k in options}
        if base == "diffusion" and req.quality != "preview":  # the sweeps and flux limiting, as auto's accurate
            base_options = {**ACCURATE_DIFFUSION, **base_options}
        cam, size = req.camera, req.window_size
        key = ("progressive_base", base, tuple(sorted(base_options.items())), tuple(self.lights),
               np.asarray(cam.params(size), np.float64).tobytes(), tuple(size), req.step, req.radius,
               req.propagation, req.phase.canonical(), req.light_resolution, req.table_quality, req.bake_lights,
               req.early_termination, req.background.tobytes(), req.backend,
               (req.jitter, req.seed if req.jitter else None))  # (the seed moves a jittered march)
        spp = check_int(options.get("samples_per_pixel", DEFAULT_SPP), "samples_per_pixel", lo=0)
        cached = key in self.cache
        if cached:
            nf, records, control_image = self.cache[key]
        else:
            records = []
            nf = self._render(req, base, base_options, records=records)
            control_image = None
        if control_image is None and records and spp > 0:  # the first samples: the control's picture
            # N' of docs/progressive.rst, marched once per view at CONTROL_STEP_FRACTION of the step:
            # the samples correct it to the transfer equation's answer up to its quadrature error
            args = list(records[0])
            lrec = args[4]
            # the control's point lights: I/d² clamped at the equiangular radius (the path tracer
            # samples the singular part near a light; the control stays smooth there); for a light
            # farther than rc from the box the clamp changes nothing
            rc = EQ_RADIUS * self.geometry.diagonal
            points = np.asarray(lrec.vec)[np.asarray(lrec.kind) == POINT]
            if len(points) and rc * rc > lrec.d2min and float(np.min(self.geometry.distance_to(points))) < rc:
                args[4] = lrec._replace(d2min=rc * rc)
            args[2] = args[2]._replace(step=args[2].step * CONTROL_STEP_FRACTION)
            args = tuple(args)
            w, h = req.window_size
            control_image = np.zeros((h, w, 3), np.float32)
            run_raycast(args, control_image, np.zeros((h, w), np.float32), backend=req.backend,
                        asked=req.asked, device_cache=self.device_cache if req.backend == "cuda" else None,
                        progress_bar=False, name="ray cast (control)")
            records = [args]
        for old in list(self.cache.keys("progressive_base")):
            if old != key:
                del self.cache[old]  # one view at a time: a camera move replaces it
        self.cache[key] = (nf, records, control_image)
        t_base = time.perf_counter() - t_start
        # this call's own preparation: none when the base picture came from the cache
        meta = dict(nf.metadata, model="progressive", requested_model=req.model, base_model=base,
                    time_base=t_base, time_prepare=0.0 if cached else nf.metadata.get("time_prepare", 0.0))
        if not records or spp == 0:  # the base picture: the first frame (or exact: nothing to march)
            meta.update(spp=0, relative_error=0.0, time_render=time.perf_counter() - t_start - meta["time_prepare"])
            return RenderResult(radiance=nf.radiance, alpha=nf.alpha, camera=cam, metadata=meta,
                                std_error=np.zeros_like(nf.radiance))
        kernel_model, _, _, _, lrec, grec, arec, drec = records[0]
        backend = req.backend
        unbiased, denoise = options.get("unbiased", False), options.get("denoise", False)
        if unbiased and denoise:
            raise ValueError("unbiased=True returns the unbiased picture as it is; denoise=True chooses between it "
                             "denoised and thresholded (docs/progressive.rst): give one of them")
        if denoise:
            from ..stages.denoise import require

            require()  # the ImportError that names the extra
        target = options.get("target_error")

        def trace(n, target_error, first_sample=0):
            return path_trace(self.geometry, self.optics, self.majorant(MAJORANT_BLOCK), self.lights, cam, size,
                              phase=req.phase, samples_per_pixel=n, target_error=target_error,
                              max_depth=options.get("max_depth"), seed=req.seed, background=req.background,
                              progress_bar=req.progress_bar is True, light_clamp=0.25 * req.step, backend=backend,
                              device_cache=self.device_cache if backend == "cuda" else None,
                              control=(kernel_model, lrec, grec, arec, drec), base=control_image,
                              first_sample=first_sample)

        control = control_image.astype(np.float64)
        with stage_bar(False if req.progress_bar else req.progress_bar, "residual samples"):
            if denoise and spp >= 2 * HELD_OUT_MIN_SAMPLES:  # two halves of one seed's samples: the held-out choice
                out = trace(spp // 2, None if target is None else target * math.sqrt(2.0))
                na = out.metadata["spp"]
                other = trace(na if target is not None else spp - na, None, first_sample=na)
                halves = [(control + o.radiance, o.std_error, o.metadata["spp"]) for o in (out, other)]
                acc = Accumulator()
                for o in (out, other):
                    acc.add(o.radiance, o.std_error, o.alpha, samples=o.metadata["spp"])
                std_error = acc.std_error.astype(np.float32)
                out.metadata.update(spp=acc.samples, target_error=target, time=out.metadata["time"] + other.metadata["time"],
                                    relative_error=relative_error(control + acc.mean, acc.std_error, acc.alpha))
                radiance, pm = progressive_picture(nf.radiance, halves, denoise=True)
            else:
                out = trace(spp, target)
                std_error = out.std_error
                estimate = control + out.radiance
                if unbiased:
                    radiance, pm = estimate, dict(kept=1.0, residual="unbiased")
                else:  # the correction where it stands out of its noise (docs/progressive.rst)
                    radiance, pm = progressive_picture(nf.radiance, [(estimate, out.std_error, out.metadata["spp"])])
        radiance = radiance.astype(np.float32)
        meta.update(pm, denoised=pm["residual"] == "denoised")
        meta.update({k: out.metadata[k] for k in ("spp", "seed", "max_depth", "target_error", "relative_error",
                                                  "light_clamp", "rr_depth", "equiangular")})
        meta.update(time_samples=out.metadata["time"], time_render=time.perf_counter() - t_start - meta["time_prepare"])
        return RenderResult(radiance=radiance, alpha=nf.alpha, camera=cam, metadata=meta, std_error=std_error)

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

    def _radius(self, radius, model="ambient_scattering"):
        h = float(np.max(self.geometry.spacing))
        if radius is None:
            return MODEL_SPECS[model].radius_voxels * h
        if isinstance(radius, str):
            parts = radius.split()
            if len(parts) == 2 and parts[1] in ("voxel", "voxels"):
                try:
                    return check_real(float(parts[0]), "radius", lo=0.0) * h
                except ValueError:
                    pass
            raise ValueError(f"radius must be a number (world units) or 'N voxels', got {radius!r}")
        return check_real(radius, "radius", lo=0.0)


def refined_picture(base, estimate, std_error, samples=None):
    """The ``progressive`` model's picture: ``base`` (the noise-free model's) plus the part of the
    correction ``estimate − base`` that stands out of its noise (``std_error``, the estimate's,
    from ``samples`` per pixel), by :func:`pv_ambient.stages.refine.threshold_correction`
    (docs/progressive.rst). Returns the float64 picture and the share of pixel-level details kept.
    With fewer than ``REFINE_MIN_SAMPLES`` samples only the corrections known exactly (no
    variance there nor around) are added.

    >>> import numpy as np
    >>> base = np.zeros((2, 2, 3))
    >>> pic, kept = refined_picture(base, base + 0.25, np.zeros((2, 2, 3)))   # exact: kept in full
    >>> float(pic.mean()), kept
    (0.25, 1.0)
    """
    b = np.asarray(base, dtype=np.float64)
    # fewer than REFINE_MIN_SAMPLES: no detail stands out yet — only the exactly known corrections
    few = samples is not None and int(samples) < REFINE_MIN_SAMPLES
    corr, kept = threshold_correction(np.asarray(estimate, dtype=np.float64) - b,
                                      np.asarray(std_error, dtype=np.float64) ** 2, samples=samples,
                                      threshold=math.inf if few else None)
    return b + corr, kept


#: Samples per pixel before the ``progressive`` model's picture keeps any detail of its correction
#: that is not known exactly (fewer: the base picture, plus the exact corrections). The threshold
#: takes the variances from the samples themselves; a heavy-tailed residual's few samples
#: underestimate them often enough that, on the six scenes of ``benchmarks/progressive.py`` at
#: 2–8 samples, the details kept made the picture worse than its base more often than better
#: (``benchmarks/refine_min.py``; docs/progressive.rst, "The picture shown").
REFINE_MIN_SAMPLES = 16


#: The held-out z statistic (:func:`pv_ambient.stages.refine.held_out_z`) below which the
#: ``progressive`` model's denoised picture replaces its thresholded one: 1 standard error (a
#: one-sided false alarm of 16 % for Gaussian noise where the two are equally good, where the
#: choice costs nothing; a margin against heavy-tailed noise elsewhere; docs/progressive.rst).
HELD_OUT_Z = 1.0
#: Samples per pixel each held-out half needs before the choice is made (fewer: the thresholded
#: picture). With 2–8 samples per pixel a heavy-tailed residual's variances are underestimated
#: and the statistic misleads (docs/progressive.rst, "Denoising": the measured wrong choices).
HELD_OUT_MIN_SAMPLES = 16


def denoise_guide(base) -> np.ndarray:
    """The guide OIDN gets beside a ``progressive`` picture: the base model's noise-free picture
    scaled by its 99th percentile and clipped to [0, 1] (float32) — its edges and shading are the
    picture's, so the denoiser keeps them (docs/progressive.rst, "Denoising").

    >>> import numpy as np
    >>> float(denoise_guide(np.linspace(0.0, 2.0, 300).reshape(10, 10, 3)).max())
    1.0
    """
    b = np.nan_to_num(np.asarray(base, dtype=np.float64), nan=0.0, posinf=0.0, neginf=0.0)
    scale = float(np.percentile(b, 99))
    if scale <= 0.0:
        scale = float(b.max())
    return np.clip(b / scale if scale > 0.0 else np.zeros_like(b), 0.0, 1.0).astype(np.float32)


def progressive_picture(base, halves, *, denoise=False, denoiser=None):
    """The ``progressive`` model's picture from its samples given as up to two independent halves
    ``[(estimate, std_error, samples), ...]`` (``estimate``: the unbiased picture ``P`` of that
    half). Returns ``(picture, metadata)``: the float64 picture and ``kept`` (the share of
    pixel-level details kept), ``residual`` (``"thresholded"`` or ``"denoised"``) and, with
    ``denoise`` and two halves, ``held_out_z`` (the statistic of the choice).

    Without ``denoise`` it is :func:`refined_picture` of all the samples. With it, a second
    candidate is the unbiased ``P`` denoised — ``denoiser(P, guide)``, by default OIDN
    (``pyoidn``) guided by the base picture (:func:`denoise_guide`) — rescaled per channel to
    ``P``'s mean. Both are made again from each half alone, and the denoised one is taken (made
    from all the samples) only when the held-out halves find it closer by more than
    ``HELD_OUT_Z`` standard errors (:func:`pv_ambient.stages.refine.held_out_z`) and each half
    has at least ``HELD_OUT_MIN_SAMPLES`` samples per pixel. Both tend to
    ``P``'s limit as samples grow, so the choice does not change what the picture converges to
    (docs/progressive.rst, "Denoising").

    >>> import numpy as np
    >>> truth = np.linspace(1.0, 2.0, 16 * 16 * 3).reshape(16, 16, 3)
    >>> rng = np.random.default_rng(1)
    >>> halves = [(truth + rng.normal(0, 0.3, truth.shape), np.full(truth.shape, 0.3), 16) for _ in range(2)]
    >>> pic, meta = progressive_picture(0.5 * truth, halves, denoise=True,   # a denoiser that knows the shape
    ...                                 denoiser=lambda p, guide: guide * p.mean() / guide.mean())
    >>> meta["residual"], bool(np.abs(pic - truth).max() < 0.1)
    ('denoised', True)
    """
    b = np.asarray(base, dtype=np.float64)
    if len(halves) == 1:  # one estimate: as it is
        mean, se, samples = halves[0]
    else:
        acc = Accumulator()
        for est, err, n in halves:
            acc.add(est, err, np.zeros(b.shape[:2]), samples=n)
        mean, se, samples = acc.mean, acc.std_error, acc.samples
    picture, kept = refined_picture(b, mean, se, samples=samples)
    meta = dict(kept=kept, residual="thresholded")
    if not denoise or len(halves) != 2 or min(int(h[2]) for h in halves) < HELD_OUT_MIN_SAMPLES:
        return picture, meta
    if denoiser is None:
        from ..stages.denoise import denoise_radiance

        def denoiser(p, guide):
            return denoise_radiance(p, albedo=guide, mean_preserving=False)
    from ..stages.denoise import preserve_mean

    guide = denoise_guide(b)

    def denoised(p):
        d = np.asarray(denoiser(p, guide), np.float64)
        return np.asarray(preserve_mean(d, p), np.float64) if np.all(np.sum(p, axis=(0, 1)) > 0) else d

    (ea, sa, na), (eb, sb, nb) = ((np.asarray(e, np.float64), np.asarray(v, np.float64), int(n)) for e, v, n in halves)
    z = held_out_z((denoised(ea), denoised(eb)),
                   (refined_picture(b, ea, sa, samples=na)[0], refined_picture(b, eb, sb, samples=nb)[0]),
                   (ea, eb), (sa * sa, sb * sb))
    meta["held_out_z"] = z
    if z < -HELD_OUT_Z:
        picture = denoised(mean)
        meta["residual"] = "denoised"
    return picture, meta


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
