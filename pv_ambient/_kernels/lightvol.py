"""Per-light volumes: optical depth to the light by an upwind sweep, and the tube-marched front.

Light grids are regular grids over the medium's box in *light index space*: node ``k`` sits at
data index ``lo + k·s`` (``s`` per axis). World vectors of light-index steps are ``B @ dk``.

Optical depth τ(x) = ∫ σt from the light (or the box boundary) to x is computed by *short
characteristics*: nodes are swept layer by layer away from the light along an axis; a node's
ray toward the light crosses the previous layer at x', where τ is interpolated bilinearly, and
τ(x) = τ(x') + ½(σ(x) + σ(x'))·|x − x'| (trapezoid). A point light needs one sweep per axis and
side (a node takes the value of the sweep along its dominant axis, where |x − x'| ≤ √3 cells);
a directional light one sweep along its dominant axis. Where x' leaves the grid, or the light
lies between x and the previous layer, τ is integrated directly along the ray (trapezoid, half-cell
steps) to the light or the box boundary. Optical depth, not transmittance, is stored and
interpolated, so lookups are not biased upward by Jensen's inequality on exp.
"""

from __future__ import annotations

import math

from ._jit import driver, prange, scalar
from .geometry import ray_box
from .interp import trilinear, trilinear_c
from .medium import sigma_at
from .preint import f_lookup


#: Tolerance (light-grid cells) of the sweep's discrete choices — a node's dominant axis, whether
#: the light is within reach, whether a characteristic leaves the box, a march's step count —
#: whose arguments are often whole numbers up to rounding (lights on nodes or half-way between,
#: diagonal characteristics, marches of exactly J layers). Why: without it the light volume
#: depends on the last bit of the world→index map, so scaling a scene changes its image
#: (``tests/test_extremes.py``). Must not exceed ``propagation.LIGHT_SNAP`` (a node at distance
#: 0 from the light along an axis is then never given that axis unless it sits on the light).
TIE = 1e-9


@scalar(inline=True)
def sigma_node(mode, field, table, lut_lo, lut_inv, lo, step, i, j, k, out):
    """σt at light-grid node (i, j, k) (data index lo + (i, j, k)·step) written to ``out[i, j, k]``:
    the loop body of :func:`sample_sigma_grid` and of the GPU's kernel (:mod:`.cuda`)."""
    out[i, j, k] = sigma_at(mode, field, table, lut_lo, lut_inv, lo[0] + i * step[0], lo[1] + j * step[1],
                            lo[2] + k * step[2])


@driver
def sample_sigma_grid(mode, field, table, lut_lo, lut_inv, lo, step, out):
    """σt at every light-grid node (node k ↦ data index lo + k·step)."""
    m0, m1, m2 = out.shape
    for i in prange(m0):  # the last index innermost: C-ordered arrays are read and written in order
        for j in range(m1):
            for k in range(m2):
                sigma_node(mode, field, table, lut_lo, lut_inv, lo, step, i, j, k, out)


@scalar(force_inline=True)
def wlen(B, dx, dy, dz):
    """World length of the light-index vector (dx, dy, dz)."""
    wx = B[0, 0] * dx + B[0, 1] * dy + B[0, 2] * dz
    wy = B[1, 0] * dx + B[1, 1] * dy + B[1, 2] * dz
    wz = B[2, 0] * dx + B[2, 1] * dy + B[2, 2] * dz
    return math.sqrt(wx * wx + wy * wy + wz * wz)


@scalar(force_inline=True)
def march_tau(sig, B, x, y, z, vx, vy, vz, tmax):
    """∫σ along x + t·v, t ∈ [0, tmax] (light index units; v need not be unit), trapezoid in
    steps of at most half a cell; σ trilinear from the light-grid σ."""
    n0, n1, n2 = sig.shape
    lo = (0.0, 0.0, 0.0)
    hi = (n0 - 1.0, n1 - 1.0, n2 - 1.0)
    t0, t1 = ray_box(x, y, z, vx, vy, vz, lo, hi)
    t1 = min(t1, tmax)
    if not (t1 > 0.0):
        return 0.0
    vmax = max(abs(vx), abs(vy), abs(vz))
    # t1·vmax is often a whole number of cells up to rounding (a sweep marches exactly J layers
    # back): TIE keeps the step count from depending on the last bit (scale invariance)
    nstep = int(math.ceil(2.0 * t1 * vmax - TIE)) + 1
    dt = t1 / nstep
    seg = wlen(B, vx, vy, vz) * dt
    acc = 0.5 * trilinear(sig, x, y, z)
    for n in range(1, nstep):
        t = n * dt
        acc += trilinear(sig, x + t * vx, y + t * vy, z + t * vz)
    acc += 0.5 * trilinear(sig, x + t1 * vx, y + t1 * vy, z + t1 * vz)
    return acc * seg


@scalar(force_inline=True)
def path_length(shape, B, x, y, z, vx, vy, vz, is_point, tmax):
    """World length of x + t·v, t ∈ [0, tmax] (point light) or t ≥ 0 (directional), inside the
    light grid's box."""
    lo = (0.0, 0.0, 0.0)
    hi = (shape[0] - 1.0, shape[1] - 1.0, shape[2] - 1.0)
    t0, t1 = ray_box(x, y, z, vx, vy, vz, lo, hi)
    t0 = max(t0, 0.0)
    if is_point:
        t1 = min(t1, tmax)
    if not (t1 > t0):
        return 0.0
    return (t1 - t0) * wlen(B, vx, vy, vz)


@scalar(force_inline=True)
def _bilerp_layer(a, u, v):
    """Bilinear value of the 2D array ``a`` at (u, v), clamped to [0, n−1]²."""
    n0, n1 = a.shape
    u = min(max(u, 0.0), n0 - 1.0)
    v = min(max(v, 0.0), n1 - 1.0)
    i0 = min(int(u), n0 - 2) if n0 > 1 else 0
    j0 = min(int(v), n1 - 2) if n1 > 1 else 0
    i1 = i0 + 1 if n0 > 1 else 0
    j1 = j0 + 1 if n1 > 1 else 0
    fu = u - i0
    fv = v - j0
    return ((1 - fu) * ((1 - fv) * a[i0, j0] + fv * a[i0, j1]) +
            fu * ((1 - fv) * a[i1, j0] + fv * a[i1, j1]))


@scalar(force_inline=True)
def _node(a, k, b, c, ib, ic):
    """Light-grid coordinates of lateral node (ib, ic) on layer k of a sweep along axis a."""
    x = 0.0
    y = 0.0
    z = 0.0
    if a == 0:
        x, y, z = k, ib, ic
    elif a == 1:
        x, y, z = ib, k, ic
    else:
        x, y, z = ib, ic, k
    return float(x), float(y), float(z)


@scalar(force_inline=True)
def put_node(out, a, k, ib, ic, value):
    """``out`` (the grid's order) at lateral node (ib, ic) of layer k of a sweep along axis a
    (:func:`_node`'s position) set to ``value``."""
    if a == 0:
        out[k, ib, ic] = value
    elif a == 1:
        out[ib, k, ic] = value
    else:
        out[ib, ic, k] = value


@scalar(force_inline=True)
def node_tau(sig, B, is_point, lx, ly, lz, a, k, J, prev, ib, ic):
    """Optical depth ``τ`` and in-box path length ``ℓ`` toward the light of node (ib, ic) of layer
    ``k`` of a sweep along axis ``a`` (:func:`sweep_tau`); ``prev`` is the layer ``J`` layers back
    (path-mean extinction). The rule of every sweep driver: :func:`sweep_node` (this one's and the
    GPU's) and :mod:`.lightsweep` (the CPU's row driver, which computes the same samples row by row)."""
    shape = sig.shape
    b = 1 if a == 0 else 0
    c = 2 if a != 2 else 1
    nb = shape[b]
    nc = shape[c]
    x, y, z = _node(a, k, b, c, ib, ic)
    if is_point:
        vx = lx - x
        vy = ly - y
        vz = lz - z
    else:
        vx = lx
        vy = ly
        vz = lz
    va = abs(vx if a == 0 else (vy if a == 1 else vz))
    if J == 0 or (is_point and va <= J + TIE):
        # nothing swept behind this node yet, or the light lies within reach:
        # integrate straight to the light (t = 1) or to where the ray leaves the box
        tau = march_tau(sig, B, x, y, z, vx, vy, vz, 1.0 if is_point else math.inf)
    else:
        f = J / va
        vb = vy if b == 1 else vx
        vc = vz if c == 2 else vy
        pb = ib + vb * f
        pc = ic + vc * f
        # (TIE: a diagonal characteristic lands exactly on the boundary, up to rounding)
        if pb < -TIE or pb > nb - 1 + TIE or pc < -TIE or pc > nc - 1 + TIE:
            # the ray leaves the box before the layer J back: integrate to the exit
            tau = march_tau(sig, B, x, y, z, vx, vy, vz, f)
        else:
            # interpolate the path-mean extinction q = τ/ℓ (ℓ: the path length inside
            # the box toward the light), exact for a homogeneous medium
            qx = x + f * vx
            qy = y + f * vy
            qz = z + f * vz
            lp = path_length(shape, B, qx, qy, qz, vx, vy, vz, is_point, 1.0 - f)
            tau = _bilerp_layer(prev, pb, pc) * lp + march_tau(sig, B, x, y, z, vx, vy, vz, f)
    ln = path_length(shape, B, x, y, z, vx, vy, vz, is_point, 1.0)
    return tau, ln


@scalar(force_inline=True)
def dominant_axis(ax, ay, az):
    """The axis of a point light's sweep that writes a node at distances (ax, ay, az) from the light
    along the axes: the first of the largest. Ties (nodes on a diagonal through the light) go to
    the first axis; TIE keeps rounding of the light's position from choosing (scale invariance)."""
    dom = 0
    if ay > ax + TIE:
        dom = 1
    if az > max(ax, ay) + TIE:
        dom = 2
    return dom


@scalar(force_inline=True)
def sweep_node(sig, B, is_point, lx, ly, lz, a, k, J, prev, ib, ic, out, cur):
    """Node (ib, ic) of layer ``k`` of a sweep along axis ``a`` (:func:`sweep_tau`): writes its
    optical depth (:func:`node_tau`) to ``out`` (point light: only if ``a`` is the node's dominant
    axis) and its path-mean extinction to ``cur`` (this layer's slot of the history ring); ``prev``
    is the layer ``J`` layers back."""
    b = 1 if a == 0 else 0
    c = 2 if a != 2 else 1
    x, y, z = _node(a, k, b, c, ib, ic)
    tau, ln = node_tau(sig, B, is_point, lx, ly, lz, a, k, J, prev, ib, ic)
    cur[ib, ic] = tau / ln if ln > 0.0 else sig[int(x), int(y), int(z)]
    write = True
    if is_point:
        write = dominant_axis(abs(lx - x), abs(ly - y), abs(lz - z)) == a
    if write:
        put_node(out, a, k, ib, ic, tau)


@scalar
def sweep_start(na, is_point, la, sign):
    """First layer of a sweep of ``na`` layers in direction ``sign`` (point light at index ``la``
    along the sweep axis: the first layer beyond it)."""
    if is_point:
        if sign > 0:
            return max(int(math.floor(la)) + 1, 0)
        return min(int(math.ceil(la)) - 1, na - 1)
    return 0 if sign > 0 else na - 1


@scalar
def lateral_range(n, l, reach):
    """Nodes ``[i0, i1]`` of a lateral axis of ``n`` nodes within ``reach`` of the light's
    coordinate ``l`` on it (all nodes for an infinite reach)."""
    if not (reach < math.inf):
        return 0, n - 1
    return max(0, int(math.floor(l - reach))), min(n - 1, int(math.ceil(l + reach)))


@driver
def sweep_tau(sig, B, is_point, lx, ly, lz, a, sign, jump, out, hist, reach):
    """One sweep along axis ``a`` in direction ``sign`` (+1: increasing index) away from the light
    (CPU driver: layers in order, each layer's nodes in parallel by :func:`sweep_node`).

    For a point light at light-index (lx, ly, lz) the sweep covers the layers beyond the light
    and writes the nodes whose dominant axis (first axis of largest |x − light|, to within ``TIE``)
    is ``a``.
    For a directional light, (lx, ly, lz) is the direction *toward* the light in light-index
    units scaled so its component along ``a`` is ±1, and every node is written.
    A node's characteristic reaches back ``jump`` layers (fewer near the start): one bilinear
    interpolation per ``jump`` layers keeps numerical diffusion low, σt is integrated along the
    segment in half-cell trapezoid steps. ``hist`` (jump + 1, nb, nc) float64 is a ring buffer of
    the last layers' path-mean extinction q = τ/ℓ (ℓ: path length inside the box toward the light);
    interpolating q rather than τ makes the scheme exact in a homogeneous medium.
    ``reach[k, q]`` bounds layer k's nodes on lateral axis q (around the light; ``inf``: all): a point
    light's sweep along ``a`` writes only the pyramid of nodes whose dominant axis is ``a``, and
    :func:`pv_ambient.stages.propagation.sweep_reach` widens it by what their characteristics read.
    """
    na = sig.shape[a]
    b = 1 if a == 0 else 0
    c = 2 if a != 2 else 1
    lb = lx if b == 0 else ly
    lc = lz if c == 2 else ly
    nb = hist.shape[1]
    nc = hist.shape[2]
    nslot = hist.shape[0]
    la = lx if a == 0 else (ly if a == 1 else lz)
    k = sweep_start(na, is_point, la, sign)
    done_layers = 0
    while 0 <= k < na:
        slot = done_layers % nslot
        J = min(jump, done_layers)
        prev = hist[(done_layers - J) % nslot]
        cur = hist[slot]
        b0, b1 = lateral_range(nb, lb, reach[k, 0])
        c0, c1 = lateral_range(nc, lc, reach[k, 1])
        for ib in prange(b0, b1 + 1):
            for ic in range(c0, c1 + 1):
                sweep_node(sig, B, is_point, lx, ly, lz, a, k, J, prev, ib, ic, out, cur)
        done_layers += 1
        k += sign


@scalar
def light_coords(lo, inv_step, x, y, z):
    """Light-grid coordinates of data-index point (x, y, z)."""
    return (x - lo[0]) * inv_step[0], (y - lo[1]) * inv_step[1], (z - lo[2]) * inv_step[2]


@driver
def tube_density(ball, lo, step, radius, F_diff, a_nodes, tau_lo_log, tau_dlog, out):
    """Tube-march extinction per channel at every light-grid node: ``−ln F(r σ̄, ā_c) / (2r)``.

    ``ball`` holds (σ̄, ā rgb) at data samples; ``out`` is (m0, m1, m2, 3). Integrated along the
    light's rays by the same sweep as σt, it gives the tube front's optical depth (see
    :mod:`pv_ambient.stages.propagation`).
    """
    m0, m1, m2 = out.shape[0], out.shape[1], out.shape[2]
    inv2r = 0.5 / radius
    for i in prange(m0):  # the last index innermost (C order)
        x = lo[0] + i * step[0]
        for j in range(m1):
            y = lo[1] + j * step[1]
            for k in range(m2):
                z = lo[2] + k * step[2]
                tau = radius * trilinear_c(ball, x, y, z, 0)
                for c in range(3):
                    f = f_lookup(F_diff, a_nodes, tau_lo_log, tau_dlog, tau, trilinear_c(ball, x, y, z, 1 + c))
                    f = min(max(f, 1e-300), 1.0)
                    out[i, j, k, c] = -math.log(f) * inv2r
