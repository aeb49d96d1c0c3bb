"""Fused vector updates of the diffusion solve's preconditioned conjugate gradients
(docs/diffusion.rst §2, "Solver"), and the diagonal (Jacobi) preconditioner.

Each reduction writes one partial sum per first-axis slab (``part``) and the caller adds them in
order. Why: a sum over threads would depend on the thread count; this one is the same on any.
"""

from __future__ import annotations

from ._jit import driver, prange
from .diffusion_operator import row_index


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
def scaled_start(x, alpha, ax, b, r, part):
    """x *= α, r = b − α·(A x before scaling) (``ax``), part[i] = Σ_jk r²: a warm start scaled by
    the α that minimises the error's energy norm along it."""
    nx, ny, nz = x.shape
    for i in prange(nx):
        s = 0.0
        for j in range(ny):
            for k in range(nz):
                x[i, j, k] *= alpha
                v = b[i, j, k] - alpha * ax[i, j, k]
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
def jacobi(wx, wy, wz, c, r, z, part):
    """z = r / diag (diag = c + Σ adjacent couplings) and part[i] = Σ_jk r·z."""
    nx, ny, nz = r.shape
    for i in prange(nx):
        im, ip, fi = row_index(i, nx)
        s = 0.0
        for j in range(ny):
            jm, jp, fj = row_index(j, ny)
            for k in range(nz):
                km = max(k - 1, 0)
                fk = 1.0 if k > 0 else 0.0
                d = (c[i, j, k] + fi * wx[im, j, k] + wx[i, j, k] + fj * wy[i, jm, k] + wy[i, j, k]
                     + fk * wz[i, j, km] + wz[i, j, k])
                v = r[i, j, k] / d
                z[i, j, k] = v
                s += v * r[i, j, k]
        part[i] = s


@driver
def anderson_gram(x0, g0, x1, g1, x2, g2, m, part):
    """The Gram matrix and right side of Anderson mixing over ``m`` (1 or 2) residual differences,
    per first-axis slab: ``part[i] = (A00, A01, A11, b0, b1)`` summed over slab i, with residuals
    ``f_j = g_j − x_j``, differences ``dF_0 = f1 − f0``, ``dF_1 = f2 − f1`` (``m`` = 2), ``A = dFᵀdF``
    and ``b = dFᵀ f_last``: one pass, no temporaries (``pv_ambient.stages.diffusion.solve``'s
    flux-limiter passes)."""
    nx, ny, nz = x0.shape
    two = m == 2
    for i in prange(nx):
        a00 = 0.0
        a01 = 0.0
        a11 = 0.0
        b0 = 0.0
        b1 = 0.0
        for j in range(ny):
            for k in range(nz):
                f0 = g0[i, j, k] - x0[i, j, k]
                f1 = g1[i, j, k] - x1[i, j, k]
                d0 = f1 - f0
                f2 = g2[i, j, k] - x2[i, j, k] if two else f1
                d1 = f2 - f1 if two else 0.0
                a00 += d0 * d0
                a01 += d0 * d1
                a11 += d1 * d1
                b0 += d0 * f2
                b1 += d1 * f2
        part[i, 0] = a00
        part[i, 1] = a01
        part[i, 2] = a11
        part[i, 3] = b0
        part[i, 4] = b1


@driver
def anderson_mix(g0, g1, g2, c0, c1, out):
    """``out = max(g2 − c0 (g1 − g0) − c1 (g2 − g1), 0)``: Anderson mixing's combination of the
    last images, clamped at 0 (``g2`` is ``g1`` and ``c1`` 0 over one difference)."""
    nx, ny, nz = out.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                v = g2[i, j, k] - c0 * (g1[i, j, k] - g0[i, j, k]) - c1 * (g2[i, j, k] - g1[i, j, k])
                out[i, j, k] = v if v > 0.0 else 0.0


@driver
def weighted_change(w, phi, x, part):
    """``part[i] = (Σ (w (φ − x))², Σ (w φ)²)`` over first-axis slab i: the flux limiter's
    relative change between two passes, weighted by σs, in one pass."""
    nx, ny, nz = phi.shape
    for i in prange(nx):
        s = 0.0
        t = 0.0
        for j in range(ny):
            for k in range(nz):
                d = w[i, j, k] * (phi[i, j, k] - x[i, j, k])
                v = w[i, j, k] * phi[i, j, k]
                s += d * d
                t += v * v
        part[i, 0] = s
        part[i, 1] = t
