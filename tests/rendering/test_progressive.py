"""Tests pv_ambient/rendering/progressive.py, the ``progressive`` model (docs/progressive.rst): a
noise-free model's picture plus residual path samples with that model's source at the first collision as
a control variate."""

import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient import datasets
from pv_ambient.rendering.presets import AUTO_SWEEP_ORDERS

SIZE = (10, 8)


def _cloud():
    lights = [pa.PointLight((0.4, 0.6, 1.6), intensity=4.0), pa.DirectionalLight((-0.3, 0.2, -1.0), 0.6)]
    tf = {"kind": "colormap", "cmap": "bone", "clim": [0.0, 1.0], "opacity": "linear", "albedo": 0.9,
          "opacity_unit_distance": 0.15}
    return pa.Renderer(datasets.cloud(n=16), transfer_function=tf, lights=lights), 0.5


def _lit_inside():
    # a point light inside the medium: the control's I/d² is clamped there, the path tracer's is not
    tf = {"kind": "colormap", "cmap": "magma", "clim": [0.0, 1.0], "opacity": "linear", "albedo": 0.8,
          "emission": 0.2, "opacity_unit_distance": 0.3}
    return pa.Renderer(datasets.supernova(n=16), transfer_function=tf,
                       lights=[pa.PointLight((0.1, 0.0, 0.05), intensity=2.0)]), 0.0


def test_no_scattering_residual_is_exactly_zero():
    """Albedo 0: a path sample is the emission at its first collision (or the background), and so
    is the control at the same collision — every residual sample is 0.0 exactly, so the picture is
    the control's: the base model marched at ``CONTROL_STEP_FRACTION`` of the step, and its
    standard error 0. A control drawn from other random numbers than the path's first free flight
    would leave a non-zero residual; a control marched at the step itself would give the base
    picture, which differs here by more than float32 rounding (checked)."""
    from pv_ambient.rendering.presets import CONTROL_STEP_FRACTION

    tf = {"kind": "colormap", "cmap": "magma", "clim": [0.0, 1.0], "opacity": "linear", "albedo": 0.0,
          "emission": 1.0, "opacity_unit_distance": 0.3}
    r = pa.Renderer(datasets.supernova(n=12), transfer_function=tf, lights=[pa.PointLight((2, 2, 2), 1.0)])
    kw = dict(window_size=SIZE, background=(0.1, 0.2, 0.3))
    base = r.render(model="single_scattering", step=0.08, **kw)
    fine = r.render(model="single_scattering", step=0.08 * CONTROL_STEP_FRACTION, **kw)
    res = r.render(model="progressive", base_model="single_scattering", samples_per_pixel=8, step=0.08, **kw)
    assert base.radiance.max() > 0.05
    assert np.abs(fine.radiance - base.radiance).max() > 1e-3 * base.radiance.max()
    np.testing.assert_array_equal(res.std_error, 0.0)
    np.testing.assert_array_equal(res.radiance, fine.radiance)
    assert res.metadata["spp"] == 8 and res.metadata["model"] == "progressive"


def test_control_of_a_baked_table_march_is_the_base_at_the_control_step(monkeypatch):
    """The control picture is the base model marched at ``CONTROL_STEP_FRACTION`` of the step with
    the table corrected for that step: with the light far from the box (nothing clamped) it equals
    the base model rendered at that step, to float32 rounding. Diffusion's baked march of a table
    TF reads a full step's opacity from the step-corrected table; a control that kept the base
    step's table was 38 % too bright on the lit-inside scene and biased every progressive
    picture."""
    import pv_ambient.backend as bmod
    from pv_ambient.rendering.presets import ACCURATE_DIFFUSION, CONTROL_STEP_FRACTION

    marched = {}
    real = bmod.run_raycast

    def spy(args, image, alpha, **kw):
        out = real(args, image, alpha, **kw)
        marched[kw.get("name")] = (args, image.copy())
        return out

    monkeypatch.setattr(bmod, "run_raycast", spy)
    tf = {"kind": "colormap", "cmap": "magma", "clim": [0.0, 1.0], "opacity": "linear", "albedo": 0.8,
          "emission": 0.2, "opacity_unit_distance": 0.3}
    r = pa.Renderer(datasets.supernova(n=16), transfer_function=tf, lights=[pa.PointLight((0.3, 0.2, 3.5), 8.0)])
    kw = dict(window_size=SIZE, step=0.06)
    r.render(model="progressive", samples_per_pixel=2, seed=1, **kw)
    args, control = marched["ray cast (control)"]
    assert args[5].baked and args[2].opacity.shape[0] > 1  # the baked march of a step-corrected table
    fine = r.render(model="diffusion", **dict(kw, step=0.06 * CONTROL_STEP_FRACTION), **ACCURATE_DIFFUSION)
    assert fine.radiance.max() > 0.05
    np.testing.assert_allclose(control, fine.radiance, rtol=1e-5, atol=1e-6 * fine.radiance.max())


def test_zero_samples_is_the_base_picture():
    r, g = _cloud()
    # the default base at quality "balanced": diffusion with the transport sweeps and flux limiting
    base = r.render(window_size=SIZE, model="diffusion", phase=g, flux_limited=True, sweep_orders=AUTO_SWEEP_ORDERS)
    res = r.render(window_size=SIZE, model="progressive", phase=g, samples_per_pixel=0)
    np.testing.assert_array_equal(res.radiance, base.radiance)
    np.testing.assert_array_equal(res.alpha, base.alpha)
    assert res.metadata["spp"] == 0 and res.metadata["base_model"] == "diffusion"
    plain = r.render(window_size=SIZE, model="diffusion", phase=g, quality="preview")
    res = r.render(window_size=SIZE, model="progressive", phase=g, samples_per_pixel=0, quality="preview")
    np.testing.assert_array_equal(res.radiance, plain.radiance)  # "preview": plain diffusion


def test_a_jittered_base_follows_its_seed():
    """The base picture is cached per view; a jittered march (a drag frame's) depends on the seed, so
    each seed — and the unjittered march — gets its own base: the base model's picture each time."""
    r, g = _cloud()
    for jitter, seed in ((True, 1), (True, 2), (False, 2)):
        base = r.render(window_size=SIZE, model="single_scattering", phase=g, jitter=jitter, seed=seed)
        res = r.render(window_size=SIZE, model="progressive", base_model="single_scattering", phase=g,
                       samples_per_pixel=0, jitter=jitter, seed=seed)
        np.testing.assert_array_equal(res.radiance, base.radiance)
    one = r.render(window_size=SIZE, model="single_scattering", phase=g, jitter=True, seed=1).radiance
    assert not np.array_equal(one, base.radiance)  # (the seeds' pictures differ: the check above could fail)


def test_times_are_this_calls_own():
    """``time_prepare + time_render`` is the call's wall time, each part ≥ 0: a second call on the
    same view takes its base picture from the cache and prepares nothing (the interactive mode's
    refinement passes) — before, it kept the first call's preparation time and reported a negative
    ``time_render``."""
    import time

    r, g = _cloud()
    for spp in (0, 4, 4, 0):
        t = time.perf_counter()
        m = r.render(window_size=SIZE, model="progressive", phase=g, samples_per_pixel=spp, seed=spp).metadata
        wall = time.perf_counter() - t
        assert m["time_prepare"] >= 0.0 and m["time_render"] >= 0.0
        assert m["time_prepare"] + m["time_render"] <= wall
    assert m["time_prepare"] == 0.0  # the cached base


@pytest.mark.parametrize("scene", [_cloud, _lit_inside])
@pytest.mark.parametrize("base", ["single_scattering", "diffusion"])
def test_converges_to_the_path_traced_answer(scene, base):
    """The unbiased progressive picture (``unbiased=True``) and an independent path-traced one agree per pixel: z-scores of their
    difference (standard errors of both) beyond 3.29 (two-sided 0.1 %) in at most 3 of the 240
    pixel channels — under agreement the count is Poisson with mean 0.24, P(≥ 4) ≈ 1.3e-4 — and the
    image means within 3 standard errors plus 1 % (the march's quadrature bias is below it,
    docs/progressive.rst)."""
    r, g = scene()
    p = r.render(window_size=SIZE, model="progressive", base_model=base, phase=g, quality="accurate",
                 samples_per_pixel=512, seed=3, unbiased=True)
    q = r.render(window_size=SIZE, model="path_traced", phase=g, quality="accurate", samples_per_pixel=2048, seed=4)
    a, b = p.radiance.astype(np.float64), q.radiance.astype(np.float64)
    se = np.sqrt(p.std_error.astype(np.float64) ** 2 + q.std_error.astype(np.float64) ** 2)
    assert np.all(np.isfinite(se)) and b.mean() > 1e-3
    # no spread: every sample escaped (the background in both; the base picture holds the faint
    # medium no free flight collided with, below 1e-5 of the brightest pixel here)
    still = se == 0
    np.testing.assert_allclose(a[still], b[still], rtol=0, atol=1e-5 * b.max())
    z = (a - b)[~still] / se[~still]
    assert int(np.sum(np.abs(z) > 3.29)) <= 3, np.sort(np.abs(z).ravel())[-6:]
    se_mean = float(np.sqrt(np.sum(se ** 2))) / se.size
    assert abs(a.mean() - b.mean()) <= 3 * se_mean + 0.01 * b.mean()


def test_fewer_than_the_minimum_samples_keep_only_the_exact_corrections():
    """Below ``REFINE_MIN_SAMPLES`` samples per pixel the picture keeps no measured detail, however
    far it stands out of its noise: only the corrections known exactly (zero variance there and
    around); from the minimum on the same correction is kept in full."""
    from pv_ambient.stages.refine import REFINE_MIN_SAMPLES, refined_picture

    base = np.zeros((16, 16, 3))
    estimate = base + 0.5  # a correction 50 standard errors above its noise
    se = np.full_like(base, 0.01)
    se[:5, :5] = 0.0  # pixels [0, 4)² have zero variance in their 3×3 neighbourhood: exact
    few, kept = refined_picture(base, estimate, se, samples=REFINE_MIN_SAMPLES - 1)
    np.testing.assert_array_equal(few[:4, :4], 0.5)
    assert np.count_nonzero(few) == 4 * 4 * 3 and kept == 0.0
    enough, kept = refined_picture(base, estimate, se, samples=REFINE_MIN_SAMPLES)
    np.testing.assert_allclose(enough, 0.5) and kept == 1.0
    # variances known exactly (samples=None): no minimum
    np.testing.assert_allclose(refined_picture(base, estimate, se)[0], 0.5)


@pytest.mark.parametrize("scene", [_cloud, _lit_inside])
def test_default_picture_keeps_the_measurable_correction(scene):
    """The default picture is the base plus the thresholded correction of the unbiased one
    (same samples): between the two per pixel where a detail is dropped, equal to the unbiased
    picture's mean wherever the whole image's correction stands out of its noise (kept together per
    block, docs/progressive.rst), and within t = √(2 ln n) of its standard errors otherwise — the
    standard errors as the rule takes them, each pixel's variance the larger of its own and its 3×3
    neighbourhood's mean. (With the raw variances the bound was tighter than the rule: a change of
    1e-7 in the base picture moved the lit-inside scene's gap from under it to 1.1× it.)"""
    from pv_ambient.stages.refine import _neighbourhood_max, refined_picture
    from pv_ambient.stages.refine import universal_threshold

    r, g = scene()
    kw = dict(window_size=SIZE, model="progressive", phase=g, samples_per_pixel=64, seed=5)
    p = r.render(**kw)
    u = r.render(unbiased=True, **kw)
    base = r.render(**dict(kw, samples_per_pixel=0))
    assert p.metadata["residual"] == "thresholded" and u.metadata["residual"] == "unbiased"
    np.testing.assert_array_equal(p.std_error, u.std_error)
    expect, kept = refined_picture(base.radiance, u.radiance, u.std_error, samples=64)
    np.testing.assert_allclose(p.radiance, expect, rtol=1e-6, atol=1e-7)
    assert p.metadata["kept"] == kept
    se_mean = float(np.sqrt(np.sum(_neighbourhood_max(u.std_error.astype(np.float64) ** 2)))) / u.std_error.size
    gap = abs(float(np.mean(p.radiance, dtype=np.float64)) - float(np.mean(u.radiance, dtype=np.float64)))
    assert gap <= universal_threshold(u.radiance.size) * se_mean + 1e-6


def test_control_variate_lowers_the_variance_where_the_model_is_close():
    """With a base model close to the answer (single scattering with max_depth=1: the same
    quantity), the residual's standard error is well below the path tracer's on the same samples
    budget — the variance of where the first collision falls is gone."""
    r, g = _cloud()
    kw = dict(window_size=SIZE, phase=g, samples_per_pixel=256, max_depth=1, quality="accurate")
    p = r.render(model="progressive", base_model="single_scattering", seed=1, **kw)
    q = r.render(model="path_traced", seed=1, **kw)
    assert float(np.mean(p.std_error ** 2)) < 0.5 * float(np.mean(q.std_error ** 2))


def test_control_march_once_per_view_and_clamped_only_near_a_light(monkeypatch):
    """The control's march runs once per view, when samples are first taken (none for the 0-sample
    picture, none again for more samples of the same view). Its point lights are clamped at the
    equiangular radius only when a light is within that radius of the box: for a light farther
    away the clamp changes nothing, and the picture equals the one with the clamp forced — bit
    for bit — while for a light inside the medium the clamp changes the control's picture."""
    import pv_ambient.backend as bmod
    import pv_ambient.rendering.progressive as rmod
    from pv_ambient.inputs.grid import GridGeometry

    marches = []
    real = bmod.run_raycast

    def counting(*args, **kw):
        marches.append(kw.get("name"))
        return real(*args, **kw)

    monkeypatch.setattr(bmod, "run_raycast", counting)
    tf = {"kind": "colormap", "cmap": "bone", "clim": [0.0, 1.0], "opacity": "linear", "albedo": 0.9,
          "opacity_unit_distance": 0.15}
    kw = dict(window_size=SIZE, model="progressive", samples_per_pixel=4, seed=3, unbiased=True)
    far = pa.PointLight((0.3, 0.2, 3.5), intensity=8.0)  # 2.5 from the box [-1, 1]³; the radius is 0.87
    r = pa.Renderer(datasets.cloud(n=12), transfer_function=tf, lights=[far])
    r.render(**dict(kw, samples_per_pixel=0))
    assert marches.count("ray cast (control)") == 0
    p = r.render(**kw)
    r.render(**dict(kw, seed=4))
    assert marches.count("ray cast (control)") == 1
    monkeypatch.setattr(GridGeometry, "distance_to", lambda self, xyz: np.zeros(len(xyz)))
    q = pa.Renderer(datasets.cloud(n=12), transfer_function=tf, lights=[far]).render(**kw)
    assert marches.count("ray cast (control)") == 2
    np.testing.assert_array_equal(p.radiance, q.radiance)
    np.testing.assert_array_equal(p.std_error, q.std_error)
    monkeypatch.undo()
    # a light inside the medium: the clamp moves the picture by more than rounding (were it not
    # applied, the two renders would be the same computation, bit for bit)
    r, _ = _lit_inside()
    inside = r.render(**kw)
    monkeypatch.setattr(rmod, "EQ_RADIUS", 0.0)  # no light within a zero radius: nothing clamped
    r2, _ = _lit_inside()
    unclamped = r2.render(**kw)
    assert np.abs(inside.radiance - unclamped.radiance).max() > 1e-3 * inside.radiance.max()


def test_bad_arguments_name_what_was_wrong():
    r, g = _cloud()
    with pytest.raises(ValueError, match="base_model"):
        r.render(window_size=SIZE, model="progressive", base_model="path_traced")
    with pytest.raises(ValueError, match="ray_end"):
        r.render(window_size=SIZE, model="progressive", ray_end=np.full(SIZE[::-1], np.inf))
    with pytest.raises(ValueError, match="samples_per_pixel"):
        r.render(window_size=SIZE, model="progressive", samples_per_pixel=-1)
    for bad in ("yes", 1):
        with pytest.raises(TypeError, match="unbiased must be True or False"):
            r.render(window_size=SIZE, model="progressive", unbiased=bad)
        with pytest.raises(TypeError, match="denoise must be True or False"):
            r.render(window_size=SIZE, model="path_traced", denoise=bad)
    with pytest.warns(UserWarning, match="base_model"):
        r.render(window_size=SIZE, model="diffusion", base_model="diffusion")


def test_halves_of_one_seed_are_its_samples():
    """``first_sample`` continues a seed's random numbers: samples [0, 3) and [3, 8) of a seed,
    pooled, are the samples of one 8-sample render of it (the progressive model's held-out halves
    are therefore exactly the samples its thresholded picture uses)."""
    from pv_ambient.stages.reference import Accumulator

    r, g = _cloud()
    cam = r.render(window_size=SIZE, model="emission_absorption").camera
    whole = r.path_trace(cam, SIZE, phase=g, samples_per_pixel=8, seed=5)
    acc = Accumulator()
    for n, first in ((3, 0), (5, 3)):
        part = r.path_trace(cam, SIZE, phase=g, samples_per_pixel=n, seed=5, first_sample=first)
        assert part.metadata["first_sample"] == first
        acc.add(part.radiance, part.std_error, part.alpha, samples=n)
    assert whole.radiance.max() > 0.01
    np.testing.assert_allclose(acc.mean, whole.radiance, rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(acc.std_error, whole.std_error, rtol=1e-4, atol=1e-7)
    np.testing.assert_allclose(acc.alpha, whole.alpha, rtol=1e-6, atol=0)
    part = r.path_trace(cam, SIZE, phase=g, samples_per_pixel=5, seed=5, first_sample=0)
    assert not np.allclose(part.radiance, r.path_trace(cam, SIZE, phase=g, samples_per_pixel=5, seed=5,
                                                             first_sample=3).radiance)


DENOISE_SIZE = (32, 24)  # enough 4×4 blocks for the held-out halves to tell pictures apart


def _stand_in_denoiser(monkeypatch, fn):
    """OIDN replaced (pyoidn is an optional extra): ``fn(radiance, albedo)`` as ``denoise_radiance``."""
    from pv_ambient.stages import denoise

    monkeypatch.setattr(denoise, "available", lambda: True)
    monkeypatch.setattr(denoise, "denoise_radiance",
                        lambda radiance, albedo=None, quality="high", mean_preserving=True: fn(radiance, albedo))


def test_denoise_chooses_an_oracle_and_keeps_the_unbiased_mean(monkeypatch):
    """``denoise=True`` with a stand-in denoiser that returns (nearly) the converged picture — the
    model's own unbiased picture at 4096 samples, another seed — whatever it is given. With
    single scattering as the base (block error 2.7 against that picture in this high-albedo
    cloud) and 8 samples, the thresholded picture is still close to its base, and the held-out
    halves (4 samples each; the minimum lowered to 4 for this) must find the stand-in closer by
    more than 2 standard errors; the
    picture is then that image rescaled to the unbiased picture's mean per channel (equal to
    1e-5: the mean stays the samples' unbiased one)."""
    from pv_ambient.stages import refine

    monkeypatch.setattr(refine, "HELD_OUT_MIN_SAMPLES", 4)  # the choice at 4 samples per half (default 16)
    r, g = _cloud()
    opts = dict(window_size=DENOISE_SIZE, model="progressive", base_model="single_scattering", phase=g)
    truth = r.render(samples_per_pixel=4096, seed=11, unbiased=True, **opts).radiance
    _stand_in_denoiser(monkeypatch, lambda radiance, albedo: truth)
    res = r.render(samples_per_pixel=8, seed=2, denoise=True, **opts)
    unb = r.render(samples_per_pixel=8, seed=2, unbiased=True, **opts)
    assert res.metadata["residual"] == "denoised" and res.metadata["denoised"], res.metadata["held_out_z"]
    assert res.metadata["held_out_z"] < -2
    np.testing.assert_allclose(res.radiance.mean(axis=(0, 1)), unb.radiance.mean(axis=(0, 1)), rtol=1e-5)
    scale = unb.radiance.astype(np.float64).sum(axis=(0, 1)) / truth.astype(np.float64).sum(axis=(0, 1))
    np.testing.assert_allclose(res.radiance, truth * scale, rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(res.std_error, unb.std_error, rtol=1e-4)  # the samples' own standard error


def test_denoise_rejects_a_bad_denoiser_and_keeps_the_thresholded_picture(monkeypatch):
    """A stand-in denoiser that makes the picture worse (a flat grey at its mean) must lose the
    held-out comparison: the picture is then exactly the thresholded one of ``denoise=False``
    with the same seed (the halves are that render's samples), up to float32 rounding."""
    r, g = _cloud()
    _stand_in_denoiser(monkeypatch, lambda radiance, albedo: np.full_like(radiance, radiance.mean()))
    plain = r.render(window_size=DENOISE_SIZE, model="progressive", phase=g, samples_per_pixel=32, seed=2)
    res = r.render(window_size=DENOISE_SIZE, model="progressive", phase=g, samples_per_pixel=32, seed=2, denoise=True)
    assert res.metadata["residual"] == "thresholded" and res.metadata["held_out_z"] > 1
    np.testing.assert_allclose(res.radiance, plain.radiance, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(res.std_error, plain.std_error, rtol=1e-4, atol=1e-7)
    assert res.metadata["spp"] == plain.metadata["spp"] == 32


def test_denoise_makes_no_choice_below_the_minimum_samples(monkeypatch):
    """Fewer than ``HELD_OUT_MIN_SAMPLES`` per half (here 8 samples: 4 per half): no choice is made,
    not even with a denoiser that returns the converged picture — the picture is the thresholded
    one of ``denoise=False``."""
    r, g = _cloud()
    opts = dict(window_size=DENOISE_SIZE, model="progressive", base_model="single_scattering", phase=g)
    truth = r.render(samples_per_pixel=1024, seed=11, unbiased=True, **opts).radiance
    _stand_in_denoiser(monkeypatch, lambda radiance, albedo: truth)
    res = r.render(samples_per_pixel=8, seed=2, denoise=True, **opts)
    plain = r.render(samples_per_pixel=8, seed=2, **opts)
    assert res.metadata["residual"] == "thresholded" and "held_out_z" not in res.metadata
    np.testing.assert_allclose(res.radiance, plain.radiance, rtol=1e-5, atol=1e-6)


def test_denoise_argument_errors(monkeypatch):
    r, g = _cloud()
    with pytest.raises(ValueError, match="unbiased=True"):
        r.render(window_size=SIZE, model="progressive", phase=g, samples_per_pixel=4, denoise=True, unbiased=True)
    from pv_ambient.stages import denoise

    monkeypatch.setattr(denoise, "available", lambda: False)
    monkeypatch.setattr(denoise, "_import_pyoidn", lambda: (_ for _ in ()).throw(ImportError("pv_ambient[denoise]")))
    with pytest.raises(ImportError, match="denoise"):
        r.render(window_size=SIZE, model="progressive", phase=g, samples_per_pixel=4, denoise=True)
