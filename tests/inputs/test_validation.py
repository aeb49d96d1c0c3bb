"""Tests pv_ambient/inputs/validation.py: argument checks whose messages name the argument and say
what was received."""
import re

import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient.inputs.validation import (check_array, check_bool, check_choice, check_int, check_real, check_rgb,
                                          check_vector, check_window_size, show_value)

from ..helpers import box_grid


@pytest.mark.parametrize("size", [(0, 10), (10, -1), (3.5, 4)])
def test_bad_window_size(size):
    g = box_grid(dims=(3, 3, 3))
    with pytest.raises((ValueError, TypeError), match="window_size"):
        pa.render(g, window_size=size)


@pytest.mark.parametrize("call, exc, message", [
    (lambda: check_real("x", "step"), TypeError, "step must be a real number, got str 'x'"),
    (lambda: check_real(True, "step"), TypeError, "step must be a real number, got bool True"),
    (lambda: check_real(float("nan"), "step"), ValueError, "step must be finite, got nan"),
    (lambda: check_real(0.0, "step", lo=0.0, lo_open=True), ValueError, "step must be > 0.0, got 0.0"),
    (lambda: check_real(2.0, "g", hi=1.0), ValueError, "g must be <= 1.0, got 2.0"),
    (lambda: check_int(2.5, "seed"), TypeError, "seed must be an integer, got float 2.5"),
    (lambda: check_int(-1, "seed", lo=0), ValueError, "seed must be >= 0, got -1"),
    (lambda: check_bool("yes", "denoise"), TypeError, "denoise must be True or False, got str 'yes'"),
    (lambda: check_vector((1, 2), "position"), ValueError, "position must have 3 components, got shape (2,): (1, 2)"),
    (lambda: check_vector("abc", "position"), TypeError, "position must be 3 numbers, got 'abc'"),
    (lambda: check_vector((1, np.inf, 0), "position"), ValueError, "position must be finite, got (1, inf, 0)"),
    (lambda: check_vector((0, 0, 0), "direction", nonzero=True), ValueError,
     "direction must not be the zero vector, got (0, 0, 0)"),
    (lambda: check_rgb((1, -0.5, 0), "albedo"), ValueError, "albedo components must be >= 0.0, got (1, -0.5, 0)"),
    (lambda: check_rgb((1, 2, 0), "albedo", hi=1.0), ValueError, "albedo components must be <= 1.0, got (1, 2, 0)"),
    (lambda: check_window_size(5), TypeError, "window_size must be (width, height), got 5"),
    (lambda: check_window_size((0, 10)), ValueError, "window_size must be two positive integers, got (0, 10)"),
    (lambda: check_choice("best", "quality", ("preview", "balanced")), ValueError,
     "quality must be one of 'preview', 'balanced'; got 'best'"),
], ids=["real-type", "real-bool", "real-nan", "real-open-bound", "real-upper-bound", "int-type", "int-bound", "bool",
        "vector-shape", "vector-type", "vector-finite", "vector-zero", "rgb-low", "rgb-high", "window-type",
        "window-zero", "choice"])
def test_scalar_checks_name_the_argument_and_the_value(call, exc, message):
    with pytest.raises(exc, match=f"^{re.escape(message)}$"):
        call()


@pytest.mark.parametrize("value, kwargs, exc, message", [
    (np.ones((2, 2)), {"ndim": 3}, ValueError, "sigma must be a 3-D array, got shape (2, 2)"),
    ([1.0, np.nan], {}, ValueError, "sigma must be finite, got 1 non-finite values"),
    ([1.0, np.nan], {"finite": "nan"}, ValueError, "sigma must not contain NaN"),
    ([-1.0, 2.0], {"lo": 0.0}, ValueError, "sigma must be non-negative, got minimum -1.0"),
    ([0.5, 2.0], {"lo": 0.0, "hi": 1.0}, ValueError, "sigma must lie in [0.0, 1.0], got values from 0.5 to 2.0"),
    ([True], {}, TypeError, "sigma must be an array of real numbers, got dtype bool ([True])"),
    (np.zeros(0), {"nonempty": True}, ValueError, "sigma must not be empty, got shape (0,)"),
], ids=["ndim", "finite", "nan", "non-negative", "bounds", "bool", "empty"])
def test_check_array_names_the_argument_and_what_was_wrong(value, kwargs, exc, message):
    with pytest.raises(exc, match=f"^{re.escape(message)}$"):
        check_array(value, "sigma", **kwargs)


def test_checks_convert_what_they_accept():
    assert check_real(np.float32(0.5), "g") == 0.5 and type(check_real(1, "g")) is float
    assert check_window_size((64.0, 48)) == (64, 48)  # an integral float is accepted as an integer
    np.testing.assert_array_equal(check_vector(2.0, "v"), [2.0, 2.0, 2.0])  # a scalar is broadcast
    assert check_array(3.0, "s", promote_scalar=True).shape == (1,)
    assert check_array(np.ones((3, 2)).T, "a").flags.c_contiguous
    assert check_array(np.ones(2, np.float32), "a", dtype="float").dtype == np.float32
    assert check_array([1, 2], "a").dtype == np.float64
    assert check_array([np.inf], "a", finite="nan")[0] == np.inf  # "nan": infinities pass
    text = show_value("x" * 100)
    assert len(text) == 80 and text.endswith("...") and text.startswith("'xxx")
