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
def restrict(src, tx, wx, ty, wy, tz, wz, out):
    """``out[I, J, K, :]`` = Σ wx[I, a]·wy[J, b]·wz[K, c]·src[tx[I, a], ty[J, b], tz[K, c], :]: the
    hat-weighted mean of ``src`` (data grid) around coarse node (I, J, K), the per-axis weights
    ``w*`` the trilinear prolongation's (its transpose), normalised per axis, over the data
    samples ``t*`` (padded with weight 0). Sums in float64."""
    m0, m1, m2, nc = out.shape
    na, nb, nd = wx.shape[1], wy.shape[1], wz.shape[1]
    for I in prange(m0):
        for J in range(m1):
            for K in range(m2):
                for ch in range(nc):
                    acc = 0.0
                    for a in range(na):
                        u = wx[I, a]
                        if u == 0.0:
                            continue
                        i = tx[I, a]
                        for b in range(nb):
                            v = u * wy[J, b]
                            j = ty[J, b]
                            for d in range(nd):
                                acc += v * wz[K, d] * src[i, j, tz[K, d], ch]
                    out[I, J, K, ch] = acc


@driver
def restrict_source(e, use_e, sig, alb, power, tx, wx, ty, wy, tz, wz, out):
    """``out[I, J, K, ch] +=`` the hat-weighted mean (as :func:`restrict`) of the first-collision
    source ``σt·a_ch·e·power[ch]`` of one light at the data samples (``e`` its irradiance per unit
    power, 1 without ``use_e``: then σs itself; ``alb`` (…, 1) for a grey albedo): restricted
    without forming the product on the data grid. ``out`` has 1 or 3 channels; each tap is read
    once for all of them, each channel summed over the taps in their order."""
    m0, m1, m2, nc = out.shape
    na, nb, nd = wx.shape[1], wy.shape[1], wz.shape[1]
    ca = alb.shape[3]
    q1 = min(1, ca - 1)
    q2 = min(2, ca - 1)
    for I in prange(m0):
        for J in range(m1):
            for K in range(m2):
                acc0 = 0.0
                acc1 = 0.0
                acc2 = 0.0
                for a in range(na):
                    u = wx[I, a]
                    if u == 0.0:
                        continue
                    i = tx[I, a]
                    for b in range(nb):
                        v = u * wy[J, b]
                        j = ty[J, b]
                        for d in range(nd):
                            k = tz[K, d]
                            ee = e[i, j, k] if use_e else 1.0
                            w = v * wz[K, d] * ee * sig[i, j, k]
                            acc0 += w * alb[i, j, k, 0]
                            if nc > 1:
                                acc1 += w * alb[i, j, k, q1]
                                acc2 += w * alb[i, j, k, q2]
                out[I, J, K, 0] += acc0 * power[0]
                if nc > 1:
                    out[I, J, K, 1] += acc1 * power[1]
                    out[I, J, K, 2] += acc2 * power[2]
