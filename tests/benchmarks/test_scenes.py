"""Tests benchmarks/scenes.py, the registry of the benchmark scenes: every scene gives what the
benchmarks need, and the three new out-of-sample scenes are what their descriptions say (light
placement, optical thickness, albedo, phase). Geometry and optics only: nothing is rendered."""
import sys
from pathlib import Path

import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient.inputs.camera import Camera

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import scenes  # noqa: E402

N = 16


def _optics(name, n=N):
    grid, tf, lights, g, cam = scenes.scene(name, n)
    r = pa.Renderer(grid, transfer_function=tf, lights=lights)
    return r, grid, lights, g, cam


def _sigma_along(r, grid, p0, p1, samples=400):
    """Optical depth from p0 to p1 by the midpoint rule on trilinearly interpolated σt."""
    from scipy.ndimage import map_coordinates

    sig = r.optics.sigma_grid().astype(np.float64)
    origin, spacing = np.array(grid.origin), np.array(grid.spacing)
    t = (np.arange(samples) + 0.5) / samples
    pts = np.asarray(p0)[None] + t[:, None] * (np.asarray(p1) - np.asarray(p0))[None]
    idx = ((pts - origin) / spacing).T
    vals = map_coordinates(sig, idx, order=1, mode="constant", cval=0.0)
    return float(vals.sum() * np.linalg.norm(np.subtract(p1, p0)) / samples)


def _in_image(cam, point, size=(64, 64)):
    (u, v), = cam.project([point], size)
    return 0 <= u <= size[0] and 0 <= v <= size[1]


def test_nine_referenced_scenes_in_three_groups_and_four_more():
    assert len(scenes.REFERENCED) == 9 and len(scenes.SCENES) == 13
    assert sorted(sum(scenes.GROUPS.values(), ())) == sorted(scenes.SCENES)
    assert scenes.REFERENCED == scenes.GROUPS["trade"] + scenes.GROUPS["floor"] + scenes.GROUPS["new"]
    assert scenes.NEW == ("haze_backlit", "dense_side", "ct_coloured")
    with pytest.raises(ValueError, match="unknown scene"):
        scenes.scene("teapot")


@pytest.mark.parametrize("name", list(scenes.SCENES))
def test_each_scene_gives_what_the_benchmarks_need(name):
    grid, tf, lights, g, cam = scenes.scene(name, N)
    assert isinstance(tf, pa.TransferFunction) and isinstance(cam, Camera)
    assert len(lights) >= 1 and -1 < g < 1
    r = pa.Renderer(grid, transfer_function=tf, lights=lights)
    assert r.geometry.shape == (N, N, N)
    assert r.optics.has_scattering
    desc = scenes.DESCRIPTIONS[name]
    assert desc and "\n" not in desc
    assert (f"g = {g:g}" in desc) if g != 0 else ("isotropic" in desc)
    # the camera looks at the volume: the box centre projects inside the image
    assert _in_image(cam, (0.0, 0.0, 0.0))


def test_trade_takes_its_scenes_from_the_registry():
    import trade

    got = trade.scenes(N)  # the name benchmarks/identity.py imports
    assert [s[0] for s in got] == list(scenes.GROUPS["trade"])
    for name, grid, tf, lights, g, cam in got:
        ref = scenes.scene(name, N)
        assert np.array_equal(grid.active_scalars, ref[0].active_scalars) and lights == ref[2] and g == ref[3]
        assert cam.to_dict() == ref[4].to_dict()


def test_the_timing_scenes_vary_as_their_benchmarks_ask():
    """The TF-change rows scale the density; the time series steps the cloud's noise; the GPU scene
    needs neither pyvista nor a colour map (a table TF on the array core's Volume)."""
    from pv_ambient.inputs.grid import Volume

    grid = scenes.scene("supernova_centre", N)[0]
    base, scaled = (pa.Renderer(grid, transfer_function=scenes.scene("supernova_centre", N, density=d)[1])
                    for d in (1.0, 2.0))
    np.testing.assert_allclose(scaled.optics.sigma_grid(), 2.0 * base.optics.sigma_grid(), rtol=1e-6)
    steps = [scenes.scene("cloud_series", N, step=s)[0].active_scalars for s in (0, 1)]
    assert not np.array_equal(*steps)
    grid, tf, *_ = scenes.scene("supernova_table", N)
    assert isinstance(grid, Volume) and tf.kind == "table"
    # the speed scene and the light-in-core scene are the trade's supernova with the light moved
    trade = scenes.scene("supernova", N)
    for name, intensity in (("supernova_centre", 4.0), ("light_in_core", 3.0)):
        grid, tf, (light,), g, cam = scenes.scene(name, N)
        assert np.array_equal(grid.active_scalars, trade[0].active_scalars) and g == trade[3]
        assert cam.to_dict() == trade[4].to_dict()
        assert light.position == (0.0, 0.0, 0.0) and light.intensity == (intensity,) * 3


def test_haze_backlit_is_thin_forward_scattering_and_lit_from_behind():
    r, grid, lights, g, cam = _optics("haze_backlit")
    (light,) = lights
    assert isinstance(light, pa.DirectionalLight)
    fwd = np.array(cam.basis()[0])
    d = np.array(light.direction)
    # the light travels toward the camera ...
    assert np.dot(d, -fwd) > 0.8
    # ... but its source direction is outside the image (a far point along −d projects outside)
    assert not _in_image(cam, np.array(cam.position) - 1e6 * d)
    assert 0.8 <= g <= 0.9
    # albedo 0.95 wherever there is medium
    sig, alb = r.optics.sigma_grid(), r.optics.albedo_grid()
    np.testing.assert_allclose(alb[sig > 0], 0.95, atol=1e-6)
    # thin: optical depth across the box along the view axis of order 0.5–1 (median over lines)
    taus = [_sigma_along(r, grid, (x, -1.0, z), (x, 1.0, z)) for x in np.linspace(-0.8, 0.8, 5)
            for z in np.linspace(-0.8, 0.8, 5)]
    assert 0.5 <= np.median(taus) <= 1.0, taus
    # a haze: it fills the box (medium on every one of those lines)
    assert min(taus) > 0.1


def test_dense_side_is_optically_thick_high_albedo_and_lit_from_outside():
    r, grid, lights, g, cam = _optics("dense_side")
    (light,) = lights
    assert isinstance(light, pa.PointLight) and g == pytest.approx(0.3)
    sig, alb = r.optics.sigma_grid(), r.optics.albedo_grid()
    np.testing.assert_allclose(alb[sig > 0], 0.99, atol=1e-6)
    # thick: optical depth ≥ 20 along each axis line through the centre
    for a in range(3):
        p0, p1 = np.zeros(3), np.zeros(3)
        p0[a], p1[a] = -1.0, 1.0
        assert _sigma_along(r, grid, p0, p1) >= 20.0
    # the light is outside the object's support, with room to spare ...
    pts = np.stack(np.meshgrid(*[np.linspace(-1, 1, N)] * 3, indexing="ij"), -1)
    support = pts[sig > 0]
    gap = np.min(np.linalg.norm(support - np.array(light.position), axis=1))
    assert gap > 0.5
    # ... at the side: its direction from the centre is across the view (|cos| < 0.5), off the image
    fwd = np.array(cam.basis()[0])
    u = np.array(light.position) / np.linalg.norm(light.position)
    assert abs(np.dot(u, fwd)) < 0.5
    assert not _in_image(cam, light.position)


def test_ct_coloured_has_coloured_lights_at_different_sides_outside_the_phantom():
    r, grid, lights, g, cam = _optics("ct_coloured")
    assert 3 <= len(lights) <= 4 and all(isinstance(lt, pa.PointLight) for lt in lights)
    # the CT phantom's TF and data, as the trade's ct_phantom scene
    ct = scenes.scene("ct_phantom", N)
    assert np.array_equal(grid.active_scalars, ct[0].active_scalars) and g == ct[3]
    # coloured: no light is near grey, and no two have the same colour
    cols = np.array([lt.intensity for lt in lights])
    assert np.all(cols.max(axis=1) >= 2.0 * cols.min(axis=1))
    chroma = cols / np.linalg.norm(cols, axis=1, keepdims=True)
    dist = np.linalg.norm(chroma[:, None] - chroma[None], axis=-1)
    assert np.all(dist[~np.eye(len(lights), dtype=bool)] > 0.2)
    assert len({int(np.argmax(c)) for c in cols}) == 3  # red, green and blue dominated lights among them
    # at different sides: pairwise angles between directions from the centre above 60°
    u = np.array([lt.position for lt in lights])
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    cos = u @ u.T
    assert np.all(cos[~np.eye(len(lights), dtype=bool)] < 0.5)
    # outside the phantom's support (and the box) and outside the image: no masked pixels
    for lt in lights:
        assert np.max(np.abs(lt.position)) > 1.0
        assert not _in_image(cam, lt.position)
