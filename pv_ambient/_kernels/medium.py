"""Optical properties at a point: interpolate, then classify (scalar kernels).

Two modes (``pv_ambient.inputs.transfer.Optics``): ``MODE_LUT`` interpolates the scalar field
trilinearly and looks it up in the table (columns σt, albedo rgb, emission rgb, colour rgb) with
linear interpolation between entries (post-classification, as VTK); ``MODE_GRID`` interpolates σt
from ``field`` and albedo/emission from ``aux`` (physical arrays, or a baked TF).
"""

from __future__ import annotations

from ._jit import scalar
from .interp import trilinear

MODE_LUT = 0
MODE_GRID = 1


@scalar
def lut_coords(s, lut_lo, lut_inv, n):
    """Entries (k0, k1) and fraction for scalar ``s`` in a table of ``n`` entries (clamped)."""
    x = (s - lut_lo) * lut_inv
    if x <= 0.0:
        return 0, 0, 0.0
    if x >= n - 1:
        return n - 1, n - 1, 0.0
    k0 = int(x)
    return k0, k0 + 1, x - k0


@scalar
def lut_value(table, k0, k1, f, col):
    return table[k0, col] + f * (table[k1, col] - table[k0, col])


@scalar
def sigma_at(mode, field, table, lut_lo, lut_inv, x, y, z):
    """Extinction σt at index-space point (x, y, z)."""
    s = trilinear(field, x, y, z)
    if mode == MODE_GRID:
        return s
    k0, k1, f = lut_coords(s, lut_lo, lut_inv, table.shape[0])
    return lut_value(table, k0, k1, f, 0)
