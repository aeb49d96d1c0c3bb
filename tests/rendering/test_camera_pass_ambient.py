"""Ambient occlusion and ambient scattering (docs/ambient_scattering.rst §4, §5): consistency with the models they
reduce to, caching, the ``auto`` rules. Accuracy against the path-traced reference is measured by
``benchmarks/trade.py`` (a benchmark, not a test)."""

import numpy as np
import pytest

from pv_ambient.inputs.camera import Camera
from pv_ambient.inputs.phase import as_phase
from pv_ambient.inputs.lights import DirectionalLight, PointLight
from pv_ambient.rendering.presets import AUTO_SWEEP_ORDERS
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


def test_camera_move_and_relight_reuse_caches():
    r = renderer(physical_grid())
    render(r, "ambient_scattering", propagation="tube")
    keys = set(r.cache)
    cam2 = Camera((1.0, -3.5, 0.5), (0, 0, 0), (0, 0, 1), view_angle=35)
    r.render(camera=cam2, window_size=SIZE, model="ambient_scattering", quality="preview", propagation="tube")
    assert set(r.cache) == keys  # a camera move computes nothing but the ray cast
    moved = PointLight((-0.3, -1.6, 0.9), intensity=(3.0, 2.5, 2.0))
    r.set_lights([moved, LIGHTS[1]])
    render(r, "ambient_scattering", propagation="tube")
    new = set(r.cache) - keys
    # only the moved light's volumes are computed, and the entries of the new set of lights — the
    # baked in-scattering (isotropic phase), the light volumes side by side — which replace the old set's
    per_set = ("incident", "tau_stack", "front_stack")
    assert new and all(moved in (k[1] if k[0] in per_set else k) for k in new)
    for kind in per_set:
        assert sum(k[0] == kind for k in new) == 1 and sum(k[0] == kind for k in r.cache) == 1


def test_auto_rules():
    # albedo 0 everywhere: no scattering, no light volume is built
    r = renderer(physical_grid(albedo=0.0, emission=(0.2, 0.2, 0.2)))
    res = r.render(camera=CAM, window_size=SIZE, model="auto")
    assert res.metadata["model"] == "single_scattering" and res.metadata["lights"] == 0
    assert not any(k[0] == "tau" for k in r.cache)
    # lights with zero intensity or behind an opaque wall are skipped
    grid = physical_grid(n=9, albedo=0.8, noise=False)
    dark = PointLight((0, -1.5, 0), intensity=0.0)
    r = renderer(grid, lights=[dark])
    with pytest.warns(UserWarning, match="none of the 1 lights reaches the volume"):
        res = r.render(camera=CAM, window_size=SIZE, model="auto")
    assert res.metadata["model"] == "single_scattering" and res.metadata["lights"] == 0
    # an opaque, non-scattering sheet between the light and the only scattering medium
    wall = physical_grid(n=9, sigma=0.0, albedo=0.8)
    s = np.zeros((9, 9, 9), np.float32)
    a = np.full((9, 9, 9), 0.8, np.float32)
    s[:, :, 4] = 1e6  # the sheet at z = 0, black (albedo 0)
    a[:, :, 4] = 0.0
    s[:, :, :4] = 0.5  # scattering medium below it
    wall["sigma_t"] = s.ravel(order="F")
    wall["albedo"] = np.repeat(a.ravel(order="F")[:, None], 3, axis=1)
    above = PointLight((0, 0, 0.9), intensity=1.0)
    below = DirectionalLight((0, 0, 1.0))  # propagates +z: enters through the bottom face
    r = renderer(wall, lights=[above, below])
    assert r.stages.active_lights(r.lights, r.stages.light_grid()) == (below,)
    res = r.render(camera=CAM, window_size=SIZE, model="single_scattering")
    assert res.metadata["lights"] == 1
    # with scattering and a light: ambient scattering; g = 0 uses a 1D table slice
    r = renderer(physical_grid())
    res = r.render(camera=CAM, window_size=SIZE, model="auto", quality="preview")
    assert res.metadata["model"] == "ambient_scattering"
    tab = [v for k, v in r.cache.items() if k[0] == "table"][0]
    assert tab.D.shape[2] == 1
    # "accurate" asks for the measured most accurate noise-free model: the first scattering
    # orders by transport sweeps, flux-limited diffusion for the rest
    res = r.render(camera=CAM, window_size=SIZE, model="auto", quality="accurate")
    assert res.metadata["model"] == "diffusion"
    assert res.metadata["flux_limited"] is True and res.metadata["sweep_orders"] == AUTO_SWEEP_ORDERS
    assert any(k[0] == "diffusion" and k[4] is True and k[5] == AUTO_SWEEP_ORDERS for k in r.cache)
    # the default ("balanced"): plain diffusion, lower error than ambient scattering on every
    # trade scene at a similar camera-move cost
    res = r.render(camera=CAM, window_size=SIZE, model="auto")
    assert res.metadata["model"] == "diffusion" and res.metadata["flux_limited"] is False
    assert res.metadata["sweep_orders"] == 0
    assert any(k[0] == "diffusion" and k[-1] is False for k in r.cache)


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


def test_three_albedo_lookup_equals_single_lookups():
    from pv_ambient._kernels.preint import d_lookup, tau_coord
    from pv_ambient._kernels.raycast import d_lookup3
    from pv_ambient.stages.preintegration import get_table

    rng = np.random.default_rng(1)
    for g in (0.0, 0.6):
        tab = get_table(g, (0.3, 1.0), quality="preview")
        D, _, a_nodes, lo, dl = tab.lookup_args()
        for _ in range(200):
            c, tau = rng.uniform(-1, 1), rng.choice([0.0, 1e-4, rng.uniform(0, 60)])
            a = rng.uniform(0.2, 1.0, 3)
            a[rng.integers(3)] = a[0]  # equal channels take the shortcut
            it, tt = tau_coord(D.shape[1], lo, dl, tau)
            got = d_lookup3(D, a_nodes, it, tt, c, a[0], a[1], a[2])
            want = [d_lookup(D, a_nodes, lo, dl, c, tau, ac) for ac in a]
            np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-12)
