"""Tests pv_ambient/inputs/lights.py: point and directional lights, the default rig and its placement
from the camera, pyvista.Light conversion, the JSON form and its errors."""
import re

import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient import datasets
from pv_ambient.inputs.lights import DirectionalLight, PointLight, as_light, as_lights, pack_lights


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


def test_lights_are_checked_and_normalised_and_their_json_form_round_trips():
    sun = DirectionalLight((0, 0, -2), 0.5)
    assert sun.direction == (0.0, 0.0, -1.0) and sun.irradiance == (0.5, 0.5, 0.5)
    lamp = PointLight((1, 2, 3), 2.0)
    assert as_light(lamp.to_dict()) == lamp and as_light(sun.to_dict()) == sun
    with pytest.raises(ValueError, match=r"^light intensity components must be >= 0\.0, got -1$"):
        PointLight((0, 0, 1), -1)
    with pytest.raises(ValueError, match=r"^light direction must not be the zero vector, got \(0, 0, 0\)$"):
        DirectionalLight((0, 0, 0))
    assert as_lights(None) == ()  # not given, and no camera to place the default rig with
    assert as_lights(lamp) == (lamp,)


@pytest.mark.parametrize("spec, exc, message", [
    ({"kind": "spot"}, ValueError, "lights[2]['kind'] must be 'point' or 'directional', got 'spot'"),
    ({"kind": "point", "position": [0, 0, 1], "power": 2}, ValueError,
     "lights[2] (point) has unknown keys ['power']; allowed: ['intensity', 'position']"),
    (42, TypeError, "lights[2] must be a PointLight, DirectionalLight, pyvista.Light or dict, got int"),
], ids=["kind", "unknown key", "not a light"])
def test_a_bad_light_is_named_by_its_index(spec, exc, message):
    with pytest.raises(exc, match=f"^{re.escape(message)}$"):
        as_light(spec, 2)
    with pytest.raises(TypeError, match=r"^lights must be a sequence of lights \(or one light\), got str$"):
        as_lights("lamp")


def test_pack_lights_gives_the_kernels_kinds_vectors_and_powers():
    kind, vec, power = pack_lights([PointLight((1, 2, 3), (1.0, 0.5, 0.25)), DirectionalLight((0, 0, -2), 0.5)])
    assert kind.dtype == np.int64 and kind.tolist() == [0, 1]  # POINT, DIRECTIONAL
    np.testing.assert_array_equal(vec, [[1.0, 2.0, 3.0], [0.0, 0.0, -1.0]])
    np.testing.assert_array_equal(power, [[1.0, 0.5, 0.25], [0.5, 0.5, 0.5]])
    kind, vec, power = pack_lights([])
    assert kind.shape == (0,) and vec.shape == (0, 3) and power.shape == (0, 3)
