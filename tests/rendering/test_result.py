"""Tests pv_ambient/rendering/result.py: RenderResult's display conversions (exposure "auto", the
black-display warning), its repr and the display keys."""
import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient import datasets
from pv_ambient.rendering.presets import ALL_MODELS
from pv_ambient.rendering.result import DISPLAY_KEYS, auto_exposure, is_lit_model, unknown_display_keys


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


def test_auto_exposure_reads_only_the_covered_pixels():
    assert auto_exposure(np.full((4, 4, 3), 0.1)) == 3.0  # 0.1 · 2³ = 0.8
    assert auto_exposure(np.zeros((4, 4, 3))) == 0.0  # black: nothing to expose
    rad = np.full((10, 10, 3), 0.05)
    rad[:5] = 10.0  # bright, but where the volume is absent (alpha 0)
    alpha = np.zeros((10, 10))
    alpha[5:] = 1.0
    assert auto_exposure(rad, alpha) == 4.0  # 0.05 · 2⁴ = 0.8
    assert auto_exposure(rad) < 0.0  # every pixel counts when none is covered


def test_display_keys_and_which_models_are_lit():
    assert DISPLAY_KEYS == ("exposure", "tonemap", "srgb")
    assert unknown_display_keys({"exposure": 1, "gamma": 2.2, "srgb": True, "alpha": 1}) == ["alpha", "gamma"]
    unlit = {"emission_absorption", "ambient_occlusion"}
    assert {m for m in ALL_MODELS if not is_lit_model(m)} == unlit  # their display keeps VTK's exposure 0
    assert not is_lit_model(None) and not is_lit_model("magic")
    res = pa.RenderResult(np.zeros((2, 2, 3), np.float32), np.zeros((2, 2), np.float32), None)
    with pytest.raises(ValueError, match=r"^tonemap must be one of 'clip', 'reinhard', 'aces'; got 'gamma'$"):
        res.to_uint8(tonemap="gamma")
