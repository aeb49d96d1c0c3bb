"""Denoising of path-traced images with Intel Open Image Denoise (optional extra ``denoise``).

``path_traced`` with ``denoise=True`` passes its linear HDR radiance through OIDN's ``RT`` filter
(``pyoidn``; install with ``pip install "pv_ambient[denoise]"``). The result keeps the
un-denoised standard-error image and says in its metadata that it was denoised. No guide
images are used: a volume has no surface albedo or normal, and OIDN's guides are defined for
surfaces.

>>> import numpy as np
>>> from pv_ambient.denoise import available
>>> isinstance(available(), bool)
True
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


def denoise_radiance(radiance, *, quality="high") -> np.ndarray:
    """OIDN-denoised copy of linear HDR ``radiance`` (H, W, 3), float32.

    Raises ``ImportError`` naming the optional extra when ``pyoidn`` is missing.
    """
    try:
        import pyoidn
    except ImportError:
        raise ImportError("denoise=True needs Intel Open Image Denoise: pip install "
                          f"'pv_ambient[{EXTRA}]' (the pyoidn package)") from None
    rad = np.ascontiguousarray(np.clip(np.nan_to_num(radiance, nan=0.0, posinf=0.0), 0.0, None), dtype=np.float32)
    if rad.ndim != 3 or rad.shape[2] != 3 or min(rad.shape[:2]) == 0:
        raise ValueError(f"radiance must have shape (H, W, 3) with H, W > 0, got {rad.shape}")
    return np.asarray(pyoidn.denoise(rad, hdr=True, quality=quality), dtype=np.float32)
