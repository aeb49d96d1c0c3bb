"""Tests pv_ambient/inputs/validation.py: argument checks whose messages name the argument and say
what was received."""
import pytest

import pv_ambient as pa

from ..helpers import box_grid


@pytest.mark.parametrize("size", [(0, 10), (10, -1), (3.5, 4)])
def test_bad_window_size(size):
    g = box_grid(dims=(3, 3, 3))
    with pytest.raises((ValueError, TypeError), match="window_size"):
        pa.render(g, window_size=size)
