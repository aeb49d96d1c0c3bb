"""Tests pv_ambient/rendering/renderer.py: the Renderer and render() — ``auto`` decided in one place,
the docstrings that list every model and option, lights set and placed, steps of the presets."""
import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient.inputs.lights import DirectionalLight, PointLight
from pv_ambient.rendering.presets import AUTO_SWEEP_ORDERS

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
