"""Kernels of the diffusion stage's transport sweep (docs/diffusion.rst §5): the radiance of the light
scattered exactly once, marched along discrete directions through the data grid by short
characteristics, and its fluence and flux.

For one direction ω the nodes are visited plane by plane along the axis the direction crosses
fastest (its *dominant* axis, in index units); within a plane every node is independent. A node's
characteristic runs back one plane, where the radiance, the source and σt are interpolated
bilinearly from the plane computed just before; along it σt is the mean of its two ends and the
source is linear, integrated exactly against the exponential:

    L = L_in e^{−τ} + ℓ (w_in(τ) S_in + w_node(τ) S_node),     τ = ℓ (σ_in + σ_node)/2.

A characteristic that leaves the box through a side face before reaching the previous plane
starts there with L = 0 (nothing enters from outside: the direct light is the camera pass's)
and the source and σt of the node. The first plane's nodes start on the box face (point data)
or half a spacing inside it (cell data).

The directions that share a dominant axis and its sign (a *group*) are swept together, plane by
plane: a plane's σt, source and light direction are first gathered into plane buffers (contiguous
whatever the sweep axis), every direction of the group then updates its radiance there, and the
plane's accumulated fluence and flux are added to the grid once. One thread owns a row of a plane,
so nothing needs atomics.

**Why the row loop vectorises** (docs/performance.rst, "Transport sweeps"). For one direction the
displacement back to the previous plane is the same at every node, so wherever a row's
characteristics land inside the previous plane its bilinear weights are the same too: the
interpolation is a fixed stencil at constant offsets, and the row's interior is a loop that LLVM
turns into SIMD instructions — ``exp`` by :func:`.expneg.exp_neg` (no library call), the
per-node quantities shared by the channels first (τ, e^{−τ} and the weights), then one loop per
channel. The few nodes whose characteristic leaves the box or lands on its edge take the general
path (:func:`sweep_node`). What the vectoriser needs: every stream in an array of its own (the
two planes of a buffer are two arrays, swapped each plane), unsigned indices affine in the loop
counter, and the row function inlined by LLVM into the ``prange`` body, whose arrays Numba marks
``noalias``. With an isotropic phase function the source is ``q/4π`` at every node in every
direction, so no per-direction source is stored: it is interpolated from ``q`` itself.

Buffers (float64, flat; ``P`` elements per plane, rows of ``nc``, ``P`` ≥ ``nb·nc`` padded so that
planes do not share a 4 KiB alias): ``LA``/``LB`` (G·C planes) the radiance of the two planes
per direction and channel, ``SA``/``SB`` likewise their source (a single element when isotropic),
``spA``/``spB`` σt, ``qA``/``qB`` (C planes) the source density, ``wp`` (4 planes) the light's
direction and its mean length, ``a0``–``a3`` (C planes) the fluence and flux accumulated over the
group, ``te``, ``twi``, ``twn`` a row's e^{−τ} and segment weights (:func:`sweep_buffers`).
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import driver, prange, scalar
from .expneg import exp_neg
from .phase import ISOTROPIC, phase_eval

INV_4PI = 1.0 / (4.0 * math.pi)


@scalar(inline=True)
def segment_weights(tau):
    """(w_in, w_node, e^{−τ}): ``∫_0^ℓ S(s) e^{−σ(ℓ − s)} ds = ℓ (w_in S(0) + w_node S(ℓ))`` for S
    linear and ``τ = σℓ``; a series below τ = 1e−3 (both weights → ½ as τ → 0)."""
    e = math.exp(-tau)
    if tau < 1e-3:
        return 0.5 - tau / 3.0 + tau * tau / 8.0, 0.5 - tau / 6.0 + tau * tau / 24.0, e
    t1 = (1.0 - e) / tau
    return (t1 - e) / tau, (1.0 - t1) / tau, e


@scalar(inline=True)
def first_scatter_phase(kind, g, ux, uy, uz, m, ox, oy, oz):
    """Angular density (1/sr) of the light scattered once at a node into ω = (ox, oy, oz):
    ``m p(ω·u) + (1 − m)/4π``, u the light's unit propagation direction there and ``m`` ≤ 1 the
    length of the control volume's mean direction (below 1 next to a point light, which the
    volume sees from several sides; its first moment is then ``g m u``, that of §1's Q1)."""
    if m <= 0.0:
        return INV_4PI
    return m * phase_eval(kind, g, ux * ox + uy * oy + uz * oz) + (1.0 - m) * INV_4PI


@scalar(inline=True)
def plane_node(a, k, b, c):
    """Grid index of node (b, c) of plane k of a sweep along axis a (b, c the other axes in order)."""
    if a == 0:
        return k, b, c
    if a == 1:
        return b, k, c
    return b, c, k


@scalar(inline=True)
def lateral(p, n):
    """Bilinear taps along a lateral axis of n nodes at index p (inside the box): lower node,
    upper node, weight of the upper; clamped to the end nodes (half a cell beyond them for cell
    data), a single node for n = 1 (an axis along which the problem is uniform)."""
    if n == 1 or p <= 0.0:
        return 0, 0, 0.0
    if p >= n - 1:
        return n - 1, n - 1, 0.0
    i0 = min(int(p), n - 2)
    return i0, i0 + 1, p - i0


@scalar(inline=True)
def entry_fraction(i, d, n, half):
    """Fraction of a characteristic (lateral index i, displacement d back to the previous plane)
    that lies inside the box ``[−half, n − 1 + half]`` along this axis (1 when it stays inside;
    always 1 on an axis with a single node)."""
    if n == 1:
        return 1.0
    p = i + d
    if p < -half:
        return (i + half) / (-d)
    if p > n - 1 + half:
        return (n - 1 + half - i) / d
    return 1.0


#: Padding of a plane buffer (elements): planes P apart with P a multiple of 4 KiB would map
#: every stream of the row loops to the same cache sets.
PLANE_PAD = 24


@scalar
def sweep_node(ic, ib, geo, half, ell, fracb, b0, b1, fb, dc, w, ox, oy, oz, dG, iso, flux,
               sp_c, sp_p, q_c, q_p, L_c, L_p, S_c, S_p, a0, a1, a2, a3):
    """Node ``ic`` of row ``ib`` for one direction by the general path: a characteristic that
    enters through a side face, one that lands on the previous plane's edge, and the first plane.
    ``geo`` = (a, bx, cx, nb, nc, C, P, step); ``b0, b1, fb``: the row's taps on the previous
    plane; ``dG`` the direction's first plane in ``L``/``S``; ``_c``/``_p``: this plane's and the
    previous one's buffers (module docstring); ``flux``: whether ``w L ω`` is accumulated too."""
    nc = geo[4]
    C = geo[5]
    P = geo[6]
    step = geo[7]
    r = ib * nc
    s_node = sp_c[np.uint64(r + ic)]
    frac = 1.0
    if step > 0:
        frac = min(fracb, entry_fraction(ic, dc, nc, half))
    if step > 0 and frac >= 1.0:
        c0, c1, fc = lateral(ic + dc, nc)
        w00 = (1.0 - fb) * (1.0 - fc)
        w10 = fb * (1.0 - fc)
        w01 = (1.0 - fb) * fc
        w11 = fb * fc
        i00 = b0 * nc + c0
        i10 = b1 * nc + c0
        i01 = b0 * nc + c1
        i11 = b1 * nc + c1
        s_in = (w00 * sp_p[np.uint64(i00)] + w10 * sp_p[np.uint64(i10)] + w01 * sp_p[np.uint64(i01)]
                + w11 * sp_p[np.uint64(i11)])
        tau = 0.5 * (s_in + s_node) * ell
        wi, wn, e = segment_weights(tau)
        for ch in range(C):
            o = dG + ch * P
            l_in = (w00 * L_p[np.uint64(o + i00)] + w10 * L_p[np.uint64(o + i10)] + w01 * L_p[np.uint64(o + i01)]
                    + w11 * L_p[np.uint64(o + i11)])
            if iso:
                oq = ch * P
                s_in_c = INV_4PI * (w00 * q_p[np.uint64(oq + i00)] + w10 * q_p[np.uint64(oq + i10)]
                                    + w01 * q_p[np.uint64(oq + i01)] + w11 * q_p[np.uint64(oq + i11)])
                s_c = INV_4PI * q_c[np.uint64(oq + r + ic)]
            else:
                s_in_c = (w00 * S_p[np.uint64(o + i00)] + w10 * S_p[np.uint64(o + i10)]
                          + w01 * S_p[np.uint64(o + i01)] + w11 * S_p[np.uint64(o + i11)])
                s_c = S_c[np.uint64(o + r + ic)]
            L_c[np.uint64(o + r + ic)] = l_in * e + ell * (wi * s_in_c + wn * s_c)
    else:
        # from the box face: the first plane (half a spacing for cell data), or a side face
        seg = ell * (half if step == 0 else frac)
        wi, wn, _ = segment_weights(s_node * seg)
        for ch in range(C):
            o = dG + ch * P
            s_c = INV_4PI * q_c[np.uint64(ch * P + r + ic)] if iso else S_c[np.uint64(o + r + ic)]
            L_c[np.uint64(o + r + ic)] = seg * (wi + wn) * s_c
    for ch in range(C):
        v = w * L_c[np.uint64(dG + ch * P + r + ic)]
        x = np.uint64(ch * P + r + ic)
        a0[x] += v
        if flux:
            a1[x] += v * ox
            a2[x] += v * oy
            a3[x] += v * oz


@scalar(force_inline=True)
def sweep_row(kind, g, flux, geo, ib, d, dirs, uvec, wgt, half, sp_c, sp_p, q_c, q_p, L_c, L_p, S_c, S_p, wp,
              a0, a1, a2, a3, te, twi, twn):
    """Row ``ib`` of the current plane for direction ``d`` of the group (:func:`sweep_group`): its
    radiance into ``L_c``, ``w L`` added to ``a0`` and, where ``flux``, ``w L ω`` to ``a1``–``a3``;
    the interior by the vectorised stencil loops, the rest by :func:`sweep_node` (module
    docstring)."""
    a, bx, cx, nb, nc, C, P, step = geo
    iso = kind == ISOTROPIC
    ox = dirs[d, 0]
    oy = dirs[d, 1]
    oz = dirs[d, 2]
    ell = 1.0 / abs(uvec[d, a])  # world length between two planes along the characteristic
    db = -uvec[d, bx] * ell
    dc = -uvec[d, cx] * ell
    w = wgt[d]
    dG = d * C * P
    r = ib * nc
    if not iso:  # this plane's source in direction d
        for icu in range(nc):
            x = np.uint64(r + icu)
            p = first_scatter_phase(kind, g, wp[x], wp[x + np.uint64(P)], wp[x + np.uint64(2 * P)],
                                    wp[x + np.uint64(3 * P)], ox, oy, oz)
            for ch in range(C):
                S_c[np.uint64(dG + ch * P) + x] = q_c[np.uint64(ch * P) + x] * p
    fracb = 1.0
    b0, b1, fb = 0, 0, 0.0
    lo = nc
    hi = nc
    if step > 0:
        fracb = entry_fraction(ib, db, nb, half)
        b0, b1, fb = lateral(ib + db, nb)
        if fracb >= 1.0 and nc > 1:
            # the nodes whose characteristic lands strictly inside the previous row: 0 < ic + dc < nc − 1
            # (|dc| ≤ 1 along a lateral axis, the sweep axis being the dominant one)
            lo = max(np.int64(math.floor(-dc)) + 1, 0)
            hi = max(min(np.int64(math.ceil(nc - 1 - dc)), nc), lo)
    for icu in range(lo):
        sweep_node(np.int64(icu), ib, geo, half, ell, fracb, b0, b1, fb, dc, w, ox, oy, oz, dG, iso, flux,
                   sp_c, sp_p, q_c, q_p, L_c, L_p, S_c, S_p, a0, a1, a2, a3)
    for icu in range(hi, nc):
        sweep_node(np.int64(icu), ib, geo, half, ell, fracb, b0, b1, fb, dc, w, ox, oy, oz, dG, iso, flux,
                   sp_c, sp_p, q_c, q_p, L_c, L_p, S_c, S_p, a0, a1, a2, a3)
    if hi > lo:
        fl = np.int64(math.floor(dc))
        fc = dc - fl
        w00 = (1.0 - fb) * (1.0 - fc)
        w10 = fb * (1.0 - fc)
        w01 = (1.0 - fb) * fc
        w11 = fb * fc
        n = np.uint64(hi - lo)
        one = np.uint64(1)
        t0 = np.uint64(b0 * nc + lo + fl)  # tap (b0, c0) of node lo; c1 = c0 + 1
        t1 = np.uint64(b1 * nc + lo + fl)
        tn = np.uint64(r + lo)
        for j in range(np.uint64(0), n):
            s_in = w00 * sp_p[t0 + j] + w10 * sp_p[t1 + j] + w01 * sp_p[t0 + j + one] + w11 * sp_p[t1 + j + one]
            tau = 0.5 * (s_in + sp_c[tn + j]) * ell
            e = exp_neg(tau)
            # segment_weights without branches (the same series below τ = 1e−3)
            small = tau < 1e-3
            inv = 1.0 / (1.0 if small else tau)
            t1w = (1.0 - e) * inv
            te[tn + j] = e
            twi[tn + j] = (0.5 - tau / 3.0 + tau * tau / 8.0) if small else (t1w - e) * inv
            twn[tn + j] = (0.5 - tau / 6.0 + tau * tau / 24.0) if small else (1.0 - t1w) * inv
        for ch in range(C):
            oc = np.uint64(ch * P)
            od = np.uint64(dG + ch * P)
            ac = oc + tn
            if iso:
                for j in range(np.uint64(0), n):
                    l_in = (w00 * L_p[od + t0 + j] + w10 * L_p[od + t1 + j] + w01 * L_p[od + t0 + j + one]
                            + w11 * L_p[od + t1 + j + one])
                    s_in_c = INV_4PI * (w00 * q_p[oc + t0 + j] + w10 * q_p[oc + t1 + j] + w01 * q_p[oc + t0 + j + one]
                                        + w11 * q_p[oc + t1 + j + one])
                    v = l_in * te[tn + j] + ell * (twi[tn + j] * s_in_c + twn[tn + j] * (INV_4PI * q_c[ac + j]))
                    L_c[od + tn + j] = v
                    a0[ac + j] += v * w
            else:
                for j in range(np.uint64(0), n):
                    l_in = (w00 * L_p[od + t0 + j] + w10 * L_p[od + t1 + j] + w01 * L_p[od + t0 + j + one]
                            + w11 * L_p[od + t1 + j + one])
                    s_in_c = (w00 * S_p[od + t0 + j] + w10 * S_p[od + t1 + j] + w01 * S_p[od + t0 + j + one]
                              + w11 * S_p[od + t1 + j + one])
                    v = l_in * te[tn + j] + ell * (twi[tn + j] * s_in_c + twn[tn + j] * S_c[od + tn + j])
                    L_c[od + tn + j] = v
                    a0[ac + j] += v * w
            if flux:  # a loop of its own: without the flux the loops above store a third as much
                for j in range(np.uint64(0), n):
                    v = L_c[od + tn + j] * w
                    a1[ac + j] += v * ox
                    a2[ac + j] += v * oy
                    a3[ac + j] += v * oz


@driver
def order_source(sig_s, phi_k, q):
    """``q = σs·φ_k`` elementwise (flat arrays of one size): the next order's source, in parallel
    where NumPy would run on one core (docs/performance.rst, "Transport sweeps")."""
    for i in prange(q.shape[0]):
        q[i] = sig_s[i] * phi_k[i]


@driver
def add_order(phi, F, phi_k, F_k):
    """``φ += φ_k``, ``F += F_k`` elementwise (flat arrays; ``F_k`` float32 into float64 ``F``): an
    order added into the sums, in parallel."""
    for i in prange(phi.shape[0]):
        phi[i] += phi_k[i]
    for i in prange(F.shape[0]):
        F[i] += F_k[i]


#: Planes of the last axis a transpose writes at a time (:func:`last_axis_first`).
TRANSPOSE_TILE = 16


@driver
def last_axis_first(src, dst):
    """``dst[l, i, j, c] = src[i, j, l, c]`` (4-D arrays): the grid with its last axis first, so that
    the sweeps along that axis read and write their planes as rows (:func:`.sweep_group` along the
    first axis). Each thread reads its ``i`` slab in memory order and writes ``n2`` lines that the
    next ``j`` continues, ``TRANSPOSE_TILE`` of them at a time (one page each: few TLB entries)."""
    n0, n1, n2, C = src.shape
    for i in prange(n0):
        for l0 in range(0, n2, TRANSPOSE_TILE):
            l1 = min(l0 + TRANSPOSE_TILE, n2)
            for j in range(n1):
                for l in range(l0, l1):
                    for c in range(C):
                        dst[l, i, j, c] = src[i, j, l, c]


@driver
def first_axis_last(src, dst):
    """The inverse of :func:`last_axis_first`: ``dst[i, j, l, c] = src[l, i, j, c]``, tiled alike."""
    n0, n1, n2, C = dst.shape
    for i in prange(n0):
        for l0 in range(0, n2, TRANSPOSE_TILE):
            l1 = min(l0 + TRANSPOSE_TILE, n2)
            for j in range(n1):
                for l in range(l0, l1):
                    for c in range(C):
                        dst[i, j, l, c] = src[l, i, j, c]


def sweep_buffers(G, C, nb, nc, kind):
    """The plane buffers of :func:`sweep_group` for ``G`` directions, ``C`` channels and planes of
    ``nb`` × ``nc`` nodes (module docstring), in its argument order, and ``P``."""
    P = nb * nc + PLANE_PAD
    z = np.zeros
    nS = 1 if kind == ISOTROPIC else G * C * P
    bufs = (z(G * C * P), z(G * C * P), z(nS), z(nS), z(P), z(P), z(C * P), z(C * P), z(4 * P),
            z(C * P), z(C * P), z(C * P), z(C * P), z(P), z(P), z(P))
    return bufs, P


@driver
def sweep_group(sig, q, wu, wm, kind, g, a, sign, dirs, uvec, wgt, half, phi, F, flux, LA, LB, SA, SB, spA, spB, qA,
                qB, wp, a0, a1, a2, a3, te, twi, twn, P):
    """Sweep the directions ``dirs`` (G, 3) (unit, world), all with dominant index axis ``a`` and
    sign ``sign`` of their component along it, through the grid; ``uvec`` (G, 3) their
    components along the index axes in index units per world length, ``wgt`` (G,) their
    quadrature weights (sr). ``q`` (nx, ny, nz, C): isotropic source density σs E_d per channel;
    ``wu`` (nx, ny, nz, 3), ``wm`` (nx, ny, nz): the light's unit direction and its mean length
    (:func:`first_scatter_phase`); ``kind``, ``g`` the phase function. ``half``: 0 for point
    data, 0.5 for cell data. Adds ``Σ w L`` to ``phi`` (nx, ny, nz, C) and, where ``flux``,
    ``Σ w L ω`` to ``F`` (nx, ny, nz, C, 3; not read otherwise); the rest are the buffers of
    :func:`sweep_buffers`."""
    n0, n1, n2 = sig.shape
    C = q.shape[3]
    G = dirs.shape[0]
    iso = kind == ISOTROPIC
    bx = 1 if a == 0 else 0
    cx = 2 if a != 2 else 1
    na = n0 if a == 0 else (n1 if a == 1 else n2)
    nb = n1 if bx == 1 else n0
    nc = n2 if cx == 2 else n1
    k0 = 0 if sign > 0 else na - 1
    for step in range(na):
        k = np.int64(k0 + sign * step)
        odd = step % 2 == 1
        geo = (a, bx, cx, nb, nc, C, P, step)
        for ibu in prange(nb):
            ib = np.int64(ibu)
            r = ib * nc
            for icu in range(nc):  # gather the plane's row
                ic = np.int64(icu)
                i, j, l = plane_node(a, k, ib, ic)
                x = np.uint64(r + ic)
                if odd:
                    spB[x] = sig[i, j, l]
                else:
                    spA[x] = sig[i, j, l]
                for ch in range(C):
                    y = np.uint64(ch * P + r + ic)
                    if odd:
                        qB[y] = q[i, j, l, ch]
                    else:
                        qA[y] = q[i, j, l, ch]
                    a0[y] = 0.0
                    if flux:
                        a1[y] = 0.0
                        a2[y] = 0.0
                        a3[y] = 0.0
                if not iso:
                    wp[x] = wu[i, j, l, 0]
                    wp[x + np.uint64(P)] = wu[i, j, l, 1]
                    wp[x + np.uint64(2 * P)] = wu[i, j, l, 2]
                    wp[x + np.uint64(3 * P)] = wm[i, j, l]
            for d in range(G):
                if odd:
                    sweep_row(kind, g, flux, geo, ib, d, dirs, uvec, wgt, half, spB, spA, qB, qA, LB, LA, SB, SA, wp,
                              a0, a1, a2, a3, te, twi, twn)
                else:
                    sweep_row(kind, g, flux, geo, ib, d, dirs, uvec, wgt, half, spA, spB, qA, qB, LA, LB, SA, SB, wp,
                              a0, a1, a2, a3, te, twi, twn)
            for icu in range(nc):  # scatter its fluence and flux
                ic = np.int64(icu)
                i, j, l = plane_node(a, k, ib, ic)
                for ch in range(C):
                    y = np.uint64(ch * P + r + ic)
                    phi[i, j, l, ch] += a0[y]
                    if flux:
                        F[i, j, l, ch, 0] += a1[y]
                        F[i, j, l, ch, 1] += a2[y]
                        F[i, j, l, ch, 2] += a3[y]
