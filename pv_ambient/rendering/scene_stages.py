"""The per-scene stages a :class:`~pv_ambient.Renderer` keeps: the majorant grid, light grids,
optical depths, the ball means σ̄, the preintegrated table slices, tube fronts, baked
in-scattering and diffusion solutions.

:class:`SceneStages` is a component the renderer owns. It decides only which stage runs when:
each entry is computed by an array-in/array-out function of :mod:`pv_ambient.stages` on the
scene's arrays and kept in a :class:`~pv_ambient.rendering.cache.SceneCache` under a key of its
inputs, so a camera move computes none of them and a relight only the moved light's
(docs/architecture.rst).
"""

from __future__ import annotations

import sys
import time

import numpy as np

from .._kernels import records as K
from ..backend import blas_before_stage
from ..inputs.lights import PointLight
from .presets import MAJORANT_BLOCK, TAU_OPAQUE, light_resolution_for
from .cache import SceneCache


class _NoGrid:
    lo = np.zeros(3)
    inv_step = np.zeros(3)


#: Stands for the light grid of a model that has none (its kernel reads no light volume).
NO_GRID = _NoGrid()


class _DeviceSlot:
    """Holds the CUDA backend's :class:`pv_ambient.backend.DeviceCache` once created, shared by
    the stages of renderers that differ only in colour (:meth:`SceneStages.with_optics`)."""

    def __init__(self):
        self.cache = None


class SceneStages:
    """The cached stages of one scene: ``optics`` (classified medium) on ``geometry``.

    Parameters
    ----------
    optics : pv_ambient.inputs.transfer.Optics
    geometry : pv_ambient.inputs.grid.GridGeometry
    cache : SceneCache, optional
        Where the entries live (a new one when None).

    Attributes
    ----------
    timings : dict
        Seconds of the last computation of each stage (``"light volume …"``, ``"table"``, …).
    """

    def __init__(self, optics, geometry, cache=None):
        self.optics = optics
        self.geometry = geometry
        self.cache = SceneCache() if cache is None else cache
        self.timings = {}
        self._device = _DeviceSlot()
        #: optical depths of lights that left, held until the light that replaced them is swept
        #: into one (:meth:`keep_lights`)
        self._spare = []
        #: (lights, model) pairs whose pictures decided the "rendered black" check
        #: (:func:`pv_ambient.rendering.request.warn_black`): its causes do not move with the camera
        self.black_checked = set()

    def __getstate__(self):
        # the GPU-resident copies stay behind: stages sent to another process (a Dask worker)
        # upload what they need there
        state = self.__dict__.copy()
        state["_device"] = _DeviceSlot()
        state["_spare"] = []
        return state

    def with_optics(self, optics) -> "SceneStages":
        """The stages of other optical properties of the same σt: the σt-only entries (majorant,
        light grids, optical depths) carried over, the GPU cache shared."""
        other = SceneStages(optics, self.geometry, self.cache.with_sigma_only())
        other.cache.share(self.cache, kinds=("diffusion_start",))  # warm starts of the new solves
        other._device = self._device
        return other

    @property
    def device_cache(self):
        """The :class:`pv_ambient.backend.DeviceCache` of the CUDA backend (created on first use)."""
        if self._device.cache is None:
            from ..backend import DeviceCache

            self._device.cache = DeviceCache()
        return self._device.cache

    @property
    def device_nbytes(self) -> int:
        """Bytes the scene holds on the GPU (0 before the CUDA backend has run)."""
        return 0 if self._device.cache is None else self._device.cache.nbytes

    def device_for(self, backend):
        """The device cache for ``backend`` ("cuda"), None for the CPU."""
        return self.device_cache if backend == "cuda" else None

    def _timed(self, name, build):
        blas_before_stage()  # a stage is computed: the CPU's kernels and BLAS may run
        t = time.perf_counter()
        out = build()
        self.timings[name] = time.perf_counter() - t
        return out

    def _replace(self, kind, key, value):
        """Keep ``value`` under ``key``, dropping the entries of stage ``kind`` that differ from it
        only in their light set (one per grid and options: a relight replaces it)."""
        for old in [k for k in self.cache.keys(kind) if k[2:] == key[2:]]:
            del self.cache[old]
        self.cache[key] = value
        return value

    # -- the medium --------------------------------------------------------------------------
    def majorant(self, block=MAJORANT_BLOCK, backend="cpu"):
        """Upper bound of σt over each block of (``block``)³ samples (cached; computed on ``backend``)."""
        from ..stages.medium import majorant_grid

        return self.cache.get(("majorant", block), lambda: majorant_grid(self.optics, block, self.device_for(backend)))

    def cast_majorant(self, block=MAJORANT_BLOCK, backend="cpu"):
        """The ray cast's majorant grid in (``block``)³ samples (cached;
        :func:`pv_ambient.stages.medium.cast_majorant`, computed on ``backend``): its empty blocks are
        those a ray skips."""
        from ..stages.medium import cast_majorant

        return self.cache.get(("cast_majorant", block), lambda: cast_majorant(self.optics, block,
                                                                              self.device_for(backend)))

    def step_opacity(self, step):
        """The medium's step-corrected table for world step ``step`` (:func:`pv_ambient.stages.medium.step_opacity`),
        cached per step: a camera move reuses it, and the GPU's copy with it."""
        from ..stages.medium import step_opacity

        return self.cache.get(("step_opacity", float(step)), lambda: step_opacity(self.optics, step))

    def ball_grid(self, radius, backend="cpu"):
        """σ̄ and the ball's mean albedo per channel at every data sample, float32 (nx, ny, nz, 4)
        (:func:`pv_ambient.stages.ball.ball_grid`; cached per radius; on ``backend``,
        :func:`pv_ambient.stages.ball.ball_on_device`)."""
        from ..stages.ball import ball_grid, ball_on_device

        def build():
            sigma = self.sigma_samples(backend)
            ball = ball_on_device(self.optics, sigma, self.geometry.spacing, radius, self.device_for(backend))
            if ball is not None:
                return ball
            return ball_grid(sigma, self.optics.albedo_channel, self.geometry.spacing, radius,
                             same_as_previous=self.optics.albedo_same_as_previous(),
                             scattering=lambda c: self.optics.scattering_channel(c, sigma))

        return self.cache.get(("ball", float(radius)), build)

    def albedo_range(self, radius, backend="cpu"):
        """(min, max) of the ball-mean albedo over the medium (cached with the ball grid: every
        frame keys its table by it; the ball grid, when this makes it, on ``backend``)."""
        from ..stages.ball import albedo_range

        return self.cache.get(("albedo_range", float(radius)), lambda: albedo_range(self.ball_grid(radius, backend)))

    def ball_inside(self, radius):
        """The ball grid with σ̄ averaged over the part of the ball inside the grid (the tube
        march's, :func:`pv_ambient.stages.ball.ball_inside`; cached)."""
        from ..stages.ball import ball_inside

        return self.cache.get(("ball_inside", float(radius)), lambda: ball_inside(
            self.ball_grid(radius), self.geometry.spacing, radius))

    # -- light grids and per-light volumes ---------------------------------------------------
    def light_grid(self, light_resolution=None):
        """The light grid of a resolution factor (the default of docs/ambient_scattering.rst §3
        when None: :func:`pv_ambient.rendering.presets.light_resolution_for`)."""
        from ..stages.propagation import make_light_grid

        f = light_resolution_for(self.optics, self.geometry) if light_resolution is None else light_resolution
        return self.cache.get(("light_grid", float(f)), lambda: make_light_grid(self.geometry, f))

    def sigma_samples(self, backend="cpu"):
        """σt at the data samples, float32 (cached; the field itself for a physical transfer
        function; :func:`pv_ambient.stages.medium.sigma_samples` on ``backend``): the ball grid's
        input, and the light grid's σt wherever its nodes are the samples."""
        from ..stages.medium import sigma_samples

        return self.cache.get(("sigma_l", "samples"), lambda: sigma_samples(self.optics, self.device_for(backend)))

    def sigma_on_light_grid(self, grid, backend="cpu"):
        """σt at the nodes of ``grid`` (cached; on ``backend``): :meth:`sigma_samples` when the nodes
        are the data samples (the same values: the interpolation at a sample is the sample), else sampled."""
        from ..stages.propagation import sigma_on_grid

        if grid.on_samples(self.optics.field.shape):
            return self.sigma_samples(backend)
        return self.cache.get(("sigma_l", grid.key()), lambda: sigma_on_grid(self.optics, grid,
                                                                             self.device_for(backend)))

    def optical_depth(self, light, grid, backend="cpu"):
        """τ from ``light`` on ``grid`` (cached per light: a relight recomputes only that light),
        swept on ``backend`` (``"cpu"`` or ``"cuda"``) when not cached."""
        from ..stages.propagation import optical_depth

        key = ("tau", light, grid.key())
        if key not in self.cache:
            out = self._take_spare(grid.shape)
            self.cache[key] = self._timed(f"light volume {light}", lambda: optical_depth(
                self.sigma_on_light_grid(grid, backend), grid, self.geometry, light,
                device_cache=self.device_for(backend), out=out))
        return self.cache[key]

    def _take_spare(self, shape):
        """An optical depth of a light that left, of ``shape``, to sweep the next one into (None if
        there is none). Why: a 256³ optical depth is 64 MB, and the first writes to freshly allocated
        memory cost more than the sweep's own writes (docs/performance.rst, "Relight: the light
        sweep"); its GPU copy, if any, is forgotten."""
        for i, arr in enumerate(self._spare):
            if arr.shape == tuple(shape):
                del self._spare[i]
                if self._device.cache is not None:
                    self._device.cache.forget(arr)
                return arr
        return None

    def keep_lights(self, lights):
        """Drop the per-light entries (optical depths, tube fronts, reach checks, diffusion
        solutions) of lights not in ``lights``: a relight keeps the volumes of the lights that stay
        and, of the lights that left, only the latest diffusion solution per grid and options — the
        warm start of the light that moved (:meth:`warm_start`). Why: every light position a drag
        visits would otherwise keep its volumes (a 256³ optical depth is 67 MB) for the life of
        the renderer."""
        current = set(lights)
        dropped = []
        for key in self.cache.keys():
            if key[0] in ("tau", "front", "reaches") and key[1] not in current:
                if key[0] == "tau":
                    dropped.append(self.cache[key])
                del self.cache[key]
            elif key[0] == "diffusion_sum" and any(part[1] not in current for part in key[1]):
                del self.cache[key]
        for kind in ("diffusion", "diffusion_start"):
            gone = [k for k in self.cache.keys(kind) if k[1] not in current]
            latest = {k[2:]: k for k in gone}  # the cache keeps insertion order: the last one wins
            for key in gone:
                if latest[key[2:]] != key:
                    del self.cache[key]
        # an optical depth no one else holds (a renderer sharing this cache would) is kept for a new
        # light's sweep, as many as there are lights still to sweep
        swept = {k[1] for k in self.cache.keys("tau")}
        free = [a for a in dropped if isinstance(a, np.ndarray) and a.flags.writeable and sys.getrefcount(a) <= 3]
        self._spare = free[:len(current - swept)]

    def scattering_nodes(self, grid):
        """The light-grid nodes nearest to a data sample that scatters (cached)."""
        from ..stages.medium import scattering_nodes

        return self.cache.get(("scattering_nodes", grid.key()), lambda: scattering_nodes(self.optics, grid))

    def scatters(self, grid) -> bool:
        """Whether anything scatters: σt·albedo > 0 at some data sample (cached per light grid)."""
        return self.cache.get(("scatters", grid.key()), lambda: bool(self.scattering_nodes(grid).any()))

    def active_lights(self, lights, grid, backend="cpu"):
        """The lights of ``lights`` that reach the scattering medium — the one place that decides
        whether a light matters: none when nothing scatters (σt·albedo = 0 everywhere: no light
        volume is built), else those of non-zero power whose optical depth is at most
        ``TAU_OPAQUE`` at some node next to a sample that scatters (cached with the light: not
        repeated at every camera move)."""
        if not self.scatters(grid):
            return ()
        out = []
        for lt in lights:
            if max(lt.power) <= 0.0:
                continue

            def reaches(lt=lt):
                from ..stages.medium import least_where

                tau = self.optical_depth(lt, grid, backend)
                return least_where(tau, self.scattering_nodes(grid)) <= TAU_OPAQUE

            if self.cache.get(("reaches", lt, grid.key()), reaches):
                out.append(lt)
        return tuple(out)

    def stacked(self, kind, lights, grid, parts, extra=()):
        """``parts`` (one light-grid array per light) side by side along a last axis
        (:func:`pv_ambient.stages.medium.stack_volumes`), made once per light set, grid and
        ``extra`` and cached under stage ``kind`` (a relight replaces it): a camera move copies no
        light volume, and the CUDA backend finds the same array, already on the GPU."""
        from ..stages.medium import stack_volumes

        key = (kind, tuple(lights), grid.key()) + tuple(extra)
        if key not in self.cache:
            self._replace(kind, key, stack_volumes(parts))
        return self.cache[key]

    # -- ambient scattering ------------------------------------------------------------------
    def table_key(self, phase, radius, quality):
        """The cache key of the table slice a render needs: keyed on the albedo nodes the scene's
        range needs, so nearby ranges share one slice."""
        from ..stages.preintegration import albedo_nodes_for

        lo, hi = self.albedo_range(radius)
        return ("table", phase.kind, float(phase.g), tuple(albedo_nodes_for(lo, hi).tolist()), quality)

    def table(self, phase, radius, quality="balanced", progress_bar=False):
        """The preintegrated D/F slice for ``phase`` and the albedo range the scene needs (cached)."""
        from ..stages.preintegration import get_table

        key = self.table_key(phase, radius, quality)
        if key not in self.cache:
            lo, hi = self.albedo_range(radius)
            self.cache[key] = self._timed("table", lambda: get_table(phase, albedo_range=(lo, hi), quality=quality,
                                                                     progress_bar=progress_bar))
        return self.cache[key]

    def front_depth(self, light, grid, radius, phase, quality="balanced"):
        """Tube-mode front optical depth per channel, (m0, m1, m2, 3) float32 (cached per light, r, table)."""
        from ..stages.propagation import front_depth

        key = ("front", light, grid.key(), float(radius), self.table_key(phase, radius, quality))
        if key not in self.cache:
            table = self.table(phase, radius, quality)
            self.cache[key] = self._timed(f"front volume {light}", lambda: front_depth(
                self.ball_inside(radius), grid, self.geometry, light, radius, table))
        return self.cache[key]

    # -- baked in-scattering and diffusion ---------------------------------------------------
    def ball_d(self, radius, phase, quality="balanced", backend="cpu"):
        """D(r σ̄, ā) per data sample and channel for an isotropic ``phase``
        (:func:`pv_ambient.stages.bake.ball_d`; cached per radius and table slice): what ambient
        scattering's bake reads on the row driver. The ball grid it is made from is dropped from the
        cache then — the baked camera pass reads neither — and rebuilt if a per-sample render asks
        for it: the two together would hold five and a half volumes of float32 where D, in 16 bits
        (:class:`pv_ambient.stages.bake.BallD`), holds one and a half (half for a grey albedo)."""
        from ..stages.bake import ball_d

        key = ("ball_d", float(radius), self.table_key(phase, radius, quality))
        if key not in self.cache:
            table = self.table(phase, radius, quality)
            ball = self.ball_grid(radius, backend)  # D itself on the CPU
            self.cache[key] = self._timed("ball D", lambda: ball_d(ball, table, radius))
            if ("ball", float(radius)) in self.cache:
                del self.cache[("ball", float(radius))]
                if self._device.cache is not None:
                    self._device.cache.forget(ball)  # and its GPU copy, if the GPU made it
            del ball
        return self.cache[key]

    def incident(self, model_id, lights, grid, records, key, taus, phis=None, diffusion=None, dgrid=None,
                 backend="cpu"):
        """The baked in-scattered light of ``lights`` on ``grid``, ``(array, nch)``
        (:func:`pv_ambient.stages.bake.bake_incident`): ``records`` are the kernel's Lights,
        LightGrid and Ambient records, ``taus`` / ``phis`` each light's optical depth and tube front,
        ``key`` what else they depend on (model, radius, table, propagation, diffusion options;
        not the ray step: a point light's slot holds its intensity, not its clamped fall-off). A
        camera move reads it; a relight rebakes the slots of the lights that moved and copies the
        others' from the bake it replaces. On ``backend`` ``"cuda"`` the bake runs on the GPU and its
        device copy stays in the device cache for the ray cast (``device_cache`` of
        :func:`pv_ambient.stages.bake.bake_incident`; a bake rebaked in place keeps its device copy,
        the lights' kept slots with it)."""
        from ..stages.bake import bake_incident, incident_slots

        key = ("incident", tuple(lights), grid.key()) + tuple(key)
        if key not in self.cache:
            reuse, into, device = {}, None, self.device_for(backend)
            kinds = [0 if isinstance(lt, PointLight) else 1 for lt in lights]
            for old in self.cache.keys("incident"):
                if old[2:] != key[2:]:
                    continue
                inc, nch = self.cache[old]
                old_lights = old[1]
                old_kinds = [0 if isinstance(lt, PointLight) else 1 for lt in old_lights]
                old_slots = incident_slots(old_kinds)
                if old_kinds == kinds:
                    # the same slots: rebaked in place, the lights that kept their index kept
                    # (stages.bake.bake_incident's ``into``); the cache no longer holds it, nor the GPU
                    # unless the GPU rebakes it (its device copy is then rebaked in place too)
                    into = inc
                    reuse = {j: inc[..., old_slots[j] * nch:(old_slots[j] + 1) * nch] for j, lt in enumerate(lights)
                             if kinds[j] == 0 and lt == old_lights[j]}
                    del self.cache[old]
                    if self._device.cache is not None and device is None:
                        self._device.cache.forget(inc)
                    break
                for j, lt in enumerate(lights):
                    if isinstance(lt, PointLight) and lt in old_lights:
                        q = old_slots[old_lights.index(lt)] * nch
                        reuse[j] = inc[..., q:q + nch]
            if into is None:
                self._release_sigma()
            value = self._timed("baked in-scattering", lambda: bake_incident(model_id, records, self.geometry, grid,
                                                                             taus, phis, diffusion, reuse, into=into,
                                                                             dgrid=dgrid, device_cache=device))
            self._replace("incident", key, value)
        return self.cache[key]

    def _release_sigma(self):
        """Drop σt (the data samples' and the light grids') from the cache before a new bake array is
        made: the bake reads the lights' optical depths, not σt, and a new bake (a first frame) is
        where a render's memory peaks. The next sweep classifies again (0.1 s at 256³); a relight
        rebakes in place and keeps it (docs/performance.rst, "Memory"). Their GPU copies go too, but
        the field's (a physical transfer function's σt, which the ray cast reads)."""
        for key in self.cache.keys("sigma_l"):
            if self._device.cache is not None and self.cache[key] is not self.optics.field:
                self._device.cache.forget(self.cache[key])
            del self.cache[key]

    def diffusion(self, lights, grid, phase, flux_limited=False, progress_bar=False, backend="cpu",
                  sweep_orders=0, tol=None, coarse=False, coarse_remainder=False):
        """The multiply-scattered light of ``lights`` packed for the camera pass, and its solve's
        information: ``(field, info)`` — the field as
        :func:`pv_ambient.stages.diffusion.packing.pack_for_march` packs it, summed over the lights,
        ``info`` the iterations, residual and convergence of the last light's solve (kept with its
        solution; None without lights).

        One solve per light, cached per light: a relight re-solves only the light that changed,
        and plain and flux-limited solves start warm (:meth:`warm_start`). σt and albedo are
        checked and converted once per scene; each light's optical depth comes from
        :meth:`optical_depth` on the light grid of ``grid``'s factor; ``sweep_orders``: the first
        scattering orders by transport sweeps (docs/diffusion.rst §5); ``tol``: the relative residual
        at which the solve stops (the quality preset's ``diffusion_tol``; None: the solver's default);
        ``coarse``: plain diffusion of an isotropic phase function may be solved on a grid twice as
        coarse, where the medium is optically thin enough (:meth:`coarse_solve`; docs/diffusion.rst,
        "Solve resolution"); ``coarse_remainder``: with the sweeps and an isotropic phase function, the
        light scattered more often than they carry may be diffused on that coarser grid
        (:meth:`coarse_remainder`)."""
        from ..stages.diffusion.packing import add_packed

        g = float(phase.mean_cosine)
        sweep = int(sweep_orders)
        # the sweeps need the phase function itself, plain diffusion only its mean cosine
        tol = None if tol is None else float(tol)  # None: the solver's default
        # isotropic scattering only: the radiance's flux term (g ≠ 0) has voxel-scale structure
        # that a coarse grid loses (docs/diffusion.rst, "Solve resolution")
        coarse = bool(coarse) and g == 0.0 and not sweep and not flux_limited and self.coarse_solve() is not None
        if sweep and coarse_remainder and g == 0.0 and self.coarse_remainder() is not None:
            coarse = "remainder"
        keys = tuple(("diffusion", lt, grid.key(), g, bool(flux_limited))
                     + ((sweep, phase.canonical()) if sweep else ()) + (tol, coarse) for lt in lights)
        if len(keys) > 1 and ("diffusion_sum", keys) in self.cache:
            return self.cache[("diffusion_sum", keys)]  # the same array: it stays on the GPU
        total, info = None, None
        for lt, key in zip(lights, keys):
            if key not in self.cache:
                x0 = None if sweep else self.warm_start(lt, lights, key)
                self.cache[key] = self._timed(f"diffusion {lt}", lambda: self._solve(
                    lt, grid, phase, sweep, bool(flux_limited), progress_bar, backend, x0, tol, coarse))
                if not sweep:
                    self.cache[("diffusion_start",) + key[1:]] = self.cache[key][0]
            part, info = self.cache[key]
            total = add_packed(total, part)
        if len(keys) > 1:
            self.cache[("diffusion_sum", keys)] = (total, info)
        return (total if total is not None else K.NONE12), info

    def warm_start(self, light, lights, key):
        """The fluence a new solve of ``light`` (cache key ``key``) starts from, float32 (nx, ny, nz,
        3), or None: the light's own previous solution under other optics (a transfer-function
        change: :meth:`with_optics` and ``SceneCache.share(kinds=("diffusion_start",))`` carry the
        ``"diffusion_start"`` entries over), else the latest solution, on the same light grid and
        options, of a light no longer in ``lights`` (a relight: the light that moved). The solver
        scales a start by its energy-optimal factor, so a poor one costs at most one matrix
        product (docs/diffusion.rst, "Warm starts"). Not for the transport sweeps, whose packed
        field holds the swept orders too."""
        from ..stages.diffusion.packing import packed_phi

        own = ("diffusion_start", light) + key[2:]
        packed = self.cache[own] if own in self.cache else None
        if packed is None:
            moved = [k for k in self.cache.keys("diffusion") if k[2:] == key[2:] and k[1] not in lights]
            packed = self.cache[moved[-1]][0] if moved else None
        if packed is None or packed.shape[:3] != tuple(self.geometry.shape):
            return None
        return packed_phi(packed)

    def coarse_solve(self):
        """``(Coarsening, coarse DiffusionMedium)`` of the grid twice as coarse that plain diffusion
        may be solved on, or None where the medium is too thick per coarse cell or the grid too small
        (:func:`pv_ambient.stages.diffusion.coarse.thin_enough`; cached per scene)."""
        return self.cache.get(("diffusion_coarse",), lambda: self._coarse_of(self._diffusion_medium()))

    def coarse_remainder(self):
        """``(Coarsening, coarse DiffusionMedium)`` on which the sweeps' remainder may be diffused: the
        sweeps' medium (:func:`pv_ambient.stages.diffusion.hat_medium`) restricted to the grid twice
        as coarse, or None where it is too thick per coarse cell or the grid too small (the rule of
        :meth:`coarse_solve`; cached per scene)."""
        return self.cache.get(("diffusion_coarse_hat",), lambda: self._coarse_of(self._hat_medium()))

    def _coarse_of(self, medium):
        from ..stages.diffusion.coarse import Coarsening, thin_enough

        co = Coarsening.of(self.geometry)
        if not co.coarser or not thin_enough(medium.sigma_t, self.geometry.spacing):
            return None
        return co, co.medium(medium)

    def _hat_medium(self):
        from ..stages.diffusion import hat_medium

        return self.cache.get(("diffusion_medium_hat",), lambda: hat_medium(self.optics, self.geometry))

    def _diffusion_medium(self):
        from ..stages.diffusion import DiffusionMedium

        return self.cache.get(("diffusion_medium",), lambda: DiffusionMedium.from_arrays(
            self.optics.sigma_grid(), self.optics.albedo_grid()))

    def _solve(self, light, grid, phase, sweep, flux_limited, progress_bar, backend, x0=None, tol=None, coarse=False):
        from ..stages.diffusion import solve_for_light
        from ..stages.diffusion.packing import pack_for_march

        g = float(phase.mean_cosine)
        # the sweeps read the classified field's node means (docs/diffusion.rst §5)
        medium = self._hat_medium() if sweep else self._diffusion_medium()
        lgrid = self.light_grid(grid.factor)
        # a mean cosine of 0: no flux term in the radiance, the packed field holds φ alone (pack_for_march)
        extra = {"sweep_orders": sweep, "optics": self.optics, "with_flux": g != 0.0} if sweep else {}
        if coarse == "remainder":
            extra["coarse_remainder"] = self.coarse_remainder()
        elif coarse:
            extra["coarse"] = self.coarse_solve()
        if tol is not None:
            extra["tol"] = tol
        sol = solve_for_light(light, phase if sweep else g, medium=medium, geometry=self.geometry,
                              tau=self.optical_depth(light, lgrid, backend), light_grid=lgrid,
                              flux_limited=flux_limited, progress_bar=progress_bar, x0=x0, **extra)
        info = {"iterations": int(sol.iterations), "residual": float(sol.residual), "converged": bool(sol.converged)}
        return pack_for_march(sol, g), info
