"""GPU launch check: consecutive ``single_scattering`` renders on ``backend="cuda"``, the time of each
ray-cast launch and the number of specialisations of the ray-cast kernel compiled so far.

Written after ``benchmarks/gpu.py``'s first run on a GPU (benchmarks/results/gpu.txt) stopped with
ray-cast stages of 42–52 s each: a kernel recompiled at every launch would look like that. This
check tells the two apart — a second launch as slow as the first and a growing overload count
mean recompilation (it then prints which argument's type changed). Array core only (no pyvista)::

    python benchmarks/gpu_launch_check.py --n 256 --size 512 --renders 3

numba-cuda 0.30.4 uses ``numpy.row_stack``, which NumPy 2.5 removed; where that alias (or
``trapz``, ``in1d``) is missing it is added back before numba-cuda is imported.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

for _old, _new in (("row_stack", "vstack"), ("trapz", "trapezoid"), ("in1d", "isin")):
    if not hasattr(np, _old) and hasattr(np, _new):
        setattr(np, _old, getattr(np, _new))

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # run from a checkout

import gpu  # noqa: E402  (benchmarks/: the script's directory is on sys.path)
import pv_ambient as pa  # noqa: E402
from pv_ambient import backend  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=32, help="data points per axis")
    ap.add_argument("--size", type=int, default=64, help="window width and height")
    ap.add_argument("--renders", type=int, default=3)
    args = ap.parse_args(argv)
    import numba

    from pv_ambient._kernels import cuda as kc

    kernel = kc.raycast_kernel
    seen = []
    real = backend.raycast

    def typeof(a):
        for f in (getattr(kernel, "typeof_pyval", None), numba.typeof):
            try:
                return f(a) if f is not None else None
            except Exception:  # noqa: BLE001 — the simulator's arrays have no Numba type
                pass
        return type(a).__name__

    def launch(cache, kargs, *rest):
        seen.append(tuple(typeof(a) for a in cache.args(kargs)))
        t = time.perf_counter()
        out = real(cache, kargs, *rest)
        print(f"  ray-cast launch {len(seen)}: {time.perf_counter() - t:.3f} s, "
              f"{len(getattr(kernel, 'overloads', {}))} specialisation(s) compiled", flush=True)
        if len(seen) > 1:
            for k, (a, b) in enumerate(zip(seen[-2], seen[-1])):
                if a != b:
                    print(f"    argument {k} changed type:\n      {str(a)[:400]}\n      {str(b)[:400]}")
        return out

    backend.raycast = launch
    vol = gpu.make_volume(args.n)
    cams = gpu.cameras()
    r = pa.Renderer(vol, transfer_function=gpu.make_tf(), lights=[pa.PointLight((0.0, 0.0, 0.0), 3.0)],
                    backend="cuda")
    print(f"{args.n}³ at {args.size}², single scattering, backend cuda")
    for k in range(args.renders):
        t = time.perf_counter()
        r.render(camera=cams[k % len(cams)], window_size=(args.size, args.size), model="single_scattering",
                 progress_bar=False)
        print(f"render {k}: {time.perf_counter() - t:.3f} s", flush=True)
    print("stage timings of the first frame:", {k: round(v, 2) for k, v in r.timings.items()})


if __name__ == "__main__":
    main()
