"""Cost of the diffusion stage's transport sweep (docs/performance.rst, "Transport sweeps"): ns per
node and direction per thread of :func:`pv_ambient.stages.diffusion.ordinates.sweep_once`, on a
synthetic shell (σt up to 20 per unit, a point-light-like source), for an isotropic and a
Henyey–Greenstein phase function, one and three channels, at 1 and 2 threads (medians of
``--repeats`` sweeps after a warm-up).

Usage: ``python benchmarks/sweep_cost.py [--n 128] [--directions 32] [--repeats 3] [--threads 1,2]``
"""

from __future__ import annotations

import argparse
import time

import numba
import numpy as np

from pv_ambient.stages.diffusion.ordinates import sweep_once

PHASES = {"isotropic": (0, 0.0), "HG g=0.5": (1, 0.5)}


def medium(n, C):
    """σt of a shell with a thin dense layer, a source falling off from the centre, its direction radial."""
    x = np.linspace(-1.0, 1.0, n)
    X, Y, Z = np.meshgrid(x, x, x, indexing="ij")
    r = np.sqrt(X * X + Y * Y + Z * Z)
    sig = 20.0 * np.exp(-(((r - 0.6) / 0.1) ** 2)) + 0.5 * (r < 0.9)
    q = np.stack([sig * (0.5 + 0.2 * c) * np.exp(-r) for c in range(C)], axis=-1)
    om = np.stack([X, Y, Z], axis=-1) / np.maximum(r, 1e-9)[..., None] * 0.9
    return sig, q, om, (2.0 / n,) * 3


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=128)
    ap.add_argument("--directions", type=int, default=32)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", default="1,2")
    args = ap.parse_args()
    threads = [int(t) for t in args.threads.split(",")]
    n, M = args.n, args.directions
    print(f"# benchmarks/sweep_cost.py --n {n} --directions {M} --repeats {args.repeats}: "
          f"{n}^3 nodes, {M} directions, ns per node and direction per thread (median)")
    print(f"{'phase':<12} {'channels':>8} " + " ".join(f"{f'{t} thread' + ('s' if t > 1 else ''):>12}" for t in threads)
          + f"  1 -> {max(threads)} threads")
    for name, (kind, g) in PHASES.items():
        for C in (1, 3):
            sig, q, om, sp = medium(n, C)
            sweep_once(sig[:8, :8, :8], q[:8, :8, :8], om[:8, :8, :8], kind, g, sp, directions=8)  # compile
            row = []
            for t in threads:
                numba.set_num_threads(t)
                ts = []
                for _ in range(args.repeats):
                    t0 = time.perf_counter()
                    sweep_once(sig, q, om, kind, g, sp, directions=M)
                    ts.append(time.perf_counter() - t0)
                row.append(float(np.median(ts)))
            ns = [s * t / (n ** 3 * M) * 1e9 for s, t in zip(row, threads)]
            by = dict(zip(threads, row))
            gain = f"  {by[1] / by[max(threads)]:.2f}x" if 1 in by and max(threads) > 1 else ""
            print(f"{name:<12} {C:>8} " + " ".join(f"{v:>12.1f}" for v in ns) + gain, flush=True)


if __name__ == "__main__":
    main()
