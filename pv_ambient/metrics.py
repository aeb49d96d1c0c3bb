"""Image error metrics of the speed–accuracy study (docs/trade.rst): block and per-pixel relative RMSE,
relative bias of the mean, SSIM of tone-mapped images.

All take linear radiance arrays ``(H, W, 3)`` (or ``(H, W)``) and a reference of the same shape;
"relative" means divided by the reference's mean over the unmasked pixels. ``mask`` (``(H, W)``
bool, True = counted) excludes e.g. a small window around a point light's projection.

>>> import numpy as np
>>> from pv_ambient import metrics
>>> ref = np.ones((8, 8, 3))
>>> round(metrics.relative_rmse(ref * 1.1, ref), 6), round(metrics.relative_bias(ref * 0.9, ref), 6)
(0.1, -0.1)
"""

from __future__ import annotations

import numpy as np


def _prep(img, ref, mask):
    img = np.asarray(img, np.float64)
    ref = np.asarray(ref, np.float64)
    if img.shape != ref.shape:
        raise ValueError(f"image shape {img.shape} differs from the reference's {ref.shape}")
    if img.ndim == 2:
        img, ref = img[..., None], ref[..., None]
    m = np.ones(img.shape[:2], bool) if mask is None else np.asarray(mask, bool)
    return img, ref, m


def relative_rmse(img, ref, mask=None) -> float:
    """Per-pixel RMSE over the masked pixels and channels, divided by the reference's mean."""
    img, ref, m = _prep(img, ref, mask)
    d = (img - ref)[m]
    return float(np.sqrt(np.mean(d * d)) / max(np.mean(ref[m]), 1e-300))


def block_relative_rmse(img, ref, mask=None, block=4) -> float:
    """RMSE of ``block``×``block`` block means (blocks touching a masked pixel are dropped),
    divided by the reference's mean: insensitive to pixel noise that averages out."""
    img, ref, m = _prep(img, ref, mask)
    H, W = m.shape
    h, w = H // block, W // block
    crop = (slice(0, h * block), slice(0, w * block))

    def blocks(a):
        a = a[crop]
        return a.reshape(h, block, w, block, *a.shape[2:]).mean(axis=(1, 3))

    keep = blocks(m.astype(np.float64)) == 1.0
    d = (blocks(img) - blocks(ref))[keep]
    return float(np.sqrt(np.mean(d * d)) / max(np.mean(blocks(ref)[keep]), 1e-300))


def relative_bias(img, ref, mask=None) -> float:
    """(mean(img) − mean(ref)) / mean(ref) over the masked pixels."""
    img, ref, m = _prep(img, ref, mask)
    return float((np.mean(img[m]) - np.mean(ref[m])) / max(np.mean(ref[m]), 1e-300))


def tonemap(img, white):
    """Reinhard-style display mapping ``x/(1 + x)`` of ``img/white`` (for SSIM)."""
    x = np.asarray(img, np.float64) / max(float(white), 1e-300)
    return x / (1.0 + x)


def ssim(img, ref, *, white=None, sigma=1.5) -> float:
    """Mean SSIM (Wang et al. 2004, Gaussian window σ = 1.5 px, K1 = 0.01, K2 = 0.03, data range 1)
    of the tone-mapped luminance-like channel mean; ``white`` defaults to the reference's 99th
    percentile."""
    from scipy.ndimage import gaussian_filter

    img, ref, _ = _prep(img, ref, None)
    white = float(np.percentile(ref, 99)) if white is None else white
    x = tonemap(img, white).mean(-1)
    y = tonemap(ref, white).mean(-1)
    c1, c2 = 0.01 ** 2, 0.03 ** 2
    mx, my = gaussian_filter(x, sigma), gaussian_filter(y, sigma)
    sxx = gaussian_filter(x * x, sigma) - mx * mx
    syy = gaussian_filter(y * y, sigma) - my * my
    sxy = gaussian_filter(x * y, sigma) - mx * my
    s = ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx * mx + my * my + c1) * (sxx + syy + c2))
    return float(np.mean(s))


def light_mask(shape, camera, window_size, lights, half=3):
    """``(H, W)`` bool mask, False in a (2·half+1)² window around each point light's projection."""
    H, W = shape[:2]
    m = np.ones((H, W), bool)
    for lt in lights:
        if getattr(lt, "position", None) is None:
            continue
        (u, v), = camera.project(np.asarray([lt.position], np.float64), window_size)
        i, j = int(np.floor(u)), int(np.floor(v))
        m[max(j - half, 0):max(j + half + 1, 0), max(i - half, 0):max(i + half + 1, 0)] = False
    return m
