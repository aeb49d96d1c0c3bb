"""The checked request of one render (pv_ambient/rendering/request.py): every argument checked
once, before any work — optional packages included — and decided in one place."""
import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient import datasets
from pv_ambient.rendering.presets import QUALITY_PRESETS, light_resolution_for
from pv_ambient.rendering.request import resolve_radius
from pv_ambient.stages.propagation import default_factor

CAM = pa.Camera((0, -4, 0.5), (0, 0, 0), (0, 0, 1), view_angle=35)


@pytest.fixture
def no_pyoidn_and_no_work(monkeypatch):
    """pyoidn missing, and every way a render starts work (a kernel launch, path samples, a light
    volume, a classification) an error: the request must fail first."""
    import sys

    from pv_ambient import backend
    from pv_ambient.rendering.scene_stages import SceneStages
    from pv_ambient.stages import denoise, reference

    monkeypatch.setattr(denoise, "available", lambda: False)
    monkeypatch.setitem(sys.modules, "pyoidn", None)  # import pyoidn → ImportError

    def work(*a, **k):
        raise AssertionError("work started before the request was checked")

    monkeypatch.setattr(backend, "run_raycast", work)
    monkeypatch.setattr(reference, "path_trace", work)
    monkeypatch.setattr(SceneStages, "optical_depth", work)
    monkeypatch.setattr(SceneStages, "light_grid", work)


@pytest.mark.parametrize("model, options", [
    ("progressive", {"samples_per_pixel": 32}),
    ("progressive", {"samples_per_pixel": 0}),
    ("path_traced", {"samples_per_pixel": 2}),
    ("auto", {"time_budget": 0.5}),
])
def test_denoise_without_pyoidn_fails_before_any_work(no_pyoidn_and_no_work, model, options):
    """Why: ``denoise=True`` without pyoidn rendered the whole base picture of ``progressive``
    first, then failed. The ImportError names the extra, before a light volume or a kernel."""
    r = pa.Renderer(datasets.cloud(n=12), lights=[pa.PointLight((0, 0, 2), 3.0)])
    with pytest.raises(ImportError, match=r"pv_ambient\[denoise\]"):
        r.render(camera=CAM, window_size=(8, 6), model=model, denoise=True, **options)


def test_unbiased_and_denoise_together_fail_before_any_work(no_pyoidn_and_no_work):
    r = pa.Renderer(datasets.cloud(n=12), lights=[pa.PointLight((0, 0, 2), 3.0)])
    with pytest.raises(ValueError, match="give one of them"):
        r.render(camera=CAM, window_size=(8, 6), model="progressive", unbiased=True, denoise=True)


def test_request_takes_renders_keywords_and_defaults():
    """``Renderer.request`` checks exactly :meth:`Renderer.render`'s keywords (written once): the
    same defaults, an unknown keyword a TypeError naming the model options."""
    r = pa.Renderer(datasets.cloud(n=12))
    req = r.request(camera=CAM, window_size=(8, 6))
    assert req.model == "emission_absorption" and req.quality == "balanced" and req.seed == 0
    assert req.step == pytest.approx(0.5 * min(r.geometry.spacing))
    with pytest.raises(TypeError, match="model options are"):
        r.request(camera=CAM, window_size=(8, 6), flux_limit=True)


@pytest.mark.parametrize("quality", list(QUALITY_PRESETS))
def test_light_resolution_is_decided_in_one_place(quality):
    """The request's light-grid factor is the preset's (accurate: never below the default), the
    default of docs/ambient_scattering.rst §3 where the preset has none; the stage's default grid
    is the same one."""
    dense = pa.TransferFunction(cmap="bone", opacity="linear", density_scale=200.0)
    r = pa.Renderer(datasets.cloud(n=12), transfer_function=dense)
    d = default_factor(r.optics, r.geometry)
    assert d == 2.0  # σt·h > 0.3: the default refines
    preset = QUALITY_PRESETS[quality]["light_resolution"]
    expect = d if preset is None else (max(preset, d) if quality == "accurate" else preset)
    req = r.request(camera=CAM, window_size=(8, 6), quality=quality)
    assert req.light_resolution == expect == light_resolution_for(r.optics, r.geometry, quality)
    assert r.request(camera=CAM, window_size=(8, 6), quality=quality, light_resolution=3.0).light_resolution == 3.0
    assert r.stages.light_grid().factor == d


def test_radius_in_voxels_world_units_and_errors():
    spacing = np.array([0.5, 0.25, 1.0])
    assert resolve_radius("3 voxels", "ambient_scattering", spacing) == 3.0
    assert resolve_radius(None, "ambient_scattering", spacing) == 8.0  # the model table's 8 voxels
    assert resolve_radius(None, "ambient_occlusion", spacing) == 4.0
    assert resolve_radius(0.7, "ambient_scattering", spacing) == 0.7
    with pytest.raises(ValueError, match="radius must be a number"):
        resolve_radius("3 cm", "ambient_scattering", spacing)
    with pytest.raises(ValueError, match="radius"):
        resolve_radius(-1.0, "ambient_scattering", spacing)
