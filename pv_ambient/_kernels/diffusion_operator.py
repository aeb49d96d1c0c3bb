"""The diffusion solve's 7-point operator, its residual and the red–black Gauss–Seidel smoother
(docs/diffusion.rst §2).

Operator storage (one level): node values ``x`` (nx, ny, nz) float64; face couplings
``wx`` (nx, ny, nz) between nodes (i, j, k) and (i+1, j, k), zero on the last plane
(i = nx − 1), likewise ``wy``, ``wz``; the diagonal ``diag`` (nx, ny, nz) = c + Σ adjacent
couplings, c the absorption and boundary terms. Then ``(A x)_n = diag_n x_n − Σ_faces w_f
x_neighbour``. Why the zero planes: they make the stencil branch-free (:func:`offdiag`).

Reductions write one partial sum per first-axis slab and the caller adds them in order, so
results do not depend on the thread count. The multigrid transfers are in
:mod:`.diffusion_multigrid`, the conjugate-gradient updates in :mod:`.diffusion_cg`.
"""

from __future__ import annotations

from ._jit import driver, prange, scalar


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


# -- red–black Gauss–Seidel (the multigrid smoother) ---------------------------------------------
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
