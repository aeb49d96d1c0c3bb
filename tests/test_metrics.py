"""Tests pv_ambient/metrics.py, the error metrics of the trade study, against values computed by hand."""

import numpy as np
import pytest

from pv_ambient import metrics
from pv_ambient.inputs.camera import Camera


def test_relative_rmse_and_bias():
    ref = np.full((8, 8, 3), 2.0)
    img = ref.copy()
    img[0, 0] += 8.0  # one pixel off by 8 in every channel: RMSE = sqrt(64/64) = 1, mean 2
    assert metrics.relative_rmse(img, ref) == pytest.approx(0.5)
    assert metrics.relative_bias(img, ref) == pytest.approx(8.0 / 64 / 2.0)
    mask = np.ones((8, 8), bool)
    mask[0, 0] = False
    assert metrics.relative_rmse(img, ref, mask) == 0.0


def test_block_rmse_ignores_noise_that_averages_out():
    ref = np.ones((8, 8, 3))
    checker = (np.indices((8, 8)).sum(0) % 2 * 2 - 1)[..., None] * 0.3  # ±0.3, zero mean per 4×4 block
    assert metrics.relative_rmse(ref + checker, ref) == pytest.approx(0.3)
    assert metrics.block_relative_rmse(ref + checker, ref) == pytest.approx(0.0, abs=1e-12)
    assert metrics.block_relative_rmse(ref * 1.2, ref) == pytest.approx(0.2)


def test_ssim_bounds():
    rng = np.random.default_rng(0)
    ref = rng.random((32, 32, 3))
    assert metrics.ssim(ref, ref) == pytest.approx(1.0)
    assert metrics.ssim(rng.random((32, 32, 3)), ref) < 0.2  # independent noise: nearly uncorrelated


def test_light_mask_window():
    cam = Camera((0, -5, 0), (0, 0, 0), (0, 0, 1), view_angle=30)

    class L:
        position = (0.0, 0.0, 0.0)

    m = metrics.light_mask((21, 21), cam, (21, 21), [L()], half=2)
    assert (~m).sum() == 25 and not m[10, 10]


def test_shape_mismatch():
    with pytest.raises(ValueError, match="differs from the reference"):
        metrics.relative_rmse(np.zeros((2, 2, 3)), np.zeros((3, 2, 3)))
