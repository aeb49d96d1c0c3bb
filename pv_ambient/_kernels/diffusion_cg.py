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
