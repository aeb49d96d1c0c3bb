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
import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..backend import BACKENDS, resolve_backend
from ..inputs.camera import as_camera
from ..inputs.grid import Volume, volume_from_image
from ..inputs.lights import as_lights, pack_lights
from ..inputs.transfer import as_transfer_function
from .._kernels import records as K
from ..inputs.validation import check_choice, check_int, check_real, check_rgb
from ..stages.reference import RR_DEPTH
from .cache import SceneCache
from .presets import (
    ALL_MODELS,
    BUDGET_MAX_SPP,
    DEFAULT_PROPAGATION,
    DEFAULT_SPP,
    ERT,
    MAJORANT_BLOCK,
    MODEL_OPTIONS,
    MODEL_SPECS,
    MODEL_TABLE,
    PROPAGATION_MODES,
    QUALITIES,
    QUALITY_PRESETS,
    TAU_OPAQUE,
    step_for,
)
from .result import RenderResult

#: The ray-cast models' kernel ids (from the model table).
MODEL_IDS = {m.name: m.kernel_id for m in MODEL_TABLE if m.kernel_id is not None}


def _tiles(n, count):
    edges = np.linspace(0, n, min(count, n) + 1).astype(int)
    return list(zip(edges[:-1], edges[1:]))


class _NoGrid:
    lo = np.zeros(3)
    inv_step = np.zeros(3)


_NO_GRID = _NoGrid()


class Renderer:
    """A volume, its transfer function and lights, with caches that survive camera moves.

    Parameters
    ----------
    grid : pyvista.ImageData, vtkImageData or pv_ambient.inputs.grid.Volume
        The volume. Never modified.
    transfer_function : TransferFunction, dict, vtkVolumeProperty or volume actor, optional
        How scalars become optical properties; PyVista's defaults when None.
    scalars : str, optional
        Array to classify (the active scalars when None).
    component : int, optional
        Component of a multi-component array (magnitude when None).
    lights : sequence of PointLight, DirectionalLight or dict, optional
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

    def __init__(self, grid, *, transfer_function=None, scalars=None, component=None, lights=(),
                 preference="point", nan_policy="raise", backend="auto"):
        check_choice(preference, "preference", ("point", "cell"))
        check_choice(backend, "backend", BACKENDS)
        self.backend = backend
        self.volume = grid if isinstance(grid, Volume) else volume_from_image(grid, preference=preference)
        self.transfer_function = as_transfer_function(transfer_function)
        t = time.perf_counter()
        self.optics = self.transfer_function.resolve(self.volume, scalars=scalars, component=component,
                                                     nan_policy=nan_policy)
        self.timings = {"classify": time.perf_counter() - t}
        self.lights = as_lights(lights)
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
        """Replace the lights; cached volumes of lights that stay are kept (a relight)."""
        self.lights = as_lights(lights)

    def majorant(self, block=MAJORANT_BLOCK):
        """Upper bound of σt over each block of (``block``)³ samples (cached)."""
        key = ("majorant", block)
        if key not in self.cache:
            from .._kernels.majorant import build_majorant

            o = self.optics
            shape = tuple(max(1, -(-(n - 1) // block)) for n in o.field.shape)
            maj = np.zeros(shape, np.float32)
            build_majorant(o.mode, o.field, o.table, o.lut_lo, o.lut_inv, block, maj)
            self.cache[key] = maj
        return self.cache[key]

    # -- cached stages ---------------------------------------------------------------------
    def light_grid(self, light_resolution=None):
        """The light grid for a resolution factor (docs/ambient_scattering.rst §3 default when None)."""
        from ..stages.propagation import default_factor, make_light_grid

        f = default_factor(self.optics, self.geometry) if light_resolution is None else light_resolution
        key = ("light_grid", float(f))
        if key not in self.cache:
            self.cache[key] = make_light_grid(self.geometry, f)
        return self.cache[key]

    def sigma_on_light_grid(self, grid):
        from ..stages.propagation import sigma_on_grid

        key = ("sigma_l", grid.key())
        if key not in self.cache:
            self.cache[key] = sigma_on_grid(self.optics, grid)
        return self.cache[key]

    def optical_depth(self, light, grid, backend="cpu"):
        """τ from ``light`` on ``grid`` (cached per light: a relight recomputes only that light),
        swept on ``backend`` (``"cpu"`` or ``"cuda"``) when not cached."""
        from ..stages.propagation import optical_depth

        key = ("tau", light, grid.key())
        if key not in self.cache:
            t = time.perf_counter()
            dev = self.device_cache if backend == "cuda" else None
            self.cache[key] = optical_depth(self.sigma_on_light_grid(grid), grid, self.geometry, light,
                                             device_cache=dev)
            self.timings[f"light volume {light}"] = time.perf_counter() - t
        return self.cache[key]

    def _scattering_nodes(self, grid):
        """Light-grid node indices (nearest node) of the data samples that scatter (σt·albedo > 0)."""
        key = ("scattering_nodes", grid.key())
        if key not in self.cache:
            sig = self.optics.sigma_grid()
            alb = self.optics.albedo_grid()
            mask = (sig > 0) & (alb.max(axis=-1) > 0)
            idx = np.nonzero(mask)
            nodes = tuple(np.clip(np.rint((i - grid.lo[a]) * grid.inv_step[a]).astype(np.intp), 0, grid.shape[a] - 1)
                          for a, i in enumerate(idx))
            self.cache[key] = nodes
        return self.cache[key]

    def active_lights(self, grid, backend="cpu"):
        """Lights that reach the scattering medium: non-zero power, and optical depth below
        ``TAU_OPAQUE`` at some sample that scatters (σt·albedo > 0)."""
        out = []
        nodes = self._scattering_nodes(grid)
        if nodes[0].size == 0:
            return ()
        for lt in self.lights:
            if max(lt.power) <= 0.0:
                continue
            if float(np.min(self.optical_depth(lt, grid, backend)[nodes])) > TAU_OPAQUE:
                continue
            out.append(lt)
        return tuple(out)

    def ball_grid(self, radius):
        """σ̄ (mean extinction over the ball of world radius ``radius``) and the ball's mean albedo
        ā = mean(σs)/σ̄ per channel, at every data sample: float32 (nx, ny, nz, 4)."""
        key = ("ball", float(radius))
        if key not in self.cache:
            from ..stages.sat import mean_extinction

            sig = self.optics.sigma_grid()
            alb = self.optics.albedo_grid()
            sp = self.geometry.spacing
            out = np.zeros(sig.shape + (4,), np.float32)
            out[..., 0] = mean_extinction(sig, sp, radius)
            for c in range(3):
                if c > 0 and np.array_equal(alb[..., c], alb[..., c - 1]):
                    out[..., 1 + c] = out[..., c]  # grey albedo: one box mean serves every channel
                    continue
                ms = mean_extinction(np.ascontiguousarray(sig * alb[..., c]), sp, radius)
                with np.errstate(divide="ignore", invalid="ignore"):
                    out[..., 1 + c] = np.where(out[..., 0] > 0, np.clip(ms / out[..., 0], 0.0, 1.0), 0.0)
            self.cache[key] = out
        return self.cache[key]

    def albedo_range(self, radius):
        """(min, max) of the ball-mean albedo ā over the medium (where σ̄ > 0), all channels."""
        ball = self.ball_grid(radius)
        inside = ball[..., 0] > 0
        if not inside.any():
            return 0.0, 0.0
        a = ball[..., 1:4][inside]
        return float(a.min()), float(a.max())

    def _table_key(self, phase, radius, quality):
        from ..stages.preintegration import albedo_nodes_for

        lo, hi = self.albedo_range(radius)
        # keyed on the albedo nodes the range needs: nearby ranges share one slice
        return ("table", phase.kind, float(phase.g), tuple(albedo_nodes_for(lo, hi).tolist()), quality)

    def table(self, phase, radius, quality="balanced", progress_bar=False):
        """The preintegrated D/F slice for ``phase`` and the albedo range the scene needs (cached)."""
        from ..stages.preintegration import get_table

        key = self._table_key(phase, radius, quality)
        if key not in self.cache:
            lo, hi = self.albedo_range(radius)
            t = time.perf_counter()
            self.cache[key] = get_table(phase, albedo_range=(lo, hi), quality=quality, progress_bar=progress_bar)
            self.timings["table"] = time.perf_counter() - t
        return self.cache[key]

    def front_depth(self, light, grid, radius, phase, quality="balanced"):
        """Tube-mode front optical depth per channel, (m0, m1, m2, 3) float32 (cached per light, r, table)."""
        from ..stages.propagation import optical_depth, tube_extinction

        key = ("front", light, grid.key(), float(radius), self._table_key(phase, radius, quality))
        if key not in self.cache:
            table = self.table(phase, radius, quality)
            t = time.perf_counter()
            rho = tube_extinction(self._ball_on_light_grid(radius, grid), grid, radius, table)
            out = np.empty_like(rho)
            for c in range(3):
                out[..., c] = optical_depth(np.ascontiguousarray(rho[..., c]), grid, self.geometry, light)
            self.cache[key] = out
            self.timings[f"front volume {light}"] = time.perf_counter() - t
        return self.cache[key]

    def _ball_on_light_grid(self, radius, grid):
        """The ball grid with σ̄ averaged over the part of the ball inside the grid.

        The tube march (docs/ambient_scattering.rst §3) starts where the light enters the medium, so its balls never
        straddle the entry face; averaging over the inside part gives the continuous march the
        same property (homogeneous medium, albedo 0: Φ equals Beer–Lambert exactly).
        """
        key = ("ball_inside", float(radius))
        if key not in self.cache:
            ball = self.ball_grid(radius).copy()
            if radius > 0:
                half = 0.5 * radius * (4.0 * np.pi / 3.0) ** (1.0 / 3.0) / self.geometry.spacing
                frac = np.ones(ball.shape[:3])
                for ax, n in enumerate(ball.shape[:3]):
                    i = np.arange(n, dtype=np.float64)
                    inside = np.clip(np.minimum(i + half[ax], n - 0.5) - np.maximum(i - half[ax], -0.5), 0.0, None)
                    shape = [1, 1, 1]
                    shape[ax] = n
                    frac = frac * (inside / (2.0 * half[ax])).reshape(shape)
                ball[..., 0] = (ball[..., 0] / np.maximum(frac, 1e-12)).astype(np.float32)
            self.cache[key] = ball
        return self.cache[key]

    def diffusion(self, lights, grid, phase, flux_limited=False, progress_bar=False, backend="cpu"):
        """Packed (φ, F) per channel of the multiply-scattered light of ``lights`` (docs/diffusion.rst),
        (nx, ny, nz, 12) float32 at the data samples; one solve per light, cached per light, so a
        relight re-solves only the light that changed (warm-started from its previous solution).

        One solve of the summed sources would cost less for the first frame (identical for plain
        diffusion; flux-limited diffusion is not linear, so it differs slightly), but every relight
        would then re-solve all lights (figures: ``benchmarks/results/diffusion_notes.md``).

        σt and albedo are checked and converted once per scene (a ``DiffusionMedium`` cached
        under ``("diffusion_medium",)``); each light's optical depth comes from
        :meth:`optical_depth` on the light grid of ``grid``'s factor."""
        from ..stages.diffusion import DiffusionMedium, solve_for_light

        g = float(phase.mean_cosine)
        total = None
        keys = tuple(("diffusion", lt, grid.key(), g, bool(flux_limited)) for lt in lights)
        if len(keys) > 1 and ("diffusion_sum", keys) in self.cache:
            return self.cache[("diffusion_sum", keys)]  # the same array: it stays on the GPU
        for lt in lights:
            key = ("diffusion", lt, grid.key(), g, bool(flux_limited))
            if key not in self.cache:
                t = time.perf_counter()
                medium = self.cache.get(("diffusion_medium",), lambda: DiffusionMedium.from_arrays(
                    self.optics.sigma_grid(), self.optics.albedo_grid()))
                lgrid = self.light_grid(grid.factor)
                sol = solve_for_light(lt, g, medium=medium, geometry=self.geometry,
                                      tau=self.optical_depth(lt, lgrid, backend), light_grid=lgrid,
                                      flux_limited=bool(flux_limited), progress_bar=progress_bar)
                packed = sol.packed()
                if np.array_equal(packed[..., 0:4], packed[..., 4:8]) and np.array_equal(packed[..., 0:4],
                                                                                       packed[..., 8:12]):
                    packed = np.ascontiguousarray(packed[..., 0:4])  # grey: one channel read per sample
                self.cache[key] = packed
                self.timings[f"diffusion {lt}"] = time.perf_counter() - t
                self._diffusion_info = {"iterations": int(sol.iterations), "residual": float(sol.residual),
                                        "converged": bool(sol.converged)}
            part = self.cache[key]
            if total is not None and total.shape != part.shape:  # grey and coloured lights: all 12
                total, part = (np.tile(a, (1, 1, 1, 3)) if a.shape[3] == 4 else a for a in (total, part))
            total = part if total is None else total + part
        if len(keys) > 1:
            self.cache[("diffusion_sum", keys)] = total
        return total if total is not None else K.NONE12

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
            return model, {"flux_limited": request.options.get("flux_limited", True)}
        return model, {}

    def render(self, *, camera=None, window_size=None, model="emission_absorption", quality="balanced", step=None,
               jitter=False, seed=0, background=(0.0, 0.0, 0.0), early_termination=ERT, phase=None,
               progress_bar=False, radius=None, light_resolution=None, ambient_radiance=1.0,
               propagation=DEFAULT_PROPAGATION, table_quality=None, ray_end=None, backend=None,
               **model_options) -> RenderResult:
        """Render one image.

        Parameters
        ----------
        camera : Camera, pyvista.Camera, pyvista.Plotter, dict or list, optional
            PyVista's default isometric view of the volume when None.
        window_size : (int, int), optional
            ``(width, height)``; the plotter's when a plotter is given, else (512, 512).
        model : str, default: "emission_absorption"
            ``"emission_absorption"``, ``"ambient_occlusion"``, ``"single_scattering"``,
            ``"ambient_scattering"``, ``"path_traced"`` (the Monte Carlo reference,
            :func:`pv_ambient.stages.reference.path_trace`; options ``samples_per_pixel``,
            ``target_error``, ``max_depth``) or ``"auto"``. ``auto`` picks the model the trade
            benchmark measured best for the quality preset, and builds nothing the scene does
            not need, by these rules (each tested):

            1. no scattering (albedo 0 wherever σt > 0): ``single_scattering`` with no light
               volume built — emission and absorption only;
            2. lights with zero intensity, or whose optical depth exceeds 700 at every sample
               that scatters (behind an opaque wall), are dropped (by every model);
            3. no light left: ``single_scattering`` (emission and absorption only);
            4. otherwise ``diffusion``, with ``quality="accurate"`` flux-limited, and with
               ``quality="preview"`` ``ambient_scattering`` (an isotropic phase function uses a
               1D table slice: D does not depend on θ). On all three scenes of the trade
               benchmark plain diffusion has a lower error than ambient scattering (4×4-block
               relative RMSE 0.35 / 0.16 / 0.11 against 0.49 / 0.75 / 0.13) at 0.5–0.7× its
               camera-move cost; its first frame costs 1.2–2.2× ambient scattering's and
               2.4–6.5× that of ambient scattering's "preview", the cheapest first frame that
               carries multiply scattered light; flux-limited diffusion is the lowest-error
               noise-free model (0.22 / 0.17 / 0.06) at a first frame 1.3–2.4× plain
               diffusion's (README, "The trade");
            5. with ``time_budget=SECONDS`` (a still image): ``path_traced`` with as many samples
               per pixel as fit in the budget (``samples_per_pixel`` is then the cap, default
               4096), denoised when ``pyoidn`` is installed — on every row of the trade
               benchmark the path tracer reaches each noise-free model's error in less time
               than that model's first frame (README, "The trade", column "PT same err"). The
               denoiser's time (one emission–absorption frame for its guide, then OIDN) comes
               on top of the budget.
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
        progress_bar : bool, default: False
            Show a tqdm progress bar over image tiles.
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
                progress_bar=False, radius=None, light_resolution=None, ambient_radiance=1.0,
                propagation=DEFAULT_PROPAGATION, table_quality=None, ray_end=None, backend=None,
                **model_options) -> "RenderRequest":
        """Check :meth:`render`'s arguments once into a frozen :class:`RenderRequest` (same parameters)."""
        from ..inputs.phase import as_phase
        from ..stages.propagation import default_factor

        cam, size = as_camera(camera, window_size=window_size, bounds=self.bounds)
        check_choice(model, "model", ALL_MODELS)
        check_choice(quality, "quality", QUALITIES)
        check_choice(propagation, "propagation", PROPAGATION_MODES)
        preset = QUALITY_PRESETS[quality]
        if table_quality is None:
            table_quality = preset["table_quality"]
        check_choice(table_quality, "table_quality", QUALITIES)
        if light_resolution is None and preset["light_resolution"] is not None:
            light_resolution = max(preset["light_resolution"],
                                   default_factor(self.optics, self.geometry) if quality == "accurate" else 0.0)
        explicit = frozenset(model_options)
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
        denoise = model_options.get("denoise", False)
        if denoise not in (True, False):
            raise TypeError(f"denoise must be True or False, got {denoise!r}")
        if model == "path_traced" and ray_end is not None:
            raise ValueError("ray_end (opaque geometry) is supported by the ray-cast models, not by path_traced")
        return RenderRequest(
            camera=cam, window_size=size, model=model, quality=quality, step=step, jitter=bool(jitter),
            seed=check_int(seed, "seed", lo=0), background=check_rgb(background, "background"),
            early_termination=check_real(early_termination, "early_termination", lo=0.0, hi=1.0),
            ambient_radiance=check_real(ambient_radiance, "ambient_radiance", lo=0.0), phase=as_phase(phase),
            radius=self._radius(radius, model), t_end=_ray_end(ray_end, size), light_resolution=light_resolution,
            table_quality=table_quality, propagation=propagation, progress_bar=bool(progress_bar), asked=asked,
            backend=resolve_backend(asked), time_budget=budget, options=dict(model_options), explicit=explicit)

    def render_request(self, req: "RenderRequest") -> RenderResult:
        """Render a checked :class:`RenderRequest` (what :meth:`render` does after checking)."""
        model, extra = self.choose_model(req)
        options = {**req.options, **extra}
        if model == "path_traced":
            return self._path_trace(req, options, requested=req.model)
        return self._render(req, model, options)

    def _render(self, req, model, model_options):
        t_start = time.perf_counter()
        cam, size, step, radius, ph = req.camera, req.window_size, req.step, req.radius, req.phase
        backend, progress_bar = req.backend, req.progress_bar
        grid = self.light_grid(req.light_resolution) if model != "emission_absorption" else None
        w, h = size
        rad = np.zeros((h, w, 3), np.float32)
        alpha = np.zeros((h, w), np.float32)
        lights = self.active_lights(grid, backend) if MODEL_SPECS[model].lit else ()
        if model in ("single_scattering", "diffusion") and not self.optics.has_scattering:
            lights = ()
        taus = [self.optical_depth(lt, grid, backend) for lt in lights]
        ball = self.ball_grid(radius) if MODEL_SPECS[model].ball else K.NONE4
        D, a_nodes, lo_log, dlog = K.NONE3, K.NONE1, 0.0, 1.0
        phi = K.NONE4
        if model == "ambient_scattering" and lights:
            tab = self.table(ph, radius, quality=req.table_quality, progress_bar=progress_bar)
            D, F_diff, a_nodes, lo_log, dlog = tab.lookup_args()
            if req.propagation == "tube":
                phi = np.concatenate([self.front_depth(lt, grid, radius, ph, req.table_quality) for lt in lights],
                                     axis=-1)
            else:
                phi = None  # the τ grids themselves, read at the ball's entry point
        diff = K.NONE12
        if model == "diffusion" and lights:
            diff = self.diffusion(lights, grid, ph, flux_limited=model_options.get("flux_limited", False),
                                  progress_bar=progress_bar, backend=backend)
        seed, bg, ert, amb, t_end, jitter, asked = (req.seed, req.background, req.early_termination,
                                                    req.ambient_radiance, req.t_end, req.jitter, req.asked)
        t_prep = time.perf_counter() - t_start
        if not self.geometry.is_empty:
            tau = np.stack(taus, axis=-1) if taus else K.NONE4
            lg = grid if grid is not None else _NO_GRID
            # the kernel's records (pv_ambient._kernels.records), after the model id
            args = (MODEL_IDS[model],
                    K.view_of(cam, size, self.geometry),
                    K.March(step, bool(jitter), seed, ert, bg, t_end),
                    K.medium_of(self.optics, self.majorant(), MAJORANT_BLOCK),
                    K.lights_of(pack_lights(lights), ph, (0.25 * step) ** 2),
                    K.LightGrid(lg.lo, lg.inv_step, tau, tau if phi is None else phi),
                    K.Ambient(radius, ball, amb, D, a_nodes, lo_log, dlog),
                    K.Diffusion(diff, float(ph.mean_cosine)))
            if backend == "cuda":
                backend = self._run_cuda(args, rad, alpha, asked)
            if backend == "cpu":
                self._run_tiles(args, rad, alpha, progress_bar, model)
        else:
            rad[:] = bg
        meta = {"model": model, "requested_model": req.model, "quality": req.quality, "step": step,
                "window_size": size, "jitter": jitter, "seed": seed, "backend": backend,
                "device_memory": self._device.nbytes if backend == "cuda" else 0,
                "lights": len(lights), "radius": radius, "phase": repr(ph),
                "propagation": req.propagation if model == "ambient_scattering" else None,
                "flux_limited": bool(model_options.get("flux_limited", False)) if model == "diffusion" else None,
                "diffusion_solver": getattr(self, "_diffusion_info", None) if model == "diffusion" else None,
                "light_grid": None if grid is None else grid.shape,
                "time_prepare": t_prep, "time_render": time.perf_counter() - t_start - t_prep,
                "early_termination": ert}
        return RenderResult(radiance=rad, alpha=alpha, camera=cam, metadata=meta)

    def path_trace(self, camera=None, window_size=None, *, phase=None, samples_per_pixel=DEFAULT_SPP,
                   target_error=None, max_depth=None, seed=0, background=(0.0, 0.0, 0.0), progress_bar=False,
                   batch=16, light_clamp=None, majorant_block=MAJORANT_BLOCK, rr_depth=RR_DEPTH, backend=None,
                   time_limit=None) -> RenderResult:
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
            ``light_clamp``, ``rr_depth``, ``time_limit``).

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
        block = check_int(majorant_block, "majorant_block", lo=1)
        asked = self.backend if backend is None else check_choice(backend, "backend", BACKENDS)
        backend = resolve_backend(asked)
        out = path_trace(self.geometry, self.optics, self.majorant(block), self.lights, cam, size, block=block,
                         phase=phase, samples_per_pixel=samples_per_pixel, target_error=target_error,
                         max_depth=max_depth, seed=seed, background=background, progress_bar=progress_bar,
                         batch=batch, light_clamp=light_clamp, rr_depth=rr_depth, backend=backend,
                         time_limit=time_limit, device_cache=self.device_cache if backend == "cuda" else None)
        return RenderResult(radiance=out.radiance, alpha=out.alpha, camera=cam, metadata=out.metadata,
                            std_error=out.std_error)

    def _path_trace(self, req, options, requested):
        denoise = options.get("denoise", False)
        if denoise:
            from ..stages.denoise import available, denoise_radiance

            if not available():
                denoise_radiance(None)  # raises the ImportError that names the extra
        res = self.path_trace(req.camera, req.window_size, phase=req.phase,
                              samples_per_pixel=options.get("samples_per_pixel", DEFAULT_SPP),
                              target_error=options.get("target_error"), max_depth=options.get("max_depth"),
                              seed=req.seed, background=req.background, progress_bar=req.progress_bar,
                              light_clamp=0.25 * req.step, backend=req.backend, time_limit=options.get("time_limit"))
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

    def _run_cuda(self, args, rad, alpha, asked):
        """The ray cast on the GPU; returns the backend that ran ("cpu" after a fallback)."""
        from .. import backend as bk

        try:
            bk.check_fits(self.device_cache, K.arrays(args), rad.nbytes + alpha.nbytes)
        except bk.DeviceMemoryError as exc:
            if asked == "cuda":
                raise
            warnings.warn(f"{exc}; rendering on the CPU instead", RuntimeWarning, stacklevel=4)
            return "cpu"
        bk.raycast(self.device_cache, args, 0, rad.shape[0], rad, alpha)
        return "cuda"

    def _run_tiles(self, args, rad, alpha, progress_bar, name):
        from .._kernels.raycast import raycast_image

        tiles = _tiles(rad.shape[0], 16 if progress_bar else 4)  # Ctrl-C is seen between tiles
        bar = None
        if progress_bar:
            from tqdm.auto import tqdm

            bar = tqdm(total=len(tiles), desc=name, unit="tile")
        try:
            for r0, r1 in tiles:
                raycast_image(*args, r0, r1, rad, alpha)
                if bar is not None:
                    bar.update(1)
        finally:
            if bar is not None:
                bar.close()


@dataclass(frozen=True)
class RenderRequest:
    """One render's inputs, checked (:meth:`Renderer.request`): what the stages and the kernels get.

    Every field is a validated value (a :class:`~pv_ambient.Camera`, a ``(width, height)`` tuple,
    floats, a phase function, arrays); ``options`` holds the model options (``MODEL_OPTIONS``)
    with the preset's ``samples_per_pixel`` filled in, ``explicit`` the option names the caller gave.
    """

    camera: object
    window_size: tuple
    model: str
    quality: str
    step: float
    jitter: bool
    seed: int
    background: np.ndarray
    early_termination: float
    ambient_radiance: float
    phase: object
    radius: float
    t_end: np.ndarray
    light_resolution: float | None
    table_quality: str
    propagation: str
    progress_bar: bool
    asked: str
    backend: str
    time_budget: float | None
    options: dict = field(default_factory=dict)
    explicit: frozenset = frozenset()


def _ray_end(ray_end, size):
    """The ``t_end`` array of the ray-cast driver: (1, 1) inf, or the validated (H, W) ``ray_end``."""
    if ray_end is None:
        return np.full((1, 1), np.inf)
    w, h = size
    arr = np.asarray(ray_end, dtype=np.float64)
    if arr.shape != (h, w):
        raise ValueError(f"ray_end must have shape (height, width) = {(h, w)}, got {arr.shape}")
    if np.isnan(arr).any() or (arr < 0).any():
        raise ValueError("ray_end must hold distances >= 0 (inf where no geometry), found NaN or negative values")
    return np.ascontiguousarray(arr)


def render(grid, *, transfer_function=None, camera=None, window_size=None, lights=(), model="emission_absorption",
           scalars=None, component=None, preference="point", nan_policy="raise", **options) -> RenderResult:
    """Render a volume: the one-call entry point.

    Parameters
    ----------
    grid : pyvista.ImageData or vtkImageData
        The volume (never modified).
    transfer_function : TransferFunction, dict, vtkVolumeProperty or volume actor, optional
        PyVista's defaults (theme colormap, linear opacity, default unit distance) when None.
    camera : pyvista.Camera, pyvista.Plotter, Camera, dict or list, optional
        PyVista's default isometric view when None.
    window_size : (int, int), optional
        ``(width, height)``.
    lights : sequence, optional
        Point and directional lights (used by the scattering models).
    model : str, default: "emission_absorption"
    **options
        Passed to :meth:`Renderer.render` (``step``, ``jitter``, ``seed``, ``background``,
        ``early_termination``, ``progress_bar``).

    Returns
    -------
    RenderResult

    Examples
    --------
    >>> import pv_ambient
    >>> from pv_ambient import datasets
    >>> grid = datasets.supernova(n=24)
    >>> res = pv_ambient.render(grid, window_size=(40, 30))
    >>> res.radiance.shape, res.alpha.shape
    ((30, 40, 3), (30, 40))
    """
    r = Renderer(grid, transfer_function=transfer_function, scalars=scalars, component=component,
                 lights=lights, preference=preference, nan_policy=nan_policy)
    return r.render(camera=camera, window_size=window_size, model=model, **options)
