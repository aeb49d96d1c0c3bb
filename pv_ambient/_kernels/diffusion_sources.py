"""The diffusion solve's sources from each light's direct light (docs/diffusion.rst §1): its
irradiance averaged over the control volumes of the finite-volume system, and the first-collision
source projected on the nodes' hat functions for the transport sweeps (docs/diffusion.rst §5).

Optical depth to the light is read trilinearly from the light grid (:func:`tau_at`). A point
light's ``1/d²`` is singular in the control volume that holds it: near it the volume integral is
taken in solid-angle form along chords from the light (:func:`point_cv_near`, exact for the
singularity), farther by midpoint sub-samples (:func:`point_cv_far`).
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import driver, prange, scalar
from .interp import trilinear
from .lightvol import TIE
from .medium import hat_axis_weight, hat_sum, scattering_at


# -- direct irradiance averaged over control volumes (§1) ---------------------------------------
@scalar
def tau_at(tau, tlo, tinv, px, py, pz):
    """Optical depth at data-index point p, trilinear on the light grid (clamped)."""
    return trilinear(tau, (px - tlo[0]) * tinv[0], (py - tlo[1]) * tinv[1], (pz - tlo[2]) * tinv[2])


@scalar
def cv_bounds(i, lo, hi):
    """Index interval of the control volume of node i on an axis with box [lo, hi]."""
    a = max(i - 0.5, lo)
    b = min(i + 0.5, hi)
    if b < a:
        b = a
    return a, b


@scalar
def chord(px, py, pz, vx, vy, vz, a0, a1, b0, b1, c0, c1):
    """Parameter interval (t0, t1), t ≥ 0, of p + t·v inside the box [a0,a1]×[b0,b1]×[c0,c1]."""
    t0 = 0.0
    t1 = math.inf
    for ax in range(3):
        if ax == 0:
            o, d, lo, hi = px, vx, a0, a1
        elif ax == 1:
            o, d, lo, hi = py, vy, b0, b1
        else:
            o, d, lo, hi = pz, vz, c0, c1
        if d == 0.0:
            if o < lo or o > hi:
                return 0.0, 0.0
        else:
            s0 = (lo - o) / d
            s1 = (hi - o) / d
            if s0 > s1:
                s0, s1 = s1, s0
            t0 = max(t0, s0)
            t1 = min(t1, s1)
    if t1 < t0:
        return 0.0, 0.0
    return t0, t1


@scalar
def cv_thin(sig, i, j, k, hmax, thin):
    """Whether the control volume of node (i, j, k) is optically thin: ``hmax`` × the largest
    σt of the node and its six neighbours at most ``thin``. There one midpoint sample gives the
    mean of T = exp(−τ) to about ``(σt·h)²/8`` (the convexity of exp across the volume), below
    0.5 % for ``thin`` = 0.2 (docs/diffusion.rst §1)."""
    nx, ny, nz = sig.shape
    s = sig[i, j, k]
    if i > 0:
        s = max(s, sig[i - 1, j, k])
    if i < nx - 1:
        s = max(s, sig[i + 1, j, k])
    if j > 0:
        s = max(s, sig[i, j - 1, k])
    if j < ny - 1:
        s = max(s, sig[i, j + 1, k])
    if k > 0:
        s = max(s, sig[i, j, k - 1])
    if k < nz - 1:
        s = max(s, sig[i, j, k + 1])
    return s * hmax <= thin


@scalar
def point_cv_far(M, lx, ly, lz, tau, tlo, tinv, a0, a1, b0, b1, c0, c1, ns):
    """Mean of T/d² and of (T/d²)·u over a control volume (index box) by ns³ midpoint
    sub-samples; u is the unit direction from the light (world). Returns (e, ux, uy, uz)
    with e the mean and (ux, uy, uz) the mean of e·u."""
    e = 0.0
    ex = 0.0
    ey = 0.0
    ez = 0.0
    inv = 1.0 / ns
    for si in range(ns):
        px = a0 + (si + 0.5) * inv * (a1 - a0)
        for sj in range(ns):
            py = b0 + (sj + 0.5) * inv * (b1 - b0)
            for sk in range(ns):
                pz = c0 + (sk + 0.5) * inv * (c1 - c0)
                wx = M[0, 0] * px + M[0, 1] * py + M[0, 2] * pz + M[0, 3] - lx
                wy = M[1, 0] * px + M[1, 1] * py + M[1, 2] * pz + M[1, 3] - ly
                wz = M[2, 0] * px + M[2, 1] * py + M[2, 2] * pz + M[2, 3] - lz
                d2 = wx * wx + wy * wy + wz * wz
                if d2 <= 0.0:
                    continue
                v = math.exp(-tau_at(tau, tlo, tinv, px, py, pz)) / d2
                d = math.sqrt(d2)
                e += v
                ex += v * wx / d
                ey += v * wy / d
                ez += v * wz / d
    n3 = ns * ns * ns
    return e / n3, ex / n3, ey / n3, ez / n3


@scalar
def point_cv_near(Minv, pl0, pl1, pl2, tau, tlo, tinv, a0, a1, b0, b1, c0, c1, nu, nchord):
    """∫ over a control volume of T/d² dV and of (T/d²)·u dV, by the solid-angle form
    ∫_{S²} ∫_{chord} T dt dΩ (exact for the 1/d² singularity): nu × 2nu midpoint directions in
    (cos θ, φ) (world frame), T at ``nchord`` midpoints of each chord. The light sits at index
    point (pl0, pl1, pl2); ``Minv`` maps a world vector to index components. Returns the
    integrals (not means)."""
    e = 0.0
    ex = 0.0
    ey = 0.0
    ez = 0.0
    nphi = 2 * nu
    du = 2.0 / nu
    dphi = 2.0 * math.pi / nphi
    for iu in range(nu):
        cz = -1.0 + (iu + 0.5) * du
        sz = math.sqrt(max(0.0, 1.0 - cz * cz))
        for ip in range(nphi):
            ph = (ip + 0.5) * dphi
            ox = sz * math.cos(ph)
            oy = sz * math.sin(ph)
            oz = cz
            vx = Minv[0, 0] * ox + Minv[0, 1] * oy + Minv[0, 2] * oz
            vy = Minv[1, 0] * ox + Minv[1, 1] * oy + Minv[1, 2] * oz
            vz = Minv[2, 0] * ox + Minv[2, 1] * oy + Minv[2, 2] * oz
            t0, t1 = chord(pl0, pl1, pl2, vx, vy, vz, a0, a1, b0, b1, c0, c1)
            if t1 <= t0:
                continue
            dt = (t1 - t0) / nchord
            s = 0.0
            for m in range(nchord):
                t = t0 + (m + 0.5) * dt
                s += math.exp(-tau_at(tau, tlo, tinv, pl0 + t * vx, pl1 + t * vy, pl2 + t * vz))
            s *= dt * du * dphi
            e += s
            ex += s * ox
            ey += s * oy
            ez += s * oz
    return e, ex, ey, ez


@driver
def irradiance_point(M, Minv, box_lo, box_hi, pl, tau, tlo, tinv, ns, ns_far, mid, near, nu, nchord, cvvol,
                     sig, use_sig, hmax, thin, far, want_w, e_out, w_out):
    """Control-volume mean of T/d² (``e_out``, per unit intensity) and the e-weighted mean
    propagation direction (``w_out``, world, |w| ≤ 1) of a point light at index point ``pl``.

    By the max-norm index distance d from the light to the control volume's box: d < ``near``
    uses the solid-angle form (:func:`point_cv_near`), d < ``mid`` ns³ midpoint sub-samples,
    farther ``ns_far``³, and a single sample (the box's midpoint) at ``far`` or farther where the
    volume is optically thin (``use_sig``: :func:`cv_thin` of ``sig`` with spacing ``hmax`` at
    most ``thin``). ``cvvol`` is the world volume of one full (unclipped) control volume;
    ``want_w`` False: ``w_out`` (a placeholder) is not written.
    Both thresholds are compared less ``TIE``. Why: a light on a sample (or half-way between two)
    has distances that equal them up to rounding, and the choice must not depend on the scene's
    scale (tests/test_extremes.py renders scenes scaled over many orders of magnitude).
    """
    nx, ny, nz = e_out.shape
    lx = M[0, 0] * pl[0] + M[0, 1] * pl[1] + M[0, 2] * pl[2] + M[0, 3]
    ly = M[1, 0] * pl[0] + M[1, 1] * pl[1] + M[1, 2] * pl[2] + M[1, 3]
    lz = M[2, 0] * pl[0] + M[2, 1] * pl[1] + M[2, 2] * pl[2] + M[2, 3]
    for i in prange(nx):
        a0, a1 = cv_bounds(i, box_lo[0], box_hi[0])
        for j in range(ny):
            b0, b1 = cv_bounds(j, box_lo[1], box_hi[1])
            for k in range(nz):
                c0, c1 = cv_bounds(k, box_lo[2], box_hi[2])
                dx = max(a0 - pl[0], pl[0] - a1, 0.0)
                dy = max(b0 - pl[1], pl[1] - b1, 0.0)
                dz = max(c0 - pl[2], pl[2] - c1, 0.0)
                vol = (a1 - a0) * (b1 - b0) * (c1 - c0)
                # thresholds less TIE: a distance that equals one up to rounding (a light on a
                # sample or a half-sample) is decided the same way at every scale
                dmax = max(dx, max(dy, dz))
                if dmax < near - TIE and vol > 0.0:
                    e, ex, ey, ez = point_cv_near(Minv, pl[0], pl[1], pl[2], tau, tlo, tinv,
                                                  a0, a1, b0, b1, c0, c1, nu, nchord)
                    w = 1.0 / (vol * cvvol)
                    e *= w
                    ex *= w
                    ey *= w
                    ez *= w
                else:
                    m = ns if dmax < mid - TIE else ns_far
                    if use_sig and dmax >= far - TIE and cv_thin(sig, i, j, k, hmax, thin):
                        m = 1
                    e, ex, ey, ez = point_cv_far(M, lx, ly, lz, tau, tlo, tinv, a0, a1, b0, b1, c0, c1, m)
                e_out[i, j, k] = e
                if not want_w:
                    continue
                if e > 0.0:
                    w_out[i, j, k, 0] = ex / e
                    w_out[i, j, k, 1] = ey / e
                    w_out[i, j, k, 2] = ez / e
                else:
                    w_out[i, j, k, 0] = 0.0
                    w_out[i, j, k, 1] = 0.0
                    w_out[i, j, k, 2] = 0.0


@driver
def transmittance_cv(box_lo, box_hi, tau, tlo, tinv, ns, sig, use_sig, hmax, thin, e_out):
    """Control-volume mean of T = exp(−τ) by ns³ midpoint sub-samples (directional light); one
    sample where the volume is optically thin (``use_sig``, as in :func:`irradiance_point`)."""
    nx, ny, nz = e_out.shape
    for i in prange(nx):
        a0, a1 = cv_bounds(i, box_lo[0], box_hi[0])
        for j in range(ny):
            b0, b1 = cv_bounds(j, box_lo[1], box_hi[1])
            for k in range(nz):
                c0, c1 = cv_bounds(k, box_lo[2], box_hi[2])
                m = 1 if use_sig and cv_thin(sig, i, j, k, hmax, thin) else ns
                inv = 1.0 / m
                s = 0.0
                for si in range(m):
                    px = a0 + (si + 0.5) * inv * (a1 - a0)
                    for sj in range(m):
                        py = b0 + (sj + 0.5) * inv * (b1 - b0)
                        for sk in range(m):
                            pz = c0 + (sk + 0.5) * inv * (c1 - c0)
                            s += math.exp(-tau_at(tau, tlo, tinv, px, py, pz))
                e_out[i, j, k] = s / (m * m * m)



# -- first-collision source projected on the nodes' hat functions (the transport sweeps, §5) ----
#: Below this σt-weighted irradiance sum a point light's mean direction at a node is not formed
#: from the sums (subnormal ratios overflow); the direction from the light to the node is used.
HAT_TINY = 1e-280


@scalar
def hat_half_row(mode, field, table, lut_lo, lut_inv, aux, M, box_lo, box_hi, is_point, lvec, tau, tlo, tinv,
                 px, b, H, slot):
    """Row ``b`` of the half-index plane at ``px`` for :func:`hat_source`: at each half-index point p
    its box weight ``f`` (:func:`.medium.hat_axis_weight` at offset 0: ½ on a face, 0 outside) and
    ``f·E·(σs rgb, σt, σt·u)``, E the direct light per unit power there, u its unit direction."""
    py = 0.5 * b - 0.5
    fy = hat_axis_weight(px, 0.0, box_lo[0], box_hi[0]) * hat_axis_weight(py, 0.0, box_lo[1], box_hi[1])
    for c in range(H.shape[2]):
        pz = 0.5 * c - 0.5
        f = fy * hat_axis_weight(pz, 0.0, box_lo[2], box_hi[2])
        for m in range(8):
            H[slot, b, c, m] = 0.0
        H[slot, b, c, 0] = f
        if f == 0.0:
            continue
        st, sr, sg, sb = scattering_at(mode, field, table, lut_lo, lut_inv, aux, px, py, pz)
        if st <= 0.0:
            continue
        e = math.exp(-tau_at(tau, tlo, tinv, px, py, pz))
        if is_point:
            wx = M[0, 0] * px + M[0, 1] * py + M[0, 2] * pz + M[0, 3] - lvec[0]
            wy = M[1, 0] * px + M[1, 1] * py + M[1, 2] * pz + M[1, 3] - lvec[1]
            wz = M[2, 0] * px + M[2, 1] * py + M[2, 2] * pz + M[2, 3] - lvec[2]
            d2 = wx * wx + wy * wy + wz * wz
            if not (d2 > 0.0):  # on the light: only nodes next to it read it, and they are skipped
                continue
            e /= d2
            d = math.sqrt(d2)
            vx = wx / d
            vy = wy / d
            vz = wz / d
        else:
            vx = lvec[0]
            vy = lvec[1]
            vz = lvec[2]
        fe = f * e
        H[slot, b, c, 1] = fe * sr
        H[slot, b, c, 2] = fe * sg
        H[slot, b, c, 3] = fe * sb
        H[slot, b, c, 4] = fe * st
        H[slot, b, c, 5] = fe * st * vx
        H[slot, b, c, 6] = fe * st * vy
        H[slot, b, c, 7] = fe * st * vz


@scalar
def hat_node(i, j, k, is_point, lvec, M, H, q_out, w_out):
    """Node (i, j, k) of :func:`hat_source` from the three half-index planes about it in ``H``."""
    wsum = hat_sum(H, i, j, k, 0)
    qr = hat_sum(H, i, j, k, 1)
    qg = hat_sum(H, i, j, k, 2)
    qb = hat_sum(H, i, j, k, 3)
    bw = hat_sum(H, i, j, k, 4)
    ux = hat_sum(H, i, j, k, 5)
    uy = hat_sum(H, i, j, k, 6)
    uz = hat_sum(H, i, j, k, 7)
    q_out[i, j, k, 0] = qr / wsum
    q_out[i, j, k, 1] = qg / wsum
    q_out[i, j, k, 2] = qb / wsum
    if not is_point:  # one direction everywhere
        w_out[i, j, k, 0] = lvec[0]
        w_out[i, j, k, 1] = lvec[1]
        w_out[i, j, k, 2] = lvec[2]
    elif bw > HAT_TINY:
        w_out[i, j, k, 0] = ux / bw
        w_out[i, j, k, 1] = uy / bw
        w_out[i, j, k, 2] = uz / bw
    else:  # no light reaches the support (or only a subnormal trace): the node's own direction
        wx = M[0, 0] * i + M[0, 1] * j + M[0, 2] * k + M[0, 3] - lvec[0]
        wy = M[1, 0] * i + M[1, 1] * j + M[1, 2] * k + M[1, 3] - lvec[1]
        wz = M[2, 0] * i + M[2, 1] * j + M[2, 2] * k + M[2, 3] - lvec[2]
        d = math.sqrt(wx * wx + wy * wy + wz * wz)
        w_out[i, j, k, 0] = wx / d
        w_out[i, j, k, 1] = wy / d
        w_out[i, j, k, 2] = wz / d


@driver
def hat_source(mode, field, table, lut_lo, lut_inv, aux, M, box_lo, box_hi, is_point, pl, lvec, tau, tlo, tinv,
               near, q_out, w_out, done):
    """The first-collision source projected on each node's hat function (trilinear basis):
    ``q_out[n, c] = ∫ hat_n σs_c E dV / ∫ hat_n dV`` per unit light power, by 3³ sub-samples at
    half-index offsets (:func:`.medium.hat_axis_weight`), σs classified at each sub-sample (the
    optics ``mode, field, table, lut_lo, lut_inv, aux``), E = T (directional light) or T/d²
    (point light at index point ``pl``, world position ``lvec``), T = exp(−τ) trilinear on the
    light grid. ``w_out``: the light's mean propagation direction weighted by σt E (world;
    |w| ≤ 1; ``lvec`` for a directional light). Nodes whose hat support comes within ``near``
    index units (max-norm) of a point light, where 1/d² is singular, are skipped and flagged
    ``done = False`` (the caller keeps their control-volume form).

    Neighbouring nodes share sub-samples (a node's 27 lie on the half-index grid), so each
    half-index point is classified and lit once (:func:`hat_half_row`), plane by plane along the
    first axis with the three planes a node plane needs kept in a ring, and each node sums its 27
    with the hat's weights (:func:`hat_node`): about 8 evaluations per node instead of 27."""
    nx, ny, nz = done.shape
    H = np.zeros((3, 2 * ny + 1, 2 * nz + 1, 8))  # half-index planes p = hh/2 − ½, hh = 0 … 2n
    top = -1  # the last half-index plane computed
    for i in range(nx):
        for hh in range(max(top + 1, 2 * i), 2 * i + 3):
            px = 0.5 * hh - 0.5
            for b in prange(2 * ny + 1):
                hat_half_row(mode, field, table, lut_lo, lut_inv, aux, M, box_lo, box_hi, is_point, lvec, tau,
                             tlo, tinv, px, b, H, hh % 3)
            top = hh
        for j in prange(ny):
            for k in range(nz):
                if is_point:
                    # less TIE: a light on a sample or half-way between two is decided the same
                    # way at every scale (as in irradiance_point)
                    dmax = max(abs(i - pl[0]), max(abs(j - pl[1]), abs(k - pl[2])))
                    if dmax < near + 1.0 - TIE:
                        done[i, j, k] = False
                        continue
                done[i, j, k] = True
                hat_node(i, j, k, is_point, lvec, M, H, q_out, w_out)
@driver
def first_collision(sig, alb, E, g, g_per_node, g0, omega, with_q1, q0, q1):
    """``q0 = a σt E`` and, when ``with_q1``, ``q1 = g q0 ω`` per node and channel, written into
    ``q0`` (nx, ny, nz, C) and ``q1`` (nx, ny, nz, C, 3) in their dtype (float32: the products
    are formed in float64, rounded once). ``alb`` (nx, ny, nz, Ca) and ``E`` (nx, ny, nz, Ce)
    broadcast along their last axis when it has one entry; ``g`` per node when ``g_per_node``,
    else ``g0``."""
    nx, ny, nz, C = q0.shape
    ca = alb.shape[3]
    ce = E.shape[3]
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                st = 1.0 * sig[i, j, k]
                gg = g[i, j, k] if g_per_node else g0
                for c in range(C):
                    v = alb[i, j, k, min(c, ca - 1)] * st * E[i, j, k, min(c, ce - 1)]
                    q0[i, j, k, c] = v
                    if with_q1:
                        for a in range(3):
                            q1[i, j, k, c, a] = gg * v * omega[i, j, k, a]
