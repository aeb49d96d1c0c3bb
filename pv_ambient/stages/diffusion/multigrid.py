"""Multigrid-preconditioned conjugate gradients of the diffusion stage (docs/diffusion.rst §2).

Preconditioned conjugate gradients, matrix-free in Numba (the operator and smoother in
``_kernels/diffusion_operator.py``, the transfers in ``_kernels/diffusion_multigrid.py``, the CG
updates in ``_kernels/diffusion_cg.py``). Precision: the CG vectors (x, r, p, Ap), the finest
level's absorption and box terms ``c`` and every sum are float64; the couplings and the coarse
levels and the V-cycle's iterates are float32 — the solve is bound by memory traffic, and a
preconditioner only has to approximate A⁻¹ (its rounding, ~1e−7 relative, is far below the
stopping tolerance). Rounding a coupling perturbs the operator but not its power balance (a
coupling's flow leaves one node and enters the other); rounding ``c`` would (hence float64). The
default preconditioner is one symmetric V-cycle of an aggregation multigrid (2×2×2 aggregates,
semi-coarsening on strongly anisotropic spacing; coarse couplings are the summed fine couplings
across an aggregate interface halved along coarsened axes, absorption and boundary terms summed;
red–black Gauss–Seidel, red→black before and black→red after the coarse correction; a dense
solve at ``COARSE_NODES`` nodes or fewer), so iteration counts barely grow with the grid.
``preconditioner="jacobi"`` is the diagonal one, for comparison (far more iterations). Grids and multigrid levels of at most ``SERIAL_NODES``
nodes run on one thread (a parallel launch costs more than the work). The iteration stops when
the relative residual ``‖b − A φ‖₂ / ‖b‖₂ ≤ tol`` (b, A: the finite-volume system, in W per
control volume). Measured iteration counts and times: docs/diffusion.rst ("Accuracy").

This module imports numpy, numba and the kernels only.
"""

from __future__ import annotations

import math
from contextlib import contextmanager

import numpy as np

__all__ = ["COARSE_NODES", "SERIAL_NODES", "Level", "hierarchy", "one_thread_if", "pcg"]

#: The multigrid hierarchy ends with a dense solve at or below this many nodes.
COARSE_NODES = 64
#: Problems and multigrid levels with at most this many nodes run their kernels on one thread.
SERIAL_NODES = 32768


class Level:
    """One level of the hierarchy: couplings ``w`` (float32) and diagonal terms ``c`` (the
    operator of ``_kernels/diffusion_operator.py``; float64 on the finest level, whose absorption
    the power balance sums, float32 below), the V-cycle's iterate and right-hand side (float32;
    on the finest level the right-hand side is the CG residual itself), the aggregation factors
    to the next level and, on the coarsest, the dense inverse."""

    def __init__(self, w, c):
        self.wx, self.wy, self.wz = (np.ascontiguousarray(x, dtype=np.float32) for x in w)
        self.c = np.ascontiguousarray(c, dtype=np.float64 if c.dtype == np.float64 else np.float32)
        self.shape = self.c.shape
        self.x = np.zeros(self.shape, np.float32)
        self.b = None  # set by the caller: the finest level's by pcg, the others' by hierarchy
        self.f = (1, 1, 1)
        self.inv = None
        self.serial = self.c.size <= SERIAL_NODES

    @property
    def ops(self):
        return self.wx, self.wy, self.wz, self.c

    def diag(self):
        """The operator's diagonal, float64 (a new array)."""
        from ..._kernels.diffusion_operator import diagonal

        d = np.empty(self.shape)
        diagonal(*self.ops, d)
        return d


def _dense(lv):
    """Dense matrix of a (small) level."""
    nx, ny, nz = lv.shape
    N = nx * ny * nz
    A = np.diag(lv.diag().ravel())
    idx = np.arange(N).reshape(lv.shape)
    for w, s0, s1 in ((lv.wx[:-1], idx[:-1], idx[1:]), (lv.wy[:, :-1], idx[:, :-1], idx[:, 1:]),
                      (lv.wz[:, :, :-1], idx[:, :, :-1], idx[:, :, 1:])):
        A[s0.ravel(), s1.ravel()] = -w.ravel()
        A[s1.ravel(), s0.ravel()] = -w.ravel()
    return A


def hierarchy(w, c, spacing, coarse_nodes=COARSE_NODES):
    """Aggregation multigrid levels, finest first; the last carries a dense inverse."""
    from ..._kernels.diffusion_multigrid import coarsen

    levels = [Level(w, c)]
    h = np.asarray(spacing, np.float64).copy()
    while True:
        lv = levels[-1]
        n = lv.shape
        if int(np.prod(n)) <= coarse_nodes or all(m == 1 for m in n):
            break
        active = [m > 1 for m in n]
        hmin = min(h[a] for a in range(3) if active[a])
        f = tuple(2 if active[a] and h[a] <= 2.0 * hmin * (1 + 1e-9) else 1 for a in range(3))
        nc = tuple(-(-n[a] // f[a]) for a in range(3))
        wc = [np.zeros(nc, np.float32) for a in range(3)]
        cc = np.zeros(nc, np.float32)
        coarsen(lv.wx, lv.wy, lv.wz, lv.c, f[0], f[1], f[2], wc[0], wc[1], wc[2], cc)
        lv.f = f
        h = h * np.asarray(f)
        levels.append(Level(wc, cc))
        levels[-1].b = np.zeros(nc, np.float32)
    A = _dense(levels[-1])
    try:
        inv = np.linalg.inv(A)
    except np.linalg.LinAlgError:  # pragma: no cover - excluded by the checks in solve_diffusion
        inv = np.linalg.pinv(A)
    levels[-1].inv = 0.5 * (inv + inv.T)
    return levels


@contextmanager
def one_thread_if(flag):
    """Run the enclosed kernels on one thread when ``flag`` (restores the thread count)."""
    if not flag:
        yield
        return
    import numba

    nt = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(nt)


def _vcycle(levels, l, part=None):
    """levels[l].x ≈ A_l⁻¹ levels[l].b by one symmetric V-cycle; with ``part`` (finest level),
    also part[i] = Σ_jk b·x (the CG's r·z) from the last half-sweep."""
    from ..._kernels.diffusion_multigrid import prolong_add, residual_restrict
    from ..._kernels.diffusion_operator import gs_color, gs_first

    lv = levels[l]
    if lv.inv is not None:
        lv.x[...] = (lv.inv @ lv.b.ravel().astype(np.float64)).reshape(lv.shape)
        return
    # small levels run on one thread: a parallel launch costs more than the work
    with one_thread_if(lv.serial and l > 0 and not levels[l - 1].serial):
        _vcycle_body(levels, l, gs_color, gs_first, prolong_add, residual_restrict, part)


def _vcycle_body(levels, l, gs_color, gs_first, prolong_add, residual_restrict, part=None):
    from ..._kernels.diffusion_operator import gs_color_dot

    lv = levels[l]
    ops = lv.ops
    # pre-smooth red → black, coarse-grid correction, post-smooth black → red (symmetric)
    gs_first(*ops, lv.x, lv.b, 0)
    gs_color(*ops, lv.x, lv.b, 1)
    nxt = levels[l + 1]
    residual_restrict(*ops, lv.x, lv.b, *lv.f, nxt.b)
    _vcycle(levels, l + 1)
    prolong_add(nxt.x, *lv.f, lv.x)
    gs_color(*ops, lv.x, lv.b, 1)
    if part is None:
        gs_color(*ops, lv.x, lv.b, 0)
    else:
        gs_color_dot(*ops, lv.x, lv.b, 0, part)


def pcg(levels, b, x0, tol, maxiter, preconditioner, bar=None):
    """Solve A x = b (A = levels[0]); returns x (float64), iterations, relative residual.

    A warm start ``x0`` is scaled by the α that minimises the error's energy norm along it
    (``α = x0·b / x0·A x0``), so it never starts further from the solution, in that norm, than
    a zero start; a start with α ≤ 0 is dropped."""
    from ..._kernels.diffusion_cg import cg_direction, cg_step, dot_parts, jacobi, scaled_start
    from ..._kernels.diffusion_operator import matvec_dot

    lv = levels[0]
    ops = lv.ops
    part = np.zeros(lv.shape[0])
    b = np.ascontiguousarray(b, np.float64)
    dot_parts(b, b, part)
    bnorm = math.sqrt(float(part.sum()))
    if bnorm == 0.0:
        return np.zeros(lv.shape), 0, 0.0
    r = np.empty(lv.shape)
    q = np.empty(lv.shape)
    x = None
    if x0 is not None:
        x = np.array(x0, dtype=np.float64)  # a copy: scaled in place
        matvec_dot(*ops, x, q, part)
        xax = float(part.sum())
        dot_parts(x, b, part)
        alpha = float(part.sum()) / xax if xax > 0.0 else 0.0
        if alpha > 0.0 and math.isfinite(alpha):
            scaled_start(x, alpha, q, b, r, part)
            rnorm = math.sqrt(float(part.sum()))
        else:
            x = None
    if x is None:
        x = np.zeros(lv.shape)
        r[...] = b
        rnorm = bnorm
    if rnorm <= tol * bnorm:
        return x, 0, rnorm / bnorm
    if preconditioner == "multigrid":
        z = lv.x
        lv.b = r  # the V-cycle's finest right-hand side is the residual itself (never copied)
    else:
        z = np.empty(lv.shape)

    def precondition():
        if preconditioner == "multigrid":
            if len(levels) > 1:
                _vcycle(levels, 0, part)  # r·z from the V-cycle's last half-sweep
            else:
                _vcycle(levels, 0)
                dot_parts(r, z, part)
        else:
            jacobi(*ops, r, z, part)
        return float(part.sum())

    rz = precondition()
    p = z.astype(np.float64)
    it = 0
    while it < maxiter:
        it += 1
        matvec_dot(*ops, p, q, part)
        pq = float(part.sum())
        if not pq > 0.0:  # pragma: no cover - breakdown: A not SPD in floating point
            break
        alpha = rz / pq
        cg_step(x, r, p, q, alpha, part)
        rnorm = math.sqrt(float(part.sum()))
        if bar is not None:
            bar.update(1)
        if rnorm <= tol * bnorm:
            break
        rz_new = precondition()
        cg_direction(p, z, rz_new / rz)
        rz = rz_new
    lv.b = None
    return x, it, rnorm / bnorm
