"""Aggregation multigrid transfers of the diffusion solve's preconditioner (docs/diffusion.rst §2,
"Solver"): the residual restricted to aggregates, piecewise-constant prolongation, and the coarse
operator. Arrays are stored as in :mod:`.diffusion_operator` (float32 coefficients and coarse
iterates; sums in float64); an aggregate is a block of ``fx × fy × fz`` fine nodes (2 along a
coarsened axis, else 1).
"""

from __future__ import annotations

import numpy as np

from ._jit import driver, prange
from .diffusion_operator import RESIDUAL, row_apply, row_index


@driver
def residual_restrict(wx, wy, wz, c, x, b, fx, fy, fz, rc):
    """rc[I, J, K] = Σ over the fine block of node (I, J, K) of the residual b − A x
    (blocks of fx × fy × fz; the residual is never stored)."""
    nx, ny, nz = x.shape
    mx, my, mz = rc.shape
    for ci in prange(mx):
        row = np.empty(nz)
        acc = np.zeros((my, mz))  # float64 sums, stored in rc's dtype once
        for i in range(ci * fx, min(ci * fx + fx, nx)):
            im, ip, fi = row_index(i, nx)
            for j in range(ny):
                jm, jp, fj = row_index(j, ny)
                cj = j // fy
                row_apply(wx, wy, wz, c, x, b, i, j, im, ip, jm, jp, fi, fj, RESIDUAL, row)
                for ck in range(mz):
                    s = 0.0
                    for k in range(ck * fz, min(ck * fz + fz, nz)):
                        s += row[k]
                    acc[cj, ck] += s
        for cj in range(my):
            for ck in range(mz):
                rc[ci, cj, ck] = acc[cj, ck]


@driver
def prolong_add(xc, fx, fy, fz, x):
    """x += xc of the block each fine node belongs to (piecewise-constant prolongation)."""
    nx, ny, nz = x.shape
    for i in prange(nx):
        ci = i // fx
        for j in range(ny):
            cj = j // fy
            for k in range(nz):
                x[i, j, k] += xc[ci, cj, k // fz]


@driver
def coarsen(wx, wy, wz, c, fx, fy, fz, wxc, wyc, wzc, cc):
    """Coarse operator of fx × fy × fz aggregates: c summed; a coarse face coupling is the sum
    of the fine couplings across the aggregates' interface (Galerkin with piecewise-constant
    prolongation), halved along a coarsened axis (re-discretisation: the distance between
    aggregate centres doubled)."""
    nx, ny, nz = c.shape
    mx, my, mz = cc.shape
    sx = 0.5 if fx == 2 else 1.0
    sy = 0.5 if fy == 2 else 1.0
    sz = 0.5 if fz == 2 else 1.0
    for ci in prange(mx):
        i0 = ci * fx
        i1 = min(i0 + fx, nx)
        for cj in range(my):
            j0 = cj * fy
            j1 = min(j0 + fy, ny)
            for ck in range(mz):
                k0 = ck * fz
                k1 = min(k0 + fz, nz)
                s = 0.0
                for i in range(i0, i1):
                    for j in range(j0, j1):
                        for k in range(k0, k1):
                            s += c[i, j, k]
                cc[ci, cj, ck] = s
                if ci < mx - 1:
                    s = 0.0
                    for j in range(j0, j1):
                        for k in range(k0, k1):
                            s += wx[i1 - 1, j, k]
                    wxc[ci, cj, ck] = sx * s
                if cj < my - 1:
                    s = 0.0
                    for i in range(i0, i1):
                        for k in range(k0, k1):
                            s += wy[i, j1 - 1, k]
                    wyc[ci, cj, ck] = sy * s
                if ck < mz - 1:
                    s = 0.0
                    for i in range(i0, i1):
                        for j in range(j0, j1):
                            s += wz[i, j, k1 - 1]
                    wzc[ci, cj, ck] = sz * s
