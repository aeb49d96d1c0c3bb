"""Tests pv_ambient/stages/medium.py's reductions: the least value under a mask (whether a light
reaches the medium that scatters) against NumPy's boolean indexing."""

import numpy as np
import pytest

from pv_ambient.stages.medium import least_where


@pytest.mark.parametrize("shape,fraction", [((7, 5, 6), 0.3), ((1, 9, 4), 0.9), ((12, 1, 1), 0.5)])
def test_least_where_equals_numpy(shape, fraction):
    rng = np.random.default_rng(31)
    values = (rng.random(shape) * 50).astype(np.float32)
    mask = rng.random(shape) < fraction
    mask.flat[rng.integers(mask.size)] = True
    assert least_where(values, mask) == float(np.min(values[mask]))


def test_least_where_of_nothing_is_inf():
    assert least_where(np.zeros((3, 4, 5), np.float32), np.zeros((3, 4, 5), bool)) == np.inf
    assert least_where(np.zeros((0, 4, 5), np.float32), np.zeros((0, 4, 5), bool)) == np.inf
