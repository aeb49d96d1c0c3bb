"""Optical properties at a point: interpolate, then classify (scalar kernels).

Two modes (``pv_ambient.inputs.transfer.Optics``): ``MODE_LUT`` interpolates the scalar field
trilinearly and looks it up in the table (columns σt, albedo rgb, emission rgb, colour rgb) with
linear interpolation between entries (post-classification, as VTK); ``MODE_GRID`` interpolates σt
from ``field`` and albedo/emission from ``aux`` (physical arrays, or a baked TF).
"""

from __future__ import annotations

from ._jit import driver, prange, scalar
from .interp import trilinear, trilinear_c

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


@driver
def hat_medium(mode, field, table, lut_lo, lut_inv, aux, box_lo, box_hi, sig_out, sigs_out):
    """Each node's hat-weighted mean of σt (``sig_out``, (nx, ny, nz)) and of σs rgb
    (``sigs_out``, (nx, ny, nz, 3)), ``∫ hat_n σ dV / ∫ hat_n dV``, classified at 3³ half-index
    sub-samples (:func:`hat_axis_weight`; box ``[box_lo, box_hi]`` in index units). Summed over
    the nodes with their volumes it is the integral of the classified field (up to the
    quadrature), where the node samples' own values are not: classification is not linear."""
    nx, ny, nz = sig_out.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                wsum = 0.0
                st = 0.0
                sr = 0.0
                sg = 0.0
                sb = 0.0
                for q in range(27):
                    px, py, pz, w = hat_sub(q, i, j, k, box_lo, box_hi)
                    if w == 0.0:
                        continue
                    t, r, g, bb = scattering_at(mode, field, table, lut_lo, lut_inv, aux, px, py, pz)
                    wsum += w
                    st += w * t
                    sr += w * r
                    sg += w * g
                    sb += w * bb
                sig_out[i, j, k] = st / wsum
                sigs_out[i, j, k, 0] = sr / wsum
                sigs_out[i, j, k, 1] = sg / wsum
                sigs_out[i, j, k, 2] = sb / wsum
