"""Tests pv_ambient/stages/refine.py, the progressive model's thresholded correction
(docs/progressive.rst): exact corrections kept in full, unmeasured ones dropped, block means preserved,
and a picture no worse than either the base or the unbiased estimate over a range of noise levels."""

import numpy as np
import pytest

from pv_ambient.stages.refine import held_out_z, threshold_correction, universal_threshold


def _smooth(h=64, w=48):
    y, x = np.mgrid[0:h, 0:w]
    return (0.3 * np.sin(x / 9.0) + 0.2 * (y / h))[..., None] * np.array([1.0, 0.8, 0.6])


def test_exact_correction_is_kept_in_full_and_unmeasured_is_dropped():
    rng = np.random.default_rng(0)
    d = rng.normal(size=(37, 23, 3))  # odd sizes: partial blocks at every level
    out, kept = threshold_correction(d, np.zeros_like(d))
    np.testing.assert_allclose(out, d, rtol=0, atol=1e-12)
    assert kept == 1.0
    for v in (np.inf, np.nan):
        out, kept = threshold_correction(d, np.full_like(d, v))
        np.testing.assert_array_equal(out, 0.0)
        assert kept == 0.0


def test_image_mean_is_the_estimates_when_measurable():
    """Details are kept per parent, all children together: the picture's mean is the estimate's
    whole-image mean however many details are dropped (here: a significant offset under noise that
    hides every single pixel's detail)."""
    rng = np.random.default_rng(1)
    d = 0.3 + rng.normal(0.0, 1.0, (37, 23, 3))  # the mean 8.8 standard errors from 0
    out, kept = threshold_correction(d, np.ones_like(d))
    assert kept < 0.05  # almost no pixel stands out of its noise ...
    np.testing.assert_allclose(out.mean(axis=(0, 1)), d.mean(axis=(0, 1)), rtol=1e-12)  # ... the mean does


def test_pure_noise_is_dropped():
    """No correction, unit noise: a kept pixel group is a false alarm of the pixel level's
    threshold (√(2 ln n) = 4.5 standard errors here; expected false groups ≈ 768·4·P(|z| > 4.5)
    < 0.03, at most 2 allowed). The coarse levels' lower thresholds let more through, but their
    noise is small (a 2^k block's mean: 1/2^k): expected energy kept Σ_k P(|z| > t_k)·(t_k² + 1)·
    4^-k ≈ 1e-3 per pixel — the picture's noise below a tenth of the estimate's (measured 0.06)."""
    rng = np.random.default_rng(2)
    d = rng.normal(size=(64, 48, 3))
    out, kept = threshold_correction(d, np.ones_like(d))
    assert kept <= 2 / (32 * 24)
    assert np.sqrt(np.mean(out ** 2)) < 0.1


@pytest.mark.parametrize("sigma", [3.0, 1.0, 0.3, 0.1, 0.03, 0.001])
def test_no_worse_than_the_base_nor_the_unbiased_estimate(sigma):
    """RMS error against the true correction, averaged over 4 fixed seeds: at most the base's
    (no correction) and at most 1.5× the unbiased estimate's — the threshold gives up little where
    the noise is small (every detail kept) and adds none where it is large."""
    true = _smooth()
    rng = np.random.default_rng(3)
    errs = []
    for _ in range(4):
        est = true + rng.normal(0.0, sigma, true.shape)
        out, _ = threshold_correction(est, np.full(true.shape, sigma ** 2))
        errs.append(np.sqrt(np.mean((out - true) ** 2)))
    err, base, raw = float(np.mean(errs)), float(np.sqrt(np.mean(true ** 2))), sigma
    assert err <= base and err <= 1.5 * raw, (err, base, raw)


def test_threshold_and_shapes():
    assert universal_threshold(1) == universal_threshold(2) > 0
    assert abs(universal_threshold(64 * 48 * 3) - np.sqrt(2 * np.log(64 * 48 * 3))) < 1e-12
    d = np.zeros((4, 4))
    out, _ = threshold_correction(d + 1.0, d)  # (H, W): one channel
    np.testing.assert_array_equal(out, 1.0)
    with pytest.raises(ValueError, match="delta and variance"):
        threshold_correction(np.zeros((4, 4, 3)), np.zeros((4, 4, 1)))


def test_few_samples_raise_the_threshold():
    """A variance estimated from few samples: the threshold is Student's t quantile of the
    Gaussian one's tail probability. Pure noise whose variance estimates come from 2 samples per
    pixel (χ² with 1 degree of freedom: often far too small) crosses the Gaussian threshold in
    1–3 pixel groups of 768 over seeds 0–5 (expected with the true variance: 0.03); told the sample
    count, in none, and from one sample nothing is kept."""
    rng = np.random.default_rng(4)
    x = rng.normal(size=(2, 64, 48, 3))  # two samples per pixel, true variance 1
    mean = x.mean(axis=0)
    var_of_mean = x.var(axis=0, ddof=1) / 2
    _, kept_gauss = threshold_correction(mean, var_of_mean)
    out, kept = threshold_correction(mean, var_of_mean, samples=2)
    assert kept_gauss >= 1 / 768 and kept == 0.0
    out, kept = threshold_correction(mean, var_of_mean, samples=1)
    np.testing.assert_array_equal(out, 0.0)


def test_exact_pixels_keep_their_own_correction():
    """Pixels whose correction is known exactly (zero variance there and around: e.g. background
    every sample left at once) keep exactly their own value — a correction measured on the medium
    does not leak into them — and the block means are those of the other pixels."""
    rng = np.random.default_rng(5)
    d = np.zeros((32, 32, 3))
    v = np.zeros_like(d)
    d[8:24, 8:24] = 0.5 + rng.normal(0.0, 0.1, (16, 16, 3))  # the medium: a clear shift under noise
    v[8:24, 8:24] = 0.01
    out, _ = threshold_correction(d, v)
    np.testing.assert_array_equal(out[:6], 0.0)  # two pixels from the medium: outside its 3×3 reach
    np.testing.assert_array_equal(out[:, :6], 0.0)
    inner = out[10:22, 10:22]
    assert abs(float(inner.mean()) - 0.5) < 0.03  # the shift is kept where the medium is


def _block_means(a, b=4):
    h, w, c = a.shape
    return a.reshape(h // b, b, w // b, b, c).mean(axis=(1, 3))


def test_held_out_z_is_a_standard_normal_about_the_analytic_difference():
    """Two fixed ways of making a picture (their half-sample pictures fixed, so independent of the
    held-out estimates) and Gaussian half-estimates of a known limit: ``held_out_z`` must be
    normal with unit variance about ``D/√V`` — ``D`` the difference of the two ways' squared
    4×4-block errors (both halves), ``V`` the variance the docstring derives, computed here from
    the block means directly. 2000 draws, seed 0: the mean within 4 standard errors (0.09) and
    the standard deviation within ±0.08 of 1 (over 5 of its standard errors, 0.016), for both
    an equal pair (D = 0) and an unequal one."""
    rng = np.random.default_rng(0)
    h, w, c = 16, 16, 3
    limit = 1.0 + rng.random((h, w, c))
    sd = 0.2 + 0.3 * rng.random((h, w, c))
    var = sd * sd
    bump = np.zeros((h, w, c))
    bump[:8] = 0.03
    for first, second in [((limit + bump, limit - bump), (limit - bump, limit + bump)),
                          ((limit + 2 * bump, limit), (limit + 4 * bump, limit - 4 * bump))]:
        ml = _block_means(limit)
        vb = _block_means(var) / 16  # Var of a 4×4 block mean
        d = sum(np.sum((_block_means(x) - ml) ** 2 - (_block_means(y) - ml) ** 2) for x, y in zip(first, second))
        v = 4 * sum(np.sum((_block_means(x) - _block_means(y)) ** 2 * vb) for x, y in zip(first, second))
        expected = d / np.sqrt(v)
        z = np.array([held_out_z(first, second, (limit + sd * rng.standard_normal((h, w, c)),
                                                 limit + sd * rng.standard_normal((h, w, c))), (var, var))
                      for _ in range(2000)])
        assert abs(z.mean() - expected) < 4 / np.sqrt(2000), (z.mean(), expected)
        assert abs(z.std() - 1.0) < 0.08, z.std()
    assert expected < -3  # the second pair: the first way is the closer, and it shows


def test_held_out_z_cannot_tell_without_variances():
    a = np.ones((8, 8, 3))
    inf = np.full_like(a, np.inf)
    assert held_out_z((a, a), (a + 1, a + 1), (a, a), (inf, inf)) == 0.0  # one sample per pixel
    assert held_out_z((a, a), (a, a), (a, a), (a, a)) == 0.0  # the two ways alike
    with pytest.raises(ValueError, match="one shape"):
        held_out_z((a, a), (a, a), (a, a[:4]), (a, a))
