"""Kernels of the diffusion solver (docs/diffusion.rst): a 7-point operator, red–black Gauss–Seidel,
aggregation multigrid transfers, fused conjugate-gradient updates, and the control-volume
average of a light's direct irradiance.

Operator storage (one level): node values ``x`` (nx, ny, nz) float64; face couplings
``wx`` (nx, ny, nz) between nodes (i, j, k) and (i+1, j, k), zero on the last plane
(i = nx − 1), likewise ``wy``, ``wz``; the diagonal ``diag`` (nx, ny, nz) = c + Σ adjacent
couplings, c the absorption and boundary terms. The zero planes make the stencil branch-free.
Then ``(A x)_n = diag_n x_n − Σ_faces w_f x_neighbour``.

Reductions write one partial sum per first-axis slab and the caller adds them in order, so
results do not depend on the thread count.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import driver, prange, scalar
from .interp import trilinear
from .medium import hat_sub, scattering_at
from .lightvol import TIE


# -- the operator ---------------------------------------------------------------------------
@scalar
def offdiag(wx, wy, wz, x, i, j, k, im, ip, jm, jp, fi, fj):
    """Σ over the neighbours of node (i, j, k) of coupling × neighbour value, branch-free.

    ``im, ip, jm, jp`` are the clamped neighbour indices along i and j, ``fi``/``fj`` 0.0 on the
    low face (i = 0 / j = 0) and 1.0 elsewhere; the coupling arrays are zero on their last
    plane, so clamped upper neighbours contribute nothing."""
    nz = x.shape[2]
    km = max(k - 1, 0)
    kp = min(k + 1, nz - 1)
    fk = 1.0 if k > 0 else 0.0
    return (fi * wx[im, j, k] * x[im, j, k] + wx[i, j, k] * x[ip, j, k]
            + fj * wy[i, jm, k] * x[i, jm, k] + wy[i, j, k] * x[i, jp, k]
            + fk * wz[i, j, km] * x[i, j, km] + wz[i, j, k] * x[i, j, kp])


@scalar
def row_index(i, n):
    """Clamped lower and upper neighbour of i on n nodes and the low-face flag."""
    return max(i - 1, 0), min(i + 1, n - 1), 1.0 if i > 0 else 0.0


@driver
def make_diag(wx, wy, wz, c, diag):
    """diag = c + Σ adjacent couplings."""
    nx, ny, nz = c.shape
    for i in prange(nx):
        im, ip, fi = row_index(i, nx)
        for j in range(ny):
            jm, jp, fj = row_index(j, ny)
            for k in range(nz):
                km = max(k - 1, 0)
                fk = 1.0 if k > 0 else 0.0
                diag[i, j, k] = (c[i, j, k] + fi * wx[im, j, k] + wx[i, j, k] + fj * wy[i, jm, k] + wy[i, j, k]
                                 + fk * wz[i, j, km] + wz[i, j, k])


@driver
def matvec_dot(wx, wy, wz, diag, x, y, part):
    """y = A x and part[i] = Σ_jk x·y (so x·Ax = Σ part)."""
    nx, ny, nz = x.shape
    for i in prange(nx):
        im, ip, fi = row_index(i, nx)
        s = 0.0
        for j in range(ny):
            jm, jp, fj = row_index(j, ny)
            for k in range(nz):
                v = diag[i, j, k] * x[i, j, k] - offdiag(wx, wy, wz, x, i, j, k, im, ip, jm, jp, fi, fj)
                y[i, j, k] = v
                s += v * x[i, j, k]
        part[i] = s


@driver
def residual(wx, wy, wz, diag, x, b, r):
    """r = b − A x."""
    nx, ny, nz = x.shape
    for i in prange(nx):
        im, ip, fi = row_index(i, nx)
        for j in range(ny):
            jm, jp, fj = row_index(j, ny)
            for k in range(nz):
                r[i, j, k] = (b[i, j, k] - diag[i, j, k] * x[i, j, k]
                              + offdiag(wx, wy, wz, x, i, j, k, im, ip, jm, jp, fi, fj))


@driver
def gs_color(wx, wy, wz, diag, x, b, color):
    """One Gauss–Seidel half-sweep over the nodes with (i + j + k) % 2 == color."""
    nx, ny, nz = x.shape
    for i in prange(nx):
        im, ip, fi = row_index(i, nx)
        for j in range(ny):
            jm, jp, fj = row_index(j, ny)
            for k in range((color + i + j) & 1, nz, 2):
                x[i, j, k] = (b[i, j, k] + offdiag(wx, wy, wz, x, i, j, k, im, ip, jm, jp, fi, fj)) / diag[i, j, k]


@driver
def gs_first(wx, wy, wz, diag, x, b, color):
    """The first half-sweep from x = 0: x = b/diag on ``color``, 0 elsewhere."""
    nx, ny, nz = x.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                if ((i + j + k) & 1) == color:
                    x[i, j, k] = b[i, j, k] / diag[i, j, k]
                else:
                    x[i, j, k] = 0.0


# -- aggregation multigrid transfers ---------------------------------------------------------
@driver
def residual_restrict(wx, wy, wz, diag, x, b, fx, fy, fz, rc):
    """rc[I, J, K] = Σ over the fine block of node (I, J, K) of the residual b − A x
    (blocks of fx × fy × fz; the residual is never stored)."""
    nx, ny, nz = x.shape
    mx, my, mz = rc.shape
    for ci in prange(mx):
        row = np.empty(nz)
        for cj in range(my):
            for ck in range(mz):
                rc[ci, cj, ck] = 0.0
        for i in range(ci * fx, min(ci * fx + fx, nx)):
            im, ip, fi = row_index(i, nx)
            for j in range(ny):
                jm, jp, fj = row_index(j, ny)
                cj = j // fy
                for k in range(nz):
                    row[k] = (b[i, j, k] - diag[i, j, k] * x[i, j, k]
                              + offdiag(wx, wy, wz, x, i, j, k, im, ip, jm, jp, fi, fj))
                for ck in range(mz):
                    s = 0.0
                    for k in range(ck * fz, min(ck * fz + fz, nz)):
                        s += row[k]
                    rc[ci, cj, ck] += s


@driver
def prolong_add(xc, fx, fy, fz, x):
    """x += xc of the block each fine node belongs to (piecewise-constant prolongation)."""
    nx, ny, nz = x.shape
    for i in prange(nx):
        ci = i // fx
        for j in range(ny):
            cj = j // fy
            for k in range(nz):
                x[i, j, k] += xc[ci, cj, k // fz]


@driver
def coarsen(wx, wy, wz, c, fx, fy, fz, wxc, wyc, wzc, cc):
    """Coarse operator of fx × fy × fz aggregates: c summed; a coarse face coupling is the sum
    of the fine couplings across the aggregates' interface (Galerkin with piecewise-constant
    prolongation), halved along a coarsened axis (re-discretisation: the distance between
    aggregate centres doubled)."""
    nx, ny, nz = c.shape
    mx, my, mz = cc.shape
    sx = 0.5 if fx == 2 else 1.0
    sy = 0.5 if fy == 2 else 1.0
    sz = 0.5 if fz == 2 else 1.0
    for ci in prange(mx):
        i0 = ci * fx
        i1 = min(i0 + fx, nx)
        for cj in range(my):
            j0 = cj * fy
            j1 = min(j0 + fy, ny)
            for ck in range(mz):
                k0 = ck * fz
                k1 = min(k0 + fz, nz)
                s = 0.0
                for i in range(i0, i1):
                    for j in range(j0, j1):
                        for k in range(k0, k1):
                            s += c[i, j, k]
                cc[ci, cj, ck] = s
                if ci < mx - 1:
                    s = 0.0
                    for j in range(j0, j1):
                        for k in range(k0, k1):
                            s += wx[i1 - 1, j, k]
                    wxc[ci, cj, ck] = sx * s
                if cj < my - 1:
                    s = 0.0
                    for i in range(i0, i1):
                        for k in range(k0, k1):
                            s += wy[i, j1 - 1, k]
                    wyc[ci, cj, ck] = sy * s
                if ck < mz - 1:
                    s = 0.0
                    for i in range(i0, i1):
                        for j in range(j0, j1):
                            s += wz[i, j, k1 - 1]
                    wzc[ci, cj, ck] = sz * s


# -- conjugate-gradient vector updates -------------------------------------------------------
@driver
def dot_parts(a, b, part):
    """part[i] = Σ_jk a·b."""
    nx, ny, nz = a.shape
    for i in prange(nx):
        s = 0.0
        for j in range(ny):
            for k in range(nz):
                s += a[i, j, k] * b[i, j, k]
        part[i] = s


@driver
def cg_step(x, r, p, q, alpha, part):
    """x += α p, r −= α q, part[i] = Σ_jk r²."""
    nx, ny, nz = x.shape
    for i in prange(nx):
        s = 0.0
        for j in range(ny):
            for k in range(nz):
                x[i, j, k] += alpha * p[i, j, k]
                v = r[i, j, k] - alpha * q[i, j, k]
                r[i, j, k] = v
                s += v * v
        part[i] = s


@driver
def cg_direction(p, z, beta):
    """p = z + β p."""
    nx, ny, nz = p.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                p[i, j, k] = z[i, j, k] + beta * p[i, j, k]


@driver
def jacobi(diag, r, z, part):
    """z = r / diag and part[i] = Σ_jk r·z."""
    nx, ny, nz = r.shape
    for i in prange(nx):
        s = 0.0
        for j in range(ny):
            for k in range(nz):
                v = r[i, j, k] / diag[i, j, k]
                z[i, j, k] = v
                s += v * r[i, j, k]
        part[i] = s


# -- direct irradiance averaged over control volumes ------------------------------------------
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
                     e_out, w_out):
    """Control-volume mean of T/d² (``e_out``, per unit intensity) and the e-weighted mean
    propagation direction (``w_out``, world, |w| ≤ 1) of a point light at index point ``pl``.

    By the max-norm index distance d from the light to the control volume's box: d < ``near``
    uses the solid-angle form (:func:`point_cv_near`), d < ``mid`` ns³ midpoint sub-samples,
    farther ``ns_far``³. ``cvvol`` is the world volume of one full (unclipped) control volume.
    Both thresholds are compared less ``TIE``: a light on a sample (or half-way between two) has
    distances that equal them up to rounding, and the choice must not depend on the scene's
    scale (tests/test_extremes.py: images within 7e−8 over scales 1e−9 … 1e4; 2.8e−5 before).
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
                    e, ex, ey, ez = point_cv_far(M, lx, ly, lz, tau, tlo, tinv, a0, a1, b0, b1, c0, c1, m)
                e_out[i, j, k] = e
                if e > 0.0:
                    w_out[i, j, k, 0] = ex / e
                    w_out[i, j, k, 1] = ey / e
                    w_out[i, j, k, 2] = ez / e
                else:
                    w_out[i, j, k, 0] = 0.0
                    w_out[i, j, k, 1] = 0.0
                    w_out[i, j, k, 2] = 0.0


@driver
def transmittance_cv(box_lo, box_hi, tau, tlo, tinv, ns, e_out):
    """Control-volume mean of T = exp(−τ) by ns³ midpoint sub-samples (directional light)."""
    nx, ny, nz = e_out.shape
    inv = 1.0 / ns
    for i in prange(nx):
        a0, a1 = cv_bounds(i, box_lo[0], box_hi[0])
        for j in range(ny):
            b0, b1 = cv_bounds(j, box_lo[1], box_hi[1])
            for k in range(nz):
                c0, c1 = cv_bounds(k, box_lo[2], box_hi[2])
                s = 0.0
                for si in range(ns):
                    px = a0 + (si + 0.5) * inv * (a1 - a0)
                    for sj in range(ns):
                        py = b0 + (sj + 0.5) * inv * (b1 - b0)
                        for sk in range(ns):
                            pz = c0 + (sk + 0.5) * inv * (c1 - c0)
                            s += math.exp(-tau_at(tau, tlo, tinv, px, py, pz))
                e_out[i, j, k] = s / (ns * ns * ns)


# -- flux limiter -----------------------------------------------------------------------------
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


# -- assembly -----------------------------------------------------------------------------------
@scalar
def face_terms(d0, d1, q0, q1, area, h, use_q1):
    """Coupling ``D_f A/h`` and first-moment flow ``3 D_f A (q0 + q1)/2`` through the face between
    two nodes, ``D_f`` the harmonic mean of their D."""
    df = 2.0 * d0 * d1 / (d0 + d1)
    flow = 3.0 * df * area * 0.5 * (q0 + q1) if use_q1 else 0.0
    return df * area / h, flow


@driver
def assemble_faces(D, q1, use_q1, wdx, wdy, wdz, hx, hy, hz, wx, wy, wz, b):
    """Interior face couplings ``wx, wy, wz`` (zero on each last plane) and the first-moment
    source's divergence added to ``b`` (``3 D_f Q1_f·n`` leaves node i, enters node i+1). Each
    node computes both of its faces per axis, so no two threads write the same entry."""
    nx, ny, nz = D.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                d0 = D[i, j, k]
                acc = 0.0
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
                if i > 0:
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
                if j > 0:
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
                if k > 0:
                    _, f = face_terms(D[i, j, k - 1], d0, q1[i, j, k - 1, 2] if use_q1 else 0.0,
                                      q1[i, j, k, 2] if use_q1 else 0.0, az, hz, use_q1)
                    acc += f
                b[i, j, k] += acc


# -- first-collision source projected on the nodes' hat functions (the transport sweeps) -------
#: Below this σt-weighted irradiance sum a point light's mean direction at a node is not formed
#: from the sums (subnormal ratios overflow); the direction from the light to the node is used.
HAT_TINY = 1e-280


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
    ``done = False`` (the caller keeps their control-volume form)."""
    nx, ny, nz = done.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                if is_point:
                    # less TIE: a light on a sample or half-way between two is decided the same
                    # way at every scale (as in irradiance_point)
                    dmax = max(abs(i - pl[0]), max(abs(j - pl[1]), abs(k - pl[2])))
                    if dmax < near + 1.0 - TIE:
                        done[i, j, k] = False
                        continue
                done[i, j, k] = True
                wsum = 0.0
                qr = 0.0
                qg = 0.0
                qb = 0.0
                bw = 0.0
                ux = 0.0
                uy = 0.0
                uz = 0.0
                for q in range(27):
                    px, py, pz, w = hat_sub(q, i, j, k, box_lo, box_hi)
                    if w == 0.0:
                        continue
                    wsum += w
                    st, sr, sg, sb = scattering_at(mode, field, table, lut_lo, lut_inv, aux, px, py, pz)
                    if st <= 0.0:
                        continue
                    e = math.exp(-tau_at(tau, tlo, tinv, px, py, pz))
                    if is_point:
                        wx = M[0, 0] * px + M[0, 1] * py + M[0, 2] * pz + M[0, 3] - lvec[0]
                        wy = M[1, 0] * px + M[1, 1] * py + M[1, 2] * pz + M[1, 3] - lvec[1]
                        wz = M[2, 0] * px + M[2, 1] * py + M[2, 2] * pz + M[2, 3] - lvec[2]
                        d2 = wx * wx + wy * wy + wz * wz
                        e /= d2
                        d = math.sqrt(d2)
                        vx = wx / d
                        vy = wy / d
                        vz = wz / d
                    else:
                        vx = lvec[0]
                        vy = lvec[1]
                        vz = lvec[2]
                    we = w * e
                    qr += we * sr
                    qg += we * sg
                    qb += we * sb
                    bw += we * st
                    ux += we * st * vx
                    uy += we * st * vy
                    uz += we * st * vz
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
