"""Tests pv_ambient/rendering/camera_pass.py, the ``diffusion`` model (docs/diffusion.rst): exact single
scattering plus the multiply-scattered light of the diffusion solve; its limits, its vacuum floor and
the fluence-only layout."""

import math

import numpy as np
import pytest

from pv_ambient.inputs.lights import PointLight
from ..helpers import CAM, physical_grid, rel, render, renderer


def test_albedo_zero_is_single_scattering():
    r = renderer(physical_grid(albedo=0.0, emission=(0.5, 0.3, 0.1)))
    assert rel(render(r, "diffusion"), render(r, "single_scattering")) == 0.0


def test_no_lights_is_black():
    with pytest.warns(UserWarning, match=r"rendered black: no lights were given"):  # since 0.3.0
        out = render(renderer(physical_grid(), lights=()), "diffusion")
    assert np.all(out == 0)


def test_multiple_scattering_is_second_order_in_albedo():
    ratios = []
    for a in (0.2, 0.05, 0.01):
        r = renderer(physical_grid(sigma=4.0, albedo=a, noise=False))
        ss = render(r, "single_scattering")
        d = render(r, "diffusion")
        assert np.all(d >= ss - 1e-9)
        ratios.append((d - ss).sum() / ss.sum())  # multiply- over single-scattered: O(albedo)
    # single scattering is O(a), the diffusion part O(a²): the ratio falls ~4× and ~5× here
    assert ratios[0] > 3.0 * ratios[1] > 0 and ratios[1] > 4.0 * ratios[2] > 0


def test_vacuum_floor_against_path_tracing(monkeypatch):
    """A hollow scattering shell (σt ≤ 12, albedo 0.9) lit from inside, off centre: the fluence
    scattered off the shell's lit side crosses the empty interior in straight lines. With the
    default floor (empty space has the box's mean chord as transport length) the diffusion image
    is much closer to converged path tracing than with a near-perfect conductor (the earlier floor
    0.01/diagonal), which spreads the light over the whole cavity and darkens the lit side.
    Measured (24³, 32², reference 2048 spp, 4×4-block noise 0.025): block error 0.177 (bias
    −9 %) against 0.387 (−19 %); single scattering 1.52."""
    import pyvista as pv

    import pv_ambient as pa
    from pv_ambient.stages import diffusion as dm
    from pv_ambient.stages.diffusion import solve as dsolve
    from pv_ambient import metrics

    n = 24
    g = pv.ImageData(dimensions=(n, n, n), spacing=(2 / (n - 1),) * 3, origin=(-1, -1, -1))
    rad = np.linalg.norm(g.points, axis=1)
    g["sigma_t"] = (12.0 * np.exp(-(((rad - 0.7) / 0.12) ** 2))).astype(np.float32)
    g["albedo"] = np.full((g.n_points, 3), 0.9, np.float32)
    g["emission"] = np.zeros((g.n_points, 3), np.float32)
    lights = [PointLight((0.0, 0.0, 0.35), intensity=1.0)]
    cam = pa.Camera((0, -4, 0.8), (0, 0, 0), (0, 0, 1), view_angle=35)
    size = (32, 32)

    def make():
        return pa.Renderer(g, transfer_function=pa.TransferFunction.physical(), lights=lights)

    ref = make().render(camera=cam, window_size=size, model="path_traced", samples_per_pixel=2048, seed=7)
    mask = metrics.light_mask(size[::-1], cam, size, lights)
    noise = np.sqrt(np.mean(ref.std_error[mask] ** 2) / 16) / np.mean(ref.radiance[mask])
    assert noise < 0.03
    err = {}
    for name, rel in (("default", dsolve.SIGMA_FLOOR_REL), ("conductor", 0.01 * dm.mean_chord((n,) * 3, (2 / (n - 1),) * 3)
                                                      / (2 * math.sqrt(3)))):
        monkeypatch.setattr(dsolve, "SIGMA_FLOOR_REL", rel)
        img = make().render(camera=cam, window_size=size, model="diffusion", quality="preview").radiance
        err[name] = (metrics.block_relative_rmse(img, ref.radiance, mask), metrics.relative_bias(img, ref.radiance, mask))
    assert err["default"][0] < 0.25 and abs(err["default"][1]) < 0.15, err
    assert err["conductor"][0] > err["default"][0] + 0.1, err


def test_flux_limited_converges_with_a_light_inside():
    """A point light at the centre of a small medium (tests/acceptance/test_extremes.py's scale scene): the
    limiter's lagged passes need more than the earlier default of 10 there (which warned); with
    the default of 20 they converge without a warning."""
    import warnings

    from ..helpers import scaled_scene

    from pv_ambient.stages import diffusion as dm

    r, cam, g, options = scaled_scene("outside", 1.0)
    inside = r.lights[0]
    grid = r.stages.light_grid()
    args = dict(medium=dm.DiffusionMedium.from_arrays(r.optics.sigma_grid(), r.optics.albedo_grid()),
                geometry=r.geometry, tau=r.stages.optical_depth(inside, grid), light_grid=grid)
    with pytest.warns(UserWarning, match="did not converge"):
        dm.solve_for_light(inside, 0.6, **args, flux_limited=True, max_outer=10)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sol = dm.solve_for_light(inside, 0.6, **args, flux_limited=True)
    assert sol.converged


def test_isotropic_phase_keeps_the_fluence_alone_and_renders_the_same():
    """Why: with mean cosine 0 the flux term of the radiance vanishes, so the renderer keeps φ alone
    (a quarter of the memory the march reads). The kernel must read the φ-only layout as it reads φ
    in the full one — bit for bit, coloured and grey — and keep the full layout for g ≠ 0."""
    from pv_ambient._kernels.raycast import diffusion_light

    rng = np.random.default_rng(3)
    full = rng.uniform(-0.2, 2.0, (5, 6, 7, 12)).astype(np.float32)
    for packed in (full, np.ascontiguousarray(full[..., 0:4])):  # coloured, grey
        phi = np.ascontiguousarray(packed[..., 0::4])
        for x, y, z in rng.uniform(-0.5, 6.5, (50, 3)):
            d = rng.normal(size=3)
            d /= np.linalg.norm(d)
            want = diffusion_light(packed, x, y, z, *d, 0.0)
            assert diffusion_light(phi, x, y, z, *d, 0.0) == want
    r = renderer(physical_grid())
    iso = render(r, "diffusion")
    shapes = {r.cache[k][0].shape[3] for k in r.cache if k[0] == "diffusion"}
    assert shapes <= {1, 3} and shapes
    assert iso.max() > 0
    render(r, "diffusion", phase=0.5)
    assert {r.cache[k][0].shape[3] for k in r.cache if k[0] == "diffusion" and k[3] == 0.5} <= {4, 12}


def test_each_quality_solves_to_its_own_tolerance(monkeypatch):
    """Why: the quality preset sets the relative residual at which the diffusion solve stops
    (``diffusion_tol``, docs/diffusion.rst "Solver tolerance"). Each render reports a residual
    within its preset's tolerance, a looser one stops after fewer iterations, and the balanced
    preset's picture stays within 1e-4 (4×4-block error) of the one solved to 1e-6."""
    from pv_ambient import metrics
    from pv_ambient.rendering.presets import QUALITY_PRESETS

    grid = physical_grid(n=21)
    its = {}
    for quality in ("accurate", "balanced", "preview"):
        res = renderer(grid).render(camera=CAM, window_size=(24, 24), model="diffusion", quality=quality,
                                    light_resolution=1.0, step=0.05)
        info = res.metadata["diffusion_solver"]
        assert info["converged"] and info["residual"] <= QUALITY_PRESETS[quality]["diffusion_tol"]
        its[quality] = info["iterations"]
        if quality == "balanced":
            balanced = res.radiance.astype(np.float64)
    assert its["preview"] < its["balanced"] < its["accurate"]
    monkeypatch.setitem(QUALITY_PRESETS["balanced"], "diffusion_tol", 1e-6)
    tight = renderer(grid).render(camera=CAM, window_size=(24, 24), model="diffusion", quality="balanced",
                                  light_resolution=1.0, step=0.05)
    assert tight.metadata["diffusion_solver"]["iterations"] > its["balanced"]
    assert metrics.block_relative_rmse(balanced, tight.radiance.astype(np.float64)) <= 1e-4


def _coarse_against_full(monkeypatch, grid, lights, opts, preset_key, marker):
    """Render ``opts`` with the preset's coarse option on (every diffusion cache key ends in
    ``marker``), then off (keys end in False): the pictures within 0.01 (4×4-block error). Returns
    the first renderer."""
    from pv_ambient import metrics
    from pv_ambient.rendering.presets import QUALITY_PRESETS

    r = renderer(grid, lights)
    coarse = r.render(**opts).radiance.astype(np.float64)
    assert all(k[-1] == marker and type(k[-1]) is type(marker) for k in r.cache.keys("diffusion"))
    monkeypatch.setitem(QUALITY_PRESETS[opts["quality"]], preset_key, False)
    r2 = renderer(grid, lights)
    full = r2.render(**opts).radiance.astype(np.float64)
    assert all(k[-1] is False for k in r2.cache.keys("diffusion"))
    assert coarse.max() > 0
    assert metrics.block_relative_rmse(coarse, full) <= 0.01
    return r


def _forward_scattering_asks(monkeypatch, r, lights, **kw):
    """What ``coarse`` the stage passes its solve for g = 0.5 (no solve run here)."""
    from pv_ambient.inputs.phase import HenyeyGreenstein

    asked = []
    monkeypatch.setattr(r.stages, "_solve", lambda *a: asked.append(a[-1]) or (np.zeros((1, 1, 1, 1), np.float32), None))
    r.stages.diffusion(lights, r.stages.light_grid(), HenyeyGreenstein(0.5), **kw)
    return asked


def test_coarse_solve_where_the_medium_is_thin(monkeypatch):
    """Why: on a large grid whose medium is thin per coarse cell, the preview and balanced presets
    solve plain diffusion of an isotropic phase function on a grid twice as coarse, with a box
    around each point light at the data resolution (docs/diffusion.rst, "Solve resolution"). The
    picture stays within 0.01 (4×4-block error) of the full-resolution solve, with a point light
    inside the medium and a directional one; forward scattering and a thick medium keep the full
    resolution."""
    from pv_ambient.inputs.lights import DirectionalLight
    from pv_ambient.stages.diffusion import coarse as dcoarse

    grid = physical_grid(n=161, sigma=3.0)  # σt·2h ≤ 0.075
    lights = [PointLight((0.1, -0.05, 0.0), intensity=(3.0, 2.5, 2.0)), DirectionalLight((0.2, 0.3, -1.0), 0.5)]
    opts = dict(camera=CAM, window_size=(32, 32), model="diffusion", quality="preview", step=0.03)
    r = _coarse_against_full(monkeypatch, grid, lights, opts, "diffusion_coarse", True)
    assert r.stages.coarse_solve()[0].shape == (81, 81, 81)
    assert _forward_scattering_asks(monkeypatch, r, lights[:1], coarse=True) == [False]
    assert any(k[-1] is False and k[3] == 0.5 for k in r.cache.keys("diffusion"))
    monkeypatch.setattr(dcoarse, "COARSE_SIGMA_H", 0.01)  # as if the medium were thick per coarse cell
    thick = renderer(grid, lights)
    assert thick.stages.coarse_solve() is None


def test_sweeps_remainder_on_the_coarse_grid(monkeypatch):
    """Why: with transport sweeps, the light scattered more often than they carry is diffused on the
    grid twice as coarse (every preset; the swept orders stay at the data resolution) where the
    grid qualifies as for the coarse plain solve (docs/diffusion.rst, "Solve resolution"; the size
    gate lowered here so that a 65³ grid qualifies). The picture stays within 0.01 (4×4-block
    error) of the full-resolution remainder with a point light inside the medium; forward
    scattering keeps the full resolution."""
    from pv_ambient.stages.diffusion import coarse as dcoarse

    monkeypatch.setattr(dcoarse, "COARSE_MIN_NODES", 1)
    grid = physical_grid(n=65, sigma=3.0)
    lights = [PointLight((0.1, -0.05, 0.0), intensity=(3.0, 2.5, 2.0))]
    opts = dict(camera=CAM, window_size=(32, 32), model="diffusion", quality="balanced", step=0.03,
                sweep_orders=2, flux_limited=True)
    r = _coarse_against_full(monkeypatch, grid, lights, opts, "sweep_remainder_coarse", "remainder")
    assert r.stages.coarse_remainder()[0].shape == (33, 33, 33)
    assert _forward_scattering_asks(monkeypatch, r, lights, sweep_orders=2, coarse_remainder=True) == [False]
