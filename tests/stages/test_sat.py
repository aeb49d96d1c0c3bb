"""Tests pv_ambient/stages/sat.py (and _kernels/sat.py): summed-area table and mean extinction
(docs/ambient_scattering.rst §1) against independent numpy computations.

The brute-force references integrate the piecewise-constant field directly: sample ``i`` owns
the cell ``[i−½, i+½]``, so a box's integral is ``Σ σ_ijk · ox_i · oy_j · oz_k`` with the
per-axis overlap lengths of each cell with the box (vacuum outside the grid).
"""
import doctest
import math

import numpy as np
import pytest

import pv_ambient.stages.sat as sat_mod
from pv_ambient._kernels import sat as K
from pv_ambient.stages.sat import BOX_EDGE_PER_RADIUS, box_half_edges, box_mean, box_sum, build_sat, mean_extinction

SHAPES = [(7, 9, 11), (13, 5, 3), (1, 4, 2)]


def overlaps(n, lo, hi):
    """Length of [lo, hi] ∩ [i−½, i+½] for each cell i of an axis of n cells."""
    c = np.arange(n, dtype=np.float64)
    return np.clip(np.minimum(hi, c + 0.5) - np.maximum(lo, c - 0.5), 0.0, None)


def brute_box(sigma, lo, hi):
    ox, oy, oz = (overlaps(n, a, b) for n, a, b in zip(sigma.shape, lo, hi))
    return float(np.einsum("i,j,k,ijk->", ox, oy, oz, sigma.astype(np.float64)))


def overlap_matrix(n, half):
    """W[a, i] = overlap of the box [a−half, a+half] (centred on sample a) with cell i."""
    c = np.arange(n, dtype=np.float64)
    lo, hi = c[:, None] - half, c[:, None] + half
    return np.clip(np.minimum(hi, c[None, :] + 0.5) - np.maximum(lo, c[None, :] - 0.5), 0.0, None)


def brute_mean(sigma, spacing, radius):
    half = radius * BOX_EDGE_PER_RADIUS / (2.0 * np.asarray(spacing, np.float64))
    wx, wy, wz = (overlap_matrix(n, a) for n, a in zip(sigma.shape, half))
    total = np.einsum("ai,bj,ck,ijk->abc", wx, wy, wz, sigma.astype(np.float64))
    return total / np.prod(2.0 * half)


def rel_err(a, b):
    return abs(a - b) / max(abs(b), 1e-300)


# ---------------------------------------------------------------------------------------- table


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_build_sat_is_the_guarded_triple_cumsum(shape, dtype):
    rng = np.random.default_rng(1)
    sigma = rng.random(shape).astype(dtype)
    S = build_sat(sigma)
    assert S.dtype == np.float64 and S.shape == tuple(n + 1 for n in shape)
    assert not S[0].any() and not S[:, 0].any() and not S[:, :, 0].any()
    ref = sigma.astype(np.float64).cumsum(0).cumsum(1).cumsum(2)
    np.testing.assert_allclose(S[1:, 1:, 1:], ref, rtol=1e-13, atol=0)


def test_build_sat_accepts_any_layout_and_integers():
    rng = np.random.default_rng(2)
    sigma = rng.integers(0, 100, (6, 5, 4))
    S = build_sat(np.asfortranarray(sigma))
    assert S[-1, -1, -1] == sigma.sum()
    np.testing.assert_array_equal(build_sat(sigma[::-1, :, ::2]), build_sat(np.ascontiguousarray(sigma[::-1, :, ::2])))


def test_build_sat_of_empty_grid_is_zero_guard():
    S = build_sat(np.zeros((0, 3, 2), np.float32))
    assert S.shape == (1, 4, 3) and not S.any()


# ------------------------------------------------------------------------------------ box sums


@pytest.mark.parametrize("shape", SHAPES)
def test_box_sum_integer_aligned(shape):
    """Boxes on cell faces (half-integers in sample coordinates) = plain sums of sample blocks,
    including boxes that stick out of the grid."""
    rng = np.random.default_rng(3)
    sigma = rng.random(shape) * 10
    S = build_sat(sigma)
    worst = 0.0
    for _ in range(200):
        lo = np.array([rng.integers(-3, n + 1) for n in shape])
        hi = np.array([rng.integers(a, n + 3) for a, n in zip(lo, shape)])
        ref = sigma[tuple(slice(max(a, 0), max(b, 0)) for a, b in zip(lo, hi))].sum()
        got = box_sum(S, lo - 0.5, hi - 0.5)
        if ref == 0.0:
            assert got == 0.0
        else:
            worst = max(worst, rel_err(got, ref))
    assert worst <= 1e-12, worst


@pytest.mark.parametrize("shape", SHAPES)
def test_box_sum_fractional(shape):
    rng = np.random.default_rng(4)
    sigma = rng.random(shape) * 10
    S = build_sat(sigma)
    worst = 0.0
    for _ in range(300):
        lo = np.array([rng.uniform(-2.0, n + 1.0) for n in shape])
        hi = lo + rng.uniform(0.0, 1.5, 3) * np.array(shape)
        ref = brute_box(sigma, lo, hi)
        got = box_sum(S, lo, hi)
        if ref == 0.0:
            assert abs(got) <= 1e-12
        else:
            worst = max(worst, rel_err(got, ref))
    assert worst <= 1e-9, worst


def test_box_sum_is_inclusion_exclusion_of_corners():
    """The factored stencils equal the literal Σ ± sat_corner over eight corners."""
    rng = np.random.default_rng(5)
    sigma = rng.random((7, 9, 11))
    S = build_sat(sigma)
    for _ in range(100):
        lo = rng.uniform(-2, 12, 3)
        hi = lo + rng.uniform(0, 6, 3)
        corners = sum(
            (-1) ** (3 - bx - by - bz)
            * K.sat_corner(S, (lo[0], hi[0])[bx], (lo[1], hi[1])[by], (lo[2], hi[2])[bz])
            for bx in (0, 1)
            for by in (0, 1)
            for bz in (0, 1)
        )
        got = K.box_sum(S, lo[0], hi[0], lo[1], hi[1], lo[2], hi[2])
        assert abs(got - corners) <= 1e-12 * max(1.0, abs(corners))


def test_sat_corner_limits_and_interpolation():
    rng = np.random.default_rng(6)
    sigma = rng.random((5, 4, 3))
    S = build_sat(sigma)
    assert K.sat_corner(S, -0.5, 3.0, 2.0) == 0.0
    assert K.sat_corner(S, -7.0, -7.0, -7.0) == 0.0
    assert abs(K.sat_corner(S, 4.5, 3.5, 2.5) - sigma.sum()) <= 1e-12 * sigma.sum()
    assert abs(K.sat_corner(S, 99.0, 99.0, 99.0) - sigma.sum()) <= 1e-12 * sigma.sum()
    # half of the first cell along x, whole grid along y and z
    assert abs(K.sat_corner(S, 0.0, 9.0, 9.0) - 0.5 * sigma[0].sum()) <= 1e-12


def test_tiny_box_straddling_a_face_keeps_precision():
    """A box of width 2e-9 across the face between cells 3 and 4 of a large-valued grid: its
    mean is the average of the two cells; the factored stencil keeps it to 1e-6 relative
    (a naive (1 − f0) − (1 − f1) weight would lose it to cancellation at this scale)."""
    rng = np.random.default_rng(7)
    sigma = 1e3 + rng.random((8, 6, 6))
    S = build_sat(sigma)
    got = box_mean(S, (3.5, 2.0, 3.0), (1e-9, 0.25, 0.25))
    ref = 0.5 * (sigma[3, 2, 3] + sigma[4, 2, 3])
    assert rel_err(got, ref) <= 1e-6


def _corner_sum(T, lo, hi):
    """Inclusion–exclusion over the 8 integer corners of a guarded table, in float64."""
    (a, b, c), (d, e, f) = lo, hi
    v = [float(T[x, y, z]) for x in (a, d) for y in (b, e) for z in (c, f)]
    return v[7] - v[3] - v[5] - v[6] + v[1] + v[2] + v[4] - v[0]


def test_float32_accumulation_fails_on_256_cubed_float64_does_not():
    """σ = 1e4 + m/1024 (m integer): exactly representable in float32, and every partial sum is a
    multiple of 2⁻¹⁰ below 2⁴³, so float64 sums are exact and the references are exact sums.

    A float32 table's *total* is good to ~4e-8 (its rounding errors are random and cancel), but a
    small box far from the origin is a difference of entries ~1.7e11 whose float32 spacing is
    16384: a 3³ box (sum ≈ 2.7e5) comes out ~10 % wrong. The float64 table is exact here."""
    n = 256
    rng = np.random.default_rng(8)
    m = rng.integers(0, 1024, (n, n, n), dtype=np.int32)
    sigma = (np.float32(1e4) + m.astype(np.float32) / np.float32(1024)).astype(np.float32)
    assert np.array_equal((sigma.astype(np.float64) - 1e4) * 1024, m)  # exact in float32
    del m
    # float32 summed-area table (what a float32 accumulator gives), with its zero guard planes
    s32 = np.zeros((n + 1,) * 3, np.float32)
    np.cumsum(sigma, axis=0, dtype=np.float32, out=s32[1:, 1:, 1:])
    np.cumsum(s32[1:, 1:, 1:], axis=1, dtype=np.float32, out=s32[1:, 1:, 1:])
    np.cumsum(s32[1:, 1:, 1:], axis=2, dtype=np.float32, out=s32[1:, 1:, 1:])
    S = build_sat(sigma)
    boxes = [((250, 250, 250), (253, 253, 253)), ((100, 120, 140), (104, 124, 144)), ((0, 0, 0), (n, n, n))]
    err32, err64 = [], []
    for lo, hi in boxes:
        exact = float(sigma[lo[0] : hi[0], lo[1] : hi[1], lo[2] : hi[2]].sum(dtype=np.float64))
        err32.append(rel_err(_corner_sum(s32, lo, hi), exact))
        err64.append(rel_err(box_sum(S, np.subtract(lo, 0.5), np.subtract(hi, 0.5)), exact))
    del s32
    assert err32[0] > 1e-2 and err32[1] > 1e-4, err32
    assert max(err64) <= 1e-9, err64
    # a box with fractional corners against the overlap brute force (also exact in float64)
    lo, hi = np.array([17.25, 100.5, 3.75]), np.array([200.0, 101.5, 250.5])
    sub = sigma[10:210, 95:110, :]
    assert rel_err(box_sum(S, lo, hi), brute_box(sub, lo - (10, 95, 0), hi - (10, 95, 0))) <= 1e-9


# ------------------------------------------------------------------------------ mean extinction


def test_homogeneous_interior_equals_sigma_and_boundary_fractions():
    n, s = 40, 2.5
    sigma = np.full((n, n, n), s, np.float32)
    a = 3.5  # half-edge in index units: the corner box has (a + ½) of 2a inside per axis
    radius = 2 * a / BOX_EDGE_PER_RADIUS
    m = mean_extinction(sigma, (1.0, 1.0, 1.0), radius)
    inner = m[4:-4, 4:-4, 4:-4]  # boxes [c − 3.5, c + 3.5] inside [−½, n − ½]
    assert np.max(np.abs(inner - s)) <= 1e-6 * s
    frac = (a + 0.5) / (2 * a)
    assert rel_err(float(m[0, 0, 0]), s * frac**3) <= 1e-6
    assert rel_err(float(m[-1, 0, -1]), s * frac**3) <= 1e-6
    assert rel_err(float(m[0, n // 2, n // 2]), s * frac) <= 1e-6
    assert rel_err(float(m[n // 2, -1, -1]), s * frac**2) <= 1e-6
    assert np.all(m <= s * (1 + 1e-6))


def test_world_spacing_scales_the_box():
    """A world spacing h shrinks the index-space box by 1/h: same σ̄ as radius/h on unit spacing."""
    rng = np.random.default_rng(9)
    sigma = rng.random((9, 8, 7)).astype(np.float32)
    np.testing.assert_allclose(
        mean_extinction(sigma, 0.25, 0.5), mean_extinction(sigma, (1.0, 1.0, 1.0), 2.0), rtol=1e-6, atol=0
    )


@pytest.mark.parametrize(
    "shape,spacing,radius",
    [((9, 7, 11), (0.5, 1.3, 2.0), 1.7), ((13, 5, 3), (1.0, 1.0, 1.0), 2.2), ((6, 10, 8), (0.1, 0.3, 0.05), 0.37)],
)
def test_mean_extinction_matches_brute_force(shape, spacing, radius):
    rng = np.random.default_rng(10)
    sigma = (rng.random(shape) ** 3 * 5).astype(np.float32)
    got = mean_extinction(sigma, np.asarray(spacing), radius)
    ref = brute_mean(sigma, spacing, radius)
    assert got.dtype == np.float32 and got.shape == shape
    np.testing.assert_allclose(got, ref, rtol=2e-6, atol=1e-6 * float(sigma.max()))


def test_mean_extinction_near_vacuum_is_not_negative():
    """Next to a dense block the table's differences over empty space round to ±ε; σ̄ ≥ 0."""
    sigma = np.zeros((64, 64, 64), np.float32)
    sigma[:32] = 1e4
    m = mean_extinction(sigma, 1.0, 1.0)
    assert m.min() >= 0.0
    assert np.max(m[40:]) <= 1e-6  # boxes of half-edge 0.8 never reach x ≤ 31.5 from x ≥ 40


def test_radius_zero_and_sub_cell_radius_return_sigma():
    rng = np.random.default_rng(11)
    sigma = rng.random((5, 6, 7))
    for radius in (0.0, 0, 1e-300, 0.3):  # half-edges ≤ ½: the box stays in the sample's cell
        m = mean_extinction(sigma, (0.9, 1.0, 1.1), radius)
        assert m.dtype == np.float32 and m is not sigma
        np.testing.assert_array_equal(m, sigma.astype(np.float32))
    s32 = sigma.astype(np.float32)
    m = mean_extinction(s32, 1.0, 0.0)
    assert m is not s32 and np.shares_memory(m, s32) is False


def test_half_edge_below_half_cell_on_one_axis_only():
    """Strong anisotropy: along z the box stays inside one cell, so σ̄ is a 2D mean per z-slice."""
    rng = np.random.default_rng(12)
    sigma = rng.random((8, 9, 5)).astype(np.float32)
    spacing = (1.0, 1.0, 1e6)
    m = mean_extinction(sigma, spacing, 2.0)
    np.testing.assert_allclose(m, brute_mean(sigma, spacing, 2.0), rtol=2e-6, atol=1e-7)
    half = box_half_edges(spacing, 2.0)
    assert half[2] < 1e-5 and half[0] > 0.5


def test_box_mean_point_value_and_outside():
    sigma = np.arange(24, dtype=np.float64).reshape(2, 3, 4)
    S = build_sat(sigma)
    assert box_mean(S, (1, 2, 3), (0, 0, 0)) == sigma[1, 2, 3]
    assert box_mean(S, (0.2, 1.4, 2.6), (0, 0, 0)) == sigma[0, 1, 3]
    assert box_mean(S, (-3.0, 1.0, 1.0), (0, 0, 0)) == 0.0
    assert box_mean(S, (-3.0, 1.0, 1.0), (1.0, 1.0, 1.0)) == 0.0


def test_empty_grid_gives_empty_float32():
    for shape in [(0, 3, 4), (3, 0, 4), (0, 0, 0)]:
        m = mean_extinction(np.zeros(shape), (1, 1, 1), 2.0)
        assert m.shape == shape and m.dtype == np.float32


def test_mean_extinction_independent_of_memory_layout():
    rng = np.random.default_rng(13)
    sigma = rng.random((7, 6, 5)).astype(np.float32)
    a = mean_extinction(sigma, (1.0, 0.7, 1.4), 1.9)
    b = mean_extinction(np.asfortranarray(sigma), (1.0, 0.7, 1.4), 1.9)
    c = mean_extinction(sigma.astype(np.float64), (1.0, 0.7, 1.4), 1.9)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_allclose(a, c, rtol=1e-6)


# ----------------------------------------------------------------------------------- validation

GOOD = np.ones((3, 3, 3), np.float32)


@pytest.mark.parametrize(
    "args,exc,match",
    [
        ((np.ones((3, 3)), 1.0, 1.0), ValueError, "sigma must be a 3-D array"),
        ((np.ones((3, 3, 3, 1)), 1.0, 1.0), ValueError, "sigma must be a 3-D array"),
        ((np.full((3, 3, 3), -1.0), 1.0, 1.0), ValueError, "sigma must be non-negative"),
        ((np.full((3, 3, 3), np.nan), 1.0, 1.0), ValueError, "sigma must be finite"),
        ((np.full((3, 3, 3), np.inf), 1.0, 1.0), ValueError, "sigma must be finite"),
        ((np.full((3, 3, 3), "a"), 1.0, 1.0), TypeError, "sigma must be a 3-D array of real numbers"),
        ((np.ones((3, 3, 3), bool), 1.0, 1.0), TypeError, "sigma must be a 3-D array of real numbers"),
        ((np.ones((3, 3, 3), complex), 1.0, 1.0), TypeError, "sigma must be a 3-D array of real numbers"),
        ((GOOD, (1.0, 0.0, 1.0), 1.0), ValueError, "spacing must be three positive"),
        ((GOOD, (1.0, -2.0, 1.0), 1.0), ValueError, "spacing must be three positive"),
        ((GOOD, (1.0, 1.0), 1.0), ValueError, "spacing must have 3 components"),
        ((GOOD, (1.0, np.nan, 1.0), 1.0), ValueError, "spacing must be finite"),
        ((GOOD, "abc", 1.0), TypeError, "spacing must be 3 numbers"),
        ((GOOD, 1.0, -0.5), ValueError, "radius must be >= 0"),
        ((GOOD, 1.0, math.inf), ValueError, "radius must be finite"),
        ((GOOD, 1.0, math.nan), ValueError, "radius must be finite"),
        ((GOOD, 1.0, "2"), TypeError, "radius must be a real number"),
        ((GOOD, 1.0, True), TypeError, "radius must be a real number"),
    ],
)
def test_mean_extinction_rejects_bad_arguments(args, exc, match):
    with pytest.raises(exc, match=match):
        mean_extinction(*args)


def test_box_api_rejects_bad_arguments():
    S = build_sat(GOOD)
    with pytest.raises(ValueError, match="hi must be >= lo"):
        box_sum(S, (1, 0, 0), (0, 1, 1))
    with pytest.raises(TypeError, match="sat must be a float64 3-D array"):
        box_sum(GOOD, (0, 0, 0), (1, 1, 1))
    with pytest.raises(ValueError, match="sat must come from a non-empty grid"):
        box_sum(build_sat(np.zeros((0, 2, 2))), (0, 0, 0), (1, 1, 1))
    with pytest.raises(ValueError, match="half_edges must be non-negative"):
        box_mean(S, (0, 0, 0), (1, -1, 1))
    with pytest.raises(ValueError, match="center must have 3 components"):
        box_mean(S, (0, 0), (1, 1, 1))
    with pytest.raises(ValueError, match="sigma must be finite"):
        build_sat(np.full((2, 2, 2), np.nan))
    with pytest.raises(ValueError, match="radius must be >= 0"):
        box_half_edges(1.0, -1.0)


def test_build_sat_allows_negative_values():
    """The table itself is generic (σ̄ checks σ ≥ 0; a SAT of a signed field is meaningful)."""
    sigma = -np.ones((2, 2, 2))
    assert build_sat(sigma)[-1, -1, -1] == -8.0


def test_doctests():
    result = doctest.testmod(sat_mod, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0 and result.failed == 0
