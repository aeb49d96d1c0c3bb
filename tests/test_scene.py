"""Tests pv_ambient/scene.py: the JSON scene format (version 1) — parsing, its errors and warnings,
the one scene-file reader, and renders equal to the Python API's."""
import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient.scene import parse_scene, read_scene, render_scene, scene_options

from .helpers import SCENE_CAMERA, scene_file, write_scene


def test_scene_without_lights_key_is_lit_and_empty_lights_is_black_with_a_warning(tmp_path):
    from pv_ambient.scene import render_scene

    res = render_scene(scene_file(tmp_path))
    assert res.metadata["lights"] == 2 and float(res.radiance.max()) > 0.05
    with pytest.warns(UserWarning, match="rendered black: no lights were given"):
        res = render_scene(scene_file(tmp_path, lights=[]))
    assert float(res.radiance.max()) == 0.0


def test_dataset_volume_and_lights_in_scene(tmp_path):
    scene = {"volume": {"dataset": "cloud", "n": 16, "seed": 1},
             "transfer_function": {"kind": "colormap", "cmap": "bone", "clim": [0, 1], "opacity": "linear",
                                   "opacity_unit_distance": 0.1, "albedo": 0.9, "emission": 0.0},
             "phase": {"kind": "hg", "g": 0.6},
             "lights": [{"kind": "point", "position": [0, 0, 2], "intensity": [2, 2, 2]},
                        {"kind": "directional", "direction": [0, 0, -1], "irradiance": [1, 1, 1]}],
             "camera": SCENE_CAMERA, "image": {"width": 20, "height": 20}, "model": "single_scattering",
             "quality": "preview", "background": [0, 0, 0]}
    res = render_scene(write_scene(tmp_path, scene))
    assert res.metadata["model"] == "single_scattering" and res.metadata["lights"] == 2
    grid = pa.datasets.cloud(n=16, seed=1)
    tf = pa.TransferFunction(cmap="bone", clim=(0, 1), opacity="linear", opacity_unit_distance=0.1, albedo=0.9)
    api = pa.render(grid, transfer_function=tf, camera=pa.Camera.from_dict(SCENE_CAMERA), window_size=(20, 20),
                    lights=[pa.PointLight((0, 0, 2), intensity=2.0), pa.DirectionalLight((0, 0, -1))],
                    model="single_scattering", quality="preview", phase=0.6)
    np.testing.assert_array_equal(res.radiance, api.radiance)
    assert res.radiance.max() > 0


@pytest.mark.parametrize("scene, err, match", [
    ({"version": 2, "volume": {"dataset": "cloud"}}, ValueError, "scene version 2 is not supported"),
    ({"camera": SCENE_CAMERA}, ValueError, "scene needs a 'volume'"),
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
             "camera": SCENE_CAMERA, "backend": "cpu"}
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
    assert read_scene(write_scene(tmp_path, {"volume": {"dataset": "cloud"}})) == {"volume": {"dataset": "cloud"}}
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(ValueError, match="is not valid JSON"):
        read_scene(bad)
    (tmp_path / "list.json").write_text("[1, 2]")
    with pytest.raises(TypeError, match="a scene must be a JSON object, got list"):
        read_scene(tmp_path / "list.json")
