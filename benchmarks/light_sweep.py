"""The light sweep's CPU drivers (docs/performance.rst, "Relight: the light sweep"): time and τ
accuracy of :func:`pv_ambient.stages.propagation.optical_depth` with ``driver="nodes"`` (the
per-node sweep, the GPU's rule) and ``driver="rows"`` (the row driver), on speed.py's scene (the
supernova at ``--n``³, its light grid and σt) under its point light at the centre and directional
lights along −z, +x and obliquely.

Times: the two drivers interleaved light by light, ``--repeats`` rounds after a warm-up, medians.
Accuracy: τ at ``--nodes`` random nodes against a 4001-point trapezoid of the same trilinear σt
along the straight ray to the light (point) or to the box's exit (directional).

Usage: ``python benchmarks/light_sweep.py [--n 256] [--repeats 3] [--nodes 3000] [--out benchmarks/results]``
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).parent))

import pv_ambient as pa  # noqa: E402
from pv_ambient.stages.propagation import optical_depth  # noqa: E402

DRIVERS = ("nodes", "rows")


def scene(n):
    """speed.py's renderer at n³: its stages, light grid, σt on it and point light."""
    import speed

    frames = speed.Frames(n, (64, 64))
    st = frames.renderer.stages
    grid = st.light_grid()
    return st, grid, st.sigma_on_light_grid(grid), frames.light


def lights(point):
    return {"point (centre)": point, "directional −z": pa.DirectionalLight((0.0, 0.0, -1.0)),
            "directional +x": pa.DirectionalLight((1.0, 0.0, 0.0)),
            "directional oblique": pa.DirectionalLight(np.array((0.3, -0.5, -0.8)) / np.linalg.norm((0.3, -0.5, -0.8)))}


def reference(st, grid, sig, light, idx, K=4001):
    """τ at light-grid nodes ``idx`` (M, 3) by a fine trapezoid of trilinear σt along the ray."""
    from scipy.ndimage import map_coordinates

    shape = np.array(grid.shape)
    x = idx.astype(float)
    if isinstance(light, pa.PointLight):
        lp = grid.to_light(st.geometry.to_index(np.asarray(light.position)[None])[0])
        v = lp[None] - x
        tmax = np.ones(len(x))
    else:
        v = np.linalg.pinv(grid.B) @ (-np.asarray(light.direction))
        v = np.broadcast_to(v / np.abs(v).max(), x.shape).copy()
        with np.errstate(divide="ignore", invalid="ignore"):
            te = np.where(v > 0, (shape - 1 - x) / v, np.where(v < 0, -x / v, np.inf))
        tmax = te.min(1)
    out = np.empty(len(x))
    for s in range(0, len(x), 200):
        ts = np.linspace(0, 1, K)[None, :] * tmax[s:s + 200, None]
        pts = x[s:s + 200, None, :] + ts[..., None] * v[s:s + 200, None, :]
        val = map_coordinates(sig.astype(np.float64), pts.reshape(-1, 3).T, order=1, mode="nearest").reshape(ts.shape)
        out[s:s + 200] = np.trapezoid(val, ts, axis=1) * np.linalg.norm(v[s:s + 200] @ grid.B.T, axis=1)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--nodes", type=int, default=3000)
    ap.add_argument("--out", default=str(Path(__file__).parent / "results"))
    args = ap.parse_args()
    st, grid, sig, point = scene(args.n)
    lts = lights(point)
    lines = [f"# benchmarks/light_sweep.py --n {args.n} --repeats {args.repeats} --nodes {args.nodes}: light grid "
             f"{grid.shape}, {numba.get_num_threads()} threads"]
    for lt in lts.values():  # compile and warm up
        for d in DRIVERS:
            optical_depth(sig, grid, st.geometry, lt, driver=d)
    times = {}
    for _ in range(args.repeats):
        for name, lt in lts.items():
            for d in DRIVERS:
                t = time.perf_counter()
                optical_depth(sig, grid, st.geometry, lt, driver=d)
                times.setdefault((name, d), []).append(time.perf_counter() - t)
    lines.append(f"# load average after the timed rounds: {os.getloadavg()}")
    lines.append("")
    lines.append(f"{'light':<22}{'nodes (s)':>12}{'rows (s)':>12}{'speed-up':>10}   all rounds (nodes | rows)")
    for name in lts:
        a, b = (float(np.median(times[name, d])) for d in DRIVERS)
        lines.append(f"{name:<22}{a:>12.3f}{b:>12.3f}{a / b:>9.1f}×   "
                     f"{' '.join(f'{x:.3f}' for x in times[name, 'nodes'])} | {' '.join(f'{x:.3f}' for x in times[name, 'rows'])}")
    lines.append("")
    lines.append(f"τ against a 4001-point trapezoid at {args.nodes} random nodes: max |Δτ|, RMS Δτ, mean |Δτ|/τ (τ > 1e-3)")
    idx = np.random.default_rng(0).integers(0, grid.shape, (args.nodes, 3))
    for name, lt in lts.items():
        ref = reference(st, grid, sig, lt, idx)
        sel = ref > 1e-3
        for d in DRIVERS:
            err = optical_depth(sig, grid, st.geometry, lt, driver=d)[tuple(idx.T)] - ref
            lines.append(f"{name:<22}{d:<7}{np.abs(err).max():>11.3e}{np.sqrt(np.mean(err ** 2)):>11.3e}"
                         f"{np.mean(np.abs(err[sel]) / ref[sel]):>11.3e}")
    text = "\n".join(lines) + "\n"
    print(text)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / f"light_sweep_n{args.n}.txt").write_text(text)


if __name__ == "__main__":
    main()
