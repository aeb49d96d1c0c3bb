"""Tests pv_ambient/rendering/path_traced.py: the ``path_traced`` model through the renderer — the
target error and its warning, the time budget of ``auto``, denoising that keeps the standard error."""
import warnings

import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient import datasets
from pv_ambient.stages.denoise import available

from ..helpers import lit_box

CAM = pa.Camera((0, -4, 0.5), (0, 0, 0), (0, 0, 1), view_angle=35)


def test_target_error_not_reached_warns_with_the_error_reached():
    """Why: ``target_error=0.01`` was missed silently (the samples_per_pixel cap came first)."""
    r = pa.Renderer(datasets.cloud(n=12), lights=[pa.PointLight((1.5, 1.5, 1.5), 4.0)])
    with pytest.warns(UserWarning, match=r"target_error=0.001 was not reached: the relative error is [0-9.]+ after "
                                         r"4 samples per pixel"):
        res = r.render(window_size=(12, 10), model="path_traced", samples_per_pixel=4, target_error=1e-3)
    assert res.metadata["relative_error"] > 1e-3
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # reached: no warning
        r.render(window_size=(12, 10), model="path_traced", samples_per_pixel=64, target_error=10.0)


@pytest.mark.skipif(not available(), reason="needs the optional pyoidn")
def test_denoised_result_keeps_standard_error():
    r = lit_box()
    raw = r.render(camera=CAM, window_size=(32, 32), model="path_traced", samples_per_pixel=4, seed=3)
    den = r.render(camera=CAM, window_size=(32, 32), model="path_traced", samples_per_pixel=4, seed=3, denoise=True)
    assert den.metadata["denoised"] and not raw.metadata["denoised"]
    np.testing.assert_array_equal(den.std_error, raw.std_error)
    assert np.all(np.isfinite(den.radiance)) and den.radiance.min() >= 0
    # the denoiser removes pixel noise: neighbouring-pixel differences shrink
    assert np.abs(np.diff(den.radiance, axis=1)).mean() < np.abs(np.diff(raw.radiance, axis=1)).mean()


def test_time_budget_spends_the_budget_on_the_path_tracer():
    # auto + time_budget: path_traced with as many samples as fit; more budget, more samples
    import time

    from pv_ambient import datasets

    r = pa.Renderer(datasets.cloud(n=16), lights=[pa.PointLight((0.3, 0.2, 0.1), 2.0)])
    r.render(window_size=(16, 16), model="path_traced", samples_per_pixel=1)  # compile outside the clock
    spp = {}
    for budget in (0.05, 1.0):
        t = time.perf_counter()
        res = r.render(window_size=(16, 16), model="auto", time_budget=budget, denoise=False)
        wall = time.perf_counter() - t
        assert res.metadata["model"] == "path_traced" and res.metadata["requested_model"] == "auto"
        assert res.metadata["time"] <= budget + 0.5 and wall <= budget + 2.0
        spp[budget] = res.metadata["spp"]
    assert spp[0.05] >= 1 and spp[1.0] >= 4 * spp[0.05]
    with pytest.raises(ValueError, match="time_budget chooses the model"):
        r.render(window_size=(8, 8), model="ambient_scattering", time_budget=1.0)
    # nothing to scatter (no light, lights=(); leaving lights out gives the default rig since 0.3.0):
    # the budget does not buy a path tracer
    dark = pa.Renderer(datasets.cloud(n=16), lights=())
    with pytest.warns(UserWarning, match="rendered black: no lights were given"):
        assert dark.render(window_size=(8, 8), model="auto", time_budget=1.0).metadata["model"] == "single_scattering"
