"""Fused vector updates of the diffusion solve's preconditioned conjugate gradients
(docs/diffusion.rst §2, "Solver"), and the diagonal (Jacobi) preconditioner.

Each reduction writes one partial sum per first-axis slab (``part``) and the caller adds them in
order. Why: a sum over threads would depend on the thread count; this one is the same on any.
"""

from __future__ import annotations

from ._jit import driver, prange


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
