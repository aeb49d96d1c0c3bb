"""Coarse majorant grid: an upper bound of σt per block of samples (empty-space skipping,
delta-tracking majorants).

Block (a, b, c) of size B covers index space [aB, (a+1)B] per axis — its samples *and* the
samples on its upper faces, so the trilinear field inside the block depends only on them.
In LUT mode the bound is the table's maximum over the entries between the block's minimum and
maximum scalar (a non-monotone TF can peak between two corner values); in GRID mode it is the
maximum of the σt samples.
"""

from __future__ import annotations

import math

from ._jit import driver, prange, scalar
from .medium import MODE_GRID, lut_coords


@driver
def build_majorant(mode, field, table, lut_lo, lut_inv, block, out):
    nx, ny, nz = field.shape
    mx, my, mz = out.shape
    n = table.shape[0]
    for c in prange(mz):
        for b in range(my):
            for a in range(mx):
                smin = math.inf
                smax = -math.inf
                for k in range(c * block, min((c + 1) * block, nz - 1) + 1):
                    for j in range(b * block, min((b + 1) * block, ny - 1) + 1):
                        for i in range(a * block, min((a + 1) * block, nx - 1) + 1):
                            v = field[i, j, k]
                            if v < smin:
                                smin = v
                            if v > smax:
                                smax = v
                if mode == MODE_GRID:
                    out[a, b, c] = smax
                else:
                    k0, _, _ = lut_coords(smin, lut_lo, lut_inv, n)
                    _, k1, _ = lut_coords(smax, lut_lo, lut_inv, n)
                    m = 0.0
                    for k in range(k0, k1 + 1):
                        if table[k, 0] > m:
                            m = table[k, 0]
                    out[a, b, c] = m


@scalar
def block_of(x, block, m):
    """Block index of continuous index coordinate ``x`` (clamped to [0, m−1])."""
    a = int(math.floor(x / block))
    if a < 0:
        return 0
    if a > m - 1:
        return m - 1
    return a


@scalar
def block_exit(ox, oy, oz, dx, dy, dz, a, b, c, block):
    """Ray parameter where the ray leaves block (a, b, c) (largest slab entry is irrelevant)."""
    t = math.inf
    if dx > 0.0:
        t = min(t, ((a + 1) * block - ox) / dx)
    elif dx < 0.0:
        t = min(t, (a * block - ox) / dx)
    if dy > 0.0:
        t = min(t, ((b + 1) * block - oy) / dy)
    elif dy < 0.0:
        t = min(t, (b * block - oy) / dy)
    if dz > 0.0:
        t = min(t, ((c + 1) * block - oz) / dz)
    elif dz < 0.0:
        t = min(t, (c * block - oz) / dz)
    return t
