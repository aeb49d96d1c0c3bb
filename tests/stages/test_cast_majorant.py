"""Tests pv_ambient/stages/medium.py's cast_majorant and pv_ambient/_kernels/majorant.py's
build_cast_majorant: the ray cast's empty blocks (docs/performance.rst, "Empty space")."""

import numpy as np
import pytest

from pv_ambient._kernels.majorant import build_cast_majorant, build_majorant
from pv_ambient._kernels.medium import MODE_GRID, MODE_LUT

BLOCK = 4


def blocks(field):
    return tuple(max(1, -(-(n - 1) // BLOCK)) for n in field.shape)


def cast(mode, field, table, lo, inv, sigma_min=0.0):
    out = np.zeros(blocks(field), np.float32)
    build_cast_majorant(mode, field, table, lo, inv, BLOCK, sigma_min, out)
    return out


def conservative(mode, field, table, lo, inv):
    out = np.zeros(blocks(field), np.float32)
    build_majorant(mode, field, table, lo, inv, BLOCK, out)
    return out


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_largest_sigma_a_sample_can_take(seed):
    """LUT mode: each block's value is the largest σt of the table interpolated at any scalar between
    the block's least and greatest (its samples and those on its upper faces) — against a NumPy
    sweep of 20 001 scalars over that range, within the sweep's resolution — and never above the
    path tracer's bound."""
    rng = np.random.default_rng(seed)
    field = rng.uniform(-0.2, 1.2, (9, 10, 7)).astype(np.float32)
    field[:5, :5, :4] = rng.uniform(0.1, 0.14, (5, 5, 4))  # a block whose range sits between two entries
    n = 11
    table = np.zeros((n, 10), np.float64)
    table[:, 0] = rng.uniform(0.0, 5.0, n) * (rng.random(n) < 0.6)  # non-monotone, zeros between
    lo, inv = 0.0, float(n - 1)
    got = cast(MODE_LUT, field, table, lo, inv)
    bound = conservative(MODE_LUT, field, table, lo, inv)
    for a, b, c in np.ndindex(got.shape):
        sl = tuple(slice(BLOCK * t, min(BLOCK * t + BLOCK, m - 1) + 1) for t, m in zip((a, b, c), field.shape))
        s = field[sl].astype(np.float64)
        u = np.clip((np.linspace(s.min(), s.max(), 20001) - lo) * inv, 0.0, n - 1)
        want = np.interp(u, np.arange(n), table[:, 0]).max()
        # the sweep misses a peak by at most the table's steepest slope times its spacing in u
        slack = np.abs(np.diff(table[:, 0])).max() * (s.max() - s.min()) * inv / 20000
        assert want * (1 - 1e-6) <= got[a, b, c] <= want + slack + 1e-6
        assert got[a, b, c] <= bound[a, b, c] * (1 + 1e-6)


def test_denormal_scalars_are_empty_a_uniform_thin_medium_is_not():
    """Scalars zero but for denormal rounding (a Gaussian's tail) below a table that is zero at 0:
    the path tracer's bound counts the next entry, the ray cast's block is empty; a medium whose σt is
    1e-10 everywhere keeps every block (the threshold is relative to the medium's largest σt)."""
    field = np.zeros((9, 9, 9), np.float32)
    field[1, 2, 3] = np.float32(3.8e-44)
    table = np.zeros((5, 10), np.float64)
    table[1:, 0] = [0.5, 1.0, 2.0, 3.0]
    assert conservative(MODE_LUT, field, table, 0.0, 4.0)[0, 0, 0] > 0.0
    assert cast(MODE_LUT, field, table, 0.0, 4.0, sigma_min=1e-12 * 3.0)[0, 0, 0] == 0.0

    from pv_ambient.stages.medium import EMPTY_RATIO, cast_majorant

    class Thin:  # a GRID-mode medium: σt per sample
        mode = MODE_GRID
        field = np.full((9, 9, 9), 1e-10, np.float32)
        table = np.zeros((1, 10), np.float32)
        lut_lo, lut_inv = 0.0, 1.0

    maj = cast_majorant(Thin, BLOCK)
    assert EMPTY_RATIO < 1.0 and np.all(maj == np.float32(1e-10))
