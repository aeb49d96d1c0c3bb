"""Tests pv_ambient/rendering/result.py: RenderResult's display conversions (exposure "auto", the
black-display warning), its repr and the display keys."""
import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient import datasets


def test_auto_exposure_maps_the_99th_percentile_to_0_8_and_ea_keeps_vtk_convention():
    grid = datasets.cloud(n=16)
    lit = pa.render(grid, window_size=(32, 24), model="single_scattering",
                    lights=[pa.DirectionalLight((0, 0, -1), 1e-4)])
    lum = lit.radiance.astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722])
    p99 = np.percentile(lum[lit.alpha > 0.05], 99)
    assert lit.display_exposure() == pytest.approx(np.log2(0.8 / p99))
    assert np.array_equal(lit.to_uint8(), lit.to_uint8(exposure=np.log2(0.8 / p99)))
    assert int(lit.to_uint8().max()) > 150  # 1e-4 irradiance: black at exposure 0, visible at "auto"
    ea = pa.render(grid, window_size=(32, 24))
    assert ea.display_exposure() == 0.0
    assert np.array_equal(ea.to_uint8(), np.round(np.clip(ea.radiance, 0, 1) * 255).astype(np.uint8))


def test_black_display_at_explicit_exposure_warns_with_the_radiance_reached():
    lit = pa.render(datasets.cloud(n=12), window_size=(16, 12), model="single_scattering",
                    lights=[pa.PointLight((300.0, 0.0, 0.0), 1.0)])
    with pytest.warns(UserWarning, match=r"black at exposure=0: the radiance peaks at"):
        lit.to_uint8(exposure=0.0)


def test_render_result_repr_is_one_short_line():
    """Why: ``print(result)`` dumped whole arrays."""
    res = pa.render(datasets.cloud(n=12), window_size=(64, 48))
    text = repr(res)
    assert text.startswith("RenderResult(model='emission_absorption', window_size=(64, 48)")
    assert "\n" not in text and len(text) < 200 and "array" not in text
