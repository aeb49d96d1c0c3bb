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
