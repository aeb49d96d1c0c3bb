"""Tests pv_ambient/rendering/record.py, pv_ambient/stages/record.py and pv_ambient/_kernels/record.py:
the lit record a CPU camera pass reads (docs/performance.rst, "Lit record") — its light at the data
samples is the bake's, its image the bake's within the codes' precision, the scalar fallback reads
it too, and where it does not apply the frame is the bake's, bit for bit."""

import numpy as np
import pytest
import pyvista as pv

import pv_ambient as pa
from pv_ambient._kernels import packet
from pv_ambient._kernels.models import RECORD, RECORD_GREY, RECORD_PAIR
from pv_ambient.inputs.camera import Camera

CAM = Camera((0.4, -3.5, 0.8), (0.0, 0.05, 0.0), (0, 0, 1), view_angle=38)
SIZE = (40, 32)
RAYCAST_PACKETS = packet.raycast_packets


def blob(dims=(25, 22, 19)):
    """A smooth scalar blob on a non-cubic grid."""
    g = pv.ImageData(dimensions=dims, spacing=(0.1, 0.11, 0.13), origin=(-1.2, -1.1, -1.1))
    p = g.points
    g["d"] = np.exp(-2.0 * (p[:, 0] ** 2 + 1.5 * p[:, 1] ** 2 + 2.0 * (p[:, 2] - 0.1) ** 2)).astype(np.float32)
    return g


def renderer(lights=None):
    tf = pa.TransferFunction(cmap="viridis", clim=(0.1, 1.0), opacity="linear", opacity_unit_distance=0.3,
                             albedo=0.8)
    lights = lights or [pa.PointLight((0.1, -0.05, 0.1), intensity=(3.0, 2.0, 1.0))]
    return pa.Renderer(blob(), transfer_function=tf, lights=lights)


def render(r, monkeypatch, record, model="ambient_scattering", **kw):
    """``r``'s frame with the lit record on or off (``PV_AMBIENT_RECORD``), on the light grid of the
    data samples, and the kernel models that ran in packets."""
    models = []

    def spy(*a):
        models.append(a[0])
        return RAYCAST_PACKETS(*a)

    monkeypatch.setattr(packet, "raycast_packets", spy)
    monkeypatch.setenv("PV_AMBIENT_RECORD", "1" if record else "0")
    kw.setdefault("quality", "preview")
    res = r.render(camera=CAM, window_size=SIZE, model=model, light_resolution=1.0, progress_bar=False, **kw)
    return res, models


DIRECTIONAL = pa.DirectionalLight((0.3, 0.5, -1.0), irradiance=(7.0, 5.0, 3.0))
WHITE = pa.PointLight((0.1, -0.05, 0.1), intensity=2.0)  # a grey bake under the TF's grey albedo


def lights_of(kind):
    """The lights of each record's test scene."""
    return {RECORD: None, RECORD_GREY: [WHITE],
            RECORD_PAIR: [pa.PointLight((0.1, -0.05, 0.1), intensity=(3.0, 2.0, 1.0)), DIRECTIONAL]}[kind]


@pytest.mark.parametrize("model, lights", [("single_scattering", "point"), ("ambient_scattering", "point"),
                                           ("ambient_scattering", "directional"), ("diffusion", "directional"),
                                           ("ambient_scattering", "both"), ("diffusion", "point"),
                                           ("single_scattering", "white"),
                                           ("single_scattering", "white directional")])
def test_record_renders_the_bakes_image(model, lights, monkeypatch):
    """One rgb point light (the reference: its in-scattering is the bake's), or a directional light
    (with diffusion's field in its slot; a constant reference weight) — the one-slot record — or a
    point light beside a directional light or diffusion's field — the pair record, its slots apart —
    or a white point or directional light under the grey albedo — the grey record, one word: the
    record's image is the bake's within the 16-bit codes (the scalar to 3·(n−1)/65535 of a table
    entry, the light to 1.5e-5 of its largest value)."""
    point = pa.PointLight((0.1, -0.05, 0.1), intensity=(3.0, 2.0, 1.0))
    white_dir = pa.DirectionalLight((0.3, 0.5, -1.0), irradiance=5.0)
    r = renderer({"point": [point], "directional": [DIRECTIONAL], "both": [DIRECTIONAL, point], "white": [WHITE],
                  "white directional": [white_dir]}[lights])
    kind = (RECORD_PAIR if lights == "both" or (model, lights) == ("diffusion", "point")
            else RECORD_GREY if lights.startswith("white") else RECORD)
    old, m0 = render(r, monkeypatch, False, model)
    new, m1 = render(r, monkeypatch, True, model)
    assert kind not in m0 and m1 and set(m1) == {kind}
    a, b = np.asarray(old.radiance, np.float64), np.asarray(new.radiance, np.float64)
    assert a.mean() > 1e-2 and old.alpha.max() > 0.3
    assert np.abs(a - b).max() <= 2e-4 * a.max()
    assert np.abs(old.alpha - new.alpha).max() <= 2e-4


@pytest.mark.parametrize("kind", [RECORD, RECORD_GREY])
def test_record_light_is_the_bakes_slot(kind, monkeypatch):
    """At every data sample the record's decoded light is the bake's point-light slot, to the codes'
    precision (the slot holds the light times ``max(d², d2min)``, as the record does)."""
    from pv_ambient.rendering import camera_pass

    got = []
    real = camera_pass.record_args

    def spy(renderer, args):
        got.append((args, real(renderer, args)))
        return got[-1][1]

    monkeypatch.setattr(camera_pass, "record_args", spy)
    r = renderer(lights_of(kind))
    render(r, monkeypatch, True, "single_scattering" if kind == RECORD_GREY else "ambient_scattering")
    args, rec = got[-1]
    assert rec[0] == kind
    words, ref, grid, lights = rec[7].field, rec[4], args[5], args[4]
    scale = float(ref.power[0, 0])
    if kind == RECORD_GREY:
        light = (words[..., :1] >> 16).astype(np.float64)
    else:
        light = np.stack([(words[..., 0] >> 16), words[..., 1] & 0xFFFF, words[..., 1] >> 16], -1).astype(np.float64)
    light = light ** 2 * scale
    want = np.asarray(grid.inc, np.float64)
    assert want.shape == light.shape
    top = want.max()
    assert top > 0 and np.abs(light - want).max() <= 2e-4 * top
    assert np.array_equal(lights.vec[0], ref.vec[0]) and ref.d2min == lights.d2min


@pytest.mark.parametrize("lights", ["point", "both", "white"])
def test_packing_holds_no_shaded_copy(lights, monkeypatch):
    """Packing a record allocates its words and scalar codes and nothing of the volume's size
    beside them (NumPy's allocations, traced): 12 bytes per data sample for the one-slot record,
    20 for the pair, 8 for the grey record — a shaded float32 copy (16 bytes per sample) or a
    float64 copy of the bake's slots would more than double that at the first frame's peak. The
    words are the ones the renderer packed."""
    import tracemalloc

    from pv_ambient.rendering import record as rmod
    from pv_ambient.stages.record import packed_light_record, packed_pair_record

    calls = []
    real = rmod._record

    def spy(renderer, args, ref, kind):
        calls.append((renderer, args, ref, kind, real(renderer, args, ref, kind)))
        return calls[-1][-1]

    monkeypatch.setattr(rmod, "_record", spy)
    kind = {"point": RECORD, "both": RECORD_PAIR, "white": RECORD_GREY}[lights]
    render(renderer(lights_of(kind)), monkeypatch, True, "single_scattering" if kind == RECORD_GREY else "ambient_scattering")
    r, args, ref, got, packed = calls[-1]
    assert got == kind
    medium, grid = args[3], args[5]
    n = medium.field.size
    tracemalloc.start()
    try:
        if kind != RECORD_PAIR:
            words, codes, _, _ = packed_light_record(medium, args[4], grid, ref)
        else:
            words, codes, _, _ = packed_pair_record(medium, grid)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    held = words.nbytes + codes.nbytes
    assert held == n * {RECORD: 12, RECORD_PAIR: 20, RECORD_GREY: 8}[kind]
    assert peak <= held + 0.5 * 4 * n, (peak, held)
    np.testing.assert_array_equal(words, packed[0])
    np.testing.assert_array_equal(codes, packed[1])


@pytest.mark.parametrize("kind", [RECORD, RECORD_PAIR, RECORD_GREY])
def test_scalar_fallback_reads_the_record(kind, monkeypatch):
    """``PV_AMBIENT_PACKETS=0`` marches the same record one ray at a time: the packets' image."""
    r = renderer(lights_of(kind))
    model = "single_scattering" if kind == RECORD_GREY else "ambient_scattering"
    a, m = render(r, monkeypatch, True, model)
    monkeypatch.setenv("PV_AMBIENT_PACKETS", "0")
    b, m2 = render(r, monkeypatch, True, model)
    assert set(m) == {kind} and not m2
    assert np.abs(np.asarray(a.radiance, np.float64) - b.radiance).max() <= 1e-6 * float(a.radiance.max())
    assert np.abs(a.alpha - b.alpha).max() <= 1e-6


@pytest.mark.parametrize("case", ["two_grey_slots", "two_point_lights", "refined_grid"])
def test_the_bake_where_the_record_does_not_apply(case, monkeypatch):
    """Two grey slots (a white point light beside a white directional light) read three values per
    corner, as many as a record would; a second point light's slot would need its own ``d²``; a
    light grid finer than the data is not on its samples: the frame is the bake's, bit for bit."""
    lights = None
    if case == "two_grey_slots":
        lights = [WHITE, pa.DirectionalLight((0.3, 0.5, -1.0), irradiance=5.0)]
    elif case == "two_point_lights":
        lights = [pa.PointLight((0.1, -0.05, 0.1), intensity=(3.0, 2.0, 1.0)),
                  pa.PointLight((-0.3, 0.2, 0.0), intensity=(1.0, 2.0, 1.0))]
    r = renderer(lights)
    model = "single_scattering" if case == "two_grey_slots" else "ambient_scattering"
    if case == "refined_grid":
        monkeypatch.setenv("PV_AMBIENT_RECORD", "1")
        res = r.render(camera=CAM, window_size=SIZE, model=model, light_resolution=2.0, quality="preview",
                       progress_bar=False)
        monkeypatch.setenv("PV_AMBIENT_RECORD", "0")
        ref = r.render(camera=CAM, window_size=SIZE, model=model, light_resolution=2.0, quality="preview",
                       progress_bar=False)
        assert np.array_equal(res.radiance, ref.radiance)
        return
    old, _ = render(r, monkeypatch, False, model)
    new, m = render(r, monkeypatch, True, model)
    assert not {RECORD, RECORD_PAIR, RECORD_GREY} & set(m) and np.array_equal(old.radiance, new.radiance)


@pytest.mark.parametrize("kind", [RECORD, RECORD_PAIR, RECORD_GREY])
def test_one_and_two_threads_render_the_record_bit_for_bit(kind, monkeypatch):
    """Each pixel's ray is marched by one thread whatever the count: 1 and 2 threads, the same bits."""
    import numba

    r = renderer(lights_of(kind))
    model = "single_scattering" if kind == RECORD_GREY else "ambient_scattering"
    n0 = numba.get_num_threads()
    out = []
    try:
        for threads in sorted({1, min(2, numba.config.NUMBA_NUM_THREADS)}):
            numba.set_num_threads(threads)
            res, m = render(r, monkeypatch, True, model)
            assert set(m) == {kind}
            out.append(res)
    finally:
        numba.set_num_threads(n0)
    for res in out[1:]:
        np.testing.assert_array_equal(res.radiance, out[0].radiance)
        np.testing.assert_array_equal(res.alpha, out[0].alpha)
