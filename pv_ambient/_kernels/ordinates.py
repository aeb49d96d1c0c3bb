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
plane: a plane's σt, source, light direction are first gathered into plane buffers (contiguous
whatever the sweep axis), every direction of the group then updates its radiance there, and the
plane's accumulated fluence and flux are added to the grid once. Buffers: ``L`` and ``S`` (G, 2,
nb, nc, C), two planes of radiance and source per direction; ``sp`` (2, nb, nc) σt of two planes;
``qp`` (nb, nc, C), ``wp`` (nb, nc, 4) the plane's source and light direction (unit vector and
length); ``acc`` (nb, nc, C, 4) its fluence and flux; ``nb`` and ``nc`` the node counts of the two
lateral axes (in axis order). One thread owns a row of a plane, so nothing needs atomics.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import driver, prange, scalar
from .phase import phase_eval

INV_4PI = 1.0 / (4.0 * math.pi)


@scalar
def segment_weights(tau):
    """(w_in, w_node, e^{−τ}): ``∫_0^ℓ S(s) e^{−σ(ℓ − s)} ds = ℓ (w_in S(0) + w_node S(ℓ))`` for S
    linear and ``τ = σℓ``; a series below τ = 1e−3 (both weights → ½ as τ → 0)."""
    e = math.exp(-tau)
    if tau < 1e-3:
        return 0.5 - tau / 3.0 + tau * tau / 8.0, 0.5 - tau / 6.0 + tau * tau / 24.0, e
    t1 = (1.0 - e) / tau
    return (t1 - e) / tau, (1.0 - t1) / tau, e


@scalar
def first_scatter_phase(kind, g, ux, uy, uz, m, ox, oy, oz):
    """Angular density (1/sr) of the light scattered once at a node into ω = (ox, oy, oz):
    ``m p(ω·u) + (1 − m)/4π``, u the light's unit propagation direction there and ``m`` ≤ 1 the
    length of the control volume's mean direction (below 1 next to a point light, which the
    volume sees from several sides; its first moment is then ``g m u``, that of §1's Q1)."""
    if m <= 0.0:
        return INV_4PI
    return m * phase_eval(kind, g, ux * ox + uy * oy + uz * oz) + (1.0 - m) * INV_4PI


@scalar
def plane_node(a, k, b, c):
    """Grid index of node (b, c) of plane k of a sweep along axis a (b, c the other axes in order)."""
    if a == 0:
        return k, b, c
    if a == 1:
        return b, k, c
    return b, c, k


@scalar
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


@scalar
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


@scalar
def sweep_row(kind, g, a, bx, cx, nb, nc, ib, step, cur, prv, dirs, uvec, wgt, half, d, sp, qp, wp, L, S, acc):
    """Row ``ib`` of the current plane for direction ``d`` of the group (:func:`sweep_group`):
    its radiance into ``L``, its source into ``S``, ``w L`` and ``w L ω`` added to ``acc``."""
    C = qp.shape[2]
    ox = dirs[d, 0]
    oy = dirs[d, 1]
    oz = dirs[d, 2]
    ell = 1.0 / abs(uvec[d, a])  # world length between two planes along the characteristic
    db = -uvec[d, bx] * ell
    dc = -uvec[d, cx] * ell
    w = wgt[d]
    for icu in range(nc):
        ic = np.int64(icu)
        s_node = sp[cur, ib, ic]
        p = first_scatter_phase(kind, g, wp[ib, ic, 0], wp[ib, ic, 1], wp[ib, ic, 2], wp[ib, ic, 3], ox, oy, oz)
        for ch in range(C):
            S[d, cur, ib, ic, ch] = qp[ib, ic, ch] * p
        frac = 1.0
        if step > 0:
            frac = min(entry_fraction(ib, db, nb, half), entry_fraction(ic, dc, nc, half))
        if step > 0 and frac >= 1.0:
            b0, b1, fb = lateral(ib + db, nb)
            c0, c1, fc = lateral(ic + dc, nc)
            w00 = (1.0 - fb) * (1.0 - fc)
            w10 = fb * (1.0 - fc)
            w01 = (1.0 - fb) * fc
            w11 = fb * fc
            s_in = w00 * sp[prv, b0, c0] + w10 * sp[prv, b1, c0] + w01 * sp[prv, b0, c1] + w11 * sp[prv, b1, c1]
            tau = 0.5 * (s_in + s_node) * ell
            wi, wn, e = segment_weights(tau)
            for ch in range(C):
                l_in = (w00 * L[d, prv, b0, c0, ch] + w10 * L[d, prv, b1, c0, ch] + w01 * L[d, prv, b0, c1, ch]
                        + w11 * L[d, prv, b1, c1, ch])
                s_in_c = (w00 * S[d, prv, b0, c0, ch] + w10 * S[d, prv, b1, c0, ch] + w01 * S[d, prv, b0, c1, ch]
                          + w11 * S[d, prv, b1, c1, ch])
                L[d, cur, ib, ic, ch] = l_in * e + ell * (wi * s_in_c + wn * S[d, cur, ib, ic, ch])
        else:
            # from the box face: the first plane (half a spacing for cell data), or a side face
            seg = ell * (half if step == 0 else frac)
            wi, wn, _ = segment_weights(s_node * seg)
            for ch in range(C):
                L[d, cur, ib, ic, ch] = seg * (wi + wn) * S[d, cur, ib, ic, ch]
        for ch in range(C):
            v = w * L[d, cur, ib, ic, ch]
            acc[ib, ic, ch, 0] += v
            acc[ib, ic, ch, 1] += v * ox
            acc[ib, ic, ch, 2] += v * oy
            acc[ib, ic, ch, 3] += v * oz


@driver
def sweep_group(sig, q, wu, wm, kind, g, a, sign, dirs, uvec, wgt, half, phi, F, L, S, sp, qp, wp, acc):
    """Sweep the directions ``dirs`` (G, 3) (unit, world), all with dominant index axis ``a`` and
    sign ``sign`` of their component along it, through the grid; ``uvec`` (G, 3) their
    components along the index axes in index units per world length, ``wgt`` (G,) their
    quadrature weights (sr). ``q`` (nx, ny, nz, C): isotropic source density σs E_d per channel;
    ``wu`` (nx, ny, nz, 3), ``wm`` (nx, ny, nz): the light's unit direction and its mean length
    (:func:`first_scatter_phase`); ``kind``, ``g`` the phase function. ``half``: 0 for point
    data, 0.5 for cell data. Adds ``Σ w L`` to ``phi`` (nx, ny, nz, C) and ``Σ w L ω`` to ``F``
    (nx, ny, nz, C, 3); the rest are the buffers of the module docstring."""
    n0, n1, n2 = sig.shape
    C = q.shape[3]
    G = dirs.shape[0]
    bx = 1 if a == 0 else 0
    cx = 2 if a != 2 else 1
    na = n0 if a == 0 else (n1 if a == 1 else n2)
    nb = n1 if bx == 1 else n0
    nc = n2 if cx == 2 else n1
    k0 = 0 if sign > 0 else na - 1
    for step in range(na):
        k = np.int64(k0 + sign * step)
        cur = step % 2
        prv = 1 - cur
        for ibu in prange(nb):
            ib = np.int64(ibu)
            for icu in range(nc):  # gather the plane's row
                ic = np.int64(icu)
                i, j, l = plane_node(a, k, ib, ic)
                sp[cur, ib, ic] = sig[i, j, l]
                for ch in range(C):
                    qp[ib, ic, ch] = q[i, j, l, ch]
                    for m in range(4):
                        acc[ib, ic, ch, m] = 0.0
                wp[ib, ic, 0] = wu[i, j, l, 0]
                wp[ib, ic, 1] = wu[i, j, l, 1]
                wp[ib, ic, 2] = wu[i, j, l, 2]
                wp[ib, ic, 3] = wm[i, j, l]
            for d in range(G):
                sweep_row(kind, g, a, bx, cx, nb, nc, ib, step, cur, prv, dirs, uvec, wgt, half, d, sp, qp, wp, L, S,
                          acc)
            for icu in range(nc):  # scatter its fluence and flux
                ic = np.int64(icu)
                i, j, l = plane_node(a, k, ib, ic)
                for ch in range(C):
                    phi[i, j, l, ch] += acc[ib, ic, ch, 0]
                    F[i, j, l, ch, 0] += acc[ib, ic, ch, 1]
                    F[i, j, l, ch, 1] += acc[ib, ic, ch, 2]
                    F[i, j, l, ch, 2] += acc[ib, ic, ch, 3]
