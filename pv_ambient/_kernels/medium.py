"""Optical properties at a point: interpolate, then classify (scalar kernels).

Two modes (``pv_ambient.inputs.transfer.Optics``): ``MODE_LUT`` interpolates the scalar field
trilinearly and looks it up in the table (columns σt, albedo rgb, emission rgb, colour rgb) with
linear interpolation between entries (post-classification, as VTK); ``MODE_GRID`` interpolates σt
from ``field`` and albedo/emission from ``aux`` (physical arrays, or a baked TF).
"""

from __future__ import annotations

from ._jit import driver, prange, scalar
from .interp import trilinear

MODE_LUT = 0
MODE_GRID = 1


@scalar(inline=True)
def lut_coords(s, lut_lo, lut_inv, n):
    """Entries (k0, k1) and fraction for scalar ``s`` in a table of ``n`` entries (clamped)."""
    x = (s - lut_lo) * lut_inv
    if x <= 0.0:
        return 0, 0, 0.0
    if x >= n - 1:
        return n - 1, n - 1, 0.0
    k0 = int(x)
    return k0, k0 + 1, x - k0


@scalar(inline=True)
def lut_value(table, k0, k1, f, col):
    return table[k0, col] + f * (table[k1, col] - table[k0, col])


@scalar(inline=True)
def sigma_at(mode, field, table, lut_lo, lut_inv, x, y, z):
    """Extinction σt at index-space point (x, y, z)."""
    s = trilinear(field, x, y, z)
    if mode == MODE_GRID:
        return s
    k0, k1, f = lut_coords(s, lut_lo, lut_inv, table.shape[0])
    return lut_value(table, k0, k1, f, 0)


@driver
def classify_columns(field, table, lut_lo, lut_inv, col, out):
    """Columns ``col … col + ncomp − 1`` of ``table`` at every sample of the scalar ``field``
    (``out``: (nx, ny, nz, ncomp) float32), interpolated and clamped as :func:`lut_coords` /
    :func:`lut_value` do per sample, in double precision; samples in parallel."""
    nx, ny, nz = field.shape
    n = table.shape[0]
    ncomp = out.shape[3]
    for i in prange(nx):  # the last index innermost (C order)
        for j in range(ny):
            for k in range(nz):
                x = (field[i, j, k] - lut_lo) * lut_inv
                x = min(max(x, 0.0), n - 1.0)
                k0 = min(int(x), n - 2)
                f = x - k0
                for c in range(ncomp):
                    out[i, j, k, c] = (1.0 - f) * table[k0, col + c] + f * table[k0 + 1, col + c]


@driver
def scattering_nodes(mode, field, table, lut_lo, lut_inv, aux, node0, node1, node2, out):
    """Marks in ``out`` (the light grid's shape, bool) every node nearest to a data sample that
    scatters (σt > 0 and some albedo channel > 0); ``node0/1/2`` map a data index to its nearest
    node per axis. Writes only ``True`` (concurrent writes of the same value are benign)."""
    nx, ny, nz = field.shape
    n = table.shape[0]
    for i in prange(nx):  # the last index innermost (C order)
        for j in range(ny):
            for k in range(nz):
                if mode == MODE_GRID:
                    sig = field[i, j, k]
                    alb = max(aux[i, j, k, 0], max(aux[i, j, k, 1], aux[i, j, k, 2]))
                else:
                    k0, k1, f = lut_coords(field[i, j, k], lut_lo, lut_inv, n)
                    sig = lut_value(table, k0, k1, f, 0)
                    alb = max(lut_value(table, k0, k1, f, 1), max(lut_value(table, k0, k1, f, 2),
                                                                 lut_value(table, k0, k1, f, 3)))
                if sig > 0.0 and alb > 0.0:
                    out[node0[i], node1[j], node2[k]] = True
