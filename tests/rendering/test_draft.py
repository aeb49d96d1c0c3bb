"""Tests pv_ambient/rendering/draft.py and pv_ambient/_kernels/draft.py: draft frames
(``render(..., draft=True)``, what an interactive drag renders; docs/performance.rst, "Draft
frames"). Emission–absorption's draft of a one-colour transfer function is the full frame of the
volume subsampled to every other sample (an independent render of that volume); a lit draft's
record holds the full model's source
at those samples (the per-pixel march's function, called there directly) and its picture stays
near the full frame's; the record is shaded once per scene and light set; where a draft does not
apply the full frame is rendered."""

import numpy as np
import pytest
import pyvista as pv

import pv_ambient as pa
from pv_ambient.inputs.camera import Camera

CAM = Camera((0.3, -3.6, 0.8), (0.0, 0.0, 0.0), (0, 0, 1), view_angle=35)
SIZE = (40, 32)


def blob_grid(n=33, spacing=None):
    """A smooth scalar blob with a shell on [−1, 1]³, n odd: every other sample spans the same box."""
    h = 2.0 / (n - 1) if spacing is None else spacing
    g = pv.ImageData(dimensions=(n, n, n), spacing=(h, h, h), origin=(-1.0, -1.0, -1.0))
    p = g.points
    r = np.linalg.norm(p - np.array([0.1, -0.05, 0.0]), axis=1)
    g["s"] = (np.exp(-3.0 * r ** 2) + 0.6 * np.exp(-((r - 0.6) / 0.15) ** 2)).astype(np.float32)
    return g


def half_of(grid):
    """Every other sample of ``grid`` (n odd) as an ImageData of twice the spacing."""
    n = grid.dimensions
    s = np.asarray(grid["s"]).reshape(n, order="F")[::2, ::2, ::2]
    out = pv.ImageData(dimensions=s.shape, spacing=tuple(2 * v for v in grid.spacing), origin=grid.origin)
    out["s"] = np.ascontiguousarray(s).ravel(order="F")
    return out


TF = dict(cmap="magma", clim=(0.0, 1.0), density_scale=6.0, albedo=0.9)


def renderer(grid, lights=()):
    return pa.Renderer(grid, transfer_function=pa.TransferFunction(**TF), lights=list(lights), backend="cpu")


def test_emission_absorption_draft_is_the_full_frame_of_every_other_sample():
    # one colour, so that the draft's colour shaded at the samples is the full frame's; its opacity
    # reads the table at the interpolated scalar's 16-bit code: equal to a full render of the
    # subsampled volume to the code's rounding (3·255/65535 of a table entry; 6e-5 here)
    from matplotlib.colors import ListedColormap

    grid = blob_grid()
    tf = pa.TransferFunction(cmap=ListedColormap(["#ff8040"]), clim=(0.0, 1.0), density_scale=6.0)
    r = pa.Renderer(grid, transfer_function=tf, backend="cpu")
    step = r.default_step() * 2
    draft = r.render(camera=CAM, window_size=SIZE, step=step, draft=True)
    assert draft.metadata["draft"]
    full = pa.Renderer(half_of(grid), transfer_function=tf, backend="cpu").render(camera=CAM, window_size=SIZE,
                                                                                    step=step)
    assert not full.metadata["draft"]
    assert np.abs(draft.radiance - full.radiance).max() <= 3e-4 * full.radiance.max()
    assert np.abs(draft.alpha - full.alpha).max() <= 3e-4


def test_lit_draft_record_holds_the_models_source_at_every_other_sample():
    # the packed record at level sample (i, j, k), unpacked here in NumPy, holds table_source of the
    # full frame's records at data sample (2i, 2j, 2k) (called here point by point) times
    # max(d², d2min) to the point light to its 16-bit square-root code's precision, and the scalar's
    # table coordinate there to its code's
    import numba

    from pv_ambient._kernels.medium import step_lookup
    from pv_ambient._kernels.raycast import table_source
    from pv_ambient.rendering.camera_pass import render_camera_pass
    from pv_ambient.rendering.draft import draft_args

    @numba.njit
    def source_at(model, march, medium, lights, grid, ambient, diffusion, x, y, z, w):
        q0, fq = step_lookup(medium.field, march.opacity, medium.lut_lo, medium.lut_inv, x, y, z)
        return table_source(model, march.opacity, q0, fq, x, y, z, w[0], w[1], w[2], lights, grid, ambient, diffusion)

    grid = blob_grid(n=17)
    r = renderer(grid, [pa.PointLight((0.2, -1.5, 0.6), intensity=3.0), pa.DirectionalLight((0.3, 0.2, -1.0))])
    for model in ("single_scattering", "diffusion"):
        records = []
        req = r.request(camera=CAM, window_size=SIZE, model=model, draft=True)
        render_camera_pass(r, req, model, {}, records=records)
        args = records[0]
        (_, _, march, medium, ref, _, _, diffusion), scale = draft_args(r, args)
        assert np.array_equal(ref.vec[0], args[4].vec[0])  # the point light is the reference
        words = diffusion.field
        assert words.shape == (9, 9, 9, 2) and words.dtype == np.uint32 and medium.field.shape == (9, 9, 9)
        code = (words[..., 0] & 0xFFFF).astype(np.float64)
        assert np.array_equal(medium.field, code.astype(np.float32))  # the scalar pass reads the same codes
        src = scale * np.stack([(words[..., 0] >> 16), words[..., 1] & 0xFFFF, words[..., 1] >> 16], -1).astype(
            np.float64) ** 2
        top = src.max()
        lights = args[4]._replace(d2min=float(np.min(r.geometry.spacing)) ** 2)
        m = args[2].opacity.shape[0] - 1
        full = args[3]
        for i, j, k in np.random.default_rng(1).integers(0, 9, size=(40, 3)):
            x, y, z = 2.0 * i, 2.0 * j, 2.0 * k
            w = r.geometry.index_to_world @ np.array([x, y, z, 1.0])
            weight = max(float(np.sum((w[:3] - ref.vec[0]) ** 2)), ref.d2min)  # the record holds source × d²
            expect = weight * np.array(source_at(args[0], args[2], full, lights, *args[5:], x, y, z, w))
            tol = 2.0 * np.sqrt(expect * top) / 65535 + 1e-6 * top
            assert np.all(np.abs(src[i, j, k] - expect) <= tol)
            u = (full.field[2 * i, 2 * j, 2 * k] - full.lut_lo) * full.lut_inv
            u_code = (code[i, j, k] - medium.lut_lo) * medium.lut_inv
            assert abs(u_code - np.clip(u, -m, 2 * m)) <= 3 * m / 65535


def block_error(res, ref):
    """Mean |difference| of 4 × 4-pixel block means over the reference's mean."""
    a, b = (x.radiance.reshape(8, 4, 10, 4, 3).mean(axis=(1, 3)) for x in (res, ref))
    return np.abs(a - b).mean() / b.mean()


@pytest.mark.parametrize("model", ["single_scattering", "ambient_scattering", "diffusion"])
def test_lit_draft_stays_near_the_full_frame(model):
    # a directional light (no 1/d² peak to round off), a shell 2.4 samples thick: the level halves
    # it, which moves emission–absorption's draft by some per cent; the lit draft's interpolated
    # lighting adds at most 1.5 per cent to that (4.1, 4.0, 3.6 % against 3.0 % here)
    grid = blob_grid(n=33)
    r = renderer(grid, [pa.DirectionalLight((0.3, 0.2, -1.0), irradiance=2.0)])
    step = 2 * r.default_step()
    ea = [r.render(camera=CAM, window_size=SIZE, step=step, draft=d) for d in (False, True)]
    full = r.render(camera=CAM, window_size=SIZE, model=model, step=step)
    draft = r.render(camera=CAM, window_size=SIZE, model=model, step=step, draft=True)
    assert draft.metadata["draft"] and not full.metadata["draft"]
    assert block_error(draft, full) <= block_error(ea[1], ea[0]) + 0.015


def test_draft_record_is_shaded_once_per_scene_and_light_set():
    grid = blob_grid(n=17)
    light = pa.PointLight((0.2, -1.5, 0.6), intensity=3.0)
    r = renderer(grid, [light])
    r.render(camera=CAM, window_size=SIZE, model="single_scattering", draft=True)
    rec = r.cache[("draft_record",)][1]
    for k, step in enumerate((None, 0.1, 0.2)):  # camera moves, and a drag's changing step
        cam = Camera((0.3 + 0.1 * k, -3.6, 0.8), (0.0, 0.0, 0.0), (0, 0, 1), view_angle=35)
        r.render(camera=cam, window_size=SIZE, model="single_scattering", step=step, draft=True)
        assert r.cache[("draft_record",)][1] is rec
    r.set_lights([pa.PointLight((0.25, -1.5, 0.6), intensity=3.0)])  # a relight shades it again
    res = r.render(camera=CAM, window_size=SIZE, model="single_scattering", draft=True)
    assert res.metadata["draft"] and r.cache[("draft_record",)][1] is not rec


def test_draft_record_keeps_no_replaced_bake_alive():
    # the record's cache entry refers to the bake it was shaded from weakly: once the stage cache
    # drops that bake (a relight), the entry no longer holds it
    import gc
    import weakref

    r = renderer(blob_grid(n=17), [pa.PointLight((0.2, -1.5, 0.6), intensity=3.0)])
    r.render(camera=CAM, window_size=SIZE, model="single_scattering", draft=True)
    (_, (inc, _)), = r.cache.items("incident")
    gone = weakref.ref(inc)
    del inc
    r.cache.clear("incident")
    gc.collect()
    assert gone() is None
    r.render(camera=CAM, window_size=SIZE, model="single_scattering", draft=True)  # shaded again, from the new bake


def test_draft_renders_the_full_frame_where_it_does_not_apply():
    grid = blob_grid(n=17)
    r = renderer(grid, [pa.PointLight((0.2, -1.5, 0.6), intensity=3.0)])
    for model, kw in (("ambient_occlusion", {}), ("single_scattering", {"phase": 0.5})):
        draft = r.render(camera=CAM, window_size=SIZE, model=model, draft=True, **kw)
        full = r.render(camera=CAM, window_size=SIZE, model=model, **kw)
        assert not draft.metadata["draft"]
        assert np.array_equal(draft.radiance, full.radiance)
    tiny = renderer(blob_grid(n=3))  # fewer than 4 samples per axis: no level
    assert not tiny.render(camera=CAM, window_size=SIZE, draft=True).metadata["draft"]
