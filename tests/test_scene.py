"""Tests pv_ambient/scene.py: the JSON scene format (version 1) — parsing, its errors and warnings,
the one scene-file reader, and renders equal to the Python API's."""
import pytest

from pv_ambient.scene import render_scene

from .helpers import scene_file


def test_scene_without_lights_key_is_lit_and_empty_lights_is_black_with_a_warning(tmp_path):
    from pv_ambient.scene import render_scene

    res = render_scene(scene_file(tmp_path))
    assert res.metadata["lights"] == 2 and float(res.radiance.max()) > 0.05
    with pytest.warns(UserWarning, match="rendered black: no lights were given"):
        res = render_scene(scene_file(tmp_path, lights=[]))
    assert float(res.radiance.max()) == 0.0
