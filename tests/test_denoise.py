"""Denoised path tracing (optional extra ``denoise``): a clear error without pyoidn; with it, the
denoised image keeps the un-denoised standard error and says it was denoised."""

import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient.denoise import available

pv = pytest.importorskip("pyvista")


def scene():
    g = pv.ImageData(dimensions=(9, 9, 9), spacing=(0.25,) * 3, origin=(-1, -1, -1))
    g["sigma_t"] = np.full(g.n_points, 1.5, np.float32)
    g["albedo"] = np.full((g.n_points, 3), 0.8, np.float32)
    return pa.Renderer(g, transfer_function=pa.TransferFunction.physical(),
                       lights=[pa.PointLight((0, -2, 1), intensity=4.0)])


CAM = pa.Camera((0, -4, 0.5), (0, 0, 0), (0, 0, 1), view_angle=35)


@pytest.mark.skipif(available(), reason="pyoidn is installed")
def test_missing_pyoidn_names_the_extra():
    with pytest.raises(ImportError, match=r"pv_ambient\[denoise\]"):
        scene().render(camera=CAM, window_size=(8, 8), model="path_traced", samples_per_pixel=2, denoise=True)


def test_denoise_flag_is_checked():
    with pytest.raises(TypeError, match="denoise must be True or False"):
        scene().render(camera=CAM, window_size=(8, 8), model="path_traced", samples_per_pixel=2, denoise="yes")


@pytest.mark.skipif(not available(), reason="needs the optional pyoidn")
def test_denoised_result_keeps_standard_error():
    r = scene()
    raw = r.render(camera=CAM, window_size=(32, 32), model="path_traced", samples_per_pixel=4, seed=3)
    den = r.render(camera=CAM, window_size=(32, 32), model="path_traced", samples_per_pixel=4, seed=3, denoise=True)
    assert den.metadata["denoised"] and not raw.metadata["denoised"]
    np.testing.assert_array_equal(den.std_error, raw.std_error)
    assert np.all(np.isfinite(den.radiance)) and den.radiance.min() >= 0
    # the denoiser removes pixel noise: neighbouring-pixel differences shrink
    assert np.abs(np.diff(den.radiance, axis=1)).mean() < np.abs(np.diff(raw.radiance, axis=1)).mean()
