"""The diffusion solve on a grid coarser than the data (docs/diffusion.rst, "Solve resolution").

The multiply-scattered light is smooth: it varies over a transport length, not over a voxel.
Where the medium is optically thin per coarse cell the solve can run on about half the data
samples per axis — an eighth of the unknowns and of every V-cycle — and its fluence and flux be
interpolated back to the data samples, where the camera pass reads them. The first-collision
source is computed on the data grid, where σs and the light's attenuation correlate, and
restricted. Near a point light the fluence is singular (≈ 1/d) and the coarse grid cannot hold
it: a box of data samples around the light (``PATCH_RADIUS`` index units) is solved again at the
data resolution, its outer layer held at the interpolated coarse solution (a Dirichlet
condition), and replaces the interpolation there.

:class:`Coarsening` holds the two grids' relation per axis (the coarse nodes span the same box,
so every face of the medium stays where it is): restriction by the hat functions of the coarse
nodes (the transpose of trilinear interpolation, normalised: a weighted mean that keeps a thin
layer's integral) and prolongation by trilinear interpolation (``_kernels/diffusion_coarse.py``).
The medium restricts as σt and σs = a·σt, so a coarse node's albedo is the σt-weighted mean of
its neighbourhood's.

This module imports numpy, the kernels and the stage's own modules only.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from .medium import DiffusionMedium

__all__ = ["COARSE_MIN_NODES", "COARSE_SIGMA_H", "PATCH_RADIUS", "Coarsening", "coarse_shape", "local_flux",
           "solve_coarse", "solve_remainder", "thin_enough"]

#: The solve runs on the coarser grid only where the medium is optically thin per coarse cell:
#: the 99.9th percentile of σt·H (H the coarse spacing) at most this.
COARSE_SIGMA_H = 0.5
#: Half-width, in data index units, of the box around a point light solved at the data resolution.
PATCH_RADIUS = 32
#: Grids of fewer data samples are solved at the data resolution: their solve is fast already, so
#: the coarse grid would save little time for its error, and the box around a point light would
#: cover much of them (docs/diffusion.rst, "Solve resolution").
COARSE_MIN_NODES = 160 ** 3


def coarse_shape(shape, association="point", factor=2.0):
    """Nodes per axis of a grid ``factor`` times coarser than ``shape`` over the same box: for point
    data ``ceil((n − 1)/factor) + 1`` (the box ``[0, n − 1]`` keeps its faces), for cell data
    ``ceil(n/factor)``; an axis of fewer than 4 samples is kept.

    >>> coarse_shape((256, 129, 3)), coarse_shape((64, 64, 1), "cell")
    ((129, 65, 3), (32, 32, 1))
    """
    out = []
    for n in shape:
        n = int(n)
        if n < 4:
            out.append(n)
        elif association == "point":
            out.append(int(math.ceil((n - 1) / factor - 1e-9)) + 1)
        else:
            out.append(int(math.ceil(n / factor - 1e-9)))
    return tuple(out)


def _axis_map(n, m, association):
    """(c0, f, taps, weights, scale, offset) of one axis: data sample i lies between coarse nodes
    c0[i] and c0[i] + 1 at fraction f[i]; coarse node c restricts from data samples taps[c, :]
    with weights[c, :] (the prolongation's transpose, normalised to sum 1; padded with weight 0);
    the data index of coarse node c is ``offset + c·scale``."""
    if n == m:
        c0 = np.arange(n, dtype=np.int64)
        return c0, np.zeros(n), c0[:, None].copy(), np.ones((n, 1)), 1.0, 0.0
    if association == "point":
        scale, offset = (n - 1) / (m - 1), 0.0
    else:
        scale = n / m
        offset = -0.5 + 0.5 * scale
    u = np.clip((np.arange(n) - offset) / scale, 0.0, m - 1.0)
    c0 = np.minimum(np.floor(u).astype(np.int64), m - 2)
    f = u - c0
    rows = np.concatenate([c0, c0 + 1])
    cols = np.concatenate([np.arange(n), np.arange(n)])
    vals = np.concatenate([1.0 - f, f])
    keep = vals > 0.0
    rows, cols, vals = rows[keep], cols[keep], vals[keep]
    order = np.lexsort((cols, rows))
    rows, cols, vals = rows[order], cols[order], vals[order]
    count = np.bincount(rows, minlength=m)
    width = int(count.max())
    taps = np.zeros((m, width), np.int64)
    weights = np.zeros((m, width))
    start = np.concatenate([[0], np.cumsum(count)[:-1]])
    slot = np.arange(rows.size) - start[rows]
    taps[rows, slot] = cols
    weights[rows, slot] = vals
    taps[count == 0] = 0
    weights /= np.maximum(weights.sum(axis=1, keepdims=True), 1e-300)
    return c0, f, taps, weights, float(scale), float(offset)


def _four(a):
    return a if a.ndim == 4 else a[..., None]


@dataclass(frozen=True, eq=False)
class Coarsening:
    """A grid ``factor`` times coarser than ``geometry``'s over the same box, and the maps between
    the two (module docstring).

    >>> from pv_ambient.inputs.grid import GridGeometry
    >>> geo = GridGeometry((9, 9, 9), np.diag([0.25, 0.25, 0.25, 1.0]), np.zeros(3), np.full(3, 8.0))
    >>> c = Coarsening.of(geo)
    >>> c.shape, c.geometry.spacing.tolist()
    ((5, 5, 5), [0.5, 0.5, 0.5])
    >>> x = np.arange(9.0)[:, None, None] * np.ones((9, 9, 9))  # a ramp: the interior nodes keep it
    >>> c.restrict(x)[:, 0, 0].round(3).tolist()  # the faces' nodes average half a hat
    [0.333, 2.0, 4.0, 6.0, 7.667]
    >>> bool(np.allclose(c.prolong(c.restrict(x))[2:-2], x[2:-2]))
    True
    """

    fine: object
    geometry: object
    maps: tuple

    @classmethod
    def of(cls, geometry, factor=2.0):
        """The coarsening of ``geometry`` (a :class:`~pv_ambient.inputs.grid.GridGeometry`) by ``factor``."""
        from ...inputs.grid import GridGeometry

        assoc = getattr(geometry, "association", "point")
        shape = tuple(int(n) for n in geometry.shape)
        cshape = coarse_shape(shape, assoc, factor)
        maps = tuple(_axis_map(n, m, assoc) for n, m in zip(shape, cshape))
        S = np.eye(4)
        S[:3, :3] = np.diag([mp[4] for mp in maps])
        S[:3, 3] = [mp[5] for mp in maps]
        cell = assoc == "cell"
        lo = np.full(3, -0.5 if cell else 0.0)
        hi = np.array([m - 0.5 if cell else m - 1.0 for m in cshape], np.float64)
        flat = np.asarray(geometry.box_hi) <= np.asarray(geometry.box_lo)
        lo = np.where(flat, np.asarray(geometry.box_lo, np.float64), lo)
        hi = np.where(flat, lo, hi)  # a flat axis stays flat
        coarse = GridGeometry(cshape, np.asarray(geometry.index_to_world, np.float64) @ S, lo, hi, assoc)
        return cls(geometry, coarse, maps)

    @property
    def shape(self) -> tuple:
        """The coarse grid's nodes per axis."""
        return tuple(self.geometry.shape)

    @property
    def coarser(self) -> bool:
        """Whether any axis is coarser than the data's."""
        return self.shape != tuple(self.fine.shape)

    def restrict(self, arr) -> np.ndarray:
        """Data-grid ``arr`` (first three axes the data's, one trailing channel axis or none) as
        hat-weighted means at the coarse nodes, float64."""
        from ..._kernels.diffusion_coarse import restrict

        src = _four(np.asarray(arr))
        out = np.empty(self.shape + (src.shape[3],))
        args = [x for mp in self.maps for x in mp[2:4]]
        restrict(src, *args, out)
        return out if np.ndim(arr) == 4 else out[..., 0]

    def restrict_sources(self, medium, sources) -> np.ndarray:
        """The first-collision source ``σs·e·power`` of ``sources`` (``(e, power)`` pairs: a light's
        irradiance per unit power at the data samples, :func:`.sources.unit_irradiance`, and its
        power per channel), summed over them and restricted as :meth:`restrict` does, float64
        (m0, m1, m2, C) — without forming it on the data grid."""
        from ..._kernels.diffusion_coarse import restrict_source

        alb = _four(medium.albedo)
        C = max(len(p) for _, p in sources)
        out = np.zeros(self.shape + (C,))
        args = [x for mp in self.maps for x in mp[2:4]]
        for e, power in sources:
            restrict_source(e, True, medium.sigma_t, alb, np.asarray(power, np.float64), *args, out)
        return out

    def prolong(self, arr, dtype=np.float64) -> np.ndarray:
        """Coarse-grid ``arr`` trilinearly interpolated at the data samples."""
        from ..._kernels.diffusion_coarse import prolong

        src = _four(np.asarray(arr))
        out = np.empty(tuple(self.fine.shape) + (src.shape[3],), dtype)
        args = [x for mp in self.maps for x in mp[:2]]
        prolong(src, *args, out)
        return out if np.ndim(arr) == 4 else out[..., 0]

    def medium(self, medium) -> DiffusionMedium:
        """``medium`` (a :class:`.DiffusionMedium` on the data grid) on the coarse nodes: σt and
        σs = a·σt restricted, the albedo their ratio (0 where σt is 0: nothing scatters or absorbs
        there whatever the albedo)."""
        from ..._kernels.diffusion_coarse import restrict_source

        sig = medium.sigma_t
        alb = medium.albedo
        a = _four(alb)
        sig_c = self.restrict(sig)
        sig_s = np.zeros(self.shape + (a.shape[3],))
        args = [x for mp in self.maps for x in mp[2:4]]
        restrict_source(sig, False, sig, a, np.ones(a.shape[3]), *args, sig_s)
        pos = sig_c[..., None] > 0.0
        alb_c = np.clip(np.where(pos, sig_s / np.where(pos, sig_c[..., None], 1.0), 0.0), 0.0, 1.0)
        if alb.ndim == 3:
            alb_c = alb_c[..., 0]
        return DiffusionMedium(np.ascontiguousarray(sig_c), np.ascontiguousarray(alb_c.astype(alb.dtype)))


def thin_enough(sigma_t, spacing, factor=2.0) -> bool:
    """Whether the diffusion solve may run on the grid ``factor`` times coarser: the grid holds at
    least ``COARSE_MIN_NODES`` samples and the medium is optically thin per coarse cell, the 99.9th
    percentile of σt·(``factor``·h) at most ``COARSE_SIGMA_H`` (a few dense voxels are allowed: the
    restriction smooths them, and the light scattered in them is carried on)."""
    s = np.asarray(sigma_t)
    if s.size < COARSE_MIN_NODES:
        return False
    h = factor * float(np.max(spacing))
    sub = s[::2, ::2, ::2] if s.size > 1 << 20 else s  # a sample of the nodes is enough for a percentile
    return float(np.percentile(sub, 99.9)) * h <= COARSE_SIGMA_H


def _patch(shape, centre, radius):
    """Index slices of the data samples within ``radius`` (max-norm) of ``centre`` (data index),
    clipped to the grid, and per axis whether each side is cut (inside the grid: a Dirichlet
    layer) — None when the box misses the grid or is a single layer."""
    sl, cut = [], []
    for n, c in zip(shape, centre):
        lo = max(0, int(math.floor(c - radius)))
        hi = min(n - 1, int(math.ceil(c + radius)))
        if hi - lo < 2:
            return None
        sl.append(slice(lo, hi + 1))
        cut.append((lo > 0, hi < n - 1))
    return tuple(sl), tuple(cut)


def _solve_patch(sig, a, g0, sigma_floor, spacing, association, Q0, Q1, R, phi_bc, cut, tol):
    """One channel on a box of data samples whose cut sides' outer layer holds ``phi_bc``
    (Dirichlet); the other sides are the medium's own faces (Marshak). ``Q1``: index-axis
    components or None; ``R`` the index axes in world (None: identity). Returns (φ, F world
    components, the held layer) on the box."""
    from ..._kernels.diffusion_system import medium_coefficients
    from .multigrid import SERIAL_NODES, hierarchy, one_thread_if, pcg
    from .system import FVGrid, assemble, flux_and_power

    shape = sig.shape
    ghost = np.zeros(shape, bool)
    for ax in range(3):
        for side, is_cut in enumerate(cut[ax]):
            if is_cut:
                idx = [slice(None)] * 3
                idx[ax] = 0 if side == 0 else -1
                ghost[tuple(idx)] = True
    sig = np.ascontiguousarray(sig, np.float64)  # no side cut: the box is the grid, solved in full
    a = np.ascontiguousarray(a)
    D = np.empty(shape)
    part = np.zeros(shape[0])
    medium_coefficients(sig, a, np.zeros((1, 1, 1)), False, float(g0), float(sigma_floor), D, part)
    grid = FVGrid(shape, spacing, association)
    q0 = np.ascontiguousarray(Q0, np.float64)
    q1 = None if Q1 is None else np.ascontiguousarray(Q1, np.float64)
    w, c, b = assemble(grid, sig, a, D, q0, q1)
    for ax in range(3):
        lo = [slice(None)] * 3
        hi = [slice(None)] * 3
        lo[ax] = slice(0, -1)
        hi[ax] = slice(1, None)
        lo, hi = tuple(lo), tuple(hi)
        g_lo, g_hi = ghost[lo], ghost[hi]
        wl = w[ax][lo].astype(np.float64)
        # an inner node next to a held one: the coupling moves to its diagonal and right-hand side
        for m, inner, held in ((g_hi & ~g_lo, lo, hi), (g_lo & ~g_hi, hi, lo)):
            c[inner][m] += wl[m]
            b[inner][m] += wl[m] * phi_bc[held][m]
        w[ax][lo][g_lo | g_hi] = 0.0
    scale = float(np.mean(c[~ghost])) if np.any(~ghost) else 1.0
    c[ghost] = scale
    b[ghost] = scale * phi_bc[ghost]
    with one_thread_if(sig.size <= SERIAL_NODES):
        levels = hierarchy(w, c, grid.h)
        phi, _, _ = pcg(levels, b, phi_bc, tol, 200, "multigrid")
    phi[ghost] = phi_bc[ghost]
    F = np.zeros(shape + (3,), np.float32)
    flux_and_power(grid, phi, sig, a, D, q0, q1, R, F)
    return phi, F, ghost


def local_flux(medium, g, floor, Q1):
    """``3 D Q1`` per channel at the nodes of ``medium`` (world components, float32 (…, C, 3)): the
    part of the flux F = −D∇φ + 3DQ1 that follows the source node by node. The coarse grid smooths
    it away with the medium's voxel-scale structure, so it is taken off the coarse flux before the
    interpolation and added back at the data samples."""
    sig = medium.sigma_t
    alb = _four(medium.albedo)
    q1 = Q1 if Q1.ndim == 5 else Q1[..., None, :]
    out = np.empty(q1.shape, np.float32)
    for ch in range(q1.shape[3]):
        a = alb[..., min(ch, alb.shape[3] - 1)]
        D = 1.0 / (3.0 * np.maximum(sig * (1.0 - a * g), floor))
        out[..., ch, :] = 3.0 * D[..., None] * q1[..., ch, :]
    return out if Q1.ndim == 5 else out[..., 0, :]


def _box_source(medium, sources, sl, ch):
    """Channel ``ch`` of the first-collision source of ``sources`` on the data samples ``sl``."""
    alb = _four(medium.albedo)
    a = alb[..., min(ch, alb.shape[3] - 1)][sl]
    q = np.zeros(a.shape)
    for e, power in sources:
        q += e[sl] * power[min(ch, len(power) - 1)]
    return q * medium.sigma_t[sl] * a


def solve_coarse(solve, medium, coarse_medium, co, g, spacing, sources, Q1=None, points=(), *, floor, tol,
                 x0=None, association="point", direction=None, patch_radius=None):
    """Plain diffusion (mean cosine ``g``, a float) of the first-collision source of ``sources``
    (``(e, power)`` pairs, :meth:`Coarsening.restrict_sources`) and the first-moment source ``Q1``
    ((nx, ny, nz, C, 3) world components, or None) solved on ``co``'s coarse grid by
    ``solve(medium, spacing, Q0, Q1, x0)`` (the caller's :func:`.solve.solve_in_medium` with its
    options) in ``coarse_medium``; φ interpolated at the data samples (float32), F too where there
    is a first moment (its local part :func:`local_flux` the data samples' own; without ``Q1`` F is
    None: an isotropic phase function's radiance has no flux term), and boxes of ``patch_radius``
    around ``points`` (data index: the point lights; ``PATCH_RADIUS`` when None) solved again at
    the data resolution. ``floor``: the vacuum floor of σt' (the data grid's). ``x0``: a warm start
    on the data grid. Returns a :class:`.DiffusionSolution` on the data grid (``power``,
    ``iterations`` and ``residual`` are the coarse solve's)."""
    t_start = time.perf_counter()
    patch_radius = PATCH_RADIUS if patch_radius is None else patch_radius
    Hsp = np.linalg.norm(np.asarray(co.geometry.index_to_world, np.float64)[:3, :3], axis=0)
    x0c = None if x0 is None else co.restrict(x0)
    q0c = co.restrict_sources(medium, sources)
    C = q0c.shape[3]
    q1c = None
    if Q1 is not None:
        q1 = Q1 if Q1.ndim == 5 else Q1[..., None, :]
        q1c = co.restrict(q1.reshape(q1.shape[:3] + (-1,))).reshape(co.shape + q1.shape[3:])
    sol = solve(coarse_medium, Hsp, q0c, q1c, x0c)
    phi = co.prolong(sol.phi, np.float32)
    flux = None
    if Q1 is not None:
        fl = sol.flux - local_flux(coarse_medium, g, floor, q1c)
        flux = co.prolong(fl.reshape(fl.shape[:3] + (-1,)), np.float32).reshape(phi.shape[:3] + fl.shape[3:])
        flux += local_flux(medium, g, floor, q1)
    sp = np.asarray(spacing, np.float64)
    shape = tuple(medium.sigma_t.shape)
    alb = _four(medium.albedo)
    for p in points:
        box = _patch(shape, p, patch_radius)
        if box is None:
            continue
        sl, cut = box
        for ch in range(C):
            s1 = None
            if Q1 is not None:
                s1 = q1[..., ch, :][sl]
                if direction is not None:
                    s1 = s1 @ np.asarray(direction, np.float64)  # world → index-axis components
            out = _solve_patch(medium.sigma_t[sl], alb[..., min(ch, alb.shape[3] - 1)][sl], g, floor, sp, association,
                               _box_source(medium, sources, sl, ch), s1, direction,
                               np.ascontiguousarray(phi[..., ch][sl], np.float64), cut, tol)
            phi_p, F_p, ghost = out
            phi[..., ch][sl] = phi_p
            if flux is not None:
                inner = ~ghost
                flux[..., ch, :][sl][inner] = F_p[inner]
    sol.phi = phi
    sol.flux = flux
    sol.time = time.perf_counter() - t_start
    return sol


def solve_remainder(solve, coarse, q0, shape, x0=None):
    """The light the transport sweeps leave to diffusion (source ``q0``: σs φ_K on the data grid,
    per channel) solved on ``coarse`` = (Coarsening, coarse medium) by ``solve(medium, spacing, Q0,
    x0)``: ``q0`` restricted, a warm start ``x0`` (data grid) too, φ (float64) and F (float32)
    interpolated back at the data samples of ``shape``. No box around the lights: order K's fluence,
    scattered K times already, is smooth there (docs/diffusion.rst, "Solve resolution")."""
    co, medium_c = coarse
    Hsp = np.linalg.norm(np.asarray(co.geometry.index_to_world, np.float64)[:3, :3], axis=0)
    sol = solve(medium_c, Hsp, co.restrict(q0), None if x0 is None else co.restrict(x0))
    sol.phi = co.prolong(sol.phi)
    fl = sol.flux
    sol.flux = co.prolong(fl.reshape(fl.shape[:3] + (-1,)), np.float32).reshape(tuple(shape) + fl.shape[3:])
    return sol
