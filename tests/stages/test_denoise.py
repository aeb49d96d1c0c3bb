"""Tests pv_ambient/stages/denoise.py (optional extra ``denoise``): the mean-preserving rescale, the
denoiser's call and its albedo guide (the renderer's first-collision albedo), with pyoidn mocked;
with pyoidn, a guided denoise that keeps the mean. The denoised ``path_traced`` model:
tests/rendering/test_path_traced.py; ``denoise=True`` without pyoidn: tests/rendering/test_request.py."""

import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient.stages.denoise import available

from ..helpers import lit_box

pv = pytest.importorskip("pyvista")


CAM = pa.Camera((0, -4, 0.5), (0, 0, 0), (0, 0, 1), view_angle=35)


# --- mean preservation and the albedo guide (run without pyoidn: the denoiser is mocked) ---

from pv_ambient.stages import denoise as dn  # noqa: E402


class FakeOIDN:
    """Stands in for pyoidn: a biased 'denoiser' (3×3 box blur × 0.7) that records its call."""

    def __init__(self):
        self.calls = []

    def denoise(self, color, albedo=None, normal=None, *, hdr=False, clean_aux=False, quality="high"):
        self.calls.append(dict(color=color, albedo=albedo, hdr=hdr, clean_aux=clean_aux, quality=quality))
        p = np.pad(color, ((1, 1), (1, 1), (0, 0)), mode="edge")
        H, W = color.shape[:2]
        blur = sum(p[i:i + H, j:j + W] for i in range(3) for j in range(3)) / 9.0
        return (0.7 * blur).astype(np.float32)


@pytest.fixture
def fake_oidn(monkeypatch):
    import sys

    fake = FakeOIDN()
    monkeypatch.setitem(sys.modules, "pyoidn", fake)
    return fake


def test_preserve_mean_is_exact_per_channel():
    rng = np.random.default_rng(0)
    noisy = rng.exponential(size=(17, 23, 3)) ** 3  # heavy-tailed, like a few-spp image
    den = rng.uniform(0.1, 2.0, size=noisy.shape)
    out = dn.preserve_mean(den, noisy)
    assert out.dtype == np.float32 and out.shape == noisy.shape
    np.testing.assert_allclose(out.astype(np.float64).sum(axis=(0, 1)), noisy.sum(axis=(0, 1)), rtol=1e-6)
    # a per-channel rescale: ratios between pixels of a channel are kept
    np.testing.assert_allclose(out[..., 1] / out[0, 0, 1], den[..., 1] / den[0, 0, 1], rtol=1e-5)


def test_preserve_mean_leaves_an_all_zero_channel_and_checks_shapes():
    den = np.ones((4, 4, 3))
    den[..., 2] = 0.0
    out = dn.preserve_mean(den, np.full((4, 4, 3), 2.0))
    np.testing.assert_array_equal(out[..., 2], 0.0)
    np.testing.assert_allclose(out[..., :2], 2.0)
    with pytest.raises(ValueError, match="shape"):
        dn.preserve_mean(np.ones((4, 4, 3)), np.ones((4, 5, 3)))


def test_denoise_radiance_preserves_the_noisy_mean(fake_oidn):
    rng = np.random.default_rng(1)
    noisy = (rng.exponential(size=(12, 10, 3)) ** 2).astype(np.float32)
    noisy[0, 0] = [np.nan, -1.0, np.inf]  # counted as 0
    clean = np.nan_to_num(noisy, nan=0.0, posinf=0.0).clip(0, None)
    out = dn.denoise_radiance(noisy)
    np.testing.assert_allclose(out.astype(np.float64).sum(axis=(0, 1)), clean.astype(np.float64).sum(axis=(0, 1)),
                               rtol=1e-5)
    call = fake_oidn.calls[-1]
    assert call["hdr"] is True and call["albedo"] is None
    raw = dn.denoise_radiance(noisy, mean_preserving=False)  # the filter's own (here 30 % dark) output
    np.testing.assert_allclose(raw.sum(), 0.7 * clean.sum(), rtol=0.05)


def test_denoise_radiance_passes_a_clean_albedo_guide(fake_oidn):
    noisy = np.ones((6, 5, 3), np.float32)
    alb = np.full((6, 5, 3), 0.5, np.float32)
    alb[0, 0] = 1.5  # clipped to [0, 1]
    dn.denoise_radiance(noisy, albedo=alb)
    call = fake_oidn.calls[-1]
    assert call["clean_aux"] is True and call["albedo"].dtype == np.float32
    assert call["albedo"].max() == 1.0 and call["albedo"].flags["C_CONTIGUOUS"]
    with pytest.raises(ValueError, match="albedo shape"):
        dn.denoise_radiance(noisy, albedo=alb[:5])


def test_albedo_guide_is_first_collision_albedo():
    # constant albedo a: ∫ T σt a dt = a (1 − T) = a · alpha of the emission–absorption render
    r = lit_box()
    g = r.albedo_guide(CAM, (16, 12))
    ea = r.render(camera=CAM, window_size=(16, 12), step=r.default_step())
    assert g.shape == (12, 16, 3) and g.dtype == np.float32 and g.min() >= 0 and g.max() <= 1
    assert ea.alpha.max() > 0.5
    np.testing.assert_allclose(g, 0.8 * np.repeat(ea.alpha[..., None], 3, -1), atol=1e-5)
    # the renderer itself is untouched: its own EA image is unchanged after the guide
    np.testing.assert_array_equal(r.render(camera=CAM, window_size=(16, 12), step=r.default_step()).radiance,
                                  ea.radiance)


def test_albedo_guide_of_a_colormap_tf_scales_its_colour():
    # scalar albedo k scales the TF colour: the guide is k × the emission–absorption image
    g = pv.ImageData(dimensions=(9, 9, 9), spacing=(0.25,) * 3, origin=(-1, -1, -1))
    g["s"] = np.linspace(0.0, 1.0, g.n_points).astype(np.float32)
    r = pa.Renderer(g, transfer_function=pa.TransferFunction(cmap="viridis", opacity="linear", density_scale=4.0,
                                                             albedo=0.6))
    guide = r.albedo_guide(CAM, (12, 12))
    ea = r.render(camera=CAM, window_size=(12, 12), step=r.default_step()).radiance
    assert ea.max() > 0.05
    np.testing.assert_allclose(guide, 0.6 * ea, atol=1e-5)


@pytest.mark.skipif(not available(), reason="needs the optional pyoidn")
def test_oidn_with_albedo_guide_keeps_the_mean():
    r = lit_box()
    raw = r.render(camera=CAM, window_size=(32, 32), model="path_traced", samples_per_pixel=4, seed=5)
    out = dn.denoise_radiance(raw.radiance, albedo=r.albedo_guide(CAM, (32, 32)))
    assert np.all(np.isfinite(out)) and out.min() >= 0
    np.testing.assert_allclose(out.astype(np.float64).sum(axis=(0, 1)),
                               raw.radiance.astype(np.float64).sum(axis=(0, 1)), rtol=1e-5)
    assert np.abs(np.diff(out, axis=1)).mean() < np.abs(np.diff(raw.radiance, axis=1)).mean()

