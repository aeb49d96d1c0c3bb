"""Coarse majorant grid: an upper bound of σt per block of samples (empty-space skipping,
delta-tracking majorants).

Block (a, b, c) of size B covers index space [aB, (a+1)B] per axis — its samples *and* the
samples on its upper faces, so the trilinear field inside the block depends only on them.
In LUT mode the bound is the table's maximum over the entries between the block's minimum and
maximum scalar (a non-monotone TF can peak between two corner values); in GRID mode it is the
maximum of the σt samples.

The walk through the grid is written once, here: :func:`block_at` locates a point's block,
:func:`block_span` gives a block's exit along a ray, and :func:`walk_start` / :func:`walk_step`
step the blocks a ray crosses in order (3D DDA) for the null-collision trackers
(:mod:`.tracking`). The ray cast (:mod:`.raycast`) locates the block of each segment's midpoint
and skips an empty one to its :func:`block_span` exit. The first and last block along each axis
extend to ±∞ (lookups clamp to the boundary samples there), so their exit on that side is
``inf`` and the walk never leaves the grid.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import driver, prange, scalar
from .medium import MODE_GRID, lut_coords


@scalar(inline=True)
def block_range(field, a, b, c, block):
    """The least and the greatest value of ``field`` over block (a, b, c) of ``block``³ samples — its
    samples and those on its upper faces (this module's docstring)."""
    nx, ny, nz = field.shape
    smin = math.inf
    smax = -math.inf
    for i in range(a * block, min((a + 1) * block, nx - 1) + 1):  # C order: k innermost
        for j in range(b * block, min((b + 1) * block, ny - 1) + 1):
            for k in range(c * block, min((c + 1) * block, nz - 1) + 1):
                v = field[i, j, k]
                if v < smin:
                    smin = v
                if v > smax:
                    smax = v
    return smin, smax


@scalar(inline=True)
def majorant_block(mode, field, table, lut_lo, lut_inv, block, a, b, c):
    """The bound of :func:`build_majorant` on block (a, b, c): the largest σt sample (GRID), or
    the table's largest σt over every entry the block's least and greatest scalar touch (LUT)."""
    smin, smax = block_range(field, a, b, c, block)
    if mode == MODE_GRID:
        return np.float64(smax)
    n = table.shape[0]
    k0, _, _ = lut_coords(smin, lut_lo, lut_inv, n)
    _, k1, _ = lut_coords(smax, lut_lo, lut_inv, n)
    m = 0.0
    for k in range(k0, k1 + 1):
        if table[k, 0] > m:
            m = table[k, 0]
    return m


@driver
def build_majorant(mode, field, table, lut_lo, lut_inv, block, out):
    """:func:`majorant_block` of every block (its loop body, as the GPU's kernel's, :mod:`.cuda`)."""
    mx, my, mz = out.shape
    for c in prange(mz):
        for b in range(my):
            for a in range(mx):
                out[a, b, c] = majorant_block(mode, field, table, lut_lo, lut_inv, block, a, b, c)


@scalar(inline=True)
def cast_majorant_block(mode, field, table, lut_lo, lut_inv, block, sigma_min, a, b, c):
    """The value of :func:`build_cast_majorant` on block (a, b, c)."""
    smin, smax = block_range(field, a, b, c, block)
    if mode == MODE_GRID:
        m = np.float64(smax)
    else:
        n = table.shape[0]
        i0, i1, f0 = lut_coords(smin, lut_lo, lut_inv, n)
        j0, j1, f1 = lut_coords(smax, lut_lo, lut_inv, n)
        m = max(table[i0, 0] + f0 * (table[i1, 0] - table[i0, 0]),
                table[j0, 0] + f1 * (table[j1, 0] - table[j0, 0]))
        for k in range(i0 + 1, j0 + 1):
            if table[k, 0] > m:
                m = table[k, 0]
    return m if m > sigma_min else 0.0


@driver
def build_cast_majorant(mode, field, table, lut_lo, lut_inv, block, sigma_min, out):
    """The ray cast's majorant grid: :func:`build_majorant`'s blocks, each the largest σt a sample
    in it can take, and 0 where that is at most ``sigma_min`` (a negligible σt: the caller's). In
    LUT mode the σt of an interpolated scalar is piecewise linear in it, so its largest over the
    block's scalars is the table interpolated at the least and the greatest scalar or an entry
    between them — where :func:`build_majorant`
    takes every entry the two touch: a block of scalars that are zero but for denormal rounding
    is empty here and not there. The path tracer's delta tracking keeps :func:`build_majorant`
    (it needs a bound, not the ray cast's skip). Each block is :func:`cast_majorant_block` (the
    GPU's kernel's loop body too, :mod:`.cuda`)."""
    mx, my, mz = out.shape
    for c in prange(mz):
        for b in range(my):
            for a in range(mx):
                out[a, b, c] = cast_majorant_block(mode, field, table, lut_lo, lut_inv, block, sigma_min, a, b, c)


@scalar(inline=True)
def block_of(x, block, m):
    """Block index of continuous index coordinate ``x`` (clamped to [0, m−1]). Comparisons with
    ``m`` rather than ``m − 1`` here and in :func:`axis_exit`: a CUDA thread holds no ``m − 1`` per
    axis across its sample loop (:func:`.interp.cell_coords`)."""
    a = int(math.floor(x / block))
    if a < 0:
        return 0
    if a >= m:
        return m - 1
    return a


@scalar(inline=True)
def block_at(x, y, z, maj, block):
    """Block (a, b, c) of majorant grid ``maj`` that holds index-space point (x, y, z) (clamped)."""
    mx, my, mz = maj.shape
    return block_of(x, block, mx), block_of(y, block, my), block_of(z, block, mz)


@scalar
def axis_exit(p, q, a, block, m):
    """Ray parameter where ``p + t·q`` leaves slab ``a`` of ``m`` slabs of width ``block``.

    The first slab extends to −∞ and the last to +∞ (lookups clamp there), so the exit on
    those sides, and along an axis the ray does not move on, is ``inf``.
    """
    if q > 0.0:
        if a + 1 >= m:
            return math.inf
        return ((a + 1) * block - p) / q
    if q < 0.0:
        if a <= 0:
            return math.inf
        return (a * block - p) / q
    return math.inf


@scalar
def block_span(px, py, pz, qx, qy, qz, a, b, c, maj, block, t, t1):
    """Exits of block (a, b, c) of ``maj`` along each axis and overall, ``(tx, ty, tz, tb)``;
    ``tb`` is clipped to ``t1`` and never behind ``t``, whatever the rounding."""
    mx, my, mz = maj.shape
    tx = axis_exit(px, qx, a, block, mx)
    ty = axis_exit(py, qy, b, block, my)
    tz = axis_exit(pz, qz, c, block, mz)
    return tx, ty, tz, max(min(min(tx, ty), min(tz, t1)), t)


@scalar
def next_block(a, b, c, tx, ty, tz, tb, qx, qy, qz):
    """The block entered at ``tb``: step every axis whose exit is reached (DDA)."""
    if tx <= tb:
        a += 1 if qx > 0.0 else -1
    if ty <= tb:
        b += 1 if qy > 0.0 else -1
    if tz <= tb:
        c += 1 if qz > 0.0 else -1
    return a, b, c


# --- the walk: the blocks a ray crosses, in order (3D DDA, Amanatides & Woo 1987) -----------
#
# State ``(a, b, c, t)``: the current block and where the ray enters it. No generators or
# closures (CUDA device code): the walk is a tuple and a step function,
#
#     walk = walk_start(px, py, pz, qx, qy, qz, t0, maj, block)
#     while walk[3] < t1:
#         walk, ta, tb, m = walk_step(walk, px, py, pz, qx, qy, qz, t1, maj, block)
#         ...  # [ta, tb) lies in one block of majorant m


@scalar
def walk_start(px, py, pz, qx, qy, qz, t0, maj, block):
    """The walk of ray ``p + t·q`` (index space) from ``t0``: its first block and ``t0``."""
    a, b, c = block_at(px + t0 * qx, py + t0 * qy, pz + t0 * qz, maj, block)
    return a, b, c, t0


@scalar
def walk_step(walk, px, py, pz, qx, qy, qz, t1, maj, block):
    """``(walk', ta, tb, m)``: the current block's interval ``[ta, tb)`` (``tb`` clipped to ``t1``),
    its majorant ``m``, and the walk advanced to the next block at ``tb``."""
    a, b, c, t = walk
    tx, ty, tz, tb = block_span(px, py, pz, qx, qy, qz, a, b, c, maj, block, t, t1)
    m = maj[a, b, c]
    if tb < t1:
        a, b, c = next_block(a, b, c, tx, ty, tz, tb, qx, qy, qz)
    return (a, b, c, tb), t, tb, m


@scalar
def walk_optical_depth(px, py, pz, qx, qy, qz, t0, t1, grid, block):
    """``Σ grid[block] × length`` over the blocks ray ``p + t·q`` crosses on ``[t0, t1)``: with the
    majorant grid, the majorant's optical depth, a deterministic upper bound of the medium's."""
    tau = 0.0
    walk = walk_start(px, py, pz, qx, qy, qz, t0, grid, block)
    while walk[3] < t1:
        walk, ta, tb, m = walk_step(walk, px, py, pz, qx, qy, qz, t1, grid, block)
        tau += m * (tb - ta)
    return tau


@driver
def masked_min(values, mask):
    """The least of ``values`` where ``mask`` (same 3-D shape) is true, ``inf`` where it never is:
    one parallel pass, no copy of the selected values (a light's smallest optical depth at the
    nodes that scatter, :meth:`pv_ambient.rendering.scene_stages.SceneStages.active_lights`)."""
    n0 = values.shape[0]
    lows = np.full(n0, np.inf)
    for i in prange(n0):
        low = np.inf
        for j in range(values.shape[1]):
            for k in range(values.shape[2]):
                if mask[i, j, k] and values[i, j, k] < low:
                    low = values[i, j, k]
        lows[i] = low
    return lows.min() if n0 else np.inf


#: The distance :func:`empty_distance` gives where a grid has no empty block.
NO_EMPTY = 1 << 30


@scalar
def _line_distance(line, m):
    """``line[i] = min_k max(|i − k|, line[k])`` over the first ``m`` entries, in place (one axis of
    :func:`empty_distance`; a copy of the line's input is kept in its second half)."""
    for i in range(m):
        line[m + i] = line[i]
    for i in range(m):
        best = line[m + i]
        for k in range(m):
            d = max(abs(i - k), line[m + k])
            if d < best:
                best = d
        line[i] = best


@driver
def _distance_along_first(d):
    """One axis of :func:`empty_distance`: every line of ``d`` along its first axis through
    :func:`_line_distance` (``d`` a view with that axis first)."""
    m, u, v = d.shape
    for j in prange(u):
        line = np.empty(2 * m, np.int64)
        for k in range(v):
            for i in range(m):
                line[i] = d[i, j, k]
            _line_distance(line, m)
            for i in range(m):
                d[i, j, k] = line[i]


def empty_distance(maj):
    """The Chebyshev distance, in blocks, from each block of majorant grid ``maj`` to its nearest
    empty block (int64, ``maj``'s shape; 0 for an empty block, :data:`NO_EMPTY` where none is), by
    one pass per axis of ``d[i] = min_k max(|i − k|, d[k])`` (the distance is separable). Every block
    less than ``d`` blocks away along each axis is non-empty: :func:`run_end` crosses such a cube of
    blocks in one step."""
    out = np.where(np.asarray(maj) <= 0.0, 0, NO_EMPTY).astype(np.int64)
    for axes in ((0, 1, 2), (1, 0, 2), (2, 0, 1)):
        _distance_along_first(out.transpose(axes))
    return out


@scalar
def run_end(px, py, pz, qx, qy, qz, a, b, c, t, t1, maj, dist, block):
    """Where the run of non-empty blocks that block (a, b, c) starts at ``t`` ends along ray
    ``p + t·q`` (clipped to ``t1``), or a boundary before it: the packet driver marches to it
    without a block lookup — in the per-pixel march a lookup at a boundary between non-empty blocks
    changes nothing but the next boundary (docs/performance.rst, "CPU camera pass"). From a block
    ``dist[a, b, c]`` = d ≥ 2 blocks from the nearest empty one (:func:`empty_distance`) the walk
    crosses the cube of blocks d − 1 around it in one step — in a grid without empty blocks the
    whole ray — and otherwise steps one block, keeping each axis's exit and computing it again only
    for the axis it steps along (the block walk's values, :func:`walk_step`, with one division a
    block instead of three). A cube's exit through a face is the block walk's boundary there."""
    mx, my, mz = maj.shape
    sa = 1 if qx > 0.0 else -1
    sb = 1 if qy > 0.0 else -1
    sc = 1 if qz > 0.0 else -1
    while True:
        r = dist[a, b, c] - 1
        if r >= 1:
            if r >= NO_EMPTY - 1:
                return max(t1, t)
            tx = axis_exit(px, qx, a + sa * r, block, mx)
            ty = axis_exit(py, qy, b + sb * r, block, my)
            tz = axis_exit(pz, qz, c + sc * r, block, mz)
            tc = max(min(min(tx, ty), min(tz, t1)), t)
            if tc >= t1:
                return tc
            if tc > t:
                # the block entered at tc: a face's axis one past the cube, the others where the ray is
                na = a + sa * (r + 1) if tx <= tc else min(max(block_of(px + tc * qx, block, mx), a - r), a + r)
                nb = b + sb * (r + 1) if ty <= tc else min(max(block_of(py + tc * qy, block, my), b - r), b + r)
                nc = c + sc * (r + 1) if tz <= tc else min(max(block_of(pz + tc * qz, block, mz), c - r), c + r)
                a, b, c, t = na, nb, nc, tc
                if maj[a, b, c] <= 0.0:
                    return tc
                continue
        tx = axis_exit(px, qx, a, block, mx)
        ty = axis_exit(py, qy, b, block, my)
        tz = axis_exit(pz, qz, c, block, mz)
        tb = max(min(min(tx, ty), min(tz, t1)), t)  # block_span's exit
        if tb >= t1 or tb <= t:
            return tb
        if tx <= tb:  # next_block
            a += sa
        if ty <= tb:
            b += sb
        if tz <= tb:
            c += sc
        t = tb
        if maj[a, b, c] <= 0.0:
            return tb
