"""The JSON scene format and the ``pv-ambient`` command line (one code path with the Python API)."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient import cli
from pv_ambient.scene import load_scene, parse_scene, read_scene, render_scene, scene_options

from ..helpers import scene_file

pv = pytest.importorskip("pyvista")

CAMERA = {"position": [0.0, -5.0, 0.0], "focal_point": [0.0, 0.0, 0.0], "view_up": [0.0, 0.0, 1.0],
          "view_angle": 30.0, "parallel_projection": False, "parallel_scale": 1.0}


def _slab(tmp_path):
    """A physical slab |x| ≤ 1 in a 1-wide grid: σt = 2, albedo 0.5, emission (1, 0.5, 0.25)."""
    grid = pv.ImageData(dimensions=(9, 9, 9), spacing=(0.25, 0.25, 0.25), origin=(-1, -1, -1))
    n = grid.n_points
    grid.point_data["sigma_t"] = np.full(n, 2.0, np.float32)
    grid.point_data["albedo"] = np.full(n, 0.5, np.float32)
    grid.point_data["emission"] = np.tile(np.array([1.0, 0.5, 0.25], np.float32), (n, 1))
    path = tmp_path / "slab.vti"
    grid.save(path)
    return grid, path


def _write(tmp_path, scene, name="scene.json"):
    p = tmp_path / name
    p.write_text(json.dumps(scene))
    return p


def test_cli_render_writes_png_and_radiance_equal_to_api(tmp_path):
    grid, vti = _slab(tmp_path)
    scene = {"version": 1, "volume": vti.name, "transfer_function": {"kind": "physical"},
             "camera": {**CAMERA, "parallel_projection": True, "parallel_scale": 1.5},
             "image": {"width": 24, "height": 16}, "model": "emission_absorption"}
    sp = _write(tmp_path, scene)
    out, rad = tmp_path / "out" / "img.png", tmp_path / "rad.npy"
    assert cli.main(["render", str(sp), "-o", str(out), "--radiance", str(rad)]) == 0
    img = pv.read(out)
    assert img.dimensions[:2] == (24, 16)
    radiance = np.load(rad)
    assert radiance.dtype == np.float32 and radiance.shape == (16, 24, 3)
    # same code path as the Python API
    api = pa.render(grid, transfer_function=pa.TransferFunction.physical(), camera=pa.Camera.from_dict(scene["camera"]),
                    window_size=(24, 16))
    np.testing.assert_array_equal(radiance, api.radiance)
    # units: the centre ray crosses 2 world units of σt = 2; EA's colour for a physical TF is its
    # emission array (docs/models.rst), so L = Le·(1 − e^{−σt·2}) in closed form
    centre = radiance[8, 12]
    expected = np.array([1.0, 0.5, 0.25]) * (1.0 - np.exp(-4.0))
    np.testing.assert_allclose(centre, expected, rtol=1e-3)


def test_dataset_volume_and_lights_in_scene(tmp_path):
    scene = {"volume": {"dataset": "cloud", "n": 16, "seed": 1},
             "transfer_function": {"kind": "colormap", "cmap": "bone", "clim": [0, 1], "opacity": "linear",
                                   "opacity_unit_distance": 0.1, "albedo": 0.9, "emission": 0.0},
             "phase": {"kind": "hg", "g": 0.6},
             "lights": [{"kind": "point", "position": [0, 0, 2], "intensity": [2, 2, 2]},
                        {"kind": "directional", "direction": [0, 0, -1], "irradiance": [1, 1, 1]}],
             "camera": CAMERA, "image": {"width": 20, "height": 20}, "model": "single_scattering",
             "quality": "preview", "background": [0, 0, 0]}
    res = render_scene(_write(tmp_path, scene))
    assert res.metadata["model"] == "single_scattering" and res.metadata["lights"] == 2
    grid = pa.datasets.cloud(n=16, seed=1)
    tf = pa.TransferFunction(cmap="bone", clim=(0, 1), opacity="linear", opacity_unit_distance=0.1, albedo=0.9)
    api = pa.render(grid, transfer_function=tf, camera=pa.Camera.from_dict(CAMERA), window_size=(20, 20),
                    lights=[pa.PointLight((0, 0, 2), intensity=2.0), pa.DirectionalLight((0, 0, -1))],
                    model="single_scattering", quality="preview", phase=0.6)
    np.testing.assert_array_equal(res.radiance, api.radiance)
    assert res.radiance.max() > 0


@pytest.mark.parametrize("scene, err, match", [
    ({"version": 2, "volume": {"dataset": "cloud"}}, ValueError, "scene version 2 is not supported"),
    ({"camera": CAMERA}, ValueError, "scene needs a 'volume'"),
    ({"volume": {"dataset": "teapot"}}, ValueError, "volume dataset 'teapot' is unknown"),
    ({"volume": "missing.vti"}, FileNotFoundError, "does not exist"),
    ({"volume": {"dataset": "cloud", "n": 8}, "image": {"width": 0, "height": 8}}, ValueError, "image width/height"),
    ({"volume": {"dataset": "cloud", "n": 8}, "quality": "best"}, ValueError, "quality"),
    ({"volume": {"dataset": "cloud", "n": 8}, "display": {"gamma": 2}}, ValueError, "display must hold only"),
])
def test_bad_scenes(tmp_path, scene, err, match):
    with pytest.raises(err, match=match):
        parse_scene(scene, base_dir=tmp_path)


def test_unknown_top_level_key_warns(tmp_path):
    with pytest.warns(UserWarning, match="not part of scene format 1"):
        parse_scene({"volume": {"dataset": "cloud", "n": 8}, "future_knob": 3}, base_dir=tmp_path)


def test_scene_options_check_every_key_but_the_volume(tmp_path):
    # what `pv-ambient series --volumes` parses: the volume is neither required nor read
    scene = {"volume": "missing.vti", "image": {"width": 8, "height": 6}, "model": "single_scattering",
             "camera": CAMERA, "backend": "cpu"}
    s = scene_options(scene, base_dir=tmp_path)
    assert s.grid is None and s.render_kwargs["window_size"] == (8, 6) and s.renderer_kwargs["backend"] == "cpu"
    assert scene_options({"model": "diffusion"}).grid is None
    with pytest.raises(FileNotFoundError, match="does not exist"):
        parse_scene(scene, base_dir=tmp_path)
    for bad, err, match in (({"quality": "best"}, ValueError, "quality"), ({"version": 2}, ValueError, "version 2"),
                            ({"display": {"gamma": 2}}, ValueError, "display must hold only")):
        with pytest.raises(err, match=match):
            scene_options(bad)


def test_read_scene_is_the_one_reader(tmp_path):
    assert read_scene(_write(tmp_path, {"volume": {"dataset": "cloud"}})) == {"volume": {"dataset": "cloud"}}
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(ValueError, match="is not valid JSON"):
        read_scene(bad)
    (tmp_path / "list.json").write_text("[1, 2]")
    with pytest.raises(TypeError, match="a scene must be a JSON object, got list"):
        read_scene(tmp_path / "list.json")


def test_cli_errors_exit_2_with_message(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    assert cli.main(["render", str(bad), "-o", str(tmp_path / "x.png")]) == 2
    assert "is not valid JSON" in capsys.readouterr().err


def test_console_script_is_installed(tmp_path):
    exe = Path(sys.executable).parent / "pv-ambient"
    assert exe.exists(), "the pv-ambient console script is not installed"
    scene = {"volume": {"dataset": "supernova", "n": 12}, "image": {"width": 8, "height": 6}}
    sp = _write(tmp_path, scene)
    out = tmp_path / "o.npy"
    proc = subprocess.run([str(exe), "render", str(sp), "-o", str(out)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert np.load(out).shape == (6, 8, 3)
    assert load_scene(sp).render_kwargs["window_size"] == (8, 6)


def test_bench_backend_cuda_runs_the_gpu_benchmark(monkeypatch):
    # `pv-ambient bench --backend cuda ARGS` runs benchmarks/gpu.py with ARGS (options pass through)
    import runpy

    from pv_ambient.cli import main

    seen = {}
    monkeypatch.setattr(runpy, "run_path", lambda path, run_name: seen.update(path=path, argv=list(sys.argv)))
    monkeypatch.setattr(sys, "argv", list(sys.argv))
    monkeypatch.setattr(sys, "path", list(sys.path))
    assert main(["bench", "--backend", "cuda", "--cases", "8:4", "--repeats", "1"]) == 0
    assert seen["path"].endswith("gpu.py") and seen["argv"][1:] == ["--cases", "8:4", "--repeats", "1"]
    assert main(["bench", "ambient", "--sizes", "16"]) == 0
    assert seen["path"].endswith("ambient.py") and seen["argv"][1:] == ["--sizes", "16"]


def test_cli_denoise_without_pyoidn_is_one_line_before_any_work(tmp_path, capsys, monkeypatch):
    """Why: a scene asking for ``"denoise": true`` without pyoidn rendered the base picture first,
    then printed a full traceback. Now: exit status 2, one line naming the extra, no output file,
    and no kernel launched."""
    from pv_ambient import backend
    from pv_ambient.stages import denoise

    monkeypatch.setattr(denoise, "available", lambda: False)
    monkeypatch.setitem(sys.modules, "pyoidn", None)

    def work(*a, **k):
        raise AssertionError("a kernel ran before the request was checked")

    monkeypatch.setattr(backend, "run_raycast", work)
    scene = {"volume": {"dataset": "cloud", "n": 12}, "image": {"width": 8, "height": 6}, "model": "progressive",
             "samples_per_pixel": 32, "denoise": True}
    out = tmp_path / "o.png"
    assert cli.main(["render", str(_write(tmp_path, scene)), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "pv_ambient[denoise]" in err and "Traceback" not in err
    assert not out.exists()


def test_cli_png_of_a_lit_model_is_auto_exposed_and_the_npy_is_the_radiance(tmp_path):
    """A 1 W/sr point light 300 units away: black PNG in 0.2.0, visible now; the .npy unchanged."""
    from PIL import Image

    from pv_ambient.cli import main

    path = scene_file(tmp_path, lights=[{"kind": "point", "position": [0, 0, 300], "intensity": 1.0}])
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
    assert main(["render", str(scene_file(tmp_path)), "-o", str(tmp_path / "o.png")]) == 130
    err = capsys.readouterr().err
    assert err.strip() == "pv-ambient: interrupted"
