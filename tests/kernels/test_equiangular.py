"""Tests pv_ambient/_kernels/equiangular.py, equiangular distance sampling: the density integrates to
one over its segment and equals an independent closed form, its samples follow it (χ² test), and it
stays finite where the ray passes through the light or the segment is short and far away."""

import math

import numpy as np
import pytest
from scipy import integrate, stats

from pv_ambient._kernels.equiangular import equiangular_pdf, equiangular_sample, equiangular_setup

# (origin, direction, light, a, b): light beside the segment's middle, before it, behind it, far off
# to the side, almost on the ray
CASES = [
    ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.5, 0.3, 0.0), 0.0, 1.0),
    ((0.0, 0.0, 0.0), (0.0, 0.6, 0.8), (0.1, -0.5, -0.2), 0.2, 2.5),
    ((1.0, 2.0, 3.0), (0.0, 0.0, -1.0), (1.0, 2.2, -4.0), 0.0, 3.0),
    ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (40.0, 25.0, -10.0), 0.5, 0.75),
    ((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), (1e-4, 0.6, 0.0), 0.0, 1.0),
]
D_MIN = 1e-3


def _setup(case):
    o, d, c, a, b = case
    return equiangular_setup(*o, *d, *c, a, b, D_MIN)


def _closed_form(t, case):
    """The density ∝ 1/(D² + (t − Δ)²) on [a, b], normalised by its antiderivative (an independent
    computation in NumPy: the distance from the light by vector algebra)."""
    o, d, c, a, b = (np.asarray(x, float) if i < 3 else x for i, x in enumerate(case))
    foot = o + np.dot(c - o, d) * d
    D = max(np.linalg.norm(c - foot), D_MIN)
    delta = np.dot(c - o, d)
    norm = (np.arctan((b - delta) / D) - np.arctan((a - delta) / D)) / D
    return 1.0 / (norm * (D * D + (t - delta) ** 2))


@pytest.mark.parametrize("case", CASES)
def test_pdf_integrates_to_one_and_equals_the_closed_form(case):
    delta, D, _, span = _setup(case)
    a, b = case[3], case[4]
    total, err = integrate.quad(lambda t: equiangular_pdf(t, delta, D, span), a, b,
                                points=[min(max(delta, a), b)], limit=200, epsabs=0.0, epsrel=1e-10)
    assert total == pytest.approx(1.0, rel=1e-8)
    ts = np.linspace(a, b, 17)
    ours = np.array([equiangular_pdf(t, delta, D, span) for t in ts])
    np.testing.assert_allclose(ours, _closed_form(ts, case), rtol=1e-9)


@pytest.mark.parametrize("case", CASES)
def test_samples_follow_the_pdf_chi2(case):
    """20 bins of equal probability under the closed-form CDF; 20,000 samples from a fixed-seed
    stream; χ² with 19 degrees of freedom, rejected at p < 1e-3 (false-alarm rate 0.1 % per case)."""
    delta, D, tau_a, span = _setup(case)
    a, b = case[3], case[4]
    u = np.random.default_rng(7).random(20000)
    out = np.array([equiangular_sample(x, a, D, tau_a, span) for x in u])
    t, pdf = out[:, 0], out[:, 1]
    assert np.all((t >= a - 1e-12 * (1 + abs(a))) & (t <= b + 1e-12 * (1 + abs(b))))
    np.testing.assert_allclose(pdf, [equiangular_pdf(x, delta, D, span) for x in t], rtol=1e-12)
    # the closed-form CDF, inverted at the bin edges: equal-probability bins
    d_ = np.asarray(case[1], float)
    c_, o_ = np.asarray(case[2], float), np.asarray(case[0], float)
    dl = np.dot(c_ - o_, d_)
    DD = max(np.linalg.norm(c_ - (o_ + dl * d_)), D_MIN)
    th_a, th_b = math.atan((a - dl) / DD), math.atan((b - dl) / DD)
    edges = dl + DD * np.tan(th_a + np.linspace(0.0, 1.0, 21) * (th_b - th_a))
    counts, _ = np.histogram(np.clip(t, a, b), bins=edges)
    _, p = stats.chisquare(counts)
    assert p > 1e-3, (counts, p)


def test_light_on_the_ray_and_far_short_segments_stay_finite():
    # the light on the ray: D clamped at d_min, the density proper and peaked at the light
    delta, D, tau_a, span = equiangular_setup(0, 0, 0, 1, 0, 0, 0.5, 0, 0, 0.0, 1.0, D_MIN)
    assert D == D_MIN and 0 < span < math.pi
    t, pdf = equiangular_sample(0.5, 0.0, D, tau_a, span)
    assert abs(t - 0.5) < 1e-12 and pdf == pytest.approx(1.0 / (D_MIN * span))
    # a segment of length 1e-9 at distance 1e6: the span keeps its precision (pdf ≈ 1/length)
    delta, D, tau_a, span = equiangular_setup(0, 0, 0, 1, 0, 0, -1e6, 1.0, 0, 0.0, 1e-9, D_MIN)
    for u in (0.0, 0.5, 0.999):
        t, pdf = equiangular_sample(u, 0.0, D, tau_a, span)
        assert t == pytest.approx(u * 1e-9, rel=1e-6, abs=1e-24) and pdf == pytest.approx(1e9, rel=1e-6)
