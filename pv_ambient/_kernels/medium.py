"""Optical properties at a point: interpolate, then classify (scalar kernels).

Two modes (``pv_ambient.inputs.transfer.Optics``): ``MODE_LUT`` interpolates the scalar field
trilinearly and looks it up in the table (columns σt, albedo rgb, emission rgb, colour rgb) with
linear interpolation between entries (post-classification, as VTK); ``MODE_GRID`` interpolates σt
from ``field`` and albedo/emission from ``aux`` (physical arrays, or a baked TF).
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import driver, prange, scalar
from .interp import cell_coords, trilinear, trilinear_c

MODE_LUT = 0
MODE_GRID = 1

#: A segment at least this fraction of the step long is a full step (the ray cast's segments are
#: ``step`` long but for the first, with jitter, and the last): the step-corrected table's opacity
#: applies to it. Why not equality: a segment ``[t, t + step]`` measures ``step`` only to the
#: rounding of ``t``.
FULL_STEP = 1.0 - 1e-9

#: Columns of :func:`step_table`: the opacity of one full step, the colour (rgb), the albedo (rgb),
#: the emission (rgb) and σt.
STEP_COLUMNS = 11


@scalar(inline=True)
def lut_coords(s, lut_lo, lut_inv, n):
    """Entries (k0, k1) and fraction for scalar ``s`` in a table of ``n`` entries: the table's
    continuous index located by :func:`.interp.cell_coords` (the same clamps)."""
    return cell_coords((s - lut_lo) * lut_inv, n)


@scalar(inline=True)
def lut_value(table, k0, k1, f, col):
    return table[k0, col] + f * (table[k1, col] - table[k0, col])


def step_table(table, step):
    """The step-corrected table of a LUT-mode medium (VTK's opacity correction for the sample
    distance): per entry of ``table`` (columns as :mod:`pv_ambient.inputs.transfer`) the opacity
    ``1 − e^{−σt·step}`` of one full step of world length ``step``, the colour, the albedo, the
    emission and σt (for a partial step: :func:`step_opacity`), float32 ``(n, 11)`` (:data:`STEP_COLUMNS`). :func:`step_sample` interpolates it between entries, so a full segment of the ray
    cast costs no ``exp``; the difference from ``1 − e^{−σ̂·step}`` of the interpolated σ̂ is second
    order in one entry's change of σt·step (docs/performance.rst, "CPU camera pass")."""
    out = np.zeros((table.shape[0], STEP_COLUMNS), np.float32)
    out[:, 0] = -np.expm1(-np.asarray(table[:, 0], np.float64) * float(step))
    out[:, 1:4] = table[:, 7:10]
    out[:, 4:10] = table[:, 1:7]
    out[:, 10] = table[:, 0]
    return out


@scalar
def full_segment(t, te, step):
    """1.0 when segment ``[t, te]`` is a full step (:data:`FULL_STEP`), else 0.0 (a float: the
    packet driver's lane loop keeps no boolean copies, which would cost it Numba's ``noalias``)."""
    return 1.0 if te - t >= FULL_STEP * step else 0.0


@scalar(inline=True)
def clamp32(x, hi):
    """``x`` clamped to [0, hi] as a select (float32; the lane loops vectorise only branch-free code)."""
    x = x if x > np.float32(0.0) else np.float32(0.0)
    return x if x < hi else hi


@scalar(inline=True)
def min_index(a, b):
    """The smaller of two unsigned indices (a select)."""
    return a if a < b else b


@scalar(inline=True)
def upper_corner(i0, hi):
    """``min(i0 + 1, hi)`` of an unsigned corner index ``i0`` and a grid's last index ``hi`` (float32,
    as :func:`corners32` holds it; the comparison is exact below 2²⁴): a CUDA thread then holds one value
    per axis and grid across its sample loop, the float32 last index, and no integer copies of it."""
    return np.uint32(i0 + np.uint32(1)) if np.float32(i0) < hi else i0


@scalar(inline=True)
def corners32(nx, ny, nz, x, y, z):
    """Corners and fractions of index-space point (x, y, z) on an (nx, ny, nz) grid, float32 and
    unsigned 32-bit (:func:`trilinear32`; a CUDA thread then holds an index in one register).
    Positions outside [0, n−1] are clamped as by :func:`.interp.cell_coords`. The lower corner is the
    integer part of the clamped position, the upper one the next sample or, at the last sample, the
    last sample again (fraction 0 there, so the last sample's value exactly). Every bound comes from
    one float32 ``n − 1`` per axis (:func:`upper_corner`): the only value per axis and grid that a
    CUDA thread holds across its sample loop."""
    hx, hy, hz = np.float32(nx - 1), np.float32(ny - 1), np.float32(nz - 1)
    x = clamp32(np.float32(x), hx)
    y = clamp32(np.float32(y), hy)
    z = clamp32(np.float32(z), hz)
    i0 = np.uint32(x)
    j0 = np.uint32(y)
    k0 = np.uint32(z)
    return (i0, upper_corner(i0, hx), x - np.float32(i0),
            j0, upper_corner(j0, hy), y - np.float32(j0),
            k0, upper_corner(k0, hz), z - np.float32(k0))


@scalar(inline=True)
def trilinear32(g, x, y, z):
    """Trilinear value of the 3D array ``g`` at index-space point (x, y, z), float32, unsigned
    indices: the interpolation of the vectorised lane loops (:mod:`.packet`) and of the per-pixel
    code that must equal them (:func:`corners32`)."""
    i0, i1, fx, j0, j1, fy, k0, k1, fz = corners32(g.shape[0], g.shape[1], g.shape[2], x, y, z)
    c00 = g[i0, j0, k0] + fx * (g[i1, j0, k0] - g[i0, j0, k0])
    c10 = g[i0, j1, k0] + fx * (g[i1, j1, k0] - g[i0, j1, k0])
    c01 = g[i0, j0, k1] + fx * (g[i1, j0, k1] - g[i0, j0, k1])
    c11 = g[i0, j1, k1] + fx * (g[i1, j1, k1] - g[i0, j1, k1])
    c0 = c00 + fy * (c10 - c00)
    c1 = c01 + fy * (c11 - c01)
    return c0 + fz * (c1 - c0)


@scalar(inline=True)
def trilinear32_c(g, x, y, z, c):
    """:func:`trilinear32` of component ``c`` of the 4D array ``g``."""
    i0, i1, fx, j0, j1, fy, k0, k1, fz = corners32(g.shape[0], g.shape[1], g.shape[2], x, y, z)
    return corner32(g, i0, i1, fx, j0, j1, fy, k0, k1, fz, c)


@scalar(inline=True)
def corner32(g, i0, i1, fx, j0, j1, fy, k0, k1, fz, c):
    """Component ``c`` of the 4D array ``g`` interpolated between corners located by :func:`corners32`."""
    q = np.uint32(c)
    c00 = g[i0, j0, k0, q] + fx * (g[i1, j0, k0, q] - g[i0, j0, k0, q])
    c10 = g[i0, j1, k0, q] + fx * (g[i1, j1, k0, q] - g[i0, j1, k0, q])
    c01 = g[i0, j0, k1, q] + fx * (g[i1, j0, k1, q] - g[i0, j0, k1, q])
    c11 = g[i0, j1, k1, q] + fx * (g[i1, j1, k1, q] - g[i0, j1, k1, q])
    c0 = c00 + fy * (c10 - c00)
    c1 = c01 + fy * (c11 - c01)
    return c0 + fz * (c1 - c0)


@scalar(force_inline=True)
def table_coords(s, stab, lut_lo, lut_inv):
    """``(q0, f)``: the step-corrected table's entry below scalar ``s`` (float32) and the fraction
    towards the next, the table coordinate clamped to the table."""
    nt = stab.shape[0]
    u = clamp32((s - np.float32(lut_lo)) * np.float32(lut_inv), np.float32(nt - 1))
    q0 = min_index(np.uint64(np.uint32(u)), np.uint64(nt - 2))
    return q0, u - np.float32(q0)


@scalar(force_inline=True)
def step_lookup(field, stab, lut_lo, lut_inv, x, y, z):
    """``(q0, f)``: the step-corrected table's entry below the scalar at index-space point (x, y, z)
    of a LUT-mode medium, and the fraction towards the next (float32; :func:`trilinear32`,
    :func:`table_coords`)."""
    return table_coords(trilinear32(field, x, y, z), stab, lut_lo, lut_inv)


@scalar(inline=True)
def step_column(stab, q0, f, c):
    """Column ``c`` of the step-corrected table interpolated at ``(q0, f)`` (:func:`step_lookup`)."""
    a = stab[q0, c]
    return a + f * (stab[q0 + np.uint64(1), c] - a)


@scalar(force_inline=True)
def step_opacity(stab, q0, f, full, length):
    """The opacity of a segment of world length ``length`` at the step-corrected table's ``(q0, f)``
    (:func:`step_lookup`): the table's column for a full step (``full`` non-zero:
    :func:`full_segment`), else ``1 − e^{−σt·length}`` of the interpolated σt (float64)."""
    if full != 0.0:
        return np.float64(step_column(stab, q0, f, 0))
    return 1.0 - math.exp(-np.float64(step_column(stab, q0, f, 10)) * length)


@scalar(force_inline=True)
def step_sample(field, stab, lut_lo, lut_inv, x, y, z):
    """(opacity of one full step, colour rgb) at index-space point (x, y, z) of a LUT-mode medium:
    the scalar trilinear at the point, looked up in ``stab`` (:func:`step_table`) — one sample of
    emission–absorption on a full segment, float32, unsigned indices (:func:`trilinear32`), so the
    CPU's packet driver (:mod:`.packet`) vectorises it and a CUDA thread keeps its address
    arithmetic small."""
    q0, f = step_lookup(field, stab, lut_lo, lut_inv, x, y, z)
    return (step_column(stab, q0, f, 0), step_column(stab, q0, f, 1), step_column(stab, q0, f, 2),
            step_column(stab, q0, f, 3))


@scalar(force_inline=True)
def step_albedo_emission(stab, q0, f):
    """(albedo rgb, emission rgb) of the step-corrected table at ``(q0, f)`` (:func:`step_lookup`)."""
    return (step_column(stab, q0, f, 4), step_column(stab, q0, f, 5), step_column(stab, q0, f, 6),
            step_column(stab, q0, f, 7), step_column(stab, q0, f, 8), step_column(stab, q0, f, 9))


@scalar(inline=True)
def sigma_at(mode, field, table, lut_lo, lut_inv, x, y, z):
    """Extinction σt at index-space point (x, y, z)."""
    s = trilinear(field, x, y, z)
    if mode == MODE_GRID:
        return s
    k0, k1, f = lut_coords(s, lut_lo, lut_inv, table.shape[0])
    return lut_value(table, k0, k1, f, 0)


#: Edge of the tiles in which :func:`copy_float32` transposes a plane (both sides stay in cache).
COPY_TILE = 32


@driver
def copy_float32(src, dst):
    """``dst[...] = src`` as float32, ``dst`` C-ordered, ``src`` any layout and numeric dtype: in
    parallel over the middle axis, each (first, last) plane in tiles. Why: a grid's point data
    arrives x fastest (a Fortran-ordered view), and NumPy's copy of it into C order runs on one
    thread through the cache at a stride — the first step of every classification."""
    n0, n1, n2 = dst.shape
    for j in prange(n1):
        for i0 in range(0, n0, COPY_TILE):
            for k0 in range(0, n2, COPY_TILE):
                for i in range(i0, min(i0 + COPY_TILE, n0)):
                    for k in range(k0, min(k0 + COPY_TILE, n2)):
                        dst[i, j, k] = np.float32(src[i, j, k])


@scalar(force_inline=True)
def table_entry(v, lut_lo, lut_inv, n):
    """Entry ``k0`` (at most ``n − 2``) and fraction of scalar ``v`` in a table of ``n`` entries,
    clamped at both ends: the grid drivers' lookup (:func:`classify_columns`,
    :func:`scattering_column`), whose last entry is the last cell at fraction 1."""
    x = (v - lut_lo) * lut_inv
    x = min(max(x, 0.0), n - 1.0)
    k0 = min(int(x), n - 2)
    return k0, x - k0


@scalar(inline=True)
def table_column(table, k0, f, col):
    """Column ``col`` of ``table`` at entry ``k0`` and fraction ``f`` (:func:`table_entry`), in
    double precision: the grid drivers' interpolation between two entries."""
    return (1.0 - f) * table[k0, col] + f * table[k0 + 1, col]


@scalar(inline=True)
def sigma_sample_node(field, table, lut_lo, lut_inv, i, j, k, out):
    """σt of a LUT-mode medium at data sample (i, j, k) written to ``out[i, j, k]`` (float32): the
    σt column of :func:`classify_columns` at one sample, the loop body of the GPU's kernel
    (:mod:`.cuda`)."""
    k0, f = table_entry(field[i, j, k], lut_lo, lut_inv, table.shape[0])
    out[i, j, k] = table_column(table, k0, f, 0)


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
                k0, f = table_entry(field[i, j, k], lut_lo, lut_inv, n)
                for c in range(ncomp):
                    out[i, j, k, c] = table_column(table, k0, f, col + c)


@driver
def scattering_column(field, table, lut_lo, lut_inv, col, sigma, out):
    """``out = sigma ·`` column ``col`` of ``table`` at every sample of ``field`` (float32): the
    lookup of :func:`classify_columns` rounded to float32, times σt in float32 — the product NumPy
    forms from the two arrays, in one parallel pass with no column array."""
    nx, ny, nz = field.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                out[i, j, k] = scattering_lut(field, table, lut_lo, lut_inv, col, sigma, i, j, k)


@scalar(inline=True)
def scattering_lut(field, table, lut_lo, lut_inv, col, sigma, i, j, k):
    """σt times albedo column ``col`` at data sample (i, j, k) of a LUT-mode medium: the lookup
    rounded to float32, times ``sigma[i, j, k]`` in float32 (:func:`scattering_column`'s loop body)."""
    k0, f = table_entry(field[i, j, k], lut_lo, lut_inv, table.shape[0])
    a = np.float32((1.0 - f) * table[k0, col] + f * table[k0 + 1, col])
    return sigma[i, j, k] * a


@scalar(inline=True)
def scattering_sample(mode, field, table, lut_lo, lut_inv, aux, col, sigma, i, j, k):
    """σs of the albedo column ``col`` (:data:`pv_ambient.inputs.transfer.COL_ALBEDO` + channel in mode LUT, the channel in
    mode GRID) at data sample (i, j, k), float32: :func:`scattering_lut` in mode LUT, else
    ``sigma · aux[..., col]`` in float32 — what :meth:`pv_ambient.inputs.transfer.Optics.scattering_channel`
    forms with NumPy. The GPU's ball grid calls it per sample (:mod:`.cuda`)."""
    if mode == MODE_LUT:
        return scattering_lut(field, table, lut_lo, lut_inv, col, sigma, i, j, k)
    return sigma[i, j, k] * aux[i, j, k, col]


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


@scalar(inline=True)
def scattering_at(mode, field, table, lut_lo, lut_inv, aux, x, y, z):
    """(σt, σs r, σs g, σs b) at index-space point (x, y, z): extinction and scattering
    coefficient ``albedo·σt``, each channel classified at the point (post-classification)."""
    s = trilinear(field, x, y, z)
    if mode == MODE_GRID:
        return (s, s * trilinear_c(aux, x, y, z, 0), s * trilinear_c(aux, x, y, z, 1),
                s * trilinear_c(aux, x, y, z, 2))
    k0, k1, f = lut_coords(s, lut_lo, lut_inv, table.shape[0])
    st = lut_value(table, k0, k1, f, 0)
    return (st, st * lut_value(table, k0, k1, f, 1), st * lut_value(table, k0, k1, f, 2),
            st * lut_value(table, k0, k1, f, 3))


@scalar(inline=True)
def hat_axis_weight(p, off, lo, hi):
    """Weight along one axis of the sub-sample at index ``p`` (offset ``off`` ∈ {−½, 0, ½} from
    its node) in ``∫ hat_n(x) f(x) dx ≈ (h/2) Σ w f`` (trapezoid rule on the half-index grid): the
    hat's value (1 at the node, ½ half-way) times the trapezoid's end weight (½ on a box face);
    0 outside the box [lo, hi]. ``hat_n`` is node n's trilinear basis function."""
    if p < lo - 1e-9 or p > hi + 1e-9:
        return 0.0
    w = 1.0 if off == 0.0 else 0.5
    if abs(p - lo) <= 1e-9 or abs(p - hi) <= 1e-9:
        w *= 0.5
    return w



@scalar(inline=True)
def hat_sub(q, i, j, k, box_lo, box_hi):
    """Sub-sample ``q`` (0 … 26) of node (i, j, k)'s 3³ half-index stencil: its index-space point
    and weight ``w`` (the product of the three :func:`hat_axis_weight` factors; 0 outside the box),
    visited in the order a, b, c = q // 9, q // 3 % 3, q % 3."""
    ox = 0.5 * (q // 9 - 1)
    oy = 0.5 * (q // 3 % 3 - 1)
    oz = 0.5 * (q % 3 - 1)
    w = (hat_axis_weight(i + ox, ox, box_lo[0], box_hi[0]) * hat_axis_weight(j + oy, oy, box_lo[1], box_hi[1])
         * hat_axis_weight(k + oz, oz, box_lo[2], box_hi[2]))
    return i + ox, j + oy, k + oz, w


@scalar(force_inline=True)
def hat_sum(H, i, j, k, m):
    """Node (i, j, k)'s hat-weighted sum of column ``m`` of its 27 half-index sub-samples, read from
    the ring of three half-index planes ``H[slot, b, c, m]`` (slot = half-index plane mod 3, b, c
    = half-index row and column) that :func:`hat_medium` and :func:`.diffusion_sources.hat_source`
    fill: weights 1 at the node and ½ half-way, per axis (the box weights are already in ``H``)."""
    s = 0.0
    for a in range(3):
        slot = (2 * i + a) % 3
        ha = 1.0 if a == 1 else 0.5
        for bb in range(3):
            hb = ha * (1.0 if bb == 1 else 0.5)
            b = 2 * j + bb
            for cc in range(3):
                s += hb * (1.0 if cc == 1 else 0.5) * H[slot, b, 2 * k + cc, m]
    return s


@scalar
def hat_medium_row(mode, field, table, lut_lo, lut_inv, aux, box_lo, box_hi, px, b, H, slot):
    """Row ``b`` of the half-index plane at ``px`` for :func:`hat_medium`: at each half-index point
    its box weight ``f`` (:func:`hat_axis_weight` at offset 0) and ``f·(σt, σs rgb)``."""
    py = 0.5 * b - 0.5
    fy = hat_axis_weight(px, 0.0, box_lo[0], box_hi[0]) * hat_axis_weight(py, 0.0, box_lo[1], box_hi[1])
    for c in range(H.shape[2]):
        pz = 0.5 * c - 0.5
        f = fy * hat_axis_weight(pz, 0.0, box_lo[2], box_hi[2])
        H[slot, b, c, 0] = f
        if f == 0.0:
            for m in range(1, 5):
                H[slot, b, c, m] = 0.0
            continue
        t, r, g, bb = scattering_at(mode, field, table, lut_lo, lut_inv, aux, px, py, pz)
        H[slot, b, c, 1] = f * t
        H[slot, b, c, 2] = f * r
        H[slot, b, c, 3] = f * g
        H[slot, b, c, 4] = f * bb


@driver
def hat_medium(mode, field, table, lut_lo, lut_inv, aux, box_lo, box_hi, sig_out, sigs_out):
    """Each node's hat-weighted mean of σt (``sig_out``, (nx, ny, nz)) and of σs rgb
    (``sigs_out``, (nx, ny, nz, 3)), ``∫ hat_n σ dV / ∫ hat_n dV``, classified at 3³ half-index
    sub-samples (:func:`hat_axis_weight`; box ``[box_lo, box_hi]`` in index units). Summed over
    the nodes with their volumes it is the integral of the classified field (up to the
    quadrature), where the node samples' own values are not: classification is not linear.

    The sub-samples lie on the half-index grid and neighbouring nodes share them: each is
    classified once (:func:`hat_medium_row`), plane by plane along the first axis with the three
    planes a node plane needs kept in a ring, and each node sums its 27 with the hat's weights
    (1 at the node, ½ half-way, per axis)."""
    nx, ny, nz = sig_out.shape
    H = np.zeros((3, 2 * ny + 1, 2 * nz + 1, 5))  # half-index planes p = hh/2 − ½, hh = 0 … 2n
    top = -1
    for i in range(nx):
        for hh in range(max(top + 1, 2 * i), 2 * i + 3):
            px = 0.5 * hh - 0.5
            for b in prange(2 * ny + 1):
                hat_medium_row(mode, field, table, lut_lo, lut_inv, aux, box_lo, box_hi, px, b, H, hh % 3)
            top = hh
        for j in prange(ny):
            for k in range(nz):
                wsum = hat_sum(H, i, j, k, 0)
                st = hat_sum(H, i, j, k, 1)
                sr = hat_sum(H, i, j, k, 2)
                sg = hat_sum(H, i, j, k, 3)
                sb = hat_sum(H, i, j, k, 4)
                sig_out[i, j, k] = st / wsum
                sigs_out[i, j, k, 0] = sr / wsum
                sigs_out[i, j, k, 1] = sg / wsum
                sigs_out[i, j, k, 2] = sb / wsum


@driver
def scattering_to_albedo(sig, sigs):
    """``sigs`` (nx, ny, nz, C), the scattering coefficient per channel, turned in place into the
    albedo ``σs/σt`` clipped to [0, 1], 0 where ``sig`` (σt) is 0 (nothing scatters or absorbs
    there): :func:`hat_medium`'s means as a medium, in one parallel pass."""
    for i in prange(sig.shape[0]):
        for j in range(sig.shape[1]):
            for k in range(sig.shape[2]):
                s = sig[i, j, k]
                for c in range(sigs.shape[3]):
                    sigs[i, j, k, c] = min(max(sigs[i, j, k, c] / s, 0.0), 1.0) if s > 0.0 else 0.0
