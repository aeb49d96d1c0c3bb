"""The benchmarks' one timing rule: a warm-up call (compilation, caches), then the median of
``repeats`` timed calls. numpy-free, so benchmarks/gpu.py still runs on the array core alone."""

from __future__ import annotations

import statistics
import time


def median_time(fn, repeats):
    """Median wall time of ``fn(k)`` for k = 1…repeats, after the warm-up ``fn(0)``."""
    fn(0)
    times = []
    for k in range(1, repeats + 1):
        t = time.perf_counter()
        fn(k)
        times.append(time.perf_counter() - t)
    return float(statistics.median(times))
