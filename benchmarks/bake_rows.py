"""The bake's two CPU drivers (docs/performance.rst, "Relight: the bake"): time of
:func:`pv_ambient.stages.bake.bake_incident` with ``driver="nodes"`` (node by node, the rule) and
``driver="rows"`` (vectorised chunks of a row, :mod:`pv_ambient._kernels.bake_rows`), and the
largest difference between their arrays, on speed.py's scene (the supernova at ``--n``³, its light
grid on the data samples) under its point light at the centre and under a directional light, for
single and ambient scattering.

Times: the two drivers interleaved, ``--repeats`` rounds after a warm-up, medians; each call
allocates its output as a relight's does.

Usage: ``python benchmarks/bake_rows.py [--n 256] [--repeats 5] [--out benchmarks/results]``
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
import pv_ambient.stages.bake as stage_bake  # noqa: E402

DRIVERS = ("nodes", "rows")
MODELS = {"SS": "single_scattering", "AS": "ambient_scattering"}


def bake_calls(frames, light, model):
    """The stage-level bake call of a camera move of ``model`` under ``light`` alone, per driver:
    {driver: (args, kw)} — the row driver's reads D per sample (``dgrid``), the node driver's the
    ball grid (in the records)."""
    calls = []
    orig = stage_bake.bake_incident

    def spy(*args, **kw):
        calls.append((args, kw))
        return orig(*args, **kw)

    stage_bake.bake_incident = spy
    try:
        r = pa.Renderer(frames.grid, backend="cpu", transfer_function=frames.renderer.transfer_function, lights=[light])
        r.cache.share(frames.renderer.cache)
        r.render(camera=frames.cam, window_size=(64, 64), model=model, step=frames.step)
    finally:
        stage_bake.bake_incident = orig
    args, kw = calls[-1]
    lrec, grec, arec = args[1]
    ball = r.stages.ball_grid(arec.radius) if kw.get("dgrid") is not None else arec.ball
    nodes = (args[:1] + ((lrec, grec, arec._replace(ball=ball)),) + args[2:], {k: v for k, v in kw.items() if k != "dgrid"})
    return {"rows": (args, kw), "nodes": nodes}, r


def r_phase():
    """The isotropic phase function of the renders above (their default)."""
    from pv_ambient.inputs.phase import as_phase

    return as_phase(None)


def main():
    import speed

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", default=str(Path(__file__).parent / "results"))
    args = ap.parse_args()
    frames = speed.make_frames(args.n, (64, 64))
    lights = {"point (centre)": frames.light, "directional −z": pa.DirectionalLight((0.0, 0.0, -1.0))}
    made = {(ln, m): bake_calls(frames, lt, MODELS[m]) for ln, lt in lights.items() for m in MODELS}
    cases = {key: calls for key, (calls, _) in made.items()}
    shape = frames.renderer.stages.light_grid().shape
    lines = [f"$ python benchmarks/bake_rows.py --n {args.n} --repeats {args.repeats}",
             f"# light grid {tuple(shape)} (the data samples), {numba.get_num_threads()} threads; medians of "
             f"{args.repeats}, the drivers interleaved"]
    out = {}
    for key, calls in cases.items():  # compile, warm up, and keep each driver's array
        a, kw = calls["rows"]
        lines.append(f"# {key[0]}, {key[1]}: rows apply = "
                     f"{stage_bake.rows_apply(a[0], a[1], a[3], kw.get('phis'), kw.get('dgrid'))}")
        for d in DRIVERS:
            a, kw = calls[d]
            out[key + (d,)] = stage_bake.bake_incident(*a, **kw, driver=d)[0]
    times = {}
    for _ in range(args.repeats):
        for key, calls in cases.items():
            for d in DRIVERS:
                a, kw = calls[d]
                t = time.perf_counter()
                stage_bake.bake_incident(*a, **kw, driver=d)
                times.setdefault(key + (d,), []).append(time.perf_counter() - t)
    # D per sample, which ambient scattering's row driver reads: made once per transfer function
    r = made[(next(iter(lights)), "AS")][1]
    radius = float(cases[(next(iter(lights)), "AS")]["rows"][0][1][2].radius)
    table = r.stages.table(r_phase(), radius)
    ball = r.stages.ball_grid(radius)
    t_d = []
    for _ in range(args.repeats):
        t = time.perf_counter()
        stage_bake.ball_d(ball, table, radius)
        t_d.append(time.perf_counter() - t)
    lines.append(f"# load average after the timed rounds: {os.getloadavg()}")
    lines.append("")
    lines.append(f"{'light':<18}{'model':<7}{'nodes (s)':>11}{'rows (s)':>11}{'speed-up':>10}{'max |Δ|/max':>14}"
                 "   all rounds (nodes | rows)")
    for key in cases:
        a, b = (float(np.median(times[key + (d,)])) for d in DRIVERS)
        x, y = out[key + ("nodes",)], out[key + ("rows",)]
        diff = float(np.abs(y.astype(np.float64) - x).max() / max(np.abs(x).max(), 1e-30))
        lines.append(f"{key[0]:<18}{key[1]:<7}{a:>11.3f}{b:>11.3f}{a / b:>9.1f}×{diff:>14.1e}   "
                     f"{' '.join(f'{v:.3f}' for v in times[key + ('nodes',)])} | "
                     f"{' '.join(f'{v:.3f}' for v in times[key + ('rows',)])}")
    lines.append("")
    lines.append(f"D per sample (stages.bake.ball_d, once per transfer function and radius; ambient scattering's row "
                 f"driver reads it instead of the ball): {float(np.median(t_d)):.3f} s "
                 f"({' '.join(f'{v:.3f}' for v in t_d)})")
    text = "\n".join(lines) + "\n"
    print(text)
    dest = Path(args.out)
    dest.mkdir(parents=True, exist_ok=True)
    (dest / f"bake_rows_n{args.n}.txt").write_text(text)


if __name__ == "__main__":
    main()
