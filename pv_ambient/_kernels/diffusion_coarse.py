"""Transfers between the data grid and the coarser grid the diffusion solve may run on
(docs/diffusion.rst, "Solve resolution"): trilinear prolongation and its transpose, the
hat-weighted restriction. Per axis, data sample i lies between coarse nodes ``c0[i]`` and
``c0[i] + 1`` at fraction ``f[i]`` (a kept axis: ``c0[i] = i``, ``f[i] = 0``); the arrays carry a
trailing channel axis (a 3-D field is passed as a view with one channel).
"""

from __future__ import annotations

from ._jit import driver, prange


@driver
def prolong(src, c0x, fx, c0y, fy, c0z, fz, out):
    """``out[i, j, k, :]`` = ``src`` (coarse) trilinearly interpolated at data sample (i, j, k)."""
    m0, m1, m2, nc = src.shape
    n0, n1, n2, _ = out.shape
    for i in prange(n0):
        a0 = c0x[i]
        a1 = min(a0 + 1, m0 - 1)
        u = fx[i]
        for j in range(n1):
            b0 = c0y[j]
            b1 = min(b0 + 1, m1 - 1)
            v = fy[j]
            for k in range(n2):
                d0 = c0z[k]
                d1 = min(d0 + 1, m2 - 1)
                w = fz[k]
                for ch in range(nc):
                    lo = ((1.0 - v) * ((1.0 - w) * src[a0, b0, d0, ch] + w * src[a0, b0, d1, ch])
                          + v * ((1.0 - w) * src[a0, b1, d0, ch] + w * src[a0, b1, d1, ch]))
                    hi = ((1.0 - v) * ((1.0 - w) * src[a1, b0, d0, ch] + w * src[a1, b0, d1, ch])
                          + v * ((1.0 - w) * src[a1, b1, d0, ch] + w * src[a1, b1, d1, ch]))
                    out[i, j, k, ch] = (1.0 - u) * lo + u * hi


@driver
def restrict(src, c0x, fx, lox, hix, c0y, fy, loy, hiy, c0z, fz, loz, hiz, out):
    """``out[I, J, K, :]`` = the hat-weighted mean of ``src`` (data grid) around coarse node
    (I, J, K): Σ P·src / Σ P with P the trilinear prolongation's weights (its transpose,
    normalised). ``lo*[I]``, ``hi*[I]``: the data samples (inclusive) whose interval touches I."""
    n0, n1, n2, nc = src.shape
    m0, m1, m2, _ = out.shape
    for I in prange(m0):
        for J in range(m1):
            for K in range(m2):
                for ch in range(nc):
                    out[I, J, K, ch] = 0.0
                wsum = 0.0
                for i in range(lox[I], hix[I] + 1):
                    wi = (1.0 - fx[i]) if c0x[i] == I else (fx[i] if c0x[i] + 1 == I else 0.0)
                    if wi == 0.0:
                        continue
                    for j in range(loy[J], hiy[J] + 1):
                        wj = (1.0 - fy[j]) if c0y[j] == J else (fy[j] if c0y[j] + 1 == J else 0.0)
                        if wj == 0.0:
                            continue
                        wij = wi * wj
                        for k in range(loz[K], hiz[K] + 1):
                            wk = (1.0 - fz[k]) if c0z[k] == K else (fz[k] if c0z[k] + 1 == K else 0.0)
                            if wk == 0.0:
                                continue
                            wt = wij * wk
                            wsum += wt
                            for ch in range(nc):
                                out[I, J, K, ch] += wt * src[i, j, k, ch]
                if wsum > 0.0:
                    for ch in range(nc):
                        out[I, J, K, ch] /= wsum
