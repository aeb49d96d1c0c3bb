"""Tests pv_ambient/rendering/renderer.py: the Renderer and render() — ``auto`` decided in one place,
the docstrings that list every model and option, lights set and placed, steps of the presets."""
import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient import datasets
from pv_ambient.inputs.lights import DirectionalLight, PointLight
from pv_ambient.rendering import renderer as renderer_module
from pv_ambient.rendering.presets import AUTO_SWEEP_ORDERS, BALANCED_DIFFUSION, BALANCED_SWEEP_ORDERS

from ..helpers import CAM, SIZE, physical_grid, renderer


def test_render_docstrings_list_every_model_and_option():
    """Why: ``help(pa.render)`` listed neither models nor options; ``Renderer.render`` omitted diffusion."""
    from pv_ambient.rendering.presets import ALL_MODELS, MODEL_OPTIONS

    for doc in (pa.render.__doc__, pa.Renderer.render.__doc__):
        for name in ALL_MODELS:
            assert f'"{name}"' in doc, name
        for option in sorted(MODEL_OPTIONS | {"radius", "ambient_radiance", "phase", "light_resolution"}):
            assert option in doc, option
        assert "DESIGN" not in doc


def test_auto_rules(monkeypatch):
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
    # the default ("balanced"): on a volume of at most BALANCED_SWEEP_SAMPLES samples the first
    # BALANCED_SWEEP_ORDERS orders by sweeps and flux limiting (they fit in the budget there)...
    res = r.render(camera=CAM, window_size=SIZE, model="auto")
    assert res.metadata["model"] == "diffusion" and res.metadata["flux_limited"] is True
    assert res.metadata["sweep_orders"] == BALANCED_SWEEP_ORDERS == 4
    # ... and on a larger one plain diffusion, lower error than ambient scattering on every trade
    # scene at a similar camera-move cost
    monkeypatch.setattr(renderer_module, "BALANCED_SWEEP_SAMPLES", int(np.prod(r.geometry.shape)) - 1)
    res = r.render(camera=CAM, window_size=SIZE, model="auto")
    assert res.metadata["model"] == "diffusion" and res.metadata["flux_limited"] is False
    assert res.metadata["sweep_orders"] == 0
    assert any(k[0] == "diffusion" and k[4] is False for k in r.cache)


def test_choose_model_decides_auto_and_leaves_other_models_alone():
    """``Renderer.choose_model``, the one place ``auto`` is decided, asked directly with a request."""
    from pv_ambient.rendering.renderer import ACCURATE_DIFFUSION, BUDGET_MAX_SPP

    r = pa.Renderer(datasets.cloud(n=12), lights=[pa.PointLight((0, 0, 2), 3.0)])
    cam = pa.Camera((0, -4, 0.5), (0, 0, 0), (0, 0, 1), view_angle=35)

    def choose(**kw):
        return r.choose_model(r.request(camera=cam, window_size=(8, 6), **kw))

    assert choose(model="ambient_occlusion") == ("ambient_occlusion", {})
    assert not r.cache.kinds()  # a model given by name asks for no stage
    assert choose(model="auto", quality="preview") == ("ambient_scattering", {})
    assert choose(model="auto", quality="accurate") == ("diffusion", ACCURATE_DIFFUSION)
    assert ACCURATE_DIFFUSION == {"flux_limited": True, "sweep_orders": 8}
    assert choose(model="auto") == ("diffusion", BALANCED_DIFFUSION)  # 12³: within BALANCED_SWEEP_SAMPLES
    assert choose(model="auto", sweep_orders=2) == ("diffusion", {"flux_limited": True, "sweep_orders": 2})
    assert choose(model="auto", time_budget=0.5, denoise=False) == (
        "path_traced", {"time_limit": 0.5, "denoise": False, "samples_per_pixel": BUDGET_MAX_SPP})
    assert choose(model="auto", time_budget=0.5, denoise=False, samples_per_pixel=8) == (
        "path_traced", {"time_limit": 0.5, "denoise": False})  # samples given: kept
    dark = pa.Renderer(datasets.cloud(n=12), lights=())
    assert dark.choose_model(dark.request(camera=cam, window_size=(8, 6), model="auto", time_budget=0.5)) == (
        "single_scattering", {})
    off = pa.Renderer(datasets.cloud(n=12), lights=[pa.PointLight((0, 0, 2), 0.0)])  # no power: rule 3
    assert off.choose_model(off.request(camera=cam, window_size=(8, 6), model="auto", time_budget=0.5))[0] == (
        "single_scattering")
    # with a budget no light volume is swept to choose (a light behind an opaque wall is left to
    # the path tracer's shadow rays); without one, the choice sweeps each light once
    fresh = pa.Renderer(datasets.cloud(n=12), lights=[pa.PointLight((0, 0, 2), 3.0)])
    assert fresh.choose_model(fresh.request(camera=cam, window_size=(8, 6), model="auto", time_budget=0.5))[0] == (
        "path_traced")
    assert "tau" not in fresh.cache.kinds()
    fresh.choose_model(fresh.request(camera=cam, window_size=(8, 6), model="auto"))
    assert "tau" in fresh.cache.kinds()


def test_default_step_is_the_presets_fraction_of_the_finest_spacing():
    r = pa.Renderer(datasets.cloud(n=12))  # spacing 2/11
    h = float(np.min(r.geometry.spacing))
    assert r.default_step("preview") == pytest.approx(h)
    assert r.default_step() == pytest.approx(0.5 * h) and r.default_step("accurate") == pytest.approx(0.25 * h)
    assert r.light_rig == "default" and r.lights == ()  # placed at the first lit render (tests/inputs/test_lights.py)
    r.set_lights([pa.PointLight((0, 0, 2), 3.0)])
    assert r.light_rig == "given" and r.place_lights(pa.Camera((0, -4, 0), (0, 0, 0), (0, 0, 1))) == r.lights
