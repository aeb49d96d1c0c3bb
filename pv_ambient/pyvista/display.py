"""Display maths: :meth:`RenderResult.to_uint8`'s conversion (exposure, tone map, sRGB) and its
inverse, for compositing pv_ambient's pictures with what VTK has already drawn.
"""

from __future__ import annotations

import numpy as np

from ..inputs.validation import check_choice, check_real
from ..rendering.result import DISPLAY_KEYS, TONEMAPS, srgb_encode, tonemap_values  # noqa: F401


def display_to_linear(values, *, exposure=0.0, tonemap="clip", srgb=False):
    """Invert :meth:`RenderResult.to_uint8`'s display conversion: display values → linear radiance.

    ``to_uint8(exposure, tonemap, srgb)`` applied to the returned radiance gives ``values`` back
    (to the uint8 rounding): the sRGB curve is decoded, the tone map inverted (``clip`` is the
    identity on [0, 1]; ``reinhard`` ``y/(1 − y)``, display 1 read as 1 − ¼/255; ``aces``
    numerically) and the exposure undone.

    Parameters
    ----------
    values : array_like
        Display values in [0, 1] (uint8 / 255).
    exposure, tonemap, srgb
        As :meth:`RenderResult.to_uint8`.

    Returns
    -------
    numpy.ndarray
        Linear radiance, float32 for float32 values, else float64.

    Examples
    --------
    >>> from pv_ambient.pyvista.display import display_to_linear
    >>> display_to_linear([0.0, 0.5, 1.0]).tolist()
    [0.0, 0.5, 1.0]
    >>> round(float(display_to_linear(0.5, tonemap="reinhard", exposure=1.0)), 6)
    0.5
    """
    exposure = check_real(exposure, "exposure")
    check_choice(tonemap, "tonemap", TONEMAPS)
    x = np.clip(_floats(values), 0.0, 1.0)
    dtype = x.dtype
    if srgb:
        x = np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)
    if tonemap == "reinhard":
        x = np.minimum(x, 1.0 - 0.25 / 255.0)  # the map reaches 1 only at infinity
        x = x / (1.0 - x)
    elif tonemap == "aces":
        knots = np.concatenate([[0.0], np.geomspace(1e-7, 1e3, 8192)])
        y = tonemap_values(knots, "aces")
        top = int(np.argmax(y >= 1.0)) + 1 if (y >= 1.0).any() else y.size
        x = np.interp(x, y[:top], knots[:top])
    return (x / 2.0 ** exposure).astype(dtype, copy=False)


def display_values(x, *, exposure=0.0, tonemap="clip", srgb=False):
    """:meth:`RenderResult.to_uint8`'s conversion without the rounding: linear → display [0, 1].

    The inverse of :func:`display_to_linear` on [0, 1].

    Examples
    --------
    >>> from pv_ambient.pyvista.display import display_values
    >>> display_values([0.25, 0.5, 2.0], exposure=1.0).tolist()
    [0.5, 1.0, 1.0]
    """
    x = tonemap_values(_floats(x) * 2.0 ** check_real(exposure, "exposure"), tonemap)
    return srgb_encode(x) if srgb else x


def _floats(values):
    """``values`` as a float array: float32 stays float32 (a picture's radiance is float32, and
    a frame in a plotter is converted on every camera move), anything else becomes float64."""
    x = np.asarray(values)
    return x if x.dtype == np.float32 else x.astype(np.float64)
