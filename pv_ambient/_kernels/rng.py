"""Counter-based random numbers: a pure function of (seed, stream, counter).

Results are therefore independent of the thread count and of the backend: every pixel,
path and sample hashes its own coordinates, nothing is shared between threads.
The mixer is SplitMix64's finaliser (Steele, Lea, Flood 2014), applied to a combination of the
three keys; uniforms take the top 53 bits, so they lie in [0, 1) and never equal 1.
"""

from __future__ import annotations

import numpy as np

from ._jit import scalar

GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_K1 = np.uint64(0xD6E8FEB86659FD93)
_K2 = np.uint64(0xA0761D6478BD642F)
INV53 = 1.0 / 9007199254740992.0  # 2**-53


@scalar
def mix64(z):
    """SplitMix64 finaliser of a uint64."""
    z = (z ^ (z >> np.uint64(30))) * _M1
    z = (z ^ (z >> np.uint64(27))) * _M2
    return z ^ (z >> np.uint64(31))


@scalar
def key(seed, stream, counter):
    """Hash three non-negative integers into one uint64 key."""
    h = mix64(np.uint64(seed) * _K1 + GOLDEN)
    h = mix64(h ^ (np.uint64(stream) * _K2 + GOLDEN))
    return mix64(h ^ (np.uint64(counter) * _K1 + _K2))


@scalar
def uniform(seed, stream, counter, dim):
    """The ``dim``-th uniform in [0, 1) of sample ``counter`` of stream ``stream``."""
    z = mix64(key(seed, stream, counter) + np.uint64(dim) * GOLDEN)
    return np.float64(z >> np.uint64(11)) * INV53
