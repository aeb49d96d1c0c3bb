"""The flux limiter's pieces of the diffusion solve (docs/diffusion.rst, "Flux limiting"): the
Levermore–Pomraning coefficient from a lagged fluence, Anderson mixing of the lagged passes, and
the σs-weighted change that ends them. The large-grid work runs in parallel one-pass kernels
(``_kernels.diffusion_system.limiter_coefficients``, ``_kernels.diffusion_cg``) whose sums are per
slab, so a result does not depend on the thread count.

This module imports numpy and the kernels only.
"""

from __future__ import annotations

import math

import numpy as np

from .system import NO_Q1

__all__ = ["anderson", "flux_limited_D", "weighted_change"]


def flux_limited_D(grid, phi, sig_p, Q1, d_max, d_min):
    """Levermore–Pomraning D = λ(R)/σt' at the nodes, R = |∇φ − 3Q1|/(σt' φ), clipped to
    [d_min, d_max] (d_max: the vacuum floor's D); ∇φ as ``numpy.gradient`` (central differences,
    one-sided on the box faces). The kernel: ``_kernels.diffusion_system.limiter_coefficients``."""
    from ..._kernels.diffusion_system import limiter_coefficients

    out = np.empty(grid.shape)
    # a channel's Q1 is a strided view (docs/diffusion.rst, "Precision and memory traffic"): read in
    # place, not copied at every pass of the limiter
    q1 = NO_Q1 if Q1 is None else (Q1 if Q1.dtype == np.float64 else Q1.astype(np.float64))
    hx, hy, hz = (float(v) for v in grid.h)
    limiter_coefficients(np.ascontiguousarray(phi, np.float64), np.ascontiguousarray(sig_p, np.float64), q1,
                             Q1 is not None, hx, hy, hz, float(d_max), float(d_min), out)
    return out


def weighted_change(weight, phi, x):
    """``‖w (φ − x)‖ / ‖w φ‖`` (floored at 1e-300 below): in one parallel pass where the three are
    C-ordered float64 grids (``_kernels.diffusion_cg.weighted_change``), else by NumPy."""
    if all(a.ndim == 3 and a.dtype == np.float64 and a.flags.c_contiguous for a in (weight, phi, x)):
        from ..._kernels.diffusion_cg import weighted_change

        part = np.zeros((phi.shape[0], 2))
        weighted_change(weight, phi, x, part)
        s, t = part.sum(axis=0)
        return math.sqrt(s) / max(math.sqrt(t), 1e-300)
    return float(np.linalg.norm(weight * (phi - x))) / max(float(np.linalg.norm(weight * phi)), 1e-300)


def anderson(xs, gs):
    """Anderson mixing: the combination of the last images S(x_i) = gs[i] whose residuals
    f_i = gs[i] − xs[i] combine to the least 2-norm; clamped at 0 (φ ≥ 0 for the limiter).
    Over one or two differences (``ANDERSON_DEPTH`` ≤ 2) in two parallel passes with no
    temporaries (``_kernels.diffusion_cg.anderson_gram``, ``anderson_mix``): the sums are per slab,
    so the result does not depend on the thread count."""
    m = len(xs) - 1
    if 1 <= m <= 2 and all(a.ndim == 3 and a.dtype == np.float64 and a.flags.c_contiguous for a in xs + gs):
        return _anderson_fused(xs, gs, m)
    f = [g - x for x, g in zip(xs, gs)]
    dF = np.stack([(f[i + 1] - f[i]).ravel() for i in range(len(f) - 1)], axis=1)
    dG = np.stack([(gs[i + 1] - gs[i]).ravel() for i in range(len(gs) - 1)], axis=1)
    A = dF.T @ dF
    A += 1e-12 * np.trace(A) * np.eye(A.shape[0])
    try:
        gamma = np.linalg.solve(A, dF.T @ f[-1].ravel())
    except np.linalg.LinAlgError:  # pragma: no cover - degenerate history: plain lagged step
        return gs[-1]
    return np.maximum((gs[-1].ravel() - dG @ gamma).reshape(gs[-1].shape), 0.0)


def _anderson_fused(xs, gs, m):
    """:func:`anderson` over ``m`` = 1 or 2 differences of 3-D float64 arrays, by the kernels."""
    from ..._kernels.diffusion_cg import anderson_gram, anderson_mix

    part = np.zeros((xs[0].shape[0], 5))
    anderson_gram(xs[0], gs[0], xs[1], gs[1], xs[-1], gs[-1], m, part)
    a00, a01, a11, b0, b1 = part.sum(axis=0)
    A = np.array([[a00, a01], [a01, a11]])[:m, :m]
    A += 1e-12 * np.trace(A) * np.eye(m)
    try:
        gamma = np.linalg.solve(A, np.array([b0, b1])[:m])
    except np.linalg.LinAlgError:  # pragma: no cover - degenerate history: plain lagged step
        return gs[-1]
    out = np.empty_like(gs[-1])
    anderson_mix(gs[0], gs[1], gs[-1], float(gamma[0]), float(gamma[1]) if m == 2 else 0.0, out)
    return out
