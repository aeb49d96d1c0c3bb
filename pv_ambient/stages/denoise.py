"""Denoising of path-traced images with Intel Open Image Denoise (optional extra ``denoise``).

``path_traced`` with ``denoise=True`` passes its linear HDR radiance through OIDN's ``RT`` filter
(``pyoidn``; install with ``pip install "pv_ambient[denoise]"``). The result keeps the
un-denoised standard-error image and says in its metadata that it was denoised.

Two steps around the filter, both scene-independent:

* **Mean preservation** (default on). The noisy image's mean is an unbiased estimate of the
  converged image's mean; OIDN's output is not. :func:`denoise_radiance` therefore rescales each
  channel of the denoised image so that its sum equals the noisy image's (exact by
  construction); the image mean then keeps only the Monte Carlo spread of the input, which no
  post-process can remove.
* **Albedo guide** (optional ``albedo=``). A volume has no surface albedo, but the expected
  scattering albedo at a camera ray's first collision, ``∫ T(t) σt(t) a(t) dt`` (premultiplied
  by coverage, in [0, 1], noise-free), plays its role: it is the emission–absorption image with
  the colour replaced by the albedo, :meth:`pv_ambient.Renderer.albedo_guide` (one ray cast,
  passed as ``denoise_radiance(res.radiance, albedo=renderer.albedo_guide(camera, window_size))``).

The method and the measurements behind both steps: docs/path_tracer.rst, "Denoising".

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


def require() -> None:
    """Raise the ImportError that names the optional extra unless :func:`available`."""
    if not available():
        _import_pyoidn()


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
    (:func:`preserve_mean`; why: the module docstring).
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
