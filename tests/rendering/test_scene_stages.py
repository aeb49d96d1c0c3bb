"""Tests pv_ambient/rendering/scene_stages.py: which stage runs when — a camera move computes nothing
but the ray cast, a relight only the moved light's entries — and the renderers of other colours
that share its σt-only entries."""
import pickle

import weakref

import numpy as np

import pv_ambient as pa

from pv_ambient.inputs.camera import Camera
from pv_ambient.inputs.lights import PointLight
from pv_ambient.rendering.cache import SIGMA_ONLY

from ..helpers import LIGHTS, SIZE, physical_grid, rel, render, renderer


def test_camera_move_and_relight_reuse_caches():
    r = renderer(physical_grid())
    render(r, "ambient_scattering", propagation="tube")
    keys = set(r.cache)
    cam2 = Camera((1.0, -3.5, 0.5), (0, 0, 0), (0, 0, 1), view_angle=35)
    r.render(camera=cam2, window_size=SIZE, model="ambient_scattering", quality="preview", propagation="tube")
    assert set(r.cache) == keys  # a camera move computes nothing but the ray cast
    moved = PointLight((-0.3, -1.6, 0.9), intensity=(3.0, 2.5, 2.0))
    r.set_lights([moved, LIGHTS[1]])
    render(r, "ambient_scattering", propagation="tube")
    # σt, dropped before the first frame's new bake array (SceneStages._release_sigma), is classified
    # again for the moved light's sweep; the relight's bake is in place and keeps it
    assert [k for k in r.cache if k[0] == "sigma_l"]
    new = {k for k in set(r.cache) - keys if k[0] != "sigma_l"}
    # only the moved light's volumes are computed, and the new set of lights' baked in-scattering
    # (isotropic phase), which replaces the old set's; a bake reads each light's volumes where they
    # are, so no side-by-side copy of them is made
    assert new and all(moved in (k[1] if k[0] == "incident" else k) for k in new)
    assert sum(k[0] == "incident" for k in new) == 1 and sum(k[0] == "incident" for k in r.cache) == 1
    assert not [k for k in r.cache if k[0] in ("tau_stack", "front_stack")]


def test_relight_resolves_only_the_moved_light():
    r = renderer(physical_grid())
    render(r, "diffusion")
    keys = {k for k in r.cache if k[0] == "diffusion"}
    assert len(keys) == 2  # one solve per light
    moved = PointLight((-0.3, -1.6, 0.9), intensity=(3.0, 2.5, 2.0))
    r.set_lights([moved, LIGHTS[1]])
    render(r, "diffusion")
    new = {k for k in r.cache if k[0] == "diffusion"} - keys
    assert len(new) == 1 and moved in next(iter(new))


def test_other_colours_of_the_same_sigma_reuse_its_light_volumes_and_share_the_device():
    """``Renderer.with_optics`` (a TF of the same σt, other colours): the σt-only entries carried over
    by reference — a render then computes no light volume again — and one GPU cache for both."""
    r = renderer(physical_grid(n=9))
    render(r, "single_scattering")
    assert {"incident", "tau", "light_grid", "cast_majorant"} <= r.cache.kinds()
    other = r.with_optics(r.optics.albedo_as_colour())
    # σt itself was dropped before the bake array was made (SceneStages._release_sigma)
    assert other.cache.kinds() == r.cache.kinds() & SIGMA_ONLY == {"cast_majorant", "light_grid", "tau"}
    taus = {k: r.cache[k] for k in r.cache.keys("tau")}
    assert len(taus) == len(LIGHTS)
    render(other, "single_scattering")
    assert all(other.cache[k] is v for k, v in taus.items())  # reused, not recomputed
    assert other.device_cache is r.device_cache
    assert r.stages.device_for("cpu") is None and r.stages.device_for("cuda") is r.device_cache


def test_stages_sent_to_another_process_leave_the_device_copies_behind():
    r = renderer(physical_grid(n=9))
    render(r, "single_scattering")
    shipped = pickle.loads(pickle.dumps(r.stages))  # what a Dask worker receives
    assert shipped.cache.kinds() == r.cache.kinds()
    assert shipped.device_nbytes == 0 and shipped.device_cache is not r.device_cache


def _solve_of(r, light):
    """(packed field, info) of ``light``'s diffusion solve in ``r``'s cache."""
    (key,) = [k for k in r.cache.keys("diffusion") if k[1] == light]
    return r.cache[key]


def _phi(packed):
    from pv_ambient._kernels.raycast import diffusion_layout

    return packed[..., 0::diffusion_layout(packed.shape[3])[0]].astype(np.float64)


def tight_solves(monkeypatch):
    """The preview preset (the helpers' render) solving to 1e-6, so that two solves of one light agree to
    ~1e-6 whatever they start from."""
    from pv_ambient.rendering.presets import QUALITY_PRESETS

    monkeypatch.setitem(QUALITY_PRESETS["preview"], "diffusion_tol", 1e-6)


def test_relights_keep_only_the_current_lights_volumes():
    # a drag visits many light positions: each relight drops the volumes of the lights that left,
    # keeping only the latest diffusion solution of a light that left (the next warm start)
    r = renderer(physical_grid())
    render(r, "diffusion")
    render(r, "ambient_scattering", propagation="tube")
    for k in range(4):
        moved = PointLight((-0.3 + 0.05 * k, -1.6, 0.9), intensity=(3.0, 2.5, 2.0))
        r.set_lights([moved, LIGHTS[1]])
        render(r, "diffusion")
        render(r, "ambient_scattering", propagation="tube")
        for kind in ("tau", "front", "reaches"):
            assert {k[1] for k in r.cache.keys(kind)} == {moved, LIGHTS[1]}, kind
        solved = [k[1] for k in r.cache.keys("diffusion")]
        assert len(solved) == 3 and moved in solved and LIGHTS[1] in solved  # and the one that left last
    r.set_lights([LIGHTS[1]])
    assert {k[1] for k in r.cache.keys("tau")} == {LIGHTS[1]}


def test_relight_sweeps_into_the_optical_depth_of_the_light_that_left():
    """A relight (one of two lights moved) sweeps the moved light's τ into the array of the light
    that left (no fresh 64 MB at 256³; docs/performance.rst, "Relight: the light sweep"), with
    the values of a sweep into a new array; a renderer sharing the cache keeps its arrays (they
    are not reused), and removing a light keeps no spare."""
    from pv_ambient.stages.propagation import optical_depth

    r = renderer(physical_grid())
    render(r, "single_scattering")
    (old_key,) = [k for k in r.cache.keys("tau") if k[1] == LIGHTS[0]]
    old = weakref.ref(r.cache[old_key])  # a reference held here would keep it from being reused
    moved = PointLight((-0.25, -1.6, 0.9), intensity=(3.0, 2.5, 2.0))
    r.set_lights([moved, LIGHTS[1]])
    render(r, "single_scattering")
    (new_key,) = [k for k in r.cache.keys("tau") if k[1] == moved]
    tau = r.cache[new_key]
    assert old() is tau
    (grid,) = [r.cache[k] for k in r.cache.keys("light_grid") if r.cache[k].key() == new_key[2]]
    fresh = optical_depth(r.stages.sigma_on_light_grid(grid), grid, r.stages.geometry, moved)
    assert np.array_equal(tau, fresh)
    # a second renderer holding the same arrays: nothing is reused under it
    other = renderer(physical_grid(), [moved, LIGHTS[1]])
    other.cache.share(r.cache, kinds=("tau",))
    held = weakref.ref(r.cache[new_key])
    del tau
    again = PointLight((-0.2, -1.6, 0.9), intensity=(3.0, 2.5, 2.0))
    r.set_lights([again, LIGHTS[1]])
    render(r, "single_scattering")
    (k2,) = [k for k in r.cache.keys("tau") if k[1] == again]
    assert held() is not None and r.cache[k2] is not held() and np.array_equal(held(), fresh)
    r.set_lights([LIGHTS[1]])
    assert r.stages._spare == []


def test_relight_starts_warm_from_the_moved_light(monkeypatch):
    """A relight's solve starts from the moved light's solution (docs/diffusion.rst, "Warm starts"):
    fewer CG iterations than the cold solve of the same light in a new renderer, and the same φ
    within what the stopping tolerance (relative residual 1e−6) allows."""
    tight_solves(monkeypatch)
    grid = physical_grid(n=33)
    light = PointLight((0.3, -1.6, 0.9), intensity=(3.0, 2.5, 2.0))
    moved = PointLight((0.34, -1.6, 0.9), intensity=(3.0, 2.5, 2.0))
    r = renderer(grid, [light])
    render(r, "diffusion", phase=0.3)
    r.set_lights([moved])
    render(r, "diffusion", phase=0.3)
    cold = renderer(grid, [moved])
    render(cold, "diffusion", phase=0.3)
    warm_field, warm = _solve_of(r, moved)
    cold_field, cold_info = _solve_of(cold, moved)
    assert warm["converged"] and cold_info["converged"]
    assert warm["iterations"] < cold_info["iterations"]
    assert rel(_phi(warm_field), _phi(cold_field)) < 1e-5


def test_transfer_function_change_starts_warm_from_the_shared_solution(monkeypatch):
    """A renderer of other optics on the same grid that shares the ``diffusion_start`` entries
    starts each light's solve from that light's previous solution: fewer iterations than cold, the
    same φ within the tolerance (1e-6); a colour change through ``with_optics`` carries them over."""
    tight_solves(monkeypatch)
    grid = physical_grid(n=33)
    light = [LIGHTS[0]]
    r = renderer(grid, light)
    render(r, "diffusion")
    grid2 = grid.copy()
    grid2["albedo"] = grid["albedo"] * 0.97
    warm = renderer(grid2, light)
    warm.cache.share(r.cache, kinds=("diffusion_start",))
    render(warm, "diffusion")
    cold = renderer(grid2, light)
    render(cold, "diffusion")
    warm_field, warm_info = _solve_of(warm, light[0])
    cold_field, cold_info = _solve_of(cold, light[0])
    assert warm_info["converged"] and warm_info["iterations"] < cold_info["iterations"]
    assert rel(_phi(warm_field), _phi(cold_field)) < 1e-5
    other = r.with_optics(r.optics)
    assert any(k[0] == "diffusion_start" for k in other.cache)


def test_light_grid_on_the_samples_shares_the_samples_sigma():
    # where the light-grid nodes are the data samples, σt on them is the samples' σt: one cached
    # array (the ball grid's input too), equal to sampling it node by node
    import pyvista as pv

    from pv_ambient.stages.propagation import sigma_on_grid

    g = pv.ImageData(dimensions=(9, 8, 7))
    g["d"] = np.random.default_rng(3).random(g.n_points).astype(np.float32)
    for r in (renderer(physical_grid()), pa.Renderer(g, transfer_function=pa.TransferFunction(clim=(0, 1)))):
        grid = r.stages.light_grid(1.0)
        assert grid.on_samples(r.optics.field.shape)
        sig = r.stages.sigma_on_light_grid(grid)
        assert sig is r.stages.sigma_samples()
        assert np.array_equal(sig, sigma_on_grid(r.optics, grid))
        finer = r.stages.light_grid(2.0)
        assert r.stages.sigma_on_light_grid(finer).shape == tuple(finer.shape)
