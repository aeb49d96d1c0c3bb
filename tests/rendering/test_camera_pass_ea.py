"""Tests pv_ambient/rendering/camera_pass.py, the emission–absorption model: analytic cases and
behaviour at the edges of the input space."""
import numpy as np
import pytest
import pyvista as pv

import pv_ambient as pa
from pv_ambient.inputs.camera import Camera

from ..helpers import box_grid


def exact_chords(cam, size, lo, hi):
    """Exact chord length of every pixel ray through the box [lo, hi] (independent numpy slab test)."""
    o, d = cam.rays(size)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = (lo - o) / d
        b = (hi - o) / d
    t0 = np.max(np.minimum(a, b), axis=-1)
    t1 = np.min(np.maximum(a, b), axis=-1)
    return np.clip(t1 - np.maximum(t0, 0.0), 0.0, None)


@pytest.mark.parametrize("cam", [
    Camera((0.3, -5, 0.2), (0, 0, 0), (0, 0, 1), view_angle=30),
    Camera((2, 3, 4), (0.1, 0, 0), (0, 0, 1), view_angle=40),
    Camera((0.2, 0.1, 0.05), (1, 1, 1), (0, 0, 1), view_angle=70),  # camera inside the volume
    Camera((3, -4, 2), (0, 0, 0), (0, 0, 1), parallel_projection=True, parallel_scale=1.3),
])
def test_homogeneous_box_alpha_is_exact(cam):
    sigma = 3.0
    g = box_grid()
    tf = pa.TransferFunction.from_table([0.0, 2.0], sigma_t=[0.0, 2 * sigma])
    size = (64, 48)
    res = pa.render(g, transfer_function=tf, camera=cam, window_size=size, early_termination=0.0)
    chord = exact_chords(cam, size, np.full(3, -0.95), np.full(3, 0.95))
    assert (chord > 0).mean() > 0.2
    assert np.max(np.abs(res.alpha - (1 - np.exp(-sigma * chord)))) <= 1e-4


@pytest.mark.parametrize("sigma, thickness", [(0.5, 1.0), (4.0, 0.3), (40.0, 2.0)])
def test_emission_only_slab_closed_form(sigma, thickness):
    # slab of thickness L seen face-on with a parallel camera: L_out = C (1 − e^{−σL})
    g = pv.ImageData(dimensions=(6, 6, 11), spacing=(1.0, 1.0, thickness / 10), origin=(-2.5, -2.5, 0))
    g["d"] = np.ones(g.n_points)
    colour = np.array([[0.2, 0.5, 0.9], [0.2, 0.5, 0.9]])
    tf = pa.TransferFunction.from_table([0.0, 2.0], sigma_t=[0.0, 2 * sigma], color=colour * [[0], [2]])
    cam = Camera((0, 0, 5), (0, 0, 0), (0, 1, 0), parallel_projection=True, parallel_scale=2.0)
    res = pa.render(g, transfer_function=tf, camera=cam, window_size=(16, 16), early_termination=0.0)
    expected = np.array([0.2, 0.5, 0.9]) * (1 - np.exp(-sigma * thickness))
    assert np.max(np.abs(res.radiance / expected - 1)) <= 1e-4


def test_background_and_alpha():
    g = box_grid()
    tf = pa.TransferFunction.from_table([0.0, 2.0], sigma_t=[0.0, 2.0], color=[[0, 0, 0], [0, 0, 0]])
    cam = Camera((0.3, -5, 0.2), (0, 0, 0), (0, 0, 1))
    res = pa.render(g, transfer_function=tf, camera=cam, window_size=(32, 32), background=(0.2, 0.4, 0.6),
                    early_termination=0.0)
    # black medium: radiance = transmittance · background
    assert np.allclose(res.radiance, (1 - res.alpha)[..., None] * [0.2, 0.4, 0.6], atol=1e-6)
    assert res.alpha.min() == 0.0 and res.alpha.max() > 0.5


def test_empty_space_skipping_changes_nothing():
    # a small dense blob in a big empty grid: with and without skipping (huge block) agree
    g = pv.ImageData(dimensions=(48, 48, 48), spacing=(1 / 47,) * 3)
    x, y, z = g.points.T
    g["d"] = np.exp(-((x - 0.7) ** 2 + (y - 0.4) ** 2 + (z - 0.5) ** 2) / 0.01).astype(np.float32)
    tf = pa.TransferFunction.from_table([0.0, 0.05, 1.0], sigma_t=[0.0, 0.0, 30.0],
                                        color=[[1, 0, 0], [1, 0, 0], [0, 1, 1]])
    r = pa.Renderer(g, transfer_function=tf)
    assert (r.stages.majorant() == 0).mean() > 0.3
    cam = Camera((2, -1.5, 1.2), (0.5, 0.5, 0.5), (0, 0, 1))
    a = r.render(camera=cam, window_size=(40, 40), early_termination=0.0)
    r.cache[("majorant", 8)] = np.ones_like(r.stages.majorant())  # no block is empty
    b = r.render(camera=cam, window_size=(40, 40), early_termination=0.0)
    assert np.max(np.abs(a.radiance - b.radiance)) < 2e-3 * b.radiance.max()


def test_nonmonotone_tf_is_not_skipped():
    # TF opaque only between two scalar values that no sample takes: the interpolated field
    # crosses it, so the majorant must not call those blocks empty
    g = pv.ImageData(dimensions=(16, 16, 16))
    g["d"] = np.where(np.arange(g.n_points) % 2 == 0, 0.0, 1.0).astype(np.float32)
    tf = pa.TransferFunction.from_table([0.0, 0.45, 0.5, 0.55, 1.0], sigma_t=[0, 0, 5.0, 0, 0])
    r = pa.Renderer(g, transfer_function=tf)
    assert r.stages.majorant().min() > 0
    res = r.render(window_size=(16, 16))
    assert res.alpha.max() > 0.1


def test_jitter_is_seeded_and_unbiased():
    g = box_grid()
    x = g.points
    g["d"] = (1 + np.sin(3 * x[:, 0]) * np.cos(2 * x[:, 1])).astype(np.float32)
    tf = pa.TransferFunction.from_table([0.0, 2.0], sigma_t=[0.0, 4.0])
    cam = Camera((0.3, -5, 0.2), (0, 0, 0), (0, 0, 1))
    kw = dict(transfer_function=tf, camera=cam, window_size=(24, 24), step=0.08)
    a = pa.render(g, jitter=True, seed=3, **kw)
    b = pa.render(g, jitter=True, seed=3, **kw)
    c = pa.render(g, jitter=True, seed=4, **kw)
    fine = pa.render(g, **{**kw, "step": 0.005})
    assert np.array_equal(a.radiance, b.radiance) and not np.array_equal(a.radiance, c.radiance)
    # jittered coarse steps scatter around the converged image with a small mean error
    err = a.alpha - fine.alpha
    assert abs(err.mean()) < 0.2 * np.abs(err).mean() + 1e-4


def test_nan_in_data_is_refused_by_default():
    g = box_grid(dims=(4, 4, 4))
    g["d"][3] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        pa.render(g, window_size=(8, 8))
    res = pa.render(g, window_size=(8, 8), nan_policy="vacuum",
                    transfer_function=pa.TransferFunction(density_scale=1.0, clim=(0, 1)))
    assert np.all(np.isfinite(res.radiance))


def test_input_is_not_modified():
    g = box_grid(dims=(5, 5, 5))
    g["d"] = np.random.default_rng(0).random(g.n_points).astype(np.float32)
    before = (g.copy(deep=True), g.active_scalars_name)
    pa.render(g, window_size=(8, 8))
    assert g == before[0] and g.active_scalars_name == before[1]


def test_ray_end_stops_rays_exactly():
    # opaque geometry at distance t_end: alpha = 1 − e^{−σ (min(t_end, t1) − t0)} exactly
    sigma = 3.0
    g = box_grid()
    tf = pa.TransferFunction.from_table([0.0, 2.0], sigma_t=[0.0, 2 * sigma])
    cam = Camera((0.3, -5, 0.2), (0, 0, 0), (0, 0, 1), view_angle=30)
    size = (48, 40)
    o, d = cam.rays(size)
    lo, hi = np.full(3, -0.95), np.full(3, 0.95)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = (lo - o) / d
        b = (hi - o) / d
    t0 = np.maximum(np.max(np.minimum(a, b), axis=-1), 0.0)
    t1 = np.min(np.maximum(a, b), axis=-1)
    rng = np.random.default_rng(3)
    t_end = np.where(rng.random(t0.shape) < 0.5, t0 + rng.random(t0.shape) * 2.0, np.inf)
    res = pa.render(g, transfer_function=tf, camera=cam, window_size=size, early_termination=0.0, ray_end=t_end)
    chord = np.clip(np.minimum(t1, t_end) - t0, 0.0, None)
    assert 0.2 < ((chord > 0) & np.isfinite(t_end)).mean()
    assert np.max(np.abs(res.alpha - (1 - np.exp(-sigma * chord)))) <= 1e-4
    with pytest.raises(ValueError, match="ray_end must have shape"):
        pa.render(g, transfer_function=tf, camera=cam, window_size=size, ray_end=np.ones((3, 3)))
    with pytest.raises(ValueError, match="ray_end must hold distances"):
        pa.render(g, transfer_function=tf, camera=cam, window_size=size, ray_end=-t_end)

