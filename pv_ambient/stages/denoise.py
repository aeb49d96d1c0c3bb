"""Denoising of path-traced images with Intel Open Image Denoise (optional extra ``denoise``).

``path_traced`` with ``denoise=True`` passes its linear HDR radiance through OIDN's ``RT`` filter
(``pyoidn``; install with ``pip install "pv_ambient[denoise]"``). The result keeps the
un-denoised standard-error image and says in its metadata that it was denoised.

Two steps around the filter, both scene-independent:

* **Mean preservation** (default on). The noisy image's mean is an unbiased estimate of the
  converged image's mean; OIDN's is not: on the three scenes of ``benchmarks/trade.py``
  (``--size 80 --n 64``, 4 spp, 32 seeds) its output mean was off its own input's by −1.3 %
  (supernova), +2.0 % (cloud) and −1.0 % (CT phantom) on average. :func:`denoise_radiance`
  therefore rescales each channel of the denoised image so that its sum equals the noisy
  image's (exact by construction). Over those seeds the mean bias (denoised vs converged
  reference) went from −1.6 / +2.2 / −1.0 % to +0.3 / +0.2 / −0.0 %, with 4×4-block relative
  RMSE and SSIM unchanged (block 0.354 → 0.355, 0.266 → 0.257, 0.133 → 0.132). The image mean
  then keeps the Monte Carlo spread of the input: at 4 spp its standard deviation over seeds is
  2.0 / 2.8 / 1.0 % of the mean, which no post-process can remove (a single 4-spp frame of the
  cloud, e.g. the benchmark's seed 3, can be 5.8 % dark before any denoising). Coarser local
  corrections (Gaussian-smoothed ratio at σ = 8 or 16 px, 20-px tiles) measured no better than
  the global one, and tiles leave seams. Changing OIDN's HDR ``inputScale`` (0.045/m … 4/m for
  m the mean luminance of the covered pixels, against its auto-exposure) moved the mean by
  ±2 % scene-dependently and was rejected.
* **Albedo guide** (optional ``albedo=``). A volume has no surface albedo, but the expected
  scattering albedo at a camera ray's first collision, ``∫ T(t) σt(t) a(t) dt`` (premultiplied
  by coverage, in [0, 1], noise-free), plays its role: it is the emission–absorption image with
  the colour replaced by the albedo, :meth:`pv_ambient.Renderer.albedo_guide` (one ray cast). Measured as above with
  mean preservation: 4×4-block relative RMSE 0.355 → 0.331 (supernova), 0.257 → 0.186 (cloud),
  0.132 → 0.096 (CT phantom); SSIM 0.972 → 0.979, 0.948 → 0.978, 0.863 → 0.967; per-pixel
  relative RMSE 0.53 → 0.48, 0.32 → 0.22, 0.26 → 0.15 (un-denoised: 4 spp block 0.49 / 0.55 /
  0.23, 16 spp SSIM 0.89 / 0.78 / 0.77). The guide costs one emission–absorption frame. Without
  premultiplication (albedo / coverage) it measured slightly worse; a coverage-only guide
  (``1 − T``) did not help. No normal guide is used (a volume's gradient normal needs a ray
  cast of its own; not measured). The guide is used where the caller passes it:
  ``denoise_radiance(res.radiance, albedo=renderer.albedo_guide(camera, window_size))``.

>>> import numpy as np
>>> from pv_ambient.stages.denoise import available, preserve_mean
>>> isinstance(available(), bool)
True
>>> noisy = np.zeros((2, 2, 3)); noisy[0, 0] = 4.0
>>> preserve_mean(np.full((2, 2, 3), 0.5), noisy).sum(axis=(0, 1)).tolist()
[4.0, 4.0, 4.0]
"""

from __future__ import annotations

import numpy as np

EXTRA = "denoise"


def available() -> bool:
    """Whether ``pyoidn`` can be imported."""
    try:
        import pyoidn  # noqa: F401
    except ImportError:
        return False
    return True


def _import_pyoidn():
    try:
        import pyoidn
    except ImportError:
        raise ImportError("denoise=True needs Intel Open Image Denoise: pip install "
                          f"'pv_ambient[{EXTRA}]' (the pyoidn package)") from None
    return pyoidn


def _clean(image, name):
    img = np.ascontiguousarray(np.clip(np.nan_to_num(image, nan=0.0, posinf=0.0), 0.0, None), dtype=np.float32)
    if img.ndim != 3 or img.shape[2] != 3 or min(img.shape[:2]) == 0:
        raise ValueError(f"{name} must have shape (H, W, 3) with H, W > 0, got {img.shape}")
    return img


def preserve_mean(denoised, noisy) -> np.ndarray:
    """``denoised`` (H, W, 3) rescaled per channel so that its sum equals ``noisy``'s.

    The noisy Monte Carlo image's mean is an unbiased estimate of the converged image's mean;
    this carries it over to the denoised image. A channel the denoiser made all zero is left as
    it is. Returns float32.
    """
    d = np.asarray(denoised, np.float64)
    n = np.asarray(noisy, np.float64)
    if d.shape != n.shape or d.ndim != 3 or d.shape[2] != 3:
        raise ValueError(f"denoised and noisy must both have shape (H, W, 3), got {d.shape} and {n.shape}")
    sd, sn = d.sum(axis=(0, 1)), n.sum(axis=(0, 1))
    scale = np.where(sd > 0, sn / np.where(sd > 0, sd, 1.0), 1.0)
    return (d * scale).astype(np.float32)


def denoise_radiance(radiance, *, albedo=None, quality="high", mean_preserving=True) -> np.ndarray:
    """OIDN-denoised copy of linear HDR ``radiance`` (H, W, 3), float32.

    ``albedo``: optional noise-free guide (H, W, 3) in [0, 1], e.g. :meth:`pv_ambient.Renderer.albedo_guide`.
    ``mean_preserving``: rescale each channel so the image mean equals the noisy input's
    (:func:`preserve_mean`; see the module docstring for why and the measured effect).
    Non-finite and negative input values count as 0. Raises ``ImportError`` naming the optional
    extra when ``pyoidn`` is missing.
    """
    pyoidn = _import_pyoidn()
    rad = _clean(radiance, "radiance")
    guides = {}
    if albedo is not None:
        alb = np.clip(_clean(albedo, "albedo"), 0.0, 1.0)
        if alb.shape != rad.shape:
            raise ValueError(f"albedo shape {alb.shape} differs from the radiance's {rad.shape}")
        guides = {"albedo": alb, "clean_aux": True}
    out = np.asarray(pyoidn.denoise(rad, hdr=True, quality=quality, **guides), dtype=np.float32)
    return preserve_mean(out, rad) if mean_preserving else out
