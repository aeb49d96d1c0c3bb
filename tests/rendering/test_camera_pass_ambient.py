"""Tests pv_ambient/rendering/camera_pass.py, the ambient models: ambient occlusion and ambient
scattering (docs/ambient_scattering.rst §4, §5), their consistency with the models they reduce to and
the tube propagation's front. Accuracy against the path-traced reference is measured by
``benchmarks/trade.py`` (a benchmark, not a test)."""

import numpy as np
import pytest

from pv_ambient.inputs.camera import Camera
from pv_ambient.inputs.phase import as_phase
from pv_ambient.rendering.request import resolve_radius

from ..helpers import CAM, LIGHTS, SIZE, physical_grid, rel, render, renderer


@pytest.mark.parametrize("propagation", ["beer_lambert", "tube"])
def test_radius_zero_is_single_scattering(propagation):
    r = renderer(physical_grid())
    ss = render(r, "single_scattering", phase=0.4)
    as0 = render(r, "ambient_scattering", phase=0.4, radius=0.0, propagation=propagation)
    assert ss.max() > 0
    assert rel(as0, ss) <= 1e-5


def test_albedo_zero_is_single_scattering_and_ea():
    r = renderer(physical_grid(albedo=0.0, emission=(0.5, 0.3, 0.1)))
    ss = render(r, "single_scattering")
    amb = render(r, "ambient_scattering", radius="3 voxels")
    ea = render(r, "emission_absorption")
    assert ea.max() > 0.05
    assert rel(amb, ss) <= 1e-5
    assert rel(amb, ea) <= 1e-5


def test_no_lights_no_emission_is_black():
    r = renderer(physical_grid(), lights=())
    with pytest.warns(UserWarning, match=r"rendered black: no lights were given"):  # since 0.3.0
        out = r.render(camera=CAM, window_size=SIZE, model="ambient_scattering", quality="preview")
    assert np.all(out.radiance == 0) and out.alpha.max() > 0.5


@pytest.mark.parametrize("propagation", ["beer_lambert", "tube"])
def test_multiple_scattering_adds_light(propagation):
    r = renderer(physical_grid(sigma=8.0, albedo=0.95))
    ss = render(r, "single_scattering")
    amb = render(r, "ambient_scattering", radius="4 voxels", propagation=propagation)
    assert np.all(amb >= ss - 1e-7)  # D ≥ 0 and Φ ≥ 0: the ball only adds light
    assert (amb - ss).max() > 0.05 * ss.max()


def test_optically_thin_limit_is_single_scattering():
    diffs = []
    for sigma in (1.0, 0.1, 0.01):
        r = renderer(physical_grid(sigma=sigma, noise=False))
        ss = render(r, "single_scattering")
        amb = render(r, "ambient_scattering", radius="4 voxels")
        diffs.append(np.abs(amb - ss).sum() / ss.sum())
    # multiple scattering inside the ball is O(τ): the relative excess falls ~10× per decade
    assert diffs[0] > diffs[1] > diffs[2]
    assert diffs[2] < 0.2 * diffs[1] and diffs[1] < 0.2 * diffs[0]
    assert diffs[2] < 1e-2


def test_tube_front_equals_beer_lambert_at_albedo_zero():
    grid = physical_grid(n=25, sigma=2.0, albedo=0.0, noise=False)
    grid["sigma_t"] = np.full(grid.n_points, 2.0, np.float32)
    r = renderer(grid)
    lg = r.stages.light_grid(1.0)
    radius = resolve_radius("3 voxels", "ambient_scattering", r.geometry.spacing)
    for light in LIGHTS:
        tau = r.stages.optical_depth(light, lg)
        front = r.stages.front_depth(light, lg, radius, as_phase(None), quality="preview")
        for c in range(3):
            np.testing.assert_allclose(np.exp(-front[..., c]), np.exp(-tau), rtol=1e-3, atol=0)


def test_tube_front_in_vacuum_is_one():
    grid = physical_grid(n=9, sigma=0.0)
    r = renderer(grid)
    lg = r.stages.light_grid(1.0)
    radius = resolve_radius("2 voxels", "ambient_scattering", r.geometry.spacing)
    assert np.all(r.stages.front_depth(LIGHTS[0], lg, radius, as_phase(None), quality="preview") == 0.0)


def test_ambient_occlusion_homogeneous_box():
    n = 21
    grid = physical_grid(n=n, albedo=0.5, noise=False)
    grid["sigma_t"] = np.full(grid.n_points, 1.5, np.float32)
    r = renderer(grid, lights=())
    radius = 0.3
    cam = Camera((0, -5, 0), (0, 0, 0), (0, 0, 1), parallel_projection=True, parallel_scale=1.2)
    res = r.render(camera=cam, window_size=(9, 9), model="ambient_occlusion", radius=radius, ambient_radiance=2.0,
                   step=0.01)
    # centre ray along y through the box: σ̄ equals σ where the equal-volume box lies inside
    # the grid and falls (vacuum outside) within e/2 of the faces; integrate independently.
    e = radius * (4 * np.pi / 3) ** (1 / 3)
    h = 2 / (n - 1)
    ys = np.linspace(-1, 1, 20001)
    # fraction of the box (half-edge e/2) inside the cells' extent [−1 − h/2, 1 + h/2]
    frac = (np.minimum(ys + e / 2, 1 + h / 2) - np.maximum(ys - e / 2, -1 - h / 2)) / e
    sbar = 1.5 * np.clip(frac, 0, 1)
    T = np.exp(-1.5 * (ys + 1))
    L = np.trapezoid(T * 1.5 * 0.5 * 2.0 * np.exp(-radius * sbar), ys)
    np.testing.assert_allclose(res.radiance[4, 4], L, rtol=2e-3)

