"""Tests pv_ambient/rendering/camera_pass.py's baked in-scattering (docs/models.rst, "Baked
in-scattering"; the sums in pv_ambient/stages/bake.py): for an isotropic phase function the light
scattered toward the camera does not depend on the view, so the quality presets ``preview`` and
``balanced`` bake it on the light grid once per light change. Checked here: the baked nodes against an
independent NumPy evaluation, baked renders against the per-sample ones, relights, and when baking
applies. Its error against the path-traced reference: ``benchmarks/baked.py``."""

import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient.inputs.lights import DirectionalLight, PointLight
from pv_ambient.rendering import presets

from ..helpers import CAM, SIZE, physical_grid

LIGHTS = [PointLight((0.3, -1.6, 0.9), intensity=(3.0, 2.5, 2.0)), DirectionalLight((0.2, 0.3, -1.0), irradiance=0.5)]


def renderer(grid=None, lights=LIGHTS):
    return pa.Renderer(physical_grid() if grid is None else grid, transfer_function=pa.TransferFunction.physical(),
                       lights=lights)


def render(r, model, bake, **kw):
    kw.setdefault("quality", "balanced")
    saved = presets.QUALITY_PRESETS[kw["quality"]]["bake_lights"]
    presets.QUALITY_PRESETS[kw["quality"]]["bake_lights"] = bake
    try:
        res = r.render(camera=CAM, window_size=SIZE, model=model, **kw)
    finally:
        presets.QUALITY_PRESETS[kw["quality"]]["bake_lights"] = saved
    assert res.metadata["baked_lights"] == bake
    return res


def test_baked_nodes_equal_independent_numpy_sum():
    # per point light I e^{−τ} / 4π (the ray cast divides by max(d², d2min) at the sample), and the
    # directional lights' E e^{−τ} / 4π in the last slot; τ the cached optical depths
    r = renderer()
    render(r, "single_scattering", True)
    (key, (inc, nch)), = r.cache.items("incident")
    grid = r.stages.light_grid()
    assert nch == 3 and inc.shape == tuple(grid.shape) + (6,)  # coloured point light: three channels
    expect = np.zeros(inc.shape)
    for slot, lt in enumerate(LIGHTS):
        T = np.exp(-r.cache[("tau", lt, grid.key())].astype(np.float64))[..., None]
        power = np.asarray(lt.intensity if isinstance(lt, PointLight) else lt.irradiance, np.float64)
        expect[..., 3 * slot:3 * slot + 3] = power * T / (4 * np.pi)
    assert np.abs(inc - expect).max() <= 1e-6 * expect.max()


def test_baked_lookup_divides_by_distance_squared():
    # one point light in a homogeneous, thin medium: the baked lookup at a sample equals
    # I e^{−τ}/(4π d²) with τ interpolated — against the exact per-sample evaluation at points
    # between nodes, near and far from the light
    from pv_ambient._kernels import records as K
    from pv_ambient._kernels.baked import baked_light
    from pv_ambient._kernels.raycast import direct_light

    grid_data = physical_grid(n=9, sigma=0.5, noise=False)
    light = PointLight((0.1, 0.05, -0.1), intensity=2.0)
    r = renderer(grid_data, lights=[light])
    res = render(r, "single_scattering", True)
    (key, (inc, nch)), = r.cache.items("incident")
    grid = r.stages.light_grid()
    tau = r.cache[("tau", light, grid.key())][..., None]
    lrec = K.lights_of((np.zeros(1, np.int64), np.array([light.position], float), np.array([light.intensity], float)),
                       pa.inputs.phase.as_phase(0.0), (0.25 * res.metadata["step"]) ** 2)
    exact = K.LightGrid(grid.lo, grid.inv_step, tau, tau, K.NONE4, 0)
    baked = K.LightGrid(grid.lo, grid.inv_step, tau, tau, inc, nch)
    m = r.geometry.index_to_world
    rng = np.random.default_rng(2)
    worst = 0.0
    for x, y, z in rng.random((200, 3)) * 8:
        w = m[:3, :3] @ (x, y, z) + m[:3, 3]
        a = baked_light(x, y, z, *w, lrec, baked)[0]
        b = direct_light(x, y, z, *w, 0.0, 0.0, 1.0, lrec, exact)[0]
        worst = max(worst, abs(a / b - 1.0))
    # only e^{−τ} interpolated vs τ interpolated then exponentiated; measured 0.00078
    assert worst <= 0.003


def test_grey_lights_bake_one_channel():
    r = renderer(lights=[PointLight((0.3, -1.6, 0.9), intensity=2.0), DirectionalLight((0.0, 0.0, -1.0))])
    render(r, "ambient_scattering", True)
    (key, (inc, nch)), = r.cache.items("incident")
    assert nch == 1 and inc.shape[3] == 2  # the point light's slot and the directional one


@pytest.mark.parametrize("model,opts,bound", [
    # relative RMSE measured on this scene (17³, 24×20): 0.0015, 0.00076, 0.00076, 0.0010 (the
    # baked I·T interpolated between nodes against τ interpolated and exponentiated at each
    # sample); mean +0.09 %, +0.04 %, +0.04 %, +0.06 %
    ("single_scattering", {}, 0.005),
    ("ambient_scattering", {}, 0.005),
    ("ambient_scattering", {"propagation": "tube"}, 0.005),
    ("diffusion", {}, 0.005),
])
def test_baked_render_close_to_per_sample(model, opts, bound):
    r = renderer()
    exact = render(r, model, False, **opts).radiance.astype(np.float64)
    baked = render(r, model, True, **opts).radiance.astype(np.float64)
    assert exact.max() > 0
    err = np.sqrt(np.mean((baked - exact) ** 2)) / np.mean(exact)
    assert err <= bound
    assert abs(baked.mean() / exact.mean() - 1.0) <= 0.002  # no bias beyond 0.2 % of the mean


def test_relight_rebakes():
    # a relight must not read the old lights' baked in-scattering: equal to a fresh renderer
    r = renderer()
    render(r, "ambient_scattering", True)
    moved = [PointLight((-0.4, -1.5, 0.7), intensity=(3.0, 2.5, 2.0)), LIGHTS[1]]
    r.set_lights(moved)
    again = render(r, "ambient_scattering", True).radiance
    fresh = render(renderer(lights=moved), "ambient_scattering", True).radiance
    assert np.array_equal(again, fresh)


def test_when_baking_applies():
    r = renderer()
    kw = dict(camera=CAM, window_size=SIZE)
    assert r.render(model="single_scattering", **kw).metadata["baked_lights"]
    assert r.render(model="ambient_scattering", quality="preview", **kw).metadata["baked_lights"]
    assert not r.render(model="single_scattering", quality="accurate", **kw).metadata["baked_lights"]
    assert not r.render(model="single_scattering", phase=0.5, **kw).metadata["baked_lights"]  # anisotropic
    assert not r.render(model="emission_absorption", **kw).metadata["baked_lights"]
    with pytest.warns(UserWarning, match="rendered black"):  # no lights: nothing to bake
        assert not renderer(lights=()).render(model="single_scattering", **kw).metadata["baked_lights"]
    # the default light rig (no lights given): directional, isotropic phase, baked
    assert pa.Renderer(physical_grid(), transfer_function=pa.TransferFunction.physical()).render(
        model="single_scattering", **kw).metadata["baked_lights"]


GREY_LIGHTS = [PointLight((0.3, -1.6, 0.9), intensity=3.0), DirectionalLight((0.2, 0.3, -1.0), irradiance=0.5)]


@pytest.mark.parametrize("albedo, lights", [(0.9, LIGHTS), ((0.9, 0.6, 0.3), GREY_LIGHTS)],
                         ids=["grey albedo, coloured lights", "coloured albedo, grey lights"])
def test_diffusion_folded_into_the_bake_equals_its_per_sample_lookup(monkeypatch, albedo, lights):
    # light grid = data samples: diffusion's φ/4π joins the baked slot (the march is then single
    # scattering's); trilinear interpolation is linear, so the image equals reading φ per sample
    # on top of the baked direct light, up to float32 rounding. With grey lights and a coloured
    # albedo the direct light is grey but φ is not: the bake must keep three channels
    from pv_ambient.stages.propagation import LightGrid

    r = renderer(physical_grid(sigma=1.5, albedo=albedo), lights)  # optically thin: light grid = data grid
    assert r.stages.light_grid().on_samples(r.optics.field.shape)
    folded = render(r, "diffusion", True).radiance.astype(np.float64)
    monkeypatch.setattr(LightGrid, "on_samples", lambda self, shape: False)
    separate = render(renderer(physical_grid(sigma=1.5, albedo=albedo), lights), "diffusion", True)
    separate = separate.radiance.astype(np.float64)
    assert folded.max() > 0
    assert np.abs(folded - separate).max() <= 1e-5 * separate.max()


def test_relight_rebakes_only_the_moved_light():
    # two point lights and a directional one, one point light moved: the other point light's slot
    # is copied from the previous bake (not baked again), and the image equals a fresh renderer's
    from pv_ambient._kernels import bake as kernels
    from pv_ambient._kernels import bake_rows as row_kernels

    still = PointLight((-0.2, 0.15, 0.1), intensity=0.7)
    lights = [PointLight((0.05, 0.0, -0.1), intensity=(1.0, 0.8, 0.6)), still, LIGHTS[1]]
    r = renderer(lights=lights)
    render(r, "ambient_scattering", True)
    moved = [PointLight((0.1, -0.05, -0.1), intensity=(1.0, 0.8, 0.6)), still, LIGHTS[1]]
    r.set_lights(moved)
    calls = []
    bake, bake_rows = kernels.bake_incident, row_kernels.bake_rows

    def counting(model, lrec, *args):  # either driver (pv_ambient.stages.bake.rows_apply)
        calls.append(tuple(np.asarray(lrec.vec[0]).tolist()))
        return (bake_rows if len(args) > 11 else bake)(model, lrec, *args)

    kernels.bake_incident = row_kernels.bake_rows = counting
    try:
        again = render(r, "ambient_scattering", True).radiance
    finally:
        kernels.bake_incident, row_kernels.bake_rows = bake, bake_rows
    assert calls == [moved[0].position, tuple(np.asarray(LIGHTS[1].direction).tolist())]  # not `still`
    (key, (inc, nch)), = r.cache.items("incident")
    assert inc.shape[3] == 3 * nch
    fresh = render(renderer(lights=moved), "ambient_scattering", True).radiance
    assert np.array_equal(again, fresh)
