"""Tests pv_ambient/_kernels/records.py: the kernels' argument records."""
import numpy as np


def test_records_arrays_and_map_arrays():
    """The kernels' argument records: every array inside nested records is found, and replaced in
    place by map_arrays (DeviceCache.args) with the record types kept."""
    from pv_ambient._kernels import records as K

    a, b, c, d = np.zeros(3), np.ones((2, 2)), np.zeros((1, 1, 1)), np.zeros((2, 1, 1))
    args = (3, K.Diffusion(a, 0.5), (b, 2.0, K.Paths(c, 4, 2, 7, 1, d, 0.5)))
    assert [x is y for x, y in zip(K.arrays(args), (a, b, c, d))] == [True] * 4
    out = K.map_arrays(lambda x: x.shape, args)
    assert out == (3, K.Diffusion((3,), 0.5), ((2, 2), 2.0, K.Paths((1, 1, 1), 4, 2, 7, 1, (2, 1, 1), 0.5)))
    assert type(out[1]) is K.Diffusion and type(out[2][2]) is K.Paths
