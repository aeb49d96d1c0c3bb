"""Tests pv_ambient/stages/ball.py (docs/ambient_scattering.rst §1): the ball grid — σ̄ and the ball's
mean albedo ā = mean(σ a)/σ̄ per channel — against a brute-force overlap sum, one albedo channel at
a time (a function of the channel, as the renderer passes ``Optics.albedo_channel``) against the
whole albedo array, and the grey shortcut."""

import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient.stages.ball import ball_grid

from .test_sat import brute_mean


def brute_ball(sigma, albedo, spacing, radius):
    sbar = brute_mean(sigma, spacing, radius)
    out = np.zeros(sigma.shape + (4,))
    out[..., 0] = sbar
    for c in range(3):
        ms = brute_mean(sigma.astype(np.float64) * albedo[..., c], spacing, radius)
        out[..., 1 + c] = np.clip(np.where(sbar > 0, ms / np.where(sbar > 0, sbar, 1.0), 0.0), 0.0, 1.0)
    return out


@pytest.mark.parametrize("shape,spacing,radius", [((9, 7, 11), (0.5, 1.3, 2.0), 1.7), ((12, 10, 8), (1, 1, 1), 2.6)])
def test_ball_grid_matches_brute_force(shape, spacing, radius):
    rng = np.random.default_rng(21)
    sigma = (rng.random(shape) ** 3 * 5).astype(np.float32)
    sigma[:2] = 0.0  # empty slab: ā = 0 where σ̄ = 0
    albedo = rng.random(shape + (3,)).astype(np.float32)
    got = ball_grid(sigma, albedo, spacing, radius)
    ref = brute_ball(sigma, albedo, spacing, radius)
    assert got.dtype == np.float32 and got.shape == shape + (4,)
    np.testing.assert_allclose(got[..., 0], ref[..., 0], rtol=2e-6, atol=1e-6 * float(sigma.max()))
    np.testing.assert_allclose(got[..., 1:], ref[..., 1:], rtol=0, atol=2e-6)


def test_channel_function_equals_the_array_and_grey_copies():
    rng = np.random.default_rng(22)
    sigma = (rng.random((10, 9, 8)) * 3).astype(np.float32)
    albedo = rng.random((10, 9, 8, 3)).astype(np.float32)
    whole = ball_grid(sigma, albedo, 1.0, 2.2)
    calls = []

    def channel(c):
        calls.append(c)
        return albedo[..., c]

    by_channel = ball_grid(sigma, channel, 1.0, 2.2, same_as_previous=(False, False, False))
    assert np.array_equal(whole, by_channel) and calls == [0, 1, 2]
    grey = np.repeat(albedo[..., :1], 3, axis=-1)
    calls.clear()
    g = ball_grid(sigma, channel, 1.0, 2.2, same_as_previous=(False, True, True))
    assert calls == [0] and np.array_equal(g[..., 1], g[..., 2]) and np.array_equal(g[..., 1], g[..., 3])
    np.testing.assert_array_equal(g, ball_grid(sigma, grey, 1.0, 2.2))


def test_optics_albedo_channel_and_grey_flags():
    import pyvista as pv

    from pv_ambient.inputs.transfer import MODE_GRID, MODE_LUT
    from tests.helpers import physical_grid

    physical = pa.Renderer(physical_grid(albedo=(0.9, 0.6, 0.6)), transfer_function=pa.TransferFunction.physical())
    g = pv.ImageData(dimensions=(6, 5, 4))
    g["d"] = np.linspace(0, 1, g.n_points).astype(np.float32)
    table = pa.Renderer(g, transfer_function=pa.TransferFunction(clim=(0, 1)))
    for r, mode in ((physical, MODE_GRID), (table, MODE_LUT)):
        optics = r.optics
        assert optics.mode == mode
        alb = optics.albedo_grid()
        for c in range(3):
            assert np.array_equal(optics.albedo_channel(c), alb[..., c])
        assert optics.albedo_same_as_previous() == (False,) + tuple(
            bool(np.array_equal(alb[..., c], alb[..., c - 1])) for c in (1, 2))
    assert physical.optics.albedo_same_as_previous() == (False, False, True)
