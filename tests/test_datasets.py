"""Tests pv_ambient/datasets.py, the synthetic datasets: deterministic, resolution independent, in
range, wrapped as ImageData."""

import numpy as np
import pytest

import datasets_synthetic as ds
from pv_ambient import datasets
from pv_ambient.inputs.grid import volume_from_image


@pytest.mark.parametrize("name", datasets.NAMES)
def test_deterministic_and_in_range(name):
    a = ds.load(name, n=17, seed=3)
    b = ds.load(name, n=17, seed=3)
    assert a.values.dtype == np.float32 and a.values.shape == (17, 17, 17)
    assert np.array_equal(a.values, b.values)  # same seed, same bytes
    assert np.all(np.isfinite(a.values))
    assert a.values.min() >= 0.0 and a.values.max() <= 1.0
    assert a.values.max() > 0.5  # not an empty volume


@pytest.mark.parametrize("name", [n for n in datasets.NAMES if n != "marschner_lobb"])
def test_seed_changes_noise(name):
    assert not np.array_equal(ds.load(name, n=17, seed=0).values, ds.load(name, n=17, seed=1).values)


@pytest.mark.parametrize("name", datasets.NAMES)
def test_resolution_independent(name):
    # 9 points per axis are every 4th of 33 (spacing 2/8 vs 2/32): the same world points.
    coarse = ds.load(name, n=9, seed=2).values
    fine = ds.load(name, n=33, seed=2).values
    np.testing.assert_allclose(coarse, fine[::4, ::4, ::4], atol=1e-6)


def test_marschner_lobb_closed_form():
    vol = ds.marschner_lobb(n=21)
    x, y, z = np.meshgrid(*vol.axes(), indexing="ij")
    expected = np.clip(ds.marschner_lobb_formula(x, y, z), 0, 1)
    np.testing.assert_allclose(vol.values, expected, atol=1e-6)


@pytest.mark.parametrize("name", datasets.NAMES)
def test_image_data_wrapper_places_values_at_points(name):
    grid = datasets.load(name, n=(9, 11, 13))
    raw = ds.load(name, n=(9, 11, 13))
    assert grid.dimensions == (9, 11, 13)
    np.testing.assert_allclose(grid.bounds, (-1, 1, -1, 1, -1, 1))
    vol = volume_from_image(grid)
    np.testing.assert_array_equal(vol.arrays[vol.active], raw.values)
    # an independent check of the x-fastest layout: point id i + nx (j + ny k) is (i, j, k)
    pid = 3 + 9 * (5 + 11 * 7)
    np.testing.assert_allclose(grid.points[pid], [raw.axes()[0][3], raw.axes()[1][5], raw.axes()[2][7]])
    assert grid.point_data[raw.scalars_name][pid] == raw.values[3, 5, 7]


def test_styles_make_a_transfer_function():
    import pv_ambient as pa

    for name in datasets.NAMES:
        style = datasets.suggested_style(name)
        assert set(style) == {"cmap", "clim", "opacity", "density_scale"}
        tf = pa.TransferFunction(**style)
        assert tf is not None


def test_bad_names_and_sizes():
    with pytest.raises(ValueError, match="name must be one of"):
        datasets.load("teapot")
    with pytest.raises(ValueError, match="n must be >= 2"):
        datasets.cloud(n=1)
    with pytest.raises(TypeError, match="n must be an int"):
        datasets.cloud(n=2.5)
    with pytest.raises(ValueError, match="seed must be a non-negative int"):
        datasets.cloud(n=8, seed=-1)


def test_haze_fills_the_box_and_blob_is_compact():
    """The two volumes of the out-of-sample scenes (benchmarks/scenes.py): the haze is medium
    everywhere inside the faces' window, the blob is dense inside and empty away from it."""
    h = ds.haze(n=33, seed=0).values
    assert np.all(h[5:-5, 5:-5, 5:-5] >= 0.05 - 1e-6)  # never clear inside the window (0.15 = 2.5 spacings)
    assert np.all(h[0] == 0) and np.all(h[:, :, -1] == 0)
    assert 0.3 < h[5:-5, 5:-5, 5:-5].mean() < 0.7
    b = ds.blob(n=33, seed=0).values
    x = np.linspace(-1, 1, 33)
    r = np.sqrt(x[:, None, None] ** 2 + x[None, :, None] ** 2 + x[None, None, :] ** 2)
    assert np.all(b[r > 0.8] == 0)  # compact
    assert np.median(b[r < 0.35]) > 0.8  # dense, nearly uniform inside
