"""Trilinear interpolation in sample index space, clamped to the grid (scalar kernels)."""

from __future__ import annotations

from ._jit import scalar


@scalar(inline=True)
def cell_coords(x, n):
    """Lower index, upper index and fraction of continuous coordinate ``x`` on ``n`` samples.

    Positions outside [0, n−1] are clamped (the nearest sample's value continues to the box
    edge, which for cell data lies half a cell beyond the outermost centre).

    The upper clamp compares the integer index with ``n``, not ``x`` with ``n − 1``: the same
    result, but a CUDA thread then holds no float copy of ``n − 1`` per axis and grid across its
    sample loop (the compiler hoists one there for every interpolated array; ``n`` itself is a
    kernel parameter, read from constant memory). ``x < 1e9`` (beyond any grid) keeps ``int()``
    away from ``inf`` and NaN, which clamp to the last sample."""
    if x <= 0.0:
        return 0, 0, 0.0
    if x < 1e9:
        i0 = int(x)
        if i0 + 1 < n:
            return i0, i0 + 1, x - i0
    return n - 1, n - 1, 0.0


@scalar(inline=True)
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


@scalar(inline=True)
def corner_lerp(g, i0, i1, fx, j0, j1, fy, k0, k1, fz, c):
    """Component ``c`` of the 4D array ``g`` interpolated between located corners (see
    :func:`cell_coords`): lets several components share one location."""
    c00 = g[i0, j0, k0, c] + fx * (g[i1, j0, k0, c] - g[i0, j0, k0, c])
    c10 = g[i0, j1, k0, c] + fx * (g[i1, j1, k0, c] - g[i0, j1, k0, c])
    c01 = g[i0, j0, k1, c] + fx * (g[i1, j0, k1, c] - g[i0, j0, k1, c])
    c11 = g[i0, j1, k1, c] + fx * (g[i1, j1, k1, c] - g[i0, j1, k1, c])
    c0 = c00 + fy * (c10 - c00)
    c1 = c01 + fy * (c11 - c01)
    return c0 + fz * (c1 - c0)


@scalar(inline=True)
def locate(g, x, y, z):
    """Corners and fractions of index-space point (x, y, z) in ``g`` (clamped, :func:`cell_coords`)."""
    i0, i1, fx = cell_coords(x, g.shape[0])
    j0, j1, fy = cell_coords(y, g.shape[1])
    k0, k1, fz = cell_coords(z, g.shape[2])
    return i0, i1, fx, j0, j1, fy, k0, k1, fz


@scalar(inline=True)
def trilinear_c(g, x, y, z, c):
    """Trilinear value of component ``c`` of the 4D array ``g`` (nx, ny, nz, ncomp)."""
    i0, i1, fx, j0, j1, fy, k0, k1, fz = locate(g, x, y, z)
    return corner_lerp(g, i0, i1, fx, j0, j1, fy, k0, k1, fz, c)


@scalar(inline=True)
def trilinear4(g, x, y, z):
    """Trilinear values of the four components of ``g`` (nx, ny, nz, 4), located once."""
    i0, i1, fx, j0, j1, fy, k0, k1, fz = locate(g, x, y, z)
    return (corner_lerp(g, i0, i1, fx, j0, j1, fy, k0, k1, fz, 0),
            corner_lerp(g, i0, i1, fx, j0, j1, fy, k0, k1, fz, 1),
            corner_lerp(g, i0, i1, fx, j0, j1, fy, k0, k1, fz, 2),
            corner_lerp(g, i0, i1, fx, j0, j1, fy, k0, k1, fz, 3))
