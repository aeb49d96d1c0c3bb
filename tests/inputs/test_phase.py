"""Tests pv_ambient/inputs/phase.py (and the scalars of _kernels/phase.py): normalisation, moments,
closed forms, χ² goodness of fit of the samplers.

The χ² test follows Mitsuba 3's ``chi2.py``: sampled directions are histogrammed on
(φ, cos θ) cells in the frame of the incoming direction, expected counts come from the pdf
integrated per cell, cells with expected count < 5 are pooled, and the p-value is compared to
α = 0.01 with a Šidák correction over the number of χ² tests. A negative control (HG g = 0.5
samples against the g = 0.45 pdf) proves the test has the power to fail.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, stats

from pv_ambient._kernels import phase as kp
from pv_ambient._kernels import rng
from pv_ambient._kernels._jit import driver
from pv_ambient.inputs.phase import (
    HenyeyGreenstein,
    Isotropic,
    PhaseFunction,
    Rayleigh,
    Schlick,
    as_phase,
)

HG_G = [-0.99, -0.5, 0.0, 0.5, 0.99]
ALL_PHASES = (
    [Isotropic(), Rayleigh()]
    + [HenyeyGreenstein(g) for g in HG_G + [-0.999, 0.999]]
    + [Schlick(g) for g in (-0.9, -0.3, 0.0, 0.3, 0.8, 0.95, 0.999)]
)


def _quad(f, a=-1.0, b=1.0):
    """∫_a^b f(μ) dμ by adaptive quadrature, tolerances ~1e-12."""
    value, _ = integrate.quad(f, a, b, epsabs=1e-13, epsrel=1e-12, limit=500)
    return value


def _ids(p):
    return repr(p)


# --- normalisation and moments ----------------------------------------------------------


@pytest.mark.parametrize("phase", ALL_PHASES, ids=_ids)
def test_normalised_over_sphere(phase):
    total = 2.0 * math.pi * _quad(phase.eval)
    assert abs(total - 1.0) <= 1e-6, total


@pytest.mark.parametrize("g", HG_G)
def test_hg_mean_cosine_is_g(g):
    phase = HenyeyGreenstein(g)
    mean = 2.0 * math.pi * _quad(lambda mu: mu * phase.eval(mu))
    assert abs(mean - g) <= 1e-6, mean
    assert phase.mean_cosine == g


@pytest.mark.parametrize("g", [-0.9, -0.3, 0.0, 0.01, 0.3, 0.8, 0.95])
def test_schlick_mean_cosine_matches_quadrature(g):
    phase = Schlick(g)
    mean = 2.0 * math.pi * _quad(lambda mu: mu * phase.eval(mu))
    assert abs(phase.mean_cosine - mean) <= 1e-9, (phase.mean_cosine, mean)


@pytest.mark.parametrize("phase", [Isotropic(), Rayleigh()], ids=_ids)
def test_symmetric_kinds_have_zero_mean_cosine(phase):
    assert phase.mean_cosine == 0.0
    assert abs(2.0 * math.pi * _quad(lambda mu: mu * phase.eval(mu))) <= 1e-12


# --- values against the closed forms of docs/conventions.rst --------------------------


def _naive(phase, mu):
    """Slow, obviously-correct NumPy transcription of docs/conventions.rst."""
    g = phase.g
    if isinstance(phase, HenyeyGreenstein):
        return (1 - g * g) / (4 * np.pi * (1 + g * g - 2 * g * mu) ** 1.5)
    if isinstance(phase, Schlick):
        k = 1.55 * g - 0.55 * g**3
        return (1 - k * k) / (4 * np.pi * (1 - k * mu) ** 2)
    if isinstance(phase, Rayleigh):
        return 3 / (16 * np.pi) * (1 + mu * mu)
    return np.full_like(mu, 1 / (4 * np.pi))


@pytest.mark.parametrize(
    "phase",
    [Isotropic(), Rayleigh()]
    + [HenyeyGreenstein(g) for g in HG_G]
    + [Schlick(g) for g in (-0.9, -0.3, 0.0, 0.3, 0.8)],
    ids=_ids,
)
def test_eval_matches_closed_form(phase):
    mu = np.linspace(-1.0, 1.0, 201)
    np.testing.assert_allclose(phase.eval(mu), _naive(phase, mu), rtol=1e-10)


@pytest.mark.parametrize("cls", [HenyeyGreenstein, Schlick])
@pytest.mark.parametrize("g", [0.1, 0.5, 0.9])
def test_positive_g_scatters_forward(cls, g):
    forward, backward = cls(g).eval(1.0), cls(g).eval(-1.0)
    assert forward > backward
    assert cls(-g).eval(-1.0) == pytest.approx(forward, rel=1e-12)


@pytest.mark.parametrize("phase", ALL_PHASES, ids=_ids)
def test_pdf_equals_eval(phase):
    mu = np.linspace(-1.0, 1.0, 101)
    np.testing.assert_array_equal(phase.pdf(mu), phase.eval(mu))


@pytest.mark.parametrize("g", [0.2, 0.5, 0.9, 0.999])
def test_hg_symmetry_under_g_and_cos_sign_flip(g):
    mu = np.linspace(-1.0, 1.0, 401)
    np.testing.assert_allclose(HenyeyGreenstein(-g).eval(-mu), HenyeyGreenstein(g).eval(mu), rtol=1e-13)
    u = np.linspace(0.0, 1.0, 401)
    np.testing.assert_allclose(
        HenyeyGreenstein(-g).sample_cos(u), -HenyeyGreenstein(g).sample_cos(1.0 - u), atol=1e-12
    )


def test_no_nan_or_inf_at_extremes():
    u = np.array([0.0, 2.0**-53, 0.5, 1.0 - 2.0**-53, 1.0])
    u1, u2 = np.meshgrid(u, u)
    axes = np.array([[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, -1, 0], [1e-9, 0, -1.0]], dtype=float)
    with pytest.warns(UserWarning, match="beyond"):  # HG past 0.999 says it is clamped
        extremes = [cls(g) for cls in (HenyeyGreenstein, Schlick) for g in (-0.999, 0.999, -0.9999999, 0.9999999)]
    for phase in [Isotropic(), Rayleigh()] + extremes:
        values = phase.eval(np.array([-1.0, -1.0 - 1e-12, 0.0, 1.0, 1.0 + 1e-12]))
        assert np.all(np.isfinite(values)) and np.all(values > 0.0), (phase, values)
        cos = phase.sample_cos(u)
        assert np.all(np.isfinite(cos)) and np.all(np.abs(cos) <= 1.0), (phase, cos)
        for w in axes:
            d, pdf = phase.sample(u1, u2, w)
            assert np.all(np.isfinite(d)) and np.all(np.isfinite(pdf)) and np.all(pdf > 0), (phase, w)
            np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0, atol=1e-12)


@pytest.mark.parametrize("phase", [Isotropic(), Rayleigh(), HenyeyGreenstein(-0.7), Schlick(0.6)], ids=_ids)
def test_sample_cos_is_monotone_from_minus_one_to_one(phase):
    u = np.linspace(0.0, 1.0, 10001)
    cos = phase.sample_cos(u)
    assert cos[0] == -1.0 and cos[-1] == 1.0
    assert np.all(np.diff(cos) >= 0.0)


@pytest.mark.parametrize("g", [0.0, 1e-12, -1e-9, 2e-4, -9.99e-4, 1e-3, 0.3, -0.8, 0.99])
def test_hg_inverse_cdf_is_exact_at_small_and_large_g(g):
    # No isotropic fallback at small |g|: F(μ(u)) = u with F the closed-form HG CDF
    # (an isotropic branch below |g| = 1e-3 would miss by up to 3|g|/4 here).
    u = np.linspace(0.0, 1.0, 1001)
    mu = HenyeyGreenstein(g).sample_cos(u)
    if g == 0.0:
        np.testing.assert_array_equal(mu, 2.0 * u - 1.0)
    elif abs(g) <= 1e-6:
        # The closed-form CDF cancels (error ~eps/|g|); check μ = 2u − 1 + O(g) instead.
        np.testing.assert_allclose(mu, 2.0 * u - 1.0, atol=10 * abs(g) + 1e-15)
    else:
        cdf = (1 - g * g) / (2 * g) * (1 / np.sqrt(1 + g * g - 2 * g * mu) - 1 / (1 + g))
        np.testing.assert_allclose(cdf, u, atol=1e-9)


@pytest.mark.parametrize("phase", [Rayleigh(), HenyeyGreenstein(0.7), Schlick(-0.4)], ids=_ids)
def test_sampled_directions_are_unit_and_pdf_matches_their_cosine(phase):
    gen = np.random.default_rng(7)
    w = gen.normal(size=(2000, 3))
    d, pdf = phase.sample(gen.random(2000), gen.random(2000), w)
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0, atol=1e-12)
    cos = np.einsum("ij,ij->i", d, w / np.linalg.norm(w, axis=-1, keepdims=True))
    np.testing.assert_allclose(pdf, phase.eval(np.clip(cos, -1, 1)), rtol=1e-6)


def test_sample_broadcasts():
    hg = HenyeyGreenstein(0.3)
    d, pdf = hg.sample(0.25, 0.5, [0.0, 0.0, 2.0])
    assert d.shape == (3,) and isinstance(pdf, float)
    assert d[2] == pytest.approx(hg.sample_cos(0.25), abs=1e-15)
    d, pdf = hg.sample(np.full((4, 5), 0.3), 0.1, np.ones((5, 3)))
    assert d.shape == (4, 5, 3) and pdf.shape == (4, 5)


# --- χ² goodness of fit (Mitsuba 3 chi2.py) ------------------------------------------------

N_SAMPLES = 200_000
N_THETA, N_PHI = 48, 24  # cos-θ edges at cos of uniform θ steps: resolves the peaks at ±1
ALPHA = 0.01
CHI2_PHASES = (
    [HenyeyGreenstein(g) for g in (-0.9, -0.3, 0.0, 0.5, 0.95)]
    + [Schlick(g) for g in (-0.7, 0.2, 0.9)]
    + [Rayleigh(), Isotropic()]
)
SIDAK_ALPHA = 1.0 - (1.0 - ALPHA) ** (1.0 / len(CHI2_PHASES))


@driver(parallel=False)
def _counter_uniforms(seed, n):
    """Two counter-based uniform dimensions per sample, as the renderers draw them."""
    out = np.empty((n, 2))
    for i in range(n):
        out[i, 0] = rng.uniform(seed, 0, i, 0)
        out[i, 1] = rng.uniform(seed, 0, i, 1)
    return out


def _frame(w):
    """An orthonormal frame around w by Gram–Schmidt (independent of the kernel's ONB)."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(w[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    b1 = helper - (helper @ w) * w
    b1 /= np.linalg.norm(b1)
    return b1, np.cross(w, b1)


def _chi2_pvalue(sample_phase, pdf_phase, seed):
    """p-value of directions sampled from ``sample_phase`` against the pdf of ``pdf_phase``."""
    w = np.random.default_rng(1000 + seed).normal(size=3)
    w /= np.linalg.norm(w)
    u = _counter_uniforms(seed, N_SAMPLES)
    d, _ = sample_phase.sample(u[:, 0], u[:, 1], w)

    # Histogram on (θ, φ) in the frame of w; θ edges uniform, i.e. cos-θ edges at cos(θ_k).
    b1, b2 = _frame(w)
    theta = np.arccos(np.clip(d @ w, -1.0, 1.0))
    phi = np.arctan2(d @ b2, d @ b1)
    theta_edges = np.linspace(0.0, np.pi, N_THETA + 1)
    phi_edges = np.linspace(-np.pi, np.pi, N_PHI + 1)
    observed, _, _ = np.histogram2d(theta, phi, bins=[theta_edges, phi_edges])

    # Expected counts: the pdf integrated over each cell (∫ dφ ∫ p dμ; p does not depend on φ).
    mu_edges = np.cos(theta_edges)
    band = np.array([_quad(pdf_phase.eval, mu_edges[i + 1], mu_edges[i]) for i in range(N_THETA)])
    expected = N_SAMPLES * np.outer(band, np.diff(phi_edges))

    # Pool the cells with expected count < 5 (growing the pool until it reaches 5).
    obs, exp = observed.ravel(), expected.ravel()
    order = np.argsort(exp)
    obs, exp = obs[order], exp[order]
    n_pool = int(np.searchsorted(exp, 5.0))
    if n_pool:
        while n_pool < exp.size and exp[:n_pool].sum() < 5.0:
            n_pool += 1
        obs = np.concatenate([[obs[:n_pool].sum()], obs[n_pool:]])
        exp = np.concatenate([[exp[:n_pool].sum()], exp[n_pool:]])
    statistic = float(np.sum((obs - exp) ** 2 / exp))
    return float(stats.chi2.sf(statistic, exp.size - 1))


@pytest.mark.parametrize("seed,phase", list(enumerate(CHI2_PHASES)), ids=lambda x: _ids(x) if isinstance(x, PhaseFunction) else str(x))
def test_sampler_chi2(seed, phase):
    p_value = _chi2_pvalue(phase, phase, seed)
    assert p_value > SIDAK_ALPHA, f"{phase!r}: χ² p-value {p_value:.3g} <= {SIDAK_ALPHA:.3g}"


def test_chi2_negative_control_has_power():
    p_value = _chi2_pvalue(HenyeyGreenstein(0.5), HenyeyGreenstein(0.45), seed=99)
    assert p_value < SIDAK_ALPHA, f"χ² failed to reject g=0.5 samples against g=0.45: p={p_value:.3g}"


# --- validation, conversion, identity -------------------------------------------------------


@pytest.mark.parametrize("cls", [HenyeyGreenstein, Schlick])
def test_g_out_of_range_or_not_finite_is_rejected(cls):
    with pytest.raises(ValueError, match=r"\bg\b.*\|g\| < 1.*got 1\.0"):
        cls(1.0)
    with pytest.raises(ValueError, match=r"\bg\b.*got -1\.5"):
        cls(-1.5)
    with pytest.raises(ValueError, match=r"g must be finite, got nan"):
        cls(float("nan"))
    with pytest.raises(ValueError, match=r"g must be finite, got inf"):
        cls(float("inf"))
    with pytest.raises(TypeError, match=r"g must be a real number, got str '0.5'"):
        cls("0.5")


def test_hg_validation_messages_named_in_the_brief():
    with pytest.raises(ValueError, match=r"g.*1\.0"):
        HenyeyGreenstein(1.0)
    with pytest.raises(ValueError, match=r"g.*nan"):
        HenyeyGreenstein(float("nan"))
    with pytest.raises(ValueError, match=r"kind.*'foo'"):
        as_phase({"kind": "foo"})


def test_as_phase_conversions():
    assert as_phase(None) == Isotropic()
    hg = HenyeyGreenstein(0.4)
    assert as_phase(hg) is hg
    assert as_phase(0.6) == HenyeyGreenstein(0.6)
    assert as_phase(np.float32(0.5)) == HenyeyGreenstein(0.5)
    assert as_phase({"kind": "hg", "g": 0.6}) == HenyeyGreenstein(0.6)
    assert as_phase({"kind": "Henyey-Greenstein", "g": -0.2}) == HenyeyGreenstein(-0.2)
    assert as_phase({"kind": "isotropic"}) == Isotropic()
    assert as_phase({"kind": "schlick", "g": 0.3}) == Schlick(0.3)
    assert as_phase({"kind": "rayleigh"}) == Rayleigh()
    assert as_phase({"kind": "rayleigh", "g": 0}) == Rayleigh()
    assert as_phase("isotropic") == Isotropic()
    for p in (Isotropic(), Rayleigh(), HenyeyGreenstein(0.25), Schlick(-0.5)):
        assert as_phase(p.to_dict()) == p


def test_canonical_form_and_from_kind():
    for p in (Isotropic(), HenyeyGreenstein(0.0), Schlick(0.0), as_phase(0.0)):
        assert p.canonical() == (kp.ISOTROPIC, 0.0, True)
    assert Rayleigh().canonical() == (kp.RAYLEIGH, 0.0, False)
    assert HenyeyGreenstein(-0.3).canonical() == (kp.HENYEY_GREENSTEIN, -0.3, False)
    assert Schlick(0.3).canonical() == (kp.SCHLICK, 0.3, False)
    for p in (Isotropic(), Rayleigh(), HenyeyGreenstein(0.25), Schlick(-0.5)):
        q = PhaseFunction.from_kind(p.kind, p.g)
        assert q == p and type(q) is type(p)
    with pytest.raises(ValueError, match="kind 7"):
        PhaseFunction.from_kind(7)
    with pytest.raises(ValueError, match="no anisotropy"):
        PhaseFunction.from_kind(kp.RAYLEIGH, 0.5)


def test_as_phase_errors_name_the_key_and_value():
    with pytest.raises(ValueError, match=r"kind.*'foo'"):
        as_phase({"kind": "foo"})
    with pytest.raises(ValueError, match=r"needs a 'kind' key"):
        as_phase({"g": 0.5})
    with pytest.raises(ValueError, match=r"'hg' needs a 'g' key"):
        as_phase({"kind": "hg"})
    with pytest.raises(ValueError, match=r"unknown key 'anisotropy'"):
        as_phase({"kind": "hg", "anisotropy": 0.5})
    with pytest.raises(ValueError, match=r"'rayleigh' takes no anisotropy, got 'g' = 0.5"):
        as_phase({"kind": "rayleigh", "g": 0.5})
    with pytest.raises(ValueError, match=r"g must satisfy \|g\| < 1, got 1\.2"):
        as_phase({"kind": "schlick", "g": 1.2})
    with pytest.raises(ValueError, match=r"g must satisfy \|g\| < 1, got -1\.0"):
        as_phase(-1.0)
    with pytest.raises(TypeError, match=r"'kind' must be a string, got int 1"):
        as_phase({"kind": 1, "g": 0.5})
    with pytest.raises(TypeError, match=r"phase spec must be .*got list"):
        as_phase([0.5])
    with pytest.raises(TypeError, match=r"phase spec must be"):
        as_phase(True)


def test_api_argument_errors():
    hg = HenyeyGreenstein(0.5)
    with pytest.raises(ValueError, match="cos_theta must lie in"):
        hg.eval(1.5)
    with pytest.raises(ValueError, match="cos_theta must be finite"):
        hg.eval(np.nan)
    with pytest.raises(ValueError, match="u1 must hold uniforms"):
        hg.sample(1.5, 0.5, [0, 0, 1])
    with pytest.raises(ValueError, match="direction must not be the zero vector"):
        hg.sample(0.5, 0.5, [0, 0, 0])
    with pytest.raises(ValueError, match=r"direction must have shape \(\.\.\., 3\)"):
        hg.sample(0.5, 0.5, [0, 1])


def test_equality_hash_repr_and_attributes():
    assert HenyeyGreenstein(0.5) == HenyeyGreenstein(np.float64(0.5))
    assert HenyeyGreenstein(0.5) != HenyeyGreenstein(0.45)
    assert HenyeyGreenstein(0.3) != Schlick(0.3)
    assert HenyeyGreenstein(0.0) != Isotropic()  # same function, different kernel kind
    assert HenyeyGreenstein(-0.0) == HenyeyGreenstein(0.0)
    cache = {HenyeyGreenstein(0.5): 1, Schlick(0.5): 2, Isotropic(): 3, Rayleigh(): 4}
    assert cache[as_phase(0.5)] == 1 and cache[as_phase({"kind": "schlick", "g": 0.5})] == 2
    assert cache[as_phase(None)] == 3 and cache[as_phase("rayleigh")] == 4
    assert repr(HenyeyGreenstein(0.6)) == "HenyeyGreenstein(g=0.6)"
    assert repr(Schlick(-0.25)) == "Schlick(g=-0.25)"
    assert repr(Isotropic()) == "Isotropic()" and repr(Rayleigh()) == "Rayleigh()"
    kinds = {Isotropic().kind, HenyeyGreenstein(0.1).kind, Schlick(0.1).kind, Rayleigh().kind}
    assert kinds == {kp.ISOTROPIC, kp.HENYEY_GREENSTEIN, kp.SCHLICK, kp.RAYLEIGH} == {0, 1, 2, 3}
    assert Isotropic().g == 0.0 and Rayleigh().g == 0.0 and isinstance(HenyeyGreenstein(1 / 2).g, float)


def test_schlick_k_is_clamped_where_the_cubic_fit_exceeds_one():
    # k = 1.55 g − 0.55 g³ reaches 1 at g ≈ 0.938 and peaks at ≈ 1.0016.
    assert 1.55 * 0.97 - 0.55 * 0.97**3 > 1.0
    for g in (0.95, 0.97, 0.999):
        assert Schlick(g).k == 0.999 and Schlick(-g).k == -0.999
    assert Schlick(0.5).k == pytest.approx(1.55 * 0.5 - 0.55 * 0.125, rel=1e-15)


def test_kernels_callable_as_scalars():
    # The scalar kernels are the same functions renderers call; check their tuple shape.
    dx, dy, dz, pdf = kp.phase_sample(kp.HENYEY_GREENSTEIN, 0.5, 0.3, 0.7, 0.0, 0.0, -1.0)
    assert dx * dx + dy * dy + dz * dz == pytest.approx(1.0, abs=1e-14)
    assert pdf == kp.phase_eval(kp.HENYEY_GREENSTEIN, 0.5, -dz)
    assert kp.phase_sample_cos(kp.ISOTROPIC, 0.0, 0.75) == 0.5


@driver(parallel=False)
def _phase_in32_array(kind, g, mu, out):
    for i in range(mu.shape[0]):
        out[i] = kp.phase_in(np.float32, kind, g, mu[i])


@pytest.mark.parametrize("kind, g", [(kp.ISOTROPIC, 0.0), (kp.RAYLEIGH, 0.0), (kp.HENYEY_GREENSTEIN, -0.9),
                                     (kp.HENYEY_GREENSTEIN, 0.5), (kp.HENYEY_GREENSTEIN, 0.999), (kp.SCHLICK, 0.8),
                                     (kp.SCHLICK, 0.999)])
def test_phase_in_float32_is_phase_eval_to_float32_rounding(kind, g):
    """``phase_in(np.float32, ...)``, the CUDA ray cast's per-light phase function, returns float32
    and equals ``phase_eval`` to a few float32 roundings at every cosine, the forward peak of
    ``|g| → 1`` included (there ``1 − gμ`` cancels: it stays in the arguments' float64)."""
    mu = np.concatenate([np.linspace(-1.0, 1.0, 401), 1.0 - np.geomspace(1e-9, 1e-2, 50)])
    out = np.zeros(mu.shape, np.float32)
    _phase_in32_array(kind, g, mu, out)
    exact = np.zeros(mu.shape)
    kp.phase_eval_array(kind, g, mu, exact)
    np.testing.assert_allclose(out, exact, rtol=1e-6)
    kp.phase_in(np.float32, kind, g, 0.25)  # a float32 result is boxed as a float: check the type
    returns = {str(sig.args[0]): str(sig.return_type) for sig in kp.phase_in.nopython_signatures}
    assert returns["class(float32)"] == "float32"


def test_hg_beyond_kernel_limit_warns_and_equals_the_limit():
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        HenyeyGreenstein(0.999)  # at the limit: silent
    with pytest.warns(UserWarning, match=r"g=-0\.9995 is beyond \|g\| = 0\.999.*as g = -0\.999"):
        hg = HenyeyGreenstein(-0.9995)
    mu = np.linspace(-1, 1, 11)
    np.testing.assert_array_equal(hg.eval(mu), HenyeyGreenstein(-0.999).eval(mu))
