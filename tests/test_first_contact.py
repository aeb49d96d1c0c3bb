"""Issue 17, "first contact": a good picture of real data with no tuning, and honest feedback.

Every "Why" item of the issue is reproduced here; each test failed on the commit the issue starts
from (65d2e28, pv_ambient 0.2.0) unless its docstring says otherwise.
"""
import importlib.util
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient import datasets

DATA = Path(__file__).resolve().parent / "data"


def luminance_shares(img, alpha):
    """(share of covered pixels above 10 % luminance, share with a saturated channel, count):
    the figures of the issue's acceptance 1, on the 8-bit image."""
    covered = alpha > 0.5
    x = img[..., :3].astype(np.float64) / 255.0
    lum = x @ np.array([0.2126, 0.7152, 0.0722])
    return (float(np.mean(lum[covered] > 0.1)), float(np.mean((img[..., :3] == 255).any(axis=-1)[covered])),
            int(covered.sum()))


# -- acceptance 2: with lights given, the radiance of every model did not move ---------------------------------
def test_radiance_with_explicit_lights_is_bit_identical_to_0_2_0():
    """Every model, through Renderer, render() and the JSON scene → CLI → .npy, against arrays saved
    by the code issue 17's changes were merged onto (tests/data/lit_baseline.py --save, run at 4b6a28e:
    0.2.0 with the speed work of issue 16, whose baked in-scattering moves lit radiance by design)."""
    spec = importlib.util.spec_from_file_location("lit_baseline", DATA / "lit_baseline.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    saved = np.load(DATA / "lit_baseline_pre_0.3.0.npz")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # phase given to EA/AO: the new unused-option warning
        new = mod.render_all()
    assert sorted(new) == sorted(saved.files)
    # By design since: path_traced samples a point light within its equiangular radius (a quarter of
    # the box diagonal) also equiangularly (issue 19) — a different estimator of the same image. The
    # supernova's light is inside that radius (the cloud's is not: its images did not move). Checked
    # instead: free flight alone (equiangular=False, the options render() passes) reproduces the saved
    # image bit for bit, the CLI's image equals the API's, and the new image has the saved one's
    # expectation (z-test on the per-pixel differences at 4σ: false alarm 6e-5).
    by_design = {"supernova/pt/radiance", "supernova/cli_pt/radiance"}
    moved = [k for k in saved.files if k not in by_design and not np.array_equal(saved[k], new[k])]
    assert not moved, f"radiance changed: {moved}"
    assert all(float(saved[k].max()) > 0 for k in saved.files if "radiance" in k)  # nothing trivially black
    name, vol, tf, lights, g, cam = mod.scenes()[0]
    assert name == "supernova"
    r = pa.Renderer(datasets.supernova(n=vol["n"]), transfer_function=dict(tf),
                    lights=[pa.PointLight(d["position"], d["intensity"]) for d in lights])
    ff = r.path_trace(pa.Camera(**cam), mod.SIZE, phase=g, samples_per_pixel=4, seed=7,
                      light_clamp=0.25 * r.default_step(), equiangular=False)
    assert np.array_equal(ff.radiance, saved["supernova/pt/radiance"])
    assert np.array_equal(new["supernova/cli_pt/radiance"], new["supernova/pt/radiance"])
    d = (new["supernova/pt/radiance"] - saved["supernova/pt/radiance"]).astype(float).mean(axis=2).ravel()
    assert abs(d.mean() / (d.std(ddof=1) / np.sqrt(d.size))) < 4


# -- lights not given: the default rig; lights=(): black with a warning ------------------------------------
def test_lit_model_without_lights_argument_gets_the_default_rig():
    grid = datasets.cloud(n=16)
    res = pa.render(grid, window_size=(24, 20), model="single_scattering")
    assert res.metadata["lights"] == 2 and res.metadata["light_rig"] == "default"
    assert float(res.radiance.max()) > 0.05
    # placed from the camera: the key light comes from above the camera (a light kit's key light)
    r = pa.Renderer(grid)
    assert r.lights == ()
    cam = pa.Camera((0.0, -4.0, 0.0), (0, 0, 0), (0, 0, 1))
    r.render(camera=cam, window_size=(8, 8), model="single_scattering")
    key, fill = r.lights
    assert key.direction[2] < -0.7 and key.direction[1] > 0.5 and fill.direction[2] > 0.9
    assert np.isclose(key.irradiance[0], 3 * fill.irradiance[0])
    # and kept on a camera move (no relight)
    r.render(camera=pa.Camera((4.0, 0.0, 0.0), (0, 0, 0), (0, 0, 1)), window_size=(8, 8), model="single_scattering")
    assert r.lights == (key, fill)


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


# -- display: exposure "auto" for lit models, VTK's convention for EA -----------------------------------------
def test_auto_exposure_maps_the_99th_percentile_to_0_8_and_ea_keeps_vtk_convention():
    grid = datasets.cloud(n=16)
    lit = pa.render(grid, window_size=(32, 24), model="single_scattering",
                    lights=[pa.DirectionalLight((0, 0, -1), 1e-4)])
    lum = lit.radiance.astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722])
    p99 = np.percentile(lum[lit.alpha > 0.05], 99)
    assert lit.display_exposure() == pytest.approx(np.log2(0.8 / p99))
    assert np.array_equal(lit.to_uint8(), lit.to_uint8(exposure=np.log2(0.8 / p99)))
    assert int(lit.to_uint8().max()) > 150  # 1e-4 irradiance: black at exposure 0, visible at "auto"
    ea = pa.render(grid, window_size=(32, 24))
    assert ea.display_exposure() == 0.0
    assert np.array_equal(ea.to_uint8(), np.round(np.clip(ea.radiance, 0, 1) * 255).astype(np.uint8))


def test_black_display_at_explicit_exposure_warns_with_the_radiance_reached():
    lit = pa.render(datasets.cloud(n=12), window_size=(16, 12), model="single_scattering",
                    lights=[pa.PointLight((300.0, 0.0, 0.0), 1.0)])
    with pytest.warns(UserWarning, match=r"black at exposure=0: the radiance peaks at"):
        lit.to_uint8(exposure=0.0)


# -- acceptance 1: MNI152, no light or exposure arguments ----------------------------------------------------
@pytest.fixture(scope="module")
def mni152():
    """MNI152 in 2 mm voxels (2×2×2 block means), world units mm: built here from the NIfTI affine,
    independently of pv_ambient.pyvista.nifti_to_image_data (checked against it below)."""
    import pyvista as pv

    nilearn_datasets = pytest.importorskip("nilearn.datasets")
    img = nilearn_datasets.load_mni152_template()
    data = img.get_fdata(dtype=np.float32)
    n = [s // 2 for s in data.shape]
    data = data[:2 * n[0], :2 * n[1], :2 * n[2]].reshape(n[0], 2, n[1], 2, n[2], 2).mean(axis=(1, 3, 5))
    linear = img.affine[:3, :3] * 2.0
    spacing = np.linalg.norm(linear, axis=0)
    origin = img.affine[:3, 3] + img.affine[:3, :3] @ np.full(3, 0.5)  # centre of the first 2×2×2 block
    grid = pv.ImageData(dimensions=data.shape, spacing=spacing, origin=origin, direction_matrix=linear / spacing)
    grid.point_data["T1"] = data.astype(np.float32).ravel(order="F")
    return grid, img


def test_nifti_to_image_data_matches_an_independent_conversion(mni152):
    from pv_ambient.pyvista import nifti_to_image_data

    grid, img = mni152
    ours = nifti_to_image_data(img, factor=2, name="T1")
    assert ours.dimensions == grid.dimensions and np.allclose(ours.spacing, (2.0, 2.0, 2.0))
    np.testing.assert_allclose(ours.origin, grid.origin)
    np.testing.assert_allclose(ours.points[[0, -1]], grid.points[[0, -1]])
    np.testing.assert_array_equal(ours["T1"], grid["T1"])


def test_mni152_no_tuning_is_well_exposed(mni152):
    """The README's first picture: ≥ 50 % of the brain's pixels above 10 % luminance, ≤ 5 % saturated,
    with the default rig and with one default point light 300 mm above the brain."""
    mni152, _ = mni152
    tf = pa.TransferFunction(cmap="bone")
    size = (160, 160)
    res = pa.render(mni152, transfer_function=tf, model="ambient_scattering", window_size=size)
    bright, saturated, n = luminance_shares(res.to_uint8(), res.alpha)
    assert n > 1500 and bright >= 0.5 and saturated <= 0.05, (bright, saturated, n)
    top = np.reshape(mni152.bounds, (3, 2)).mean(axis=1) + (0.0, 0.0, 300.0)
    res = pa.render(mni152, transfer_function=tf, model="ambient_scattering", window_size=size,
                    lights=[pa.PointLight(tuple(top))])
    bright, saturated, n = luminance_shares(res.to_uint8(), res.alpha)
    assert n > 1500 and bright >= 0.5 and saturated <= 0.05, (bright, saturated, n)


# -- the JSON scene and the CLI ----------------------------------------------------------------------------
def _scene(tmp_path, **extra):
    import json

    scene = {"version": 1, "volume": {"dataset": "cloud", "n": 12}, "model": "single_scattering",
             "image": {"width": 16, "height": 12}, **extra}
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    return path


def test_scene_without_lights_key_is_lit_and_empty_lights_is_black_with_a_warning(tmp_path):
    from pv_ambient.scene import render_scene

    res = render_scene(_scene(tmp_path))
    assert res.metadata["lights"] == 2 and float(res.radiance.max()) > 0.05
    with pytest.warns(UserWarning, match="rendered black: no lights were given"):
        res = render_scene(_scene(tmp_path, lights=[]))
    assert float(res.radiance.max()) == 0.0


def test_cli_png_of_a_lit_model_is_auto_exposed_and_the_npy_is_the_radiance(tmp_path):
    """A 1 W/sr point light 300 units away: black PNG in 0.2.0, visible now; the .npy unchanged."""
    from PIL import Image

    from pv_ambient.cli import main

    path = _scene(tmp_path, lights=[{"kind": "point", "position": [0, 0, 300], "intensity": 1.0}])
    assert main(["render", str(path), "-o", str(tmp_path / "o.png"), "--radiance", str(tmp_path / "o.npy")]) == 0
    rad = np.load(tmp_path / "o.npy")
    assert 0 < float(rad.max()) < 1e-4
    png = np.asarray(Image.open(tmp_path / "o.png"))
    assert int(png.max()) >= 200
    assert main(["render", str(path), "-o", str(tmp_path / "e.png"), "--exposure", "auto"]) == 0
    assert np.array_equal(np.asarray(Image.open(tmp_path / "e.png")), png)


def test_cli_output_extension_is_checked_before_any_work(tmp_path, capsys):
    """Why: ``-o out.jpg`` was rejected only after an 18 s render (here the volume does not even exist)."""
    import json

    from pv_ambient.cli import main

    path = tmp_path / "scene.json"
    path.write_text(json.dumps({"version": 1, "volume": "missing.vti"}))
    assert main(["render", str(path), "-o", str(tmp_path / "out.jpg")]) == 2
    err = capsys.readouterr().err
    assert "-o/--output must end in .png, .npy, .npz" in err and "missing.vti" not in err
    assert main(["render", str(path), "-o", str(tmp_path / "out.png"), "--radiance", "r.png"]) == 2
    assert "--radiance must end in .npy" in capsys.readouterr().err


def test_cli_ctrl_c_exits_130_with_one_line(tmp_path, capsys, monkeypatch):
    from pv_ambient import scene as scene_module
    from pv_ambient.cli import main

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(scene_module, "render_scene", interrupted)
    assert main(["render", str(_scene(tmp_path)), "-o", str(tmp_path / "o.png")]) == 130
    err = capsys.readouterr().err
    assert err.strip() == "pv-ambient: interrupted"


def test_bench_help_shows_the_benchmarks_and_how_to_get_their_options(capsys):
    """Why: ``pv-ambient bench --help`` showed only ``rest``."""
    from pv_ambient.cli import main

    assert main(["bench", "--help"]) == 0
    out = capsys.readouterr().out
    assert all(f"  {name} " in out for name in ("trade", "ea", "ambient", "gpu"))
    assert "bench NAME --help" in out and "--backend cuda" in out


# -- guards --------------------------------------------------------------------------------------------------
def test_window_size_that_cannot_fit_is_a_clear_error_before_any_work(tmp_path, capsys):
    """Why: ``(1e6, 1e6)`` ended in a numpy MemoryError traceback (through the CLI) after the work began."""
    import time

    from pv_ambient.cli import main

    t = time.perf_counter()
    with pytest.raises(MemoryError, match=r"window_size=\(1000000, 1000000\) needs about .* bytes\)"):
        pa.render(datasets.cloud(n=12), window_size=(10**6, 10**6), model="ambient_scattering")
    path = _scene(tmp_path, image={"width": 10**6, "height": 10**6})
    assert main(["render", str(path), "-o", str(tmp_path / "o.png")]) == 2
    assert "window_size=(1000000, 1000000) needs about" in capsys.readouterr().err
    assert time.perf_counter() - t < 5.0


def test_view_up_parallel_to_the_view_is_a_clear_error():
    """Already an error on 65d2e28 (with numpy reprs in the message); kept, and the message cleaned."""
    with pytest.raises(ValueError, match=r"view_up \(0.0, 0.0, 1.0\) is parallel to the view direction "
                                         r"\(0.0, 0.0, -1.0\): give a view_up across the view"):
        pa.render(datasets.cloud(n=12), window_size=(8, 8), camera=[(0, 0, 5), (0, 0, 0), (0, 0, 1)])


def test_target_error_not_reached_warns_with_the_error_reached():
    """Why: ``target_error=0.01`` was missed silently (the samples_per_pixel cap came first)."""
    r = pa.Renderer(datasets.cloud(n=12), lights=[pa.PointLight((1.5, 1.5, 1.5), 4.0)])
    with pytest.warns(UserWarning, match=r"target_error=0.001 was not reached: the relative error is [0-9.]+ after "
                                         r"4 samples per pixel"):
        res = r.render(window_size=(12, 10), model="path_traced", samples_per_pixel=4, target_error=1e-3)
    assert res.metadata["relative_error"] > 1e-3
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # reached: no warning
        r.render(window_size=(12, 10), model="path_traced", samples_per_pixel=64, target_error=10.0)


# -- docstrings, repr, versions ------------------------------------------------------------------------------
def test_render_docstrings_list_every_model_and_option():
    """Why: ``help(pa.render)`` listed neither models nor options; ``Renderer.render`` omitted diffusion."""
    from pv_ambient.rendering.presets import ALL_MODELS, MODEL_OPTIONS

    for doc in (pa.render.__doc__, pa.Renderer.render.__doc__):
        for name in ALL_MODELS:
            assert f'"{name}"' in doc, name
        for option in sorted(MODEL_OPTIONS | {"radius", "ambient_radiance", "phase", "light_resolution"}):
            assert option in doc, option
        assert "DESIGN" not in doc


def test_render_result_repr_is_one_short_line():
    """Why: ``print(result)`` dumped whole arrays."""
    res = pa.render(datasets.cloud(n=12), window_size=(64, 48))
    text = repr(res)
    assert text.startswith("RenderResult(model='emission_absorption', window_size=(64, 48)")
    assert "\n" not in text and len(text) < 200 and "array" not in text


def test_version_is_0_4_0_in_the_package_and_pyproject():
    """0.3.0: documented PNG defaults changed; 0.4.0: a new model and command, the path tracer's samples
    moved (README)."""
    import re

    toml = (Path(__file__).resolve().parent.parent / "pyproject.toml").read_text()
    assert re.search(r'^version = "0\.4\.0"$', toml, re.MULTILINE)
    assert pa.__version__ == "0.4.0"


# -- PyVista habits ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("view", ["iso", "xy", "xz", "yz", "yx", "zx", "zy"])
def test_camera_strings_are_pyvistas(view):
    """Why: ``camera="iso"`` (PyVista's camera strings) was rejected."""
    import pyvista as pv

    grid = datasets.cloud(n=12)
    res = pa.render(grid, camera=view, window_size=(12, 10))
    pl = pv.Plotter(off_screen=True)
    pl.add_mesh(grid.outline())
    pl.camera_position = view
    pl.reset_camera(bounds=grid.bounds)
    ours, theirs = res.camera, pl.camera
    for a, b in ((ours.position, theirs.position), (ours.focal_point, theirs.focal_point),
                 (ours.view_up, theirs.up)):
        np.testing.assert_allclose(a, b, atol=1e-9)
    pl.close()
    with pytest.raises(ValueError, match=r"camera 'top' is not one of PyVista's camera strings"):
        pa.render(grid, camera="top", window_size=(8, 8))


def test_pyvista_lights_become_physical_lights():
    """Why: ``pyvista.Light`` objects were rejected."""
    import pyvista as pv

    from pv_ambient.inputs.lights import REFERENCE_IRRADIANCE

    grid = datasets.cloud(n=12)  # centred on the origin
    point = pv.Light(position=(0.0, 0.0, 3.0), positional=True, intensity=0.5, color=(1.0, 0.5, 0.0), cone_angle=90)
    sun = pv.Light(position=(0.0, 0.0, 1.0), focal_point=(0.0, 0.0, 0.0), intensity=1.0)
    head = pv.Light(light_type="headlight")
    r = pa.Renderer(grid, lights=[point, sun, head])
    cam = pa.Camera((0.0, -4.0, 0.0), (0, 0, 0), (0, 0, 1))
    res = r.render(camera=cam, window_size=(12, 10), model="single_scattering")
    p, s, h = r.lights
    assert isinstance(p, pa.PointLight) and p.position == (0.0, 0.0, 3.0)
    # intensity 0.5 → irradiance 0.5·8π at the volume's centre, 3 units away: I = 0.5·8π·9, coloured
    colour = np.array(point.GetDiffuseColor())  # (1, 128/255, 0): pyvista stores 8-bit colours
    assert abs(colour[1] - 0.5) < 0.01
    np.testing.assert_allclose(p.intensity, colour * 0.5 * REFERENCE_IRRADIANCE * 9.0)
    assert isinstance(s, pa.DirectionalLight) and s.direction == (0.0, 0.0, -1.0)
    np.testing.assert_allclose(s.irradiance, REFERENCE_IRRADIANCE)
    assert isinstance(h, pa.DirectionalLight) and np.allclose(h.direction, (0.0, 1.0, 0.0))  # along the view
    assert res.metadata["lights"] == 3 and float(res.radiance.max()) > 0.05
    # a spot light (VTK: positional with a cone under 90°, pyvista's default 30°) is a point light, with a warning
    with pytest.warns(UserWarning, match="spot cone and attenuation are not modelled"):
        pa.Renderer(grid, lights=pv.Light(position=(0.0, 0.0, 3.0), positional=True))
    # a camera light lives in VTK's camera frame (camera at (0, 0, 1), looking at the origin):
    # one at (1, 0, 1) shines from the camera's right, across the view direction
    side = pv.Light(position=(1.0, 0.0, 1.0), focal_point=(0.0, 0.0, 0.0), light_type="camera light")
    r2 = pa.Renderer(grid, lights=[side])
    r2.render(camera=cam, window_size=(8, 8), model="single_scattering")
    np.testing.assert_allclose(r2.lights[0].direction, np.array([-1.0, 1.0, 0.0]) / np.sqrt(2), atol=1e-12)
    # the head light stays where the first render put it
    r.render(camera=pa.Camera((4.0, 0.0, 0.0), (0, 0, 0), (0, 0, 1)), window_size=(8, 8), model="single_scattering")
    assert r.lights[2] is h


def test_add_ambient_volume_keeps_the_plotter_background():
    """Why: the plane painted the plotter's background black (PyVista's white theme lost its title)."""
    import pyvista as pv

    grid = datasets.cloud(n=12)
    pl = pv.Plotter(off_screen=True, window_size=(40, 30))
    pl.set_background("white")
    vol = pa.add_ambient_volume(pl, grid, model="single_scattering")
    shot = pl.screenshot(return_img=True)
    assert shot[0, 0].tolist() == [255, 255, 255] and shot[-1, -1].tolist() == [255, 255, 255]
    # where the volume covers a pixel, the background shows through by its transmittance: D(L) + T·B
    res, shown = vol.volume_result, vol.result.to_uint8(**vol.display)
    expect = np.clip(np.round(res.to_uint8(exposure=vol.display["exposure"]).astype(float)
                              + 255.0 * (1.0 - res.alpha[..., None])), 0, 255)
    assert np.abs(shown.astype(float) - expect).max() <= 1.0
    pl.close()
    # background= still paints that radiance
    pl = pv.Plotter(off_screen=True, window_size=(40, 30))
    pl.set_background("white")
    pa.add_ambient_volume(pl, grid, background=(0.0, 0.0, 0.0))
    assert pl.screenshot(return_img=True)[0, 0].tolist() == [0, 0, 0]
    pl.close()


# -- progress --------------------------------------------------------------------------------------------------
def test_progress_bars_are_named_per_stage_and_off_by_default_in_tests(capsys):
    """Why: the only bar covered the final ray cast (unnamed), long stages were silent, the
    diffusion solve showed an unlabelled count."""
    import re

    grid = datasets.cloud(n=12)
    pa.render(grid, window_size=(16, 12), model="single_scattering")
    assert capsys.readouterr().err == ""  # progress_bar=None: never under pytest
    pa.render(grid, window_size=(16, 12), model="single_scattering", progress_bar=True)
    err = capsys.readouterr().err
    assert "light volumes (2 lights)" in err and "ray cast (single_scattering)" in err
    pa.render(grid, window_size=(16, 12), model="diffusion", progress_bar=True)
    assert re.search(r"diffusion solve: 100%.*[0-9]+ iterations, residual [0-9.e+-]+", capsys.readouterr().err)


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


def test_compile_notice_is_one_line_once(monkeypatch, capsys):
    """Why: the first call of each model compiled for ~9 s without a word."""
    from types import SimpleNamespace

    from pv_ambient._kernels import raycast
    from pv_ambient.rendering import request

    fresh = SimpleNamespace(signatures=[], _cache=SimpleNamespace(_cache_file=SimpleNamespace(
        _index_path="/nonexistent/raycast.nbi")))
    monkeypatch.setattr(raycast, "raycast_image", fresh)
    monkeypatch.setattr(request, "_NOTICED", [])
    request.compile_notice("ambient_scattering")
    request.compile_notice("diffusion")
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("pv_ambient: compiling the rendering kernels")


# -- grids without thickness ----------------------------------------------------------------------------------
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
