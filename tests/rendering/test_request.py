"""Tests pv_ambient/rendering/request.py, the checked request of one render: every argument checked
once, before any work — optional packages included — and decided in one place; the warnings a request
earns (unused lights and options, a black picture), the memory and thickness checks, the stage bars and
the compile notice."""
import numpy as np
import pytest
import pyvista as pv

import pv_ambient as pa
from pv_ambient import datasets
from pv_ambient.rendering.presets import QUALITY_PRESETS, light_resolution_for
from pv_ambient.rendering.request import resolve_radius
from pv_ambient.stages.denoise import available
from pv_ambient.stages.propagation import default_factor

from ..helpers import box_grid, lit_box, scene_file

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


def test_lights_empty_is_black_with_a_warning_naming_the_cause():
    grid = datasets.cloud(n=16)
    with pytest.warns(UserWarning, match=r"rendered black: no lights were given"):
        res = pa.render(grid, window_size=(16, 12), model="ambient_scattering", lights=())
    assert float(res.radiance.max()) == 0.0 and float(res.alpha.max()) > 0.5
    with pytest.warns(UserWarning, match="none of the 1 lights reaches the volume"):
        pa.render(grid, window_size=(16, 12), model="single_scattering", lights=[pa.PointLight((3, 3, 3), 0.0)])


def test_lights_given_to_a_model_that_ignores_them_warn():
    """Why: ``pa.render(grid, lights=[light])`` silently used emission–absorption and dropped the light."""
    with pytest.warns(UserWarning, match=r"1 light given but model='emission_absorption' does not use lights"):
        pa.render(datasets.cloud(n=12), window_size=(8, 8), lights=[pa.PointLight((2, 2, 2), 3.0)])


def test_options_of_another_model_warn():
    grid = datasets.cloud(n=12)
    with pytest.warns(UserWarning, match=r"samples_per_pixel not used: model='diffusion' does not use it"):
        pa.render(grid, window_size=(8, 8), model="diffusion", samples_per_pixel=64)
    with pytest.warns(UserWarning, match=r"propagation not used: model='auto' chose 'diffusion'"):
        pa.render(grid, window_size=(8, 8), model="auto", propagation="tube")


def test_window_size_that_cannot_fit_is_a_clear_error_before_any_work(tmp_path, capsys):
    """Why: ``(1e6, 1e6)`` ended in a numpy MemoryError traceback (through the CLI) after the work began."""
    import time

    from pv_ambient.cli import main

    t = time.perf_counter()
    with pytest.raises(MemoryError, match=r"window_size=\(1000000, 1000000\) needs about .* bytes\)"):
        pa.render(datasets.cloud(n=12), window_size=(10**6, 10**6), model="ambient_scattering")
    path = scene_file(tmp_path, image={"width": 10**6, "height": 10**6})
    assert main(["render", str(path), "-o", str(tmp_path / "o.png")]) == 2
    assert "window_size=(1000000, 1000000) needs about" in capsys.readouterr().err
    assert time.perf_counter() - t < 5.0


def test_2d_and_single_point_grids_are_clear_errors():
    """Why: a (32, 32, 1) grid or a single voxel rendered fully transparent, without a word."""
    import pyvista as pv

    g = pv.ImageData(dimensions=(32, 32, 1))
    g["v"] = np.ones(g.n_points, np.float32)
    with pytest.raises(ValueError, match=r"the grid is 2-D \(dimensions \(32, 32, 1\): one point along z\).*"
                                         r"dimensions \(32, 32, 2\) holding the layer twice"):
        pa.render(g, model="ambient_scattering")
    one = pv.ImageData(dimensions=(1, 1, 1))
    one["v"] = np.ones(1, np.float32)
    with pytest.raises(ValueError, match=r"single point or cell \(dimensions \(1, 1, 1\)\)"):
        pa.render(one)
    # the remedy the message names renders a slab one spacing thick
    slab = pv.ImageData(dimensions=(32, 32, 2), spacing=(1.0, 1.0, 1.0))
    slab["v"] = np.ones(slab.n_points, np.float32)
    res = pa.render(slab, window_size=(16, 16), camera="xy",
                    transfer_function=pa.TransferFunction(clim=(0, 1), density_scale=2.0, opacity=[1.0, 1.0]))
    assert float(res.alpha[8, 8]) == pytest.approx(1 - np.exp(-2.0), abs=0.02)


def test_delayed_stage_bar_appears_only_after_two_seconds(monkeypatch, capsys):
    import time

    from pv_ambient.rendering import request

    monkeypatch.delenv("PYTEST_CURRENT_TEST")
    monkeypatch.setattr(request, "PROGRESS_DELAY", 0.2)
    with request.stage_bar(None, "quick stage"):
        pass
    assert "quick stage" not in capsys.readouterr().err
    with request.stage_bar(None, "slow stage") as bar:
        time.sleep(0.8)
        bar.update()
    assert "slow stage" in capsys.readouterr().err


def test_delayed_stage_bar_with_tqdm_disabled(monkeypatch):
    """TQDM_DISABLE=1 (tqdm's own switch) gives a bar with no clock: showing it raised in the
    watcher thread, every delayed stage of the process."""
    import time

    from pv_ambient.rendering import request

    monkeypatch.setenv("TQDM_DISABLE", "1")
    bar = request._DelayedBar("stage", 1, 1e9)
    try:
        bar.show(time.monotonic())  # what the watcher does once the delay has passed
        bar.update()
    finally:
        bar.close()
    assert bar.bar is not None and bar.n == 1


def test_delayed_stage_bars_share_one_thread(monkeypatch):
    """Each delayed bar started and joined a thread of its own until 0.4.0: a camera move's three
    cached stages paid for three (docs/performance.rst, "Host work of a frame")."""
    import threading

    from pv_ambient.rendering import request

    monkeypatch.delenv("PYTEST_CURRENT_TEST")
    with request.stage_bar(None, "first stage"):
        pass
    started = []
    real = threading.Thread.start
    monkeypatch.setattr(threading.Thread, "start", lambda self: started.append(self.name) or real(self))
    for name in ("light volumes", "baked in-scattering", "ray cast"):
        with request.stage_bar(None, name) as bar:
            bar.update()
    assert started == [] and request._WATCHER.bars == []


def test_compile_notice_is_one_line_once(monkeypatch, capsys):
    """Why: the first call of each model compiled for ~9 s without a word."""
    from types import SimpleNamespace

    from pv_ambient._kernels import raycast
    from pv_ambient.rendering import request

    fresh = SimpleNamespace(signatures=[], _cache=SimpleNamespace(_cache_file=SimpleNamespace(
        _index_path="/nonexistent/raycast.nbi")))
    monkeypatch.setattr(raycast, "RAYCAST_DRIVERS", {m: fresh for m in raycast.RAYCAST_DRIVERS})
    monkeypatch.setattr(request, "_NOTICED", [])
    request.compile_notice("ambient_scattering")
    request.compile_notice("diffusion")
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("pv_ambient: compiling the rendering kernels")


def test_flat_grid_is_a_clear_error():
    """A 2-D grid rendered nothing (only the background) until 0.3.0; now an error says why and what to do."""
    g = pv.ImageData(dimensions=(5, 5, 1))
    g["d"] = np.ones(25)
    with pytest.raises(ValueError, match=r"the grid is 2-D \(dimensions \(5, 5, 1\): one point along z\), so the "
                                         r"volume has no thickness.*dimensions \(5, 5, 2\) holding the layer twice"):
        pa.render(g, window_size=(8, 8), transfer_function=pa.TransferFunction(density_scale=1.0))


def test_unknown_model_and_option():
    g = box_grid(dims=(3, 3, 3))
    with pytest.raises(ValueError, match="model must be one of"):
        pa.render(g, window_size=(4, 4), model="magic")
    with pytest.raises(TypeError, match="unknown options"):
        pa.render(g, window_size=(4, 4), stepp=0.1)


@pytest.mark.skipif(available(), reason="pyoidn is installed")
def test_missing_pyoidn_names_the_extra():
    with pytest.raises(ImportError, match=r"pv_ambient\[denoise\]"):
        lit_box().render(camera=CAM, window_size=(8, 8), model="path_traced", samples_per_pixel=2, denoise=True)


def test_denoise_flag_is_checked():
    with pytest.raises(TypeError, match="denoise must be True or False"):
        lit_box().render(camera=CAM, window_size=(8, 8), model="path_traced", samples_per_pixel=2, denoise="yes")
