"""Tests pv_ambient/_kernels/bake_rows.py: the bake of one light in vectorised chunks of a row
equals the node-by-node rule (pv_ambient/_kernels/bake.py, ``driver="nodes"``) it follows, for
point lights inside and outside the box, a directional light, grey and coloured lights and
albedos, single and ambient scattering, on a grid of unequal sides and spacings; the cases it
does not cover take the node rule; and ``log_pos`` against ``math.log``."""

import math

import numpy as np
import pytest
import pyvista as pv

import pv_ambient as pa
import pv_ambient.stages.bake as stage_bake
from pv_ambient.inputs.lights import DirectionalLight, PointLight

from ..helpers import CAM, SIZE


def coloured_grid(albedo_span=(0.0, 1.0)):
    """σt a noisy blob on a box of unequal sides and spacings; the albedo varies per channel over
    ``albedo_span`` (its ends included: the D table's clamps)."""
    dims = (11, 14, 9)
    g = pv.ImageData(dimensions=dims, spacing=(0.2, 0.15, 0.25), origin=(-1.0, -1.0, -1.0))
    rng = np.random.default_rng(4)
    p = g.points
    base = np.clip(1.0 - np.linalg.norm(p, axis=1) / 1.2, 0, None) * (0.4 + rng.random(g.n_points))
    g["sigma_t"] = (6.0 * base).astype(np.float32)
    lo, hi = albedo_span
    a = np.clip(rng.uniform(lo - 0.1, hi + 0.1, (g.n_points, 3)), lo, hi)
    g["albedo"] = a.astype(np.float32)
    g["emission"] = np.zeros((g.n_points, 3), np.float32)
    return g


def captured_bakes(grid, lights, model):
    """The arguments of every stage-level bake of a balanced render (the bake on), each with the
    arguments of the node rule's bake of the same lights: the ball grid in the records instead of
    D per sample (the row driver's ``dgrid``)."""
    calls = []
    orig = stage_bake.bake_incident

    def spy(*args, **kw):
        calls.append((args, kw))
        return orig(*args, **kw)

    stage_bake.bake_incident = spy
    try:
        r = pa.Renderer(grid, transfer_function=pa.TransferFunction.physical(), lights=lights)
        res = r.render(camera=CAM, window_size=SIZE, model=model, quality="balanced", light_resolution=1.0)
    finally:
        stage_bake.bake_incident = orig
    assert res.metadata["baked_lights"]
    out = []
    for args, kw in calls:
        lrec, grec, arec = args[1]
        ball = r.stages.ball_grid(arec.radius) if "dgrid" in kw and kw["dgrid"] is not None else arec.ball
        nodes = (args[:1] + ((lrec, grec, arec._replace(ball=ball)),) + args[2:],
                 {k: v for k, v in kw.items() if k != "dgrid"})
        out.append((args, kw, nodes))
    return out


LIGHT_SETS = {
    "point inside, coloured": [PointLight((0.1, -0.2, 0.05), intensity=(3.0, 2.5, 2.0))],
    "point outside, grey": [PointLight((0.3, -1.6, 0.9), intensity=2.0)],
    "directional + point": [DirectionalLight((0.2, 0.3, -1.0), irradiance=0.5),
                            PointLight((-0.4, 0.3, 0.2), intensity=(1.0, 0.8, 0.6))],
}


@pytest.mark.parametrize("model", ["single_scattering", "ambient_scattering"])
@pytest.mark.parametrize("lights", list(LIGHT_SETS))
def test_rows_equal_the_node_rule(model, lights):
    # exp and log by polynomials (1e-13, 1e-15) and the last cell at fraction 1: equal to float32
    # rounding of the baked value; ambient scattering's ball term reads D in 16 bits (half a step is
    # 7.7e-6 of the table's largest D: stages.bake.BallD), the node rule the exact lookup
    calls = captured_bakes(coloured_grid(), LIGHT_SETS[lights], model)
    assert calls
    for args, kw, (nargs, nkw) in calls:
        model_id, records, _, grid = args[:4]
        assert stage_bake.rows_apply(model_id, records, grid, kw.get("phis"), kw.get("dgrid"))
        rows, nch = stage_bake.bake_incident(*args, **kw, driver="rows")
        nodes, nch_n = stage_bake.bake_incident(*nargs, **nkw, driver="nodes")
        assert nch == nch_n and rows.shape == nodes.shape
        tol = 1e-5 if kw.get("dgrid") is not None else 1e-6
        assert np.abs(rows - nodes).max() <= tol * np.abs(nodes).max()
        assert np.abs(nodes).max() > 0


def test_grey_albedo_bakes_one_channel_alike():
    g = coloured_grid()
    g["albedo"] = np.full((g.n_points, 3), 0.7, np.float32)
    for args, kw, (nargs, nkw) in captured_bakes(g, LIGHT_SETS["point outside, grey"], "ambient_scattering"):
        assert kw["dgrid"].shape[3] == 1  # D of a grey albedo: one channel
        rows, nch = stage_bake.bake_incident(*args, **kw, driver="rows")
        nodes, _ = stage_bake.bake_incident(*nargs, **nkw, driver="nodes")
        assert nch == 1
        assert np.abs(rows - nodes).max() <= 1e-5 * np.abs(nodes).max()  # D in 16 bits, as above


def test_cases_outside_the_rows_take_the_node_rule():
    # a light grid finer than the data, or the tube front: rows_apply says no and the default
    # driver gives the node rule's array itself
    calls = captured_bakes(coloured_grid(), LIGHT_SETS["point inside, coloured"], "ambient_scattering")
    args, kw, (nargs, nkw) = calls[0]
    model_id, records, geometry, grid = args[:4]
    dgrid = kw["dgrid"]
    assert not stage_bake.rows_apply(model_id, records, grid, [np.zeros(tuple(grid.shape) + (3,), np.float32)], dgrid)
    assert not stage_bake.rows_apply(model_id, records, grid, None, None)  # ambient scattering without D
    from pv_ambient.stages.propagation import make_light_grid

    fine = make_light_grid(geometry, 2.0)
    assert not stage_bake.rows_apply(model_id, records, fine, None, dgrid)
    with pytest.raises(ValueError, match="driver"):
        stage_bake.bake_incident(*args, **kw, driver="fast")
    with pytest.raises(ValueError, match="ball grid"):
        stage_bake.bake_incident(*args, **{k: v for k, v in kw.items() if k != "dgrid"}, driver="nodes")


def test_ball_d_equals_the_table_lookup_and_replaces_the_ball():
    # D per sample against preint.d_lookup at the ball's τ and albedo, per channel; the render
    # that made it keeps it and not the ball grid
    from pv_ambient._kernels.preint import d_lookup

    g = coloured_grid()
    r = pa.Renderer(g, transfer_function=pa.TransferFunction.physical(), lights=LIGHT_SETS["point inside, coloured"])
    r.render(camera=CAM, window_size=SIZE, model="ambient_scattering", quality="balanced", light_resolution=1.0)
    (key, dgrid), = r.cache.items("ball_d")
    assert not r.cache.keys("ball") and dgrid.shape[3] == 3
    radius = key[1]
    ball = r.stages.ball_grid(radius)
    D, _, a_nodes, lo_log, dlog = r.cache[key[2]].lookup_args()
    rng = np.random.default_rng(2)
    for idx in rng.integers(0, ball.shape[:3], (200, 3)):
        b = ball[tuple(idx)].astype(np.float64)
        for c in range(3):
            expect = d_lookup(D, a_nodes, lo_log, dlog, 1.0, radius * b[0], b[1 + c])
            # 16 bits: within half a step of the table's largest D over 65535 (stages.bake.BallD)
            got = float(dgrid.values[tuple(idx) + (c,)]) * dgrid.scale
            assert abs(got - expect) <= 0.5 * dgrid.scale * (1 + 1e-6) + 1e-6 * abs(expect)
    assert dgrid.values.dtype == np.uint16 and dgrid.scale == pytest.approx(float(np.max(D)) / 65535, rel=1e-12)


def test_log_pos_against_math_log():
    from pv_ambient._kernels.expneg import log_pos

    rng = np.random.default_rng(0)
    values = np.concatenate([10.0 ** rng.uniform(-300, 300, 2000), rng.uniform(0.5, 2.0, 2000),
                             [1.0, 2.0, 0.5, math.sqrt(2.0), np.nextafter(math.sqrt(2.0), 2.0), 1e-5, 17.5]])
    err = max(abs(log_pos(float(v)) - math.log(v)) / max(1.0, abs(math.log(v))) for v in values)
    assert err <= 1e-15


def test_relight_rebakes_in_place_and_equals_a_fresh_render():
    # two point lights and a directional one on the row driver: moving one point light and the
    # directional light rebakes their slots in the replaced array (the other point light's slot
    # kept, the moved one written whole, the directional slot cleared first), and the picture
    # equals a fresh renderer's to the bit
    still = PointLight((-0.2, 0.15, 0.1), intensity=0.7)
    before = [PointLight((0.05, 0.0, -0.1), intensity=(1.0, 0.8, 0.6)), still,
              DirectionalLight((0.2, 0.3, -1.0), irradiance=0.5)]
    after = [PointLight((0.3, -0.2, 0.0), intensity=(1.0, 0.8, 0.6)), still,
             DirectionalLight((-0.5, 0.1, -0.8), irradiance=0.4)]
    opts = dict(camera=CAM, window_size=SIZE, model="ambient_scattering", quality="balanced", light_resolution=1.0)
    g = coloured_grid()
    r = pa.Renderer(g, transfer_function=pa.TransferFunction.physical(), lights=before)
    r.render(**opts)
    (_, (old, _)), = r.cache.items("incident")
    r.set_lights(after)
    again = r.render(**opts).radiance
    (_, (inc, _)), = r.cache.items("incident")
    assert inc is old  # rebaked in place
    fresh = pa.Renderer(g, transfer_function=pa.TransferFunction.physical(), lights=after).render(**opts).radiance
    assert np.array_equal(again, fresh) and fresh.max() > 0
