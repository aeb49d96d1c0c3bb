"""The diffusion system's coefficients (docs/diffusion.rst §2–3): the Levermore–Pomraning
flux-limited diffusion coefficient at every node, and the interior face couplings and
first-moment source of the finite-volume system (box faces: :mod:`pv_ambient.stages.diffusion.system`).
Couplings are stored as in :mod:`.diffusion_operator`.
"""

from __future__ import annotations

import math

from ._jit import driver, prange, scalar


@scalar
def lp_diffusion_coefficient(G, sig_p, phi, d_max):
    """Levermore–Pomraning ``D = λ(R)/σt'`` at a node, ``R = G/(σt' φ)``, ``λ = (coth R − 1/R)/R``,
    written as ``(coth R − 1/R)·φ/G`` so that it stays finite as σt' → 0 (free streaming,
    ``D → φ/G``). No gradient and ``σt'φ = 0``: plain diffusion where σt' > 0, else ``d_max``."""
    phip = max(phi, 0.0)
    den = sig_p * phip
    if G > 0.0:
        if den > 0.0:
            R = G / den
            if R < 1e-3:  # series of λ(R)/σt'
                return (1.0 / 3.0 - R * R / 45.0) / sig_p
            if R > 20.0:
                lam_r = 1.0 - 1.0 / R
            else:
                lam_r = 1.0 / math.tanh(R) - 1.0 / R
        else:
            lam_r = 1.0  # R = ∞
        return lam_r * phip / G
    if den > 0.0:
        return 1.0 / (3.0 * sig_p)  # R = 0
    if sig_p > 0.0:
        return 1.0 / (3.0 * sig_p)
    return d_max


@scalar
def node_derivative(fm, f0, fp, i, n, h):
    """First derivative along an axis at node i of n (central inside, one-sided on the ends,
    0 on a single node) — ``numpy.gradient`` with ``edge_order=1``."""
    if n < 2:
        return 0.0
    if i == 0:
        return (fp - f0) / h
    if i == n - 1:
        return (f0 - fm) / h
    return (fp - fm) / (2.0 * h)


@driver
def limiter_coefficients(phi, sig_p, q1, use_q1, hx, hy, hz, d_max, d_min, out):
    """``out`` = Levermore–Pomraning D at every node from ``G = |∇φ − 3Q1|`` (``q1`` (nx, ny,
    nz, 3) index-axis components, read only when ``use_q1``), clipped to [d_min, d_max]."""
    nx, ny, nz = phi.shape
    for i in prange(nx):
        im = max(i - 1, 0)
        ip = min(i + 1, nx - 1)
        for j in range(ny):
            jm = max(j - 1, 0)
            jp = min(j + 1, ny - 1)
            for k in range(nz):
                km = max(k - 1, 0)
                kp = min(k + 1, nz - 1)
                f0 = phi[i, j, k]
                gx = node_derivative(phi[im, j, k], f0, phi[ip, j, k], i, nx, hx)
                gy = node_derivative(phi[i, jm, k], f0, phi[i, jp, k], j, ny, hy)
                gz = node_derivative(phi[i, j, km], f0, phi[i, j, kp], k, nz, hz)
                if use_q1:
                    gx -= 3.0 * q1[i, j, k, 0]
                    gy -= 3.0 * q1[i, j, k, 1]
                    gz -= 3.0 * q1[i, j, k, 2]
                G = math.sqrt(gx * gx + gy * gy + gz * gz)
                d = lp_diffusion_coefficient(G, sig_p[i, j, k], f0, d_max)
                out[i, j, k] = min(max(d, d_min), d_max)



@scalar
def face_terms(d0, d1, q0, q1, area, h, use_q1):
    """Coupling ``D_f A/h`` and first-moment flow ``3 D_f A (q0 + q1)/2`` through the face between
    two nodes, ``D_f`` the harmonic mean of their D."""
    df = 2.0 * d0 * d1 / (d0 + d1)
    flow = 3.0 * df * area * 0.5 * (q0 + q1) if use_q1 else 0.0
    return df * area / h, flow


@driver
def medium_coefficients(sig, alb, g, g_per_node, g0, sigma_floor, D, part):
    """``D = 1/(3 max(σt', sigma_floor))`` at every node, ``σt' = σa + σs (1 − g)``, σa = (1 − a)σt,
    σs = a σt (``alb`` one channel's albedo; ``g`` per node when ``g_per_node``, else ``g0``), and
    ``part[i]`` the largest σa of slab i (0: no absorption there)."""
    nx, ny, nz = sig.shape
    for i in prange(nx):
        m = 0.0
        for j in range(ny):
            for k in range(nz):
                st = 1.0 * sig[i, j, k]
                a = 1.0 * alb[i, j, k]
                gg = g[i, j, k] if g_per_node else g0
                sa = (1.0 - a) * st
                sp = sa + a * st * (1.0 - gg)
                D[i, j, k] = 1.0 / (3.0 * max(sp, sigma_floor))
                m = max(m, sa)
        part[i] = m


@driver
def assemble_faces(D, sig, alb, q0, q1, use_q1, wdx, wdy, wdz, hx, hy, hz, wx, wy, wz, c, b):
    """Interior face couplings ``wx, wy, wz`` (zero on each last plane), the absorption
    ``c = σa V`` (σa = (1 − a)σt, ``alb`` one channel's albedo) and the right-hand side
    ``b = Q0 V`` plus the first-moment source's divergence (``3 D_f Q1_f·n`` leaves node i,
    enters node i+1); the box faces' terms are the caller's. Each node computes both of its
    faces per axis, so no two threads write the same entry."""
    nx, ny, nz = D.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                d0 = D[i, j, k]
                vol = wdx[i] * wdy[j] * wdz[k]
                c[i, j, k] = (1.0 - alb[i, j, k]) * sig[i, j, k] * vol
                acc = q0[i, j, k] * vol
                ax = wdy[j] * wdz[k]
                ay = wdx[i] * wdz[k]
                az = wdx[i] * wdy[j]
                if i + 1 < nx:
                    w, f = face_terms(d0, D[i + 1, j, k], q1[i, j, k, 0] if use_q1 else 0.0,
                                      q1[i + 1, j, k, 0] if use_q1 else 0.0, ax, hx, use_q1)
                    wx[i, j, k] = w
                    acc -= f
                else:
                    wx[i, j, k] = 0.0
                if use_q1 and i > 0:  # the low face's flow (its coupling is the neighbour's)
                    _, f = face_terms(D[i - 1, j, k], d0, q1[i - 1, j, k, 0] if use_q1 else 0.0,
                                      q1[i, j, k, 0] if use_q1 else 0.0, ax, hx, use_q1)
                    acc += f
                if j + 1 < ny:
                    w, f = face_terms(d0, D[i, j + 1, k], q1[i, j, k, 1] if use_q1 else 0.0,
                                      q1[i, j + 1, k, 1] if use_q1 else 0.0, ay, hy, use_q1)
                    wy[i, j, k] = w
                    acc -= f
                else:
                    wy[i, j, k] = 0.0
                if use_q1 and j > 0:  # the low face's flow (its coupling is the neighbour's)
                    _, f = face_terms(D[i, j - 1, k], d0, q1[i, j - 1, k, 1] if use_q1 else 0.0,
                                      q1[i, j, k, 1] if use_q1 else 0.0, ay, hy, use_q1)
                    acc += f
                if k + 1 < nz:
                    w, f = face_terms(d0, D[i, j, k + 1], q1[i, j, k, 2] if use_q1 else 0.0,
                                      q1[i, j, k + 1, 2] if use_q1 else 0.0, az, hz, use_q1)
                    wz[i, j, k] = w
                    acc -= f
                else:
                    wz[i, j, k] = 0.0
                if use_q1 and k > 0:  # the low face's flow (its coupling is the neighbour's)
                    _, f = face_terms(D[i, j, k - 1], d0, q1[i, j, k - 1, 2] if use_q1 else 0.0,
                                      q1[i, j, k, 2] if use_q1 else 0.0, az, hz, use_q1)
                    acc += f
                b[i, j, k] = acc


@scalar(inline=True)
def face_flux(phi, D, q, use_q1, a, i0, j0, k0, i1, j1, k1, h):
    """F·n across the face from node 0 to node 1 (n from 0 to 1, along axis ``a``): ``−D_f (φ1 −
    φ0)/h + 3 D_f (q0 + q1)/2``, D_f the harmonic mean (:func:`face_terms`), q the axis's Q1
    component (``q[..., a]``)."""
    d0 = D[i0, j0, k0]
    d1 = D[i1, j1, k1]
    df = 2.0 * d0 * d1 / (d0 + d1)
    f = -df * (phi[i1, j1, k1] - phi[i0, j0, k0]) / h
    if use_q1:
        f += 3.0 * df * 0.5 * (q[i0, j0, k0, a] + q[i1, j1, k1, a])
    return f


@scalar
def node_component(phi, D, q, use_q1, i, j, k, axis, n, h, cell, lo_out, hi_out):
    """Axis ``axis``'s component of F at node (i, j, k): the mean of its two face fluxes inside;
    on a box face ``lo_out``/``hi_out`` scale the outward Marshak flux (1: vacuum, 0: a
    reflecting face) — the face value itself for point data, its mean with the inner face for
    cell data (docs/diffusion.rst §2); ``3 D Q1`` on a single node. ``q``: Q1 (nx, ny, nz, 3),
    index-axis components."""
    m = i if axis == 0 else (j if axis == 1 else k)
    if n < 2:
        return 3.0 * D[i, j, k] * q[i, j, k, axis] if use_q1 else 0.0
    di = 1 if axis == 0 else 0
    dj = 1 if axis == 1 else 0
    dk = 1 if axis == 2 else 0
    if 0 < m < n - 1:
        return 0.5 * (face_flux(phi, D, q, use_q1, axis, i - di, j - dj, k - dk, i, j, k, h)
                      + face_flux(phi, D, q, use_q1, axis, i, j, k, i + di, j + dj, k + dk, h))
    side = -1.0 if m == 0 else 1.0
    scale = lo_out if m == 0 else hi_out
    p = phi[i, j, k]
    if not cell:
        return side * scale * 0.5 * p
    dn = D[i, j, k]
    out = 2.0 * dn * p / (4.0 * dn + h)
    if use_q1:
        out += 3.0 * dn * h * side * q[i, j, k, axis] / (4.0 * dn + h)
    if m == 0:
        inner = face_flux(phi, D, q, use_q1, axis, i, j, k, i + di, j + dj, k + dk, h)
    else:
        inner = face_flux(phi, D, q, use_q1, axis, i - di, j - dj, k - dk, i, j, k, h)
    return 0.5 * (side * scale * out + inner)


@driver
def node_flux_power(phi, D, q1, use_q1, sig, alb, q0, wdx, wdy, wdz, hx, hy, hz, cell, outs, R, rotate, F,
                    part):
    """F at every node in world components (``R``: the index axes in world, when ``rotate``),
    written into ``F`` (any float dtype, e.g. a float32 channel view), and per slab i
    ``part[i] = (Σ Q0 V, Σ σa φ V)``. ``outs`` (3, 2): 1.0 for a vacuum box face, 0.0 for a
    reflecting one; ``q1`` index-axis components."""
    nx, ny, nz = phi.shape
    for i in prange(nx):
        src = 0.0
        ab = 0.0
        inner_i = 0 < i < nx - 1
        for j in range(ny):
            inner_ij = inner_i and 0 < j < ny - 1
            for k in range(nz):
                if inner_ij and 0 < k < nz - 1:  # inside the box: the mean of both faces per axis
                    fx = 0.5 * (face_flux(phi, D, q1, use_q1, 0, i - 1, j, k, i, j, k, hx)
                                + face_flux(phi, D, q1, use_q1, 0, i, j, k, i + 1, j, k, hx))
                    fy = 0.5 * (face_flux(phi, D, q1, use_q1, 1, i, j - 1, k, i, j, k, hy)
                                + face_flux(phi, D, q1, use_q1, 1, i, j, k, i, j + 1, k, hy))
                    fz = 0.5 * (face_flux(phi, D, q1, use_q1, 2, i, j, k - 1, i, j, k, hz)
                                + face_flux(phi, D, q1, use_q1, 2, i, j, k, i, j, k + 1, hz))
                else:
                    fx = node_component(phi, D, q1, use_q1, i, j, k, 0, nx, hx, cell, outs[0, 0], outs[0, 1])
                    fy = node_component(phi, D, q1, use_q1, i, j, k, 1, ny, hy, cell, outs[1, 0], outs[1, 1])
                    fz = node_component(phi, D, q1, use_q1, i, j, k, 2, nz, hz, cell, outs[2, 0], outs[2, 1])
                if rotate:
                    F[i, j, k, 0] = R[0, 0] * fx + R[0, 1] * fy + R[0, 2] * fz
                    F[i, j, k, 1] = R[1, 0] * fx + R[1, 1] * fy + R[1, 2] * fz
                    F[i, j, k, 2] = R[2, 0] * fx + R[2, 1] * fy + R[2, 2] * fz
                else:
                    F[i, j, k, 0] = fx
                    F[i, j, k, 1] = fy
                    F[i, j, k, 2] = fz
                vol = wdx[i] * wdy[j] * wdz[k]
                src += q0[i, j, k] * vol
                ab += (1.0 - alb[i, j, k]) * sig[i, j, k] * phi[i, j, k] * vol
        part[i, 0] = src
        part[i, 1] = ab
