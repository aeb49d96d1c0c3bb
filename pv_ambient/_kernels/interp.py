"""Trilinear interpolation in sample index space, clamped to the grid (scalar kernels)."""

from __future__ import annotations

from ._jit import scalar


@scalar
def cell_coords(x, n):
    """Lower index, upper index and fraction of continuous coordinate ``x`` on ``n`` samples.

    Positions outside [0, n−1] are clamped (the nearest sample's value continues to the box
    edge, which for cell data lies half a cell beyond the outermost centre)."""
    if x <= 0.0:
        return 0, 0, 0.0
    if x >= n - 1:
        return n - 1, n - 1, 0.0
    i0 = int(x)
    return i0, i0 + 1, x - i0


@scalar
def trilinear(g, x, y, z):
    """Trilinear value of the 3D array ``g`` at index-space point (x, y, z)."""
    i0, i1, fx = cell_coords(x, g.shape[0])
    j0, j1, fy = cell_coords(y, g.shape[1])
    k0, k1, fz = cell_coords(z, g.shape[2])
    c00 = g[i0, j0, k0] + fx * (g[i1, j0, k0] - g[i0, j0, k0])
    c10 = g[i0, j1, k0] + fx * (g[i1, j1, k0] - g[i0, j1, k0])
    c01 = g[i0, j0, k1] + fx * (g[i1, j0, k1] - g[i0, j0, k1])
    c11 = g[i0, j1, k1] + fx * (g[i1, j1, k1] - g[i0, j1, k1])
    c0 = c00 + fy * (c10 - c00)
    c1 = c01 + fy * (c11 - c01)
    return c0 + fz * (c1 - c0)


@scalar
def trilinear_c(g, x, y, z, c):
    """Trilinear value of component ``c`` of the 4D array ``g`` (nx, ny, nz, ncomp)."""
    i0, i1, fx = cell_coords(x, g.shape[0])
    j0, j1, fy = cell_coords(y, g.shape[1])
    k0, k1, fz = cell_coords(z, g.shape[2])
    c00 = g[i0, j0, k0, c] + fx * (g[i1, j0, k0, c] - g[i0, j0, k0, c])
    c10 = g[i0, j1, k0, c] + fx * (g[i1, j1, k0, c] - g[i0, j1, k0, c])
    c01 = g[i0, j0, k1, c] + fx * (g[i1, j0, k1, c] - g[i0, j0, k1, c])
    c11 = g[i0, j1, k1, c] + fx * (g[i1, j1, k1, c] - g[i0, j1, k1, c])
    c0 = c00 + fy * (c10 - c00)
    c1 = c01 + fy * (c11 - c01)
    return c0 + fz * (c1 - c0)


@scalar
def trilinear4(g, x, y, z):
    """Trilinear values of the four components of ``g`` (nx, ny, nz, 4), sharing the weights."""
    i0, i1, fx = cell_coords(x, g.shape[0])
    j0, j1, fy = cell_coords(y, g.shape[1])
    k0, k1, fz = cell_coords(z, g.shape[2])
    w000 = (1.0 - fx) * (1.0 - fy) * (1.0 - fz)
    w100 = fx * (1.0 - fy) * (1.0 - fz)
    w010 = (1.0 - fx) * fy * (1.0 - fz)
    w110 = fx * fy * (1.0 - fz)
    w001 = (1.0 - fx) * (1.0 - fy) * fz
    w101 = fx * (1.0 - fy) * fz
    w011 = (1.0 - fx) * fy * fz
    w111 = fx * fy * fz
    v0 = 0.0
    v1 = 0.0
    v2 = 0.0
    v3 = 0.0
    for c in range(4):
        v = (w000 * g[i0, j0, k0, c] + w100 * g[i1, j0, k0, c] + w010 * g[i0, j1, k0, c] + w110 * g[i1, j1, k0, c]
             + w001 * g[i0, j0, k1, c] + w101 * g[i1, j0, k1, c] + w011 * g[i0, j1, k1, c] + w111 * g[i1, j1, k1, c])
        if c == 0:
            v0 = v
        elif c == 1:
            v1 = v
        elif c == 2:
            v2 = v
        else:
            v3 = v
    return v0, v1, v2, v3
