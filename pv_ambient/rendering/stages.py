"""The per-scene stages a :class:`~pv_ambient.Renderer` caches: the majorant grid, light grids,
optical depths, the ball means σ̄, the preintegrated table slices, tube fronts and diffusion
solutions — each computed by an array-in/array-out function of :mod:`pv_ambient.stages` on the
scene's arrays and kept in the renderer's :class:`~pv_ambient.rendering.cache.SceneCache` under a
key of its inputs (so a camera move computes none of them and a relight only the moved light's).
"""

from __future__ import annotations

import time

import numpy as np

from .._kernels import records as K
from .presets import MAJORANT_BLOCK, TAU_OPAQUE


class _NoGrid:
    lo = np.zeros(3)
    inv_step = np.zeros(3)


#: Stands for the light grid of a model that has none (its kernel reads no light volume).
NO_GRID = _NoGrid()


class SceneStages:
    """The cached stages of one scene; a base of :class:`~pv_ambient.Renderer`, which supplies
    ``optics``, ``geometry``, ``lights``, ``cache``, ``timings`` and ``device_cache``."""

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

    def incident(self, model_id, lights, grid, records, key, diffusion=None):
        """The baked in-scattered light of ``lights`` per unit albedo at the nodes of ``grid`` for an
        isotropic phase function, ``(array, nch)``: float32 (m0, m1, m2, slots·nch), a slot per point
        light (times d²) and one for the directional lights, ``nch`` 1 when every channel is equal,
        else 3 (:func:`pv_ambient._kernels.raycast.bake_incident`): single scattering's direct light,
        plus ambient scattering's ball term. ``records`` are the kernel's Lights, LightGrid and
        Ambient records; ``key`` what else they depend on (model, step's d² clamp, radius, table,
        propagation). A camera move reads it instead of evaluating every light per sample; a
        relight rebakes it from the cached light volumes (one pass over the light grid).
        ``diffusion``: a diffusion solution (:meth:`diffusion`) on the data samples, which must be
        the light-grid nodes (``grid.on_samples``), to add as ``max(φ, 0)/4π`` (isotropic phase)."""
        from .._kernels.raycast import bake_incident, diffusion_layout

        key = ("incident", tuple(lights), grid.key()) + tuple(key)
        if key not in self.cache:
            t = time.perf_counter()
            lrec, grec, arec = records
            power = lrec.power
            ball = arec.ball
            grey = bool(np.all(power[:, 0:1] == power)) and (ball.shape[3] < 4 or bool(
                np.array_equal(ball[..., 1], ball[..., 2]) and np.array_equal(ball[..., 1], ball[..., 3])))
            diff = K.NONE12 if diffusion is None else diffusion
            if diffusion is not None and diffusion_layout(diff.shape[3])[1] == 3:
                grey = False  # coloured diffusion solution
            nch = 1 if grey else 3
            # a slot per point light, one for all directional lights (and the diffusion term)
            slots = int(np.sum(lrec.kind == 0)) + int(np.any(lrec.kind != 0) or diffusion is not None)
            out = np.zeros(tuple(grid.shape) + (slots * nch,), np.float32)
            geo = self.geometry
            bake_incident(model_id, lrec, grec, arec, geo.world_to_index, geo.index_to_world, grid.lo, grid.step,
                          nch, diff, diffusion is not None, out)
            for old in [k for k in self.cache.keys("incident") if k[2:] == key[2:]]:
                del self.cache[old]  # one baked set per grid and options: a relight replaces it
            self.cache[key] = (out, nch)
            self.timings["baked in-scattering"] = time.perf_counter() - t
        return self.cache[key]

    def _scattering_nodes(self, grid):
        """The light-grid nodes nearest to a data sample that scatters (σt·albedo > 0): a boolean
        array of the grid's shape (cached)."""
        key = ("scattering_nodes", grid.key())
        if key not in self.cache:
            from .._kernels.medium import scattering_nodes

            o = self.optics
            node = [np.clip(np.rint((np.arange(n) - grid.lo[a]) * grid.inv_step[a]).astype(np.intp), 0,
                            grid.shape[a] - 1) for a, n in enumerate(o.field.shape)]
            mask = np.zeros(tuple(grid.shape), np.bool_)
            scattering_nodes(o.mode, o.field, o.table, float(o.lut_lo), float(o.lut_inv), o.aux, *node, mask)
            self.cache[key] = mask
        return self.cache[key]

    def active_lights(self, grid, backend="cpu"):
        """Lights that reach the scattering medium: non-zero power, and optical depth below
        ``TAU_OPAQUE`` at some sample that scatters (σt·albedo > 0). Whether a light reaches it is
        cached with the light (a pass over the light grid: not repeated at every camera move)."""
        out = []
        if not self.cache.get(("scatters", grid.key()), lambda: bool(self._scattering_nodes(grid).any())):
            return ()
        for lt in self.lights:
            if max(lt.power) <= 0.0:
                continue

            def reaches(lt=lt):
                tau = self.optical_depth(lt, grid, backend)
                return float(np.min(tau[self._scattering_nodes(grid)])) <= TAU_OPAQUE

            if not self.cache.get(("reaches", lt, grid.key()), reaches):
                continue
            out.append(lt)
        return tuple(out)

    def stacked(self, kind, lights, grid, parts, extra=()):
        """``parts`` (one light-grid array per light, (m0, m1, m2) or (m0, m1, m2, c)) side by side
        along a last axis, as the kernel's records take them (a view of the one array for a single
        light), made once per light set, grid and ``extra`` and cached under stage ``kind`` (a
        relight replaces it): a camera move copies no light volume, and the CUDA backend finds the
        same array, already on the GPU."""
        key = (kind, tuple(lights), grid.key()) + tuple(extra)
        if key not in self.cache:
            for old in [k for k in self.cache.keys(kind) if k[2:] == key[2:]]:
                del self.cache[old]
            parts = [a if a.ndim == 4 else a[..., None] for a in parts]
            self.cache[key] = parts[0] if len(parts) == 1 else np.concatenate(parts, axis=-1)
        return self.cache[key]

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
        """(min, max) of the ball-mean albedo ā over the medium (where σ̄ > 0), all channels
        (cached with the ball grid: every frame keys its table by it)."""
        def build():
            ball = self.ball_grid(radius)
            a = ball[..., 1:4][ball[..., 0] > 0]
            return (float(a.min()), float(a.max())) if a.size else (0.0, 0.0)

        return self.cache.get(("albedo_range", float(radius)), build)

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

    def diffusion(self, lights, grid, phase, flux_limited=False, progress_bar=False, backend="cpu",
                  sweep_orders=0):
        """Packed (φ, F) per channel of the multiply-scattered light of ``lights`` (docs/diffusion.rst),
        (nx, ny, nz, 12) float32 at the data samples — (…, 4) when the channels are equal, and φ
        alone, (…, 3) or (…, 1), for a phase function of mean cosine 0, whose radiance has no flux
        term (the march reads a quarter of the memory); one solve per light, cached per light, so a
        relight re-solves only the light that changed (warm-started from its previous solution).

        One solve of the summed sources would cost less for the first frame (identical for plain
        diffusion; flux-limited diffusion is not linear, so it differs slightly), but every relight
        would then re-solve all lights (figures: ``benchmarks/results/diffusion_notes.md``).

        σt and albedo are checked and converted once per scene (a ``DiffusionMedium`` cached
        under ``("diffusion_medium",)``); each light's optical depth comes from
        :meth:`optical_depth` on the light grid of ``grid``'s factor. ``sweep_orders``: the first
        scattering orders by transport sweeps (docs/diffusion.rst §5)."""
        from .._kernels.raycast import diffusion_layout
        from ..stages.diffusion import DiffusionMedium, hat_medium, solve_for_light

        g = float(phase.mean_cosine)
        total = None
        sweep = int(sweep_orders)
        # the sweeps need the phase function itself, plain diffusion only its mean cosine
        keys = tuple(("diffusion", lt, grid.key(), g, bool(flux_limited))
                     + ((sweep, phase.canonical()) if sweep else ()) for lt in lights)
        if len(keys) > 1 and ("diffusion_sum", keys) in self.cache:
            return self.cache[("diffusion_sum", keys)]  # the same array: it stays on the GPU
        for lt, key in zip(lights, keys):
            if key not in self.cache:
                t = time.perf_counter()
                if sweep:  # the classified field's node means (docs/diffusion.rst §5)
                    medium = self.cache.get(("diffusion_medium_hat",), lambda: hat_medium(self.optics, self.geometry))
                else:
                    medium = self.cache.get(("diffusion_medium",), lambda: DiffusionMedium.from_arrays(
                        self.optics.sigma_grid(), self.optics.albedo_grid()))
                lgrid = self.light_grid(grid.factor)
                extra = {"sweep_orders": sweep, "optics": self.optics} if sweep else {}
                sol = solve_for_light(lt, phase if sweep else g, medium=medium, geometry=self.geometry,
                                      tau=self.optical_depth(lt, lgrid, backend), light_grid=lgrid,
                                      flux_limited=bool(flux_limited), progress_bar=progress_bar, **extra)
                packed = sol.packed()
                if g == 0.0:  # no flux term in the radiance (raycast.diffusion_light): φ alone
                    packed = packed[..., 0::4]
                n, nch = diffusion_layout(packed.shape[3])  # values per channel, channels
                if nch == 3 and np.array_equal(packed[..., 0:n], packed[..., n:2 * n]) and np.array_equal(
                        packed[..., 0:n], packed[..., 2 * n:]):
                    packed = packed[..., 0:n]  # grey: one channel read per sample
                packed = np.ascontiguousarray(packed)
                self.cache[key] = packed
                self.timings[f"diffusion {lt}"] = time.perf_counter() - t
                self._diffusion_info = {"iterations": int(sol.iterations), "residual": float(sol.residual),
                                        "converged": bool(sol.converged)}
            part = self.cache[key]
            if total is not None and total.shape != part.shape:  # grey and coloured lights: all channels
                total, part = (np.tile(a, (1, 1, 1, 3)) if diffusion_layout(a.shape[3])[1] == 1 else a
                               for a in (total, part))
            total = part if total is None else total + part
        if len(keys) > 1:
            self.cache[("diffusion_sum", keys)] = total
        return total if total is not None else K.NONE12
