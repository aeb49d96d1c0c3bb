"""Tests the ``pv-ambient render`` command (pv_ambient/cli.py): one code path with the Python API,
its outputs (PNG auto-exposed, radiance .npy), options checked before any work, errors and Ctrl-C
as one line with exit status 2 and 130, the installed console script."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient import cli
from pv_ambient.scene import load_scene

from ..helpers import SCENE_CAMERA, scene_file, write_scene

pv = pytest.importorskip("pyvista")

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


def test_cli_render_writes_png_and_radiance_equal_to_api(tmp_path):
    grid, vti = _slab(tmp_path)
    scene = {"version": 1, "volume": vti.name, "transfer_function": {"kind": "physical"},
             "camera": {**SCENE_CAMERA, "parallel_projection": True, "parallel_scale": 1.5},
             "image": {"width": 24, "height": 16}, "model": "emission_absorption"}
    sp = write_scene(tmp_path, scene)
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


def test_cli_errors_exit_2_with_message(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    assert cli.main(["render", str(bad), "-o", str(tmp_path / "x.png")]) == 2
    assert "is not valid JSON" in capsys.readouterr().err


def test_console_script_is_installed(tmp_path):
    exe = Path(sys.executable).parent / "pv-ambient"
    assert exe.exists(), "the pv-ambient console script is not installed"
    scene = {"volume": {"dataset": "supernova", "n": 12}, "image": {"width": 8, "height": 6}}
    sp = write_scene(tmp_path, scene)
    out = tmp_path / "o.npy"
    proc = subprocess.run([str(exe), "render", str(sp), "-o", str(out)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert np.load(out).shape == (6, 8, 3)
    assert load_scene(sp).render_kwargs["window_size"] == (8, 6)


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
    assert cli.main(["render", str(write_scene(tmp_path, scene)), "-o", str(out)]) == 2
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

