"""Tests pv_ambient/pyvista/display.py: the display maths and its inverse."""
import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient.pyvista.display import display_to_linear


@pytest.mark.parametrize("display", [{}, {"srgb": True}, {"tonemap": "reinhard", "exposure": -1.0},
                                     {"tonemap": "aces", "srgb": True}])
def test_display_to_linear_inverts_to_uint8(display):
    u = np.arange(256, dtype=np.uint8)
    lin = display_to_linear(u / 255.0, **display)
    res = pa.RenderResult(np.repeat(lin[None, :, None], 3, axis=2).astype(np.float32), np.ones((1, 256), np.float32),
                          None)
    assert np.array_equal(res.to_uint8(**display)[0, :, 0], u)


@pytest.mark.parametrize("display", [{"exposure": 0.7}, {"srgb": True, "exposure": -0.5},
                                     {"tonemap": "reinhard", "exposure": 1.0}, {"tonemap": "aces", "srgb": True}])
def test_composite_for_display_is_the_float64_composite_in_one_float32_pass(display):
    """The plotter's per-frame composite (float32, its uint8 returned with it) against the formula
    of composite_over_geometry evaluated independently in float64: the uint8 pictures differ by at
    most one level (rounding at a half level), the radiance it returns displays as its picture."""
    from pv_ambient.pyvista.display import display_values
    from pv_ambient.pyvista.geometry import composite_for_display

    rng = np.random.default_rng(3)
    h, w = 40, 50
    vol = pa.RenderResult((rng.random((h, w, 3)) * 1.5).astype(np.float32), rng.random((h, w)).astype(np.float32),
                          None)
    colour, cov, bg = rng.random((h, w, 3)) * 0.5, rng.random((h, w)), np.array([0.1, 0.0, 0.3])
    colour *= cov[..., None]
    res, image = composite_for_display(vol, colour, cov, background=bg, display=display)
    trans = 1.0 - vol.alpha.astype(np.float64)[..., None]
    base = vol.radiance.astype(np.float64) + trans * (1.0 - cov[..., None]) * bg
    want = np.round(np.clip(display_values(base, **display) + trans * colour, 0.0, 1.0) * 255.0)
    assert np.abs(image.astype(int) - want).max() <= 1
    assert np.abs(res.to_uint8(**display).astype(int) - image).max() <= 1
    assert np.allclose(res.alpha, 1.0 - trans[..., 0] * (1.0 - cov), atol=1e-6)
    assert res.radiance.dtype == np.float32 and image.dtype == np.uint8
