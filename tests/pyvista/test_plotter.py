"""Tests pv_ambient/pyvista/plotter.py: add_ambient_volume's picture pixel-exact in the plotter over its
background, and the interactive AmbientVolume — re-rendered on camera moves, at reduced resolution
(never below half the window per axis) while the camera is dragged, at full resolution when it
rests (issue 16's drag mode), refined while it rests (path_traced, progressive)."""

import os

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
import pyvista as pv  # noqa: E402

import pv_ambient as pa  # noqa: E402
from pv_ambient import datasets  # noqa: E402
from pv_ambient.pyvista.plane import texture_image  # noqa: E402
from pv_ambient.rendering.presets import AUTO_SWEEP_ORDERS  # noqa: E402
from pv_ambient.stages.refine import refined_picture  # noqa: E402

from .helpers import CAMERA, plotter  # noqa: E402

SIZE = (63, 47)  # odd sizes: the reduced size rounds up


@pytest.fixture(scope="module")
def scene():
    grid = datasets.cloud(n=24)
    tf = pa.TransferFunction(**datasets.suggested_style("cloud"), albedo=0.9)
    return grid, tf, [pa.PointLight((1.0, -1.5, 1.2), intensity=4.0)]


@pytest.mark.parametrize("model,fraction", [("single_scattering", 0.5), ("ambient_scattering", 0.75)])
def test_drag_renders_reduced_and_the_resting_frame_is_a_normal_render(scene, model, fraction):
    grid, tf, lights = scene
    pl = plotter(SIZE)
    vol = pa.add_ambient_volume(pl, grid, transfer_function=tf, lights=lights, model=model, interactive=True,
                                interactive_resolution=fraction)
    assert vol.result.window_size == SIZE and not vol.moving
    win = pl.ren_win
    win.SetDesiredUpdateRate(15.0)  # what VTK's interactor asks for during a drag
    for k in range(3):
        pl.camera.Azimuth(7.0)
        win.Render()
        assert vol.moving and vol.renders == 2 + k
        w, h = vol.result.window_size
        assert (w, h) == (int(np.ceil(SIZE[0] * fraction)), int(np.ceil(SIZE[1] * fraction)))
        assert 2 * w >= SIZE[0] and 2 * h >= SIZE[1]  # never below half the window per axis
        assert vol.volume_result.metadata["draft"]  # a draft frame (rendering/draft.py)
    win.SetDesiredUpdateRate(0.0001)  # the camera rests: the interactor's still rate
    win.Render()
    assert not vol.moving and vol.renders == 5 and vol.result.window_size == SIZE
    assert not vol.volume_result.metadata["draft"]
    ref = pa.render(grid, transfer_function=tf, lights=lights, model=model, camera=pl.camera, window_size=SIZE)
    assert np.array_equal(vol.volume_result.radiance, ref.radiance)
    # the plotter keeps the exposure its first picture resolved ("auto" for a lit model)
    assert np.array_equal(texture_image(vol.actor.GetTexture()), ref.to_uint8(exposure=vol.display["exposure"]))
    win.Render()
    assert vol.renders == 5  # at rest nothing changes: no re-render
    pl.close()


@pytest.mark.parametrize("samples", [4, 0])
def test_drag_frames_render_the_window_without_multisampling(scene, samples):
    """While the camera is dragged the window renders without multisampling (the plane's picture
    gains nothing from it, and a software OpenGL spends most of a frame on it); the resting frame
    and leaving interactive mode give the window its own setting back; a window without it stays so."""
    grid, tf, _ = scene
    pl = plotter(SIZE)
    win = pl.ren_win
    win.SetMultiSamples(samples)
    vol = pa.add_ambient_volume(pl, grid, transfer_function=tf, model="emission_absorption", interactive=True)
    seen = []
    win.AddObserver("EndEvent", lambda *a: seen.append(win.GetMultiSamples()))
    win.SetDesiredUpdateRate(15.0)
    for _ in range(2):
        pl.camera.Azimuth(5.0)
        win.Render()
    win.SetDesiredUpdateRate(0.0001)
    pl.camera.Azimuth(5.0)
    win.Render()
    assert seen == [0, 0, samples] and not vol.moving and vol.renders == 4
    win.SetDesiredUpdateRate(15.0)
    pl.camera.Azimuth(5.0)
    win.Render()
    assert seen[-1] == 0
    vol.remove_observer()  # left in the middle of a drag
    assert win.GetMultiSamples() == samples
    pl.close()


def test_not_interactive_ignores_the_rate(scene):
    grid, tf, lights = scene
    pl = plotter(SIZE)
    vol = pa.add_ambient_volume(pl, grid, transfer_function=tf)
    assert vol.interactive_step == 16  # the default cap of the drag step (the 256³ drag's 10 fps)
    pl.ren_win.SetDesiredUpdateRate(15.0)
    assert not vol.moving
    vol.update(force=True)
    assert vol.result.window_size == SIZE
    pl.close()


@pytest.mark.parametrize("option,bad", [("interactive_resolution", 0.49), ("interactive_resolution", 1.5),
                                        ("interactive_resolution", 0.0), ("interactive_step", 0),
                                        ("interactive_step", 3), ("interactive_step", 6)])
def test_interactive_options_are_checked(scene, option, bad):
    """interactive_resolution in [0.5, 1]; interactive_step a power of two ≥ 1."""
    grid, tf, lights = scene
    pl = plotter(SIZE)
    with pytest.raises(ValueError, match=option):
        pa.add_ambient_volume(pl, grid, transfer_function=tf, interactive=True, **{option: bad})
    pl.close()


def test_slow_drag_frames_lengthen_the_step_up_to_its_cap_and_rest_at_the_normal_step(scene):
    """A drag frame slower than the rate the window asks for doubles the ray step (up to
    ``interactive_step``); each drag frame equals a draft render at that step and the drag
    resolution, with jittered ray starts once the step is longer than the resting one; fast frames halve the
    step again; the resting frame is the normal render (resting step, no jitter)."""
    grid, tf, lights = scene
    pl = plotter(SIZE)
    vol = pa.add_ambient_volume(pl, grid, transfer_function=tf, lights=lights, model="ambient_scattering",
                                interactive=True, interactive_step=4)
    base = vol.renderer.default_step()
    win = pl.ren_win
    vol.dragged = True  # the step as a drag left it (1): the first drag's prediction has its own test
    win.SetDesiredUpdateRate(1e4)  # a budget of 0.1 ms: every frame is too slow
    seen = []
    for _ in range(4):
        pl.camera.Azimuth(5.0)
        factor = vol.step_factor
        win.Render()
        seen.append(factor)
        ref = vol.renderer.render(camera=pa.Camera.from_vtk(pl.camera), window_size=vol.result.window_size,
                                  model="ambient_scattering", step=base * factor, jitter=factor > 1, draft=True)
        assert np.array_equal(vol.volume_result.radiance, ref.radiance)
    assert seen == [1, 2, 4, 4] and vol.step_factor == 4  # doubled per slow frame, capped
    win.SetDesiredUpdateRate(1.0)  # a budget of 1 s: every frame is fast, the step halves
    pl.camera.Azimuth(5.0)
    win.Render()
    assert vol.step_factor == 2
    win.SetDesiredUpdateRate(0.0001)
    win.Render()
    assert not vol.moving and vol.result.window_size == SIZE
    ref = pa.render(grid, transfer_function=tf, lights=lights, model="ambient_scattering", camera=pl.camera,
                    window_size=SIZE)
    assert np.array_equal(vol.volume_result.radiance, ref.radiance)
    pl.close()


def test_the_first_drag_starts_at_the_step_its_budget_asks_for(scene):
    """Why: the first drag found its step by doubling, one slow frame per doubling (issue 46:
    1.6 s of stutter in a notebook). Its first frame's step is predicted from the resting picture's
    ray cast (frame ≈ rest · resolution² / step, within the window's budget); a later drag starts at
    the step the last one ended on."""
    grid, tf, lights = scene
    pl = plotter(SIZE)
    vol = pa.add_ambient_volume(pl, grid, transfer_function=tf, lights=lights, model="ambient_scattering",
                                interactive=True, interactive_step=16)
    assert vol.rest_seconds == vol.volume_result.metadata["time_render"] > 0 and not vol.dragged
    win = pl.ren_win
    vol.rest_seconds = 1.0  # a resting ray cast of 1 s: at half resolution a drag frame takes 0.25 s / step
    win.SetDesiredUpdateRate(10.0)  # budget 0.1 s: 0.25 / 4 = 0.0625 s, the smallest power of two within it
    pl.camera.Azimuth(5.0)
    win.Render()
    assert vol.dragged and vol.moving
    step = vol.volume_result.metadata["step"]
    assert step == pytest.approx(4 * vol.renderer.default_step())
    ended = vol.step_factor  # 4, or 2/8 as the frame's own time adapted it
    win.SetDesiredUpdateRate(0.0001)
    win.Render()
    assert vol.step_factor == ended  # the rest keeps the drag's step for the next drag
    vol.rest_seconds = 100.0  # no new prediction: the next drag starts where the last one ended
    win.SetDesiredUpdateRate(10.0)
    pl.camera.Azimuth(5.0)
    win.Render()
    assert vol.volume_result.metadata["step"] == pytest.approx(ended * vol.renderer.default_step())
    pl.close()


def test_a_drag_step_reuses_the_baked_light(scene, monkeypatch):
    """Why: the baked in-scattering was keyed on the d² clamp, a quarter of the ray step, so each
    new drag step re-baked it (≈ 0.44 s at 64³ in issue 46). A point light's slot holds its
    fall-off times the clamped d² — its intensity, whatever the clamp — so no rig re-bakes on a new
    step, and the picture equals a fresh renderer's at that step."""
    from pv_ambient.rendering.scene_stages import SceneStages

    grid, tf, lights = scene
    bakes = []
    real = SceneStages.incident

    def counting(self, *args, **kwargs):  # a bake adds an "incident" entry (σt may leave the cache then)
        before = set(self.cache.keys("incident"))
        out = real(self, *args, **kwargs)
        bakes.append(set(self.cache.keys("incident")) != before)
        return out

    monkeypatch.setattr(SceneStages, "incident", counting)
    assert any(isinstance(lt, pa.PointLight) for lt in lights)
    for lts in ([pa.DirectionalLight((1.0, -1.0, -1.0), 2.0)], lights):
        r = pa.Renderer(grid, transfer_function=tf, lights=lts)
        base = r.default_step()
        bakes.clear()
        for k in (1, 2, 4):
            img = r.render(camera=CAMERA, window_size=(16, 12), model="ambient_scattering", step=base * k).radiance
        assert bakes == [True, False, False]
        fresh = pa.Renderer(grid, transfer_function=tf, lights=lts).render(
            camera=CAMERA, window_size=(16, 12), model="ambient_scattering", step=base * 4).radiance
        assert np.abs(img - fresh).max() <= 1e-6 * max(1.0, float(fresh.max()))


def test_a_resize_renders_once_the_size_settles(scene):
    """Why: a notebook page settling its layout resized the view five times in 2.7 s (1024×768,
    30×30, 99×61, 985×511, 985×523), each a full render. With ``defer_resize`` (the trame views
    set it) a frame that only changes the size renders nothing and asks for :meth:`settle`, which
    renders once at the final size; a camera move still renders at once."""
    grid, tf, lights = scene
    pl = plotter(SIZE)
    vol = pa.add_ambient_volume(pl, grid, transfer_function=tf, interactive=True)
    asked = []
    vol.defer_resize = asked.append
    for size in ((30, 30), (40, 25), (70, 52)):
        pl.ren_win.SetSize(*size)
        pl.ren_win.Render()
    assert vol.renders == 1 and asked == [vol.settle] * 3 and vol.result.window_size == SIZE
    assert vol.settle() and vol.renders == 2 and vol.result.window_size == (70, 52)
    assert not vol.settle()  # settled: nothing to do
    pl.camera.Azimuth(10.0)
    pl.ren_win.Render()
    assert vol.renders == 3 and len(asked) == 3
    pl.close()


def test_a_camera_move_recomputes_nothing_view_independent(scene, monkeypatch):
    """Why: every drag frame sorted the lights out again (a minimum over each light volume) and
    copied the light volumes side by side (``np.stack``): view-independent passes over volume-sized
    arrays. A camera move must find them cached — the same baked array, no pass over the scattering
    nodes, and no light volume in the ray cast's records (it reads the bake alone) — and a relight
    must still replace them (the image equals a fresh renderer's)."""
    from pv_ambient import backend as R
    from pv_ambient.rendering.scene_stages import SceneStages

    grid, tf, lights = scene
    two = [lights[0], pa.PointLight((-1.0, 1.0, 0.5), intensity=2.0)]
    records = []
    real = R.run_raycast

    def capture(args, rad, alpha, **kw):
        records.append(args)
        return real(args, rad, alpha, **kw)

    monkeypatch.setattr(R, "run_raycast", capture)
    for model, lts in (("single_scattering", lights), ("ambient_scattering", two)):
        r = pa.Renderer(grid, transfer_function=tf, lights=lts)
        r.render(camera=CAMERA, window_size=(16, 12), model=model)

        def forbidden(*a, **k):
            raise AssertionError("a camera move went over the scattering nodes again")

        with monkeypatch.context() as m:
            m.setattr(SceneStages, "scattering_nodes", forbidden)
            cam = pa.Camera((2.0, -3.8, 1.4), CAMERA.focal_point, CAMERA.view_up, view_angle=30.0)
            moved = r.render(camera=cam, window_size=(16, 12), model=model)
        inc0, inc1 = records[-2][5].inc, records[-1][5].inc
        assert inc0 is inc1 and inc1.shape[-1] == len(lts) * records[-1][5].baked  # a slot per point light
        assert records[-1][5].tau.size == 1 and not [k for k in r.cache if k[0] == "tau_stack"]  # placeholders
        relit = lts[:-1] + [pa.PointLight((0.5, 0.5, 1.5), intensity=3.0)]
        r.set_lights(relit)
        baked = inc1.copy()
        got = r.render(camera=cam, window_size=(16, 12), model=model)
        assert not np.array_equal(records[-1][5].inc, baked)  # rebaked (in place: SceneStages.incident)
        ref = pa.Renderer(grid, transfer_function=tf, lights=relit).render(camera=cam, window_size=(16, 12),
                                                                           model=model)
        assert np.array_equal(got.radiance, ref.radiance) and not np.array_equal(got.radiance, moved.radiance)


def test_drag_frames_start_no_progress_bar_and_move_the_plane(scene, monkeypatch):
    """Why: a drag frame started a delayed progress bar (a thread) per render stage, and built a
    new texture only to read the plane's corners. Drag frames start no bar (the resting frame still
    may); the plane follows the camera exactly as a new plane would."""
    from pv_ambient.rendering import request

    grid, tf, lights = scene
    pl = plotter(SIZE)
    vol = pa.add_ambient_volume(pl, grid, transfer_function=tf, lights=lights, model="single_scattering",
                                interactive=True)
    monkeypatch.delenv("PYTEST_CURRENT_TEST")  # outside pytest a render stage starts a delayed bar
    started = []
    real = request._DelayedBar

    def counted(*a, **k):
        started.append(a[0])
        return real(*a, **k)

    monkeypatch.setattr(request, "_DelayedBar", counted)
    win = pl.ren_win
    win.SetDesiredUpdateRate(15.0)
    for _ in range(2):
        pl.camera.Azimuth(7.0)
        win.Render()
        assert vol.moving and started == []
        points = pv.wrap(vol.actor.GetMapper().GetInputDataObject(0, 0)).points
        np.testing.assert_allclose(points, vol.result.to_plane().points, rtol=0, atol=1e-6)
    win.SetDesiredUpdateRate(0.0001)
    win.Render()
    assert not vol.moving and started  # the resting frame: the default delayed bars
    pl.close()


def test_progressive_is_noise_free_while_dragged_and_refines_at_rest(scene):
    """``progressive``: a drag frame is its base model's draft picture (no samples, no noise); the
    resting frame adds ``interactive_samples`` residual samples, each refinement as many again with
    the next seed, their mean the same as one render of all of them."""
    grid, tf, lights = scene
    pl = plotter(SIZE)
    vol = pa.add_ambient_volume(pl, grid, transfer_function=tf, lights=lights, model="progressive", interactive=True,
                                interactive_resolution=1.0, samples_per_pixel=6, interactive_samples=2)
    r = vol.renderer
    assert vol.result.metadata["spp"] == 2
    win = pl.ren_win
    vol.dragged = True  # the drag at the resting step (the first drag's predicted step is tested on its own)
    win.SetDesiredUpdateRate(15.0)
    pl.camera.Azimuth(7.0)
    win.Render()
    assert vol.moving and vol.volume_result.metadata["spp"] == 0
    base = r.render(camera=pl.camera, window_size=SIZE, model="diffusion", flux_limited=True,
                    sweep_orders=AUTO_SWEEP_ORDERS, draft=True)  # a drag frame is a draft
    np.testing.assert_array_equal(vol.volume_result.radiance, base.radiance)
    win.SetDesiredUpdateRate(0.0001)  # the camera rests
    win.Render()
    if vol.volume_result.metadata["spp"] == 0:  # same view and size: the timer's first tick starts the samples
        assert vol.refine()
    assert vol.volume_result.metadata["spp"] == 2
    assert vol.refine() and vol.refine() and not vol.refine()  # 6 samples: done
    assert vol.volume_result.metadata["spp"] == 6
    base_p = r.render(camera=pl.camera, window_size=SIZE, model="progressive", samples_per_pixel=0)
    parts = [r.render(camera=pl.camera, window_size=SIZE, model="progressive", samples_per_pixel=2, seed=s,
                      unbiased=True) for s in range(3)]
    # the passes' mean, its correction over the base thresholded by the standard error of all samples
    shown, _ = refined_picture(base_p.radiance, np.mean([p.radiance for p in parts], axis=0),
                               vol.volume_result.std_error, samples=6)
    np.testing.assert_allclose(vol.volume_result.radiance, shown, rtol=1e-5, atol=1e-6)
    assert np.all(vol.volume_result.std_error >= 0)
    pl.close()


def test_progressive_denoise_takes_even_and_odd_passes_as_its_halves(scene, monkeypatch):
    """``progressive`` with ``denoise=True`` in interactive mode: the even and odd refinement passes
    are the held-out halves — after three passes of 2 samples (seeds 0, 1, 2) the picture is
    :func:`progressive_picture` of passes 0 and 2 pooled against pass 1 (a stand-in denoiser: OIDN
    is an optional extra)."""
    from pv_ambient.stages.refine import progressive_picture
    from pv_ambient.stages import denoise
    from pv_ambient.stages.reference import Accumulator

    def blur(radiance, albedo=None, quality="high", mean_preserving=True):
        from scipy.ndimage import uniform_filter
        return uniform_filter(np.asarray(radiance, np.float64), size=(3, 3, 1))

    from pv_ambient.stages import refine

    monkeypatch.setattr(denoise, "available", lambda: True)
    monkeypatch.setattr(denoise, "denoise_radiance", blur)
    monkeypatch.setattr(refine, "HELD_OUT_MIN_SAMPLES", 2)  # a choice from these few samples (default 16)
    grid, tf, lights = scene
    pl = plotter(SIZE)
    vol = pa.add_ambient_volume(pl, grid, transfer_function=tf, lights=lights, model="progressive", interactive=True,
                                interactive_resolution=1.0, samples_per_pixel=6, interactive_samples=2, denoise=True)
    r = vol.renderer
    while vol.refine():
        pass
    meta = vol.volume_result.metadata
    assert meta["spp"] == 6 and "held_out_z" in meta and meta["residual"] in ("thresholded", "denoised")
    base = r.render(camera=pl.camera, window_size=SIZE, model="progressive", samples_per_pixel=0).radiance
    parts = [r.render(camera=pl.camera, window_size=SIZE, model="progressive", samples_per_pixel=2, seed=s,
                      unbiased=True) for s in range(3)]
    even, odd = Accumulator(), Accumulator()
    for k, p in enumerate(parts):
        (even, odd)[k % 2].add(p.radiance, p.std_error, p.alpha, samples=2)
    shown, pm = progressive_picture(base, [(even.mean, even.std_error, 4), (odd.mean, odd.std_error, 2)], denoise=True)
    assert pm["residual"] == meta["residual"]
    np.testing.assert_allclose(meta["held_out_z"], pm["held_out_z"], rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(vol.volume_result.radiance, shown, rtol=1e-5, atol=1e-6)
    pl.close()


def test_add_ambient_volume_keeps_the_plotter_background():
    """Why: the plane painted the plotter's background black (PyVista's white theme lost its title)."""
    import pyvista as pv

    grid = datasets.cloud(n=12)
    pl = pv.Plotter(off_screen=True, window_size=(40, 30))
    pl.set_background("white")
    vol = pa.add_ambient_volume(pl, grid, model="single_scattering")
    shot = pl.screenshot(return_img=True)
    assert shot[0, 0].tolist() == [255, 255, 255] and shot[-1, -1].tolist() == [255, 255, 255]
    # where the volume covers a pixel, the background shows through by its transmittance: D(L) + T·B
    res, shown = vol.volume_result, vol.result.to_uint8(**vol.display)
    expect = np.clip(np.round(res.to_uint8(exposure=vol.display["exposure"]).astype(float)
                              + 255.0 * (1.0 - res.alpha[..., None])), 0, 255)
    assert np.abs(shown.astype(float) - expect).max() <= 1.0
    pl.close()
    # background= still paints that radiance
    pl = pv.Plotter(off_screen=True, window_size=(40, 30))
    pl.set_background("white")
    pa.add_ambient_volume(pl, grid, background=(0.0, 0.0, 0.0))
    assert pl.screenshot(return_img=True)[0, 0].tolist() == [0, 0, 0]
    pl.close()


def test_add_ambient_volume_shows_render_pixel_exactly(cloud):
    grid, r = cloud
    tf = r.transfer_function
    for display in ({}, {"exposure": 1.0, "tonemap": "reinhard", "srgb": True}):
        pl = plotter((64, 48))
        actor, res = pa.add_ambient_volume(pl, grid, transfer_function=tf, display=display)
        ref = pa.render(grid, transfer_function=tf, camera=CAMERA, window_size=(64, 48)).to_uint8(**display)
        # what the plane shows (its texture) and what the plotter's screenshot shows
        assert np.array_equal(texture_image(actor.GetTexture()), ref)
        assert np.array_equal(pl.screenshot()[..., :3], ref)
        assert np.array_equal(res.to_uint8(**display), ref)
        pl.close()


def test_interactive_rerenders_on_camera_moves(cloud):
    grid, r = cloud
    tf = r.transfer_function
    size = (64, 48)
    pl = plotter(size)
    vol = pa.add_ambient_volume(pl, grid, transfer_function=tf, interactive=True)
    assert vol.observer is not None and vol.renders == 1
    pl.show(auto_close=False)
    pl.render()
    assert vol.renders == 1  # no camera change, no re-render
    before = texture_image(vol.actor.GetTexture())
    moves = [lambda c: c.Azimuth(35.0), lambda c: c.Elevation(20.0), lambda c: c.Zoom(1.4)]
    for k, move in enumerate(moves, start=2):
        move(pl.camera)
        pl.render()
        assert vol.renders == k
        tex = texture_image(vol.actor.GetTexture())
        assert not np.array_equal(tex, before)
        ref = pa.render(grid, transfer_function=tf, camera=pl.camera, window_size=size).to_uint8()
        assert np.array_equal(tex, ref)
        assert np.array_equal(pl.screenshot()[..., :3], ref)  # the plane moved with the camera
        before = tex
    vol.remove_observer()
    pl.camera.Azimuth(20.0)
    pl.render()
    assert vol.renders == 4 and np.array_equal(texture_image(vol.actor.GetTexture()), before)
    pl.close()


def test_path_traced_interactive_refines_while_the_camera_rests():
    grid = datasets.cloud(n=16)
    light = pa.PointLight((1.5, 1.5, 1.5), 4.0)
    size = (24, 16)
    pl = plotter(size)
    vol = pa.add_ambient_volume(pl, grid, model="path_traced", lights=[light], interactive=True,
                                samples_per_pixel=8, interactive_samples=2)
    r = vol.renderer
    pl.show(auto_close=False)

    def pt(seed, n=2):
        return r.render(camera=CAMERA, window_size=size, model="path_traced", samples_per_pixel=n, seed=seed)

    assert vol.result.metadata["spp"] == 2
    assert np.array_equal(texture_image(vol.actor.GetTexture()), pt(0).to_uint8())
    # a repeating timer on the interactor refines: each tick adds 2 samples with the next seed
    pl.iren.interactor.InvokeEvent("TimerEvent")
    assert vol.result.metadata["spp"] == 4
    assert vol.refine() and vol.refine() and not vol.refine()  # 8 samples: done
    mean = np.mean([pt(s).radiance for s in range(4)], axis=0)
    # the volume alone (vol.result is it composited over the plotter's background, since 0.3.0)
    np.testing.assert_allclose(vol.volume_result.radiance, mean, rtol=1e-5, atol=1e-6)
    assert vol.volume_result.std_error.mean() < pt(0).std_error[np.isfinite(pt(0).std_error)].mean()
    pl.camera.Azimuth(30.0)
    pl.render()
    assert vol.result.metadata["spp"] == 2  # a camera move starts over
    vol.remove()
    assert vol.observer is None
    pl.close()
