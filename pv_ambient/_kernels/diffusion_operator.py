"""The diffusion solve's 7-point operator, its residual and the red–black Gauss–Seidel smoother
(docs/diffusion.rst §2, "Solver").

Operator storage (one level): node values ``x`` (nx, ny, nz); face couplings ``wx`` (nx, ny, nz)
between nodes (i, j, k) and (i+1, j, k), zero on the last plane (i = nx − 1), likewise ``wy``,
``wz``; ``c`` (nx, ny, nz) the absorption and box-face terms. Then

    (A x)_n = c_n x_n + Σ_faces w_f (x_n − x_neighbour),

the diagonal ``c_n + Σ w_f`` formed in float64 where it is used, never stored. Why this form:
the couplings are stored in float32 (the solve is bound by memory traffic; ``c`` is float64 on
the finest level, float32 on the coarse ones: pv_ambient/stages/diffusion/multigrid.py,
"Precision"), and a stored float32 diagonal would round the absorption ``c`` away wherever it
is small against the couplings (weakly absorbing media): kept as couplings plus ``c``, the
operator is the exact symmetric matrix of its stored coefficients, evaluated in float64. Why the
zero planes: they make the stencil branch-free (:func:`neighbours`).

Reductions write one partial sum per first-axis slab and the caller adds them in order, so
results do not depend on the thread count. The multigrid transfers are in
:mod:`.diffusion_multigrid`, the conjugate-gradient updates in :mod:`.diffusion_cg`.
"""

from __future__ import annotations

import numpy as np

from ._jit import driver, prange, scalar


@scalar
def neighbours(wx, wy, wz, x, i, j, k, im, ip, jm, jp, fi, fj):
    """(Σ coupling × neighbour value, Σ couplings) over the neighbours of node (i, j, k),
    branch-free, in float64.

    ``im, ip, jm, jp`` are the clamped neighbour indices along i and j, ``fi``/``fj`` 0.0 on the
    low face (i = 0 / j = 0) and 1.0 elsewhere; the coupling arrays are zero on their last
    plane, so clamped upper neighbours contribute nothing."""
    nz = x.shape[2]
    km = max(k - 1, 0)
    kp = min(k + 1, nz - 1)
    fk = 1.0 if k > 0 else 0.0
    a0 = fi * wx[im, j, k]
    a1 = 1.0 * wx[i, j, k]
    a2 = fj * wy[i, jm, k]
    a3 = 1.0 * wy[i, j, k]
    a4 = fk * wz[i, j, km]
    a5 = 1.0 * wz[i, j, k]
    s = (a0 * x[im, j, k] + a1 * x[ip, j, k] + a2 * x[i, jm, k] + a3 * x[i, jp, k]
         + a4 * x[i, j, km] + a5 * x[i, j, kp])
    return s, a0 + a1 + a2 + a3 + a4 + a5


@scalar
def row_index(i, n):
    """Clamped lower and upper neighbour of i on n nodes and the low-face flag."""
    return max(i - 1, 0), min(i + 1, n - 1), 1.0 if i > 0 else 0.0


#: What :func:`row_apply` writes per node: the Gauss–Seidel value, A x, or the residual b − A x.
GS, AX, RESIDUAL = 0, 1, 2


@scalar(inline=True)
def row_apply(wx, wy, wz, c, x, b, i, j, im, ip, jm, jp, fi, fj, mode, out):
    """Row (i, j, ·) of ``mode``: ``(b + Σ w x_nb)/(c + Σ w)`` (GS), ``A x`` (AX) or ``b − A x``
    (RESIDUAL), into ``out`` (length nz). The two end nodes take the clamped form
    (:func:`neighbours`); the nodes between them one branch-free loop per mode, which the
    compiler vectorises (why rows: a node-by-node red–black loop strides by 2 and does not; one
    output array, so that the loop needs few run-time alias checks)."""
    nz = x.shape[2]
    for k in (0, nz - 1):
        sk, dk = neighbours(wx, wy, wz, x, i, j, k, im, ip, jm, jp, fi, fj)
        if mode == GS:
            out[k] = (b[i, j, k] + sk) / (c[i, j, k] + dk)
        elif mode == AX:
            out[k] = (c[i, j, k] + dk) * x[i, j, k] - sk
        else:
            out[k] = b[i, j, k] - (c[i, j, k] + dk) * x[i, j, k] + sk
    if mode == GS:
        for k in range(1, nz - 1):
            a0 = fi * wx[im, j, k]
            a1 = 1.0 * wx[i, j, k]
            a2 = fj * wy[i, jm, k]
            a3 = 1.0 * wy[i, j, k]
            a4 = 1.0 * wz[i, j, k - 1]
            a5 = 1.0 * wz[i, j, k]
            sk = (a0 * x[im, j, k] + a1 * x[ip, j, k] + a2 * x[i, jm, k] + a3 * x[i, jp, k]
                  + a4 * x[i, j, k - 1] + a5 * x[i, j, k + 1])
            out[k] = (b[i, j, k] + sk) / (c[i, j, k] + a0 + a1 + a2 + a3 + a4 + a5)
    elif mode == AX:
        for k in range(1, nz - 1):
            a0 = fi * wx[im, j, k]
            a1 = 1.0 * wx[i, j, k]
            a2 = fj * wy[i, jm, k]
            a3 = 1.0 * wy[i, j, k]
            a4 = 1.0 * wz[i, j, k - 1]
            a5 = 1.0 * wz[i, j, k]
            sk = (a0 * x[im, j, k] + a1 * x[ip, j, k] + a2 * x[i, jm, k] + a3 * x[i, jp, k]
                  + a4 * x[i, j, k - 1] + a5 * x[i, j, k + 1])
            out[k] = (c[i, j, k] + a0 + a1 + a2 + a3 + a4 + a5) * x[i, j, k] - sk
    else:
        for k in range(1, nz - 1):
            a0 = fi * wx[im, j, k]
            a1 = 1.0 * wx[i, j, k]
            a2 = fj * wy[i, jm, k]
            a3 = 1.0 * wy[i, j, k]
            a4 = 1.0 * wz[i, j, k - 1]
            a5 = 1.0 * wz[i, j, k]
            sk = (a0 * x[im, j, k] + a1 * x[ip, j, k] + a2 * x[i, jm, k] + a3 * x[i, jp, k]
                  + a4 * x[i, j, k - 1] + a5 * x[i, j, k + 1])
            out[k] = b[i, j, k] - (c[i, j, k] + a0 + a1 + a2 + a3 + a4 + a5) * x[i, j, k] + sk


@driver
def diagonal(wx, wy, wz, c, diag):
    """diag = c + Σ adjacent couplings (for the dense coarsest level and the Jacobi preconditioner)."""
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
def matvec_dot(wx, wy, wz, c, x, y, part):
    """y = A x and part[i] = Σ_jk x·y (so x·Ax = Σ part)."""
    nx, ny, nz = x.shape
    for i in prange(nx):
        im, ip, fi = row_index(i, nx)
        row = np.empty(nz)
        s = 0.0
        for j in range(ny):
            jm, jp, fj = row_index(j, ny)
            row_apply(wx, wy, wz, c, x, x, i, j, im, ip, jm, jp, fi, fj, AX, row)
            for k in range(nz):
                v = row[k]
                y[i, j, k] = v
                s += v * x[i, j, k]
        part[i] = s


# -- red–black Gauss–Seidel (the multigrid smoother) ---------------------------------------------
@driver
def gs_color(wx, wy, wz, c, x, b, color):
    """One Gauss–Seidel half-sweep over the nodes with (i + j + k) % 2 == color."""
    nx, ny, nz = x.shape
    for i in prange(nx):
        im, ip, fi = row_index(i, nx)
        row = np.empty(nz)
        for j in range(ny):
            jm, jp, fj = row_index(j, ny)
            # the whole row (vectorised), then the update of this colour's nodes: their
            # neighbours along the row are of the other colour, which this half-sweep leaves as is
            row_apply(wx, wy, wz, c, x, b, i, j, im, ip, jm, jp, fi, fj, GS, row)
            for k in range((color + i + j) & 1, nz, 2):
                x[i, j, k] = row[k]


@driver
def gs_first(wx, wy, wz, c, x, b, color):
    """The first half-sweep from x = 0: x = b/diag on ``color``, 0 elsewhere."""
    nx, ny, nz = x.shape
    for i in prange(nx):
        im, ip, fi = row_index(i, nx)
        for j in range(ny):
            jm, jp, fj = row_index(j, ny)
            for k in range(nz):
                if ((i + j + k) & 1) == color:
                    km = max(k - 1, 0)
                    fk = 1.0 if k > 0 else 0.0
                    d = (c[i, j, k] + fi * wx[im, j, k] + wx[i, j, k] + fj * wy[i, jm, k] + wy[i, j, k]
                         + fk * wz[i, j, km] + wz[i, j, k])
                    x[i, j, k] = b[i, j, k] / d
                else:
                    x[i, j, k] = 0.0


@driver
def gs_color_dot(wx, wy, wz, c, x, b, color, part):
    """:func:`gs_color`, and part[i] = Σ_jk b·x after it: the V-cycle's last half-sweep on the
    finest level, fused with the CG's ``r·z`` (b = r, x = z) — each row is final once its
    colour is written, so the dot product needs no pass of its own."""
    nx, ny, nz = x.shape
    for i in prange(nx):
        im, ip, fi = row_index(i, nx)
        row = np.empty(nz)
        s = 0.0
        for j in range(ny):
            jm, jp, fj = row_index(j, ny)
            row_apply(wx, wy, wz, c, x, b, i, j, im, ip, jm, jp, fi, fj, GS, row)
            for k in range((color + i + j) & 1, nz, 2):
                x[i, j, k] = row[k]
            for k in range(nz):
                s += b[i, j, k] * x[i, j, k]
        part[i] = s
