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
