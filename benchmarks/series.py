"""Scaling of ``render_series`` (issue 18): a time series on a LocalCluster against serial loops,
and an orbit's frames against camera moves of one ``Renderer``.

Scene: ``cloud_series`` of benchmarks/scenes.py — ``--frames`` time steps of the synthetic cloud at
``--n``³ (seeds 0, 1, …, written as .vti files into a temporary folder first; point array
``density``, ``suggested_style("cloud")``, albedo 0.9), one point light of intensity 4 above the
volume, camera from (0.4, −3.8, 1.0) looking at the centre — ``--size``² pixels, model ``--model``
(quality "balanced"), PNG written per frame.

Rows:

(a) a serial loop — for each file: ``pyvista.read``, ``pv_ambient.render``, ``RenderResult.save``
    (PNG) — in a subprocess with ``NUMBA_NUM_THREADS=1``;
(b) the same loop in a subprocess with Numba's default threads (one per core);
(c) ``render_series`` on a ``LocalCluster`` of ``--workers`` processes × 1 thread × 1 Numba thread,
    started before the clock (workers warmed by a 2-frame series of a small volume);
(c') the same, cold: ``render_series(client=None, workers=...)`` from the call to its return,
    cluster start-up and the workers' loading of compiled kernels included.

Each loop first renders one small warm-up frame (loading Numba's compiled kernels from the cache),
outside the clock. Frames per second = frames / wall time of the loop. Targets on the 2-core
machine: (c)/(a) ≥ 1.8, (c)/(b) ≥ 1.1.

Orbit: ``render_series`` of one volume (time step 0) with ``--frames`` cameras
(:func:`pv_ambient.orbit`, elevation 20°) on the warm cluster; every frame after the first on a
worker reuses that worker's ``Renderer`` (light volumes, ball grid, diffusion solve). Its per-frame
cost (the worker's ``render`` time and its whole frame time, PNG write included; medians) is
compared with a camera-move frame of one ``Renderer`` in this process with one Numba thread (the same
orbit cameras, caches warm, median). Target: ratio ≤ 1.5.

The table is written to ``benchmarks/results/series.txt`` (``--out`` for another folder), the
command line at its top.

Usage (from the repository root; needs the ``distributed`` extra)::

    python benchmarks/series.py [--n 128] [--frames 16] [--size 256] [--model ambient_scattering] [--workers 2]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
SCENE = "cloud_series"  # benchmarks/scenes.py

#: The serial loop (rows a and b), run in a subprocess so that NUMBA_NUM_THREADS takes effect.
LOOP = r"""
import json, os, sys, time
import numba, pyvista as pv
import pv_ambient as pa
cfg = json.loads(sys.argv[1])
sys.path.insert(0, cfg["benchmarks"])
import scenes
small, tf, lights, _, camera = scenes.scene(cfg["scene"], 16)
kw = dict(transfer_function=tf, lights=lights, camera=camera, model=cfg["model"], window_size=(cfg["size"], cfg["size"]))
pa.render(small, **{**kw, "window_size": (16, 16)})   # warm-up: load the compiled kernels
if cfg.get("start_at"):   # row (d): the concurrent loops start together
    time.sleep(max(0.0, cfg["start_at"] - time.time()))
t = time.perf_counter()
renders = []
for i, path in enumerate(cfg["files"]):
    grid = pv.read(path)
    t1 = time.perf_counter()
    res = pa.render(grid, **kw)
    renders.append(time.perf_counter() - t1)
    res.save(os.path.join(cfg["out"], f"frame_{i:04d}.png"), exposure=cfg["exposure"])
wall = time.perf_counter() - t
print(json.dumps({"wall": wall, "threads": numba.get_num_threads(), "render": renders}))
"""


#: One PNG exposure (stops) for every frame of every row: the series' and the loop's PNGs compare
#: pixel for pixel (an "auto" exposure is per image in a loop, the first frame's in a series).
EXPOSURE = 0.0


def serial_loop(cfg, threads):
    return concurrent_loops([cfg], threads)[0]


def concurrent_loops(cfgs, threads):
    """Run the serial loop of each config in its own subprocess, all at once; their JSON results."""
    env = dict(os.environ)
    if threads is not None:
        env["NUMBA_NUM_THREADS"] = str(threads)
    logs = [(tempfile.TemporaryFile("w+"), tempfile.TemporaryFile("w+")) for _ in cfgs]  # no pipe to fill up
    procs = [subprocess.Popen([sys.executable, "-c", LOOP, json.dumps(c)], stdout=o, stderr=e, text=True, env=env)
             for c, (o, e) in zip(cfgs, logs)]
    outs = []
    for proc, (o, e) in zip(procs, logs):
        proc.wait()
        o.seek(0)
        e.seek(0)
        if proc.returncode:
            raise RuntimeError(e.read()[-3000:])
        outs.append(json.loads(o.read().strip().splitlines()[-1]))
    return outs


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=128)
    ap.add_argument("--frames", type=int, default=16)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--model", default="ambient_scattering")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=str(HERE / "results"))
    args = ap.parse_args(argv)

    import numba
    from distributed import Client, LocalCluster

    import pv_ambient as pa
    import scenes

    lines = [f"$ python benchmarks/series.py {' '.join(sys.argv[1:] if argv is None else argv)}", ""]

    def say(s=""):
        print(s, flush=True)
        lines.append(s)

    tmp = Path(tempfile.mkdtemp(prefix="pv_ambient_series_"))
    files = []
    for s in range(args.frames):
        p = tmp / "steps" / f"step_{s:03d}.vti"
        p.parent.mkdir(parents=True, exist_ok=True)
        scenes.scene(SCENE, args.n, step=s)[0].save(p)
        files.append(str(p))
    _, tf, lights, _, camera = scenes.scene(SCENE, 16)
    kw = dict(transfer_function=tf, lights=lights, camera=camera, model=args.model,
              window_size=(args.size, args.size))
    cfg = {"benchmarks": str(HERE), "scene": SCENE, "model": args.model, "size": args.size, "files": files,
           "exposure": EXPOSURE}
    say(f"cloud {args.n}³ × {args.frames} time steps (.vti, {os.path.getsize(files[0]) / 2**20:.1f} MB each), "
        f"{args.model}, {args.size}x{args.size}, one point light; read + render + PNG per frame; "
        f"{os.cpu_count()} cores; load average at the start {os.getloadavg()[0]:.2f}")
    say()
    rows = {}
    for name, threads in (("a", 1), ("b", None)):
        out = tmp / f"loop_{name}"
        out.mkdir()
        r = serial_loop({**cfg, "out": str(out)}, threads)
        rows[name] = (args.frames / r["wall"], r["wall"], f"serial loop of render, {r['threads']} Numba thread"
                      + ("s" if r["threads"] != 1 else ""), float(np.median(r["render"])))
    # (d) the ceiling of any one-process-per-core scheme on this machine: the loop (a) run in
    # --workers processes at once, no dask, each over every --workers-th file
    for w in range(args.workers):
        (tmp / "loop_d" / str(w)).mkdir(parents=True)
    start_at = time.time() + 20.0  # after every process' imports and warm-up
    parts = concurrent_loops([{**cfg, "files": files[w::args.workers], "out": str(tmp / "loop_d" / str(w)),
                               "start_at": start_at} for w in range(args.workers)], 1)
    wall = max(r["wall"] for r in parts)
    rows["d"] = (args.frames / wall, wall, f"{args.workers} serial loops (a) at once, 1 thread each, no dask: "
                 "the ceiling of one process per core", float(np.median([t for r in parts for t in r["render"]])))

    import dask

    # as render_series(client=None) starts its cluster: the workers' Numba pool of one thread
    with dask.config.set({"distributed.nanny.pre-spawn-environ.NUMBA_NUM_THREADS": "1"}):
        cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True, dashboard_address=":0")
    client = Client(cluster)
    try:
        warm = [scenes.scene(SCENE, 16, step=s)[0] for s in range(2 * args.workers)]
        pa.render_series(warm, out_dir=tmp / "warm", client=client, numba_threads=1, progress_bar=False,
                         **{**kw, "window_size": (16, 16)})
        t = time.perf_counter()
        res = pa.render_series(files, out_dir=tmp / "series", client=client, numba_threads=1, progress_bar=False,
                               display={"exposure": EXPOSURE}, **kw)
        wall = time.perf_counter() - t
        assert res.n_failed == 0, [f.error for f in res.failed]
        rows["c"] = (args.frames / wall, wall, f"render_series, LocalCluster {args.workers} workers × 1 thread "
                                               "(started, warm)", float(np.median([f.times["classify"] + f.times["render"] for f in res.frames])))
        # the orbit on the warm cluster
        cams = pa.orbit(None, args.frames, elevation=20.0, start=camera)
        okw = {k: v for k, v in kw.items() if k != "camera"}
        orb = pa.render_series(files[0], cameras=cams, out_dir=tmp / "orbit", client=client, numba_threads=1,
                               progress_bar=False, **okw)
        assert orb.n_failed == 0, [f.error for f in orb.failed]
    finally:
        client.close()
        cluster.close()
    t = time.perf_counter()
    res = pa.render_series(files, out_dir=tmp / "cold", client=None, workers=args.workers, progress_bar=False, **kw)
    wall = time.perf_counter() - t
    assert res.n_failed == 0
    rows["c'"] = (args.frames / wall, wall, f"render_series(client=None, workers={args.workers}), cold: "
                                            "cluster start-up included",
                  float(np.median([f.times["classify"] + f.times["render"] for f in res.frames])))

    # identical frames: the series' PNGs against the serial loop's
    same = sum(np.array_equal(np.asarray(_png(tmp / "series" / f"frame_{i:04d}.png")),
                              np.asarray(_png(tmp / "loop_a" / f"frame_{i:04d}.png"))) for i in range(args.frames))

    say(f"{'row':4s} {'frames/s':>9s} {'wall s':>8s} {'render s':>9s}  what (render s: median of a frame's Renderer build + render)")
    say("-" * 106)
    for k in ("a", "b", "c", "c'", "d"):
        fps, wall, what, med = rows[k]
        say(f"({k}){'':{3 - len(k)}s} {fps:9.3f} {wall:8.2f} {med:9.3f}  {what}")
    say()
    for num, den, target in (("c", "a", 1.8), ("c", "b", 1.1), ("c'", "a", None), ("c'", "b", None),
                             ("d", "a", None), ("d", "b", None), ("c", "d", None)):
        ratio = rows[num][0] / rows[den][0]
        met = "" if target is None else (f"  target ≥ {target}: " + ("met" if ratio >= target else "NOT met"))
        say(f"({num})/({den}) = {ratio:.2f}{met}")
    say(f"frames of (c) pixel-identical to the serial loop (a): {same} of {args.frames}")
    say()

    # orbit: frames after the first on each worker against one Renderer's camera moves
    reused = [f for f in orb.frames if f.reused]
    firsts = [f for f in orb.frames if not f.reused]
    r_render = float(np.median([f.times["render"] for f in reused]))
    r_total = float(np.median([f.times["total"] for f in reused]))
    prev = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        import pyvista as pv

        rend = pa.Renderer(pv.read(files[0]), transfer_function=tf, lights=lights)
        rkw = {"model": args.model, "window_size": (args.size, args.size)}
        rend.render(camera=cams[0], **rkw)  # caches warm
        moves = []
        for cam in cams[1:]:
            t = time.perf_counter()
            rend.render(camera=cam, **rkw)
            moves.append(time.perf_counter() - t)
    finally:
        numba.set_num_threads(prev)
    move = float(np.median(moves))
    say(f"orbit of step 0, {args.frames} cameras (elevation 20°) on the warm {args.workers}-worker cluster: "
        f"{len(firsts)} first frames (renderer built: median {np.median([f.times['total'] for f in firsts]):.3f} s), "
        f"{len(reused)} frames reusing the worker's renderer")
    say(f"  reused frame, worker's render call (median)            {r_render:.4f} s")
    say(f"  reused frame, whole frame incl. PNG write (median)     {r_total:.4f} s")
    say(f"  camera move of one Renderer in one process, 1 thread   {move:.4f} s")
    say(f"  ratio render / camera move = {r_render / move:.2f}; whole frame / camera move = {r_total / move:.2f}"
        f"  (target ≤ 1.5: {'met' if r_total / move <= 1.5 else 'NOT met'} for the whole frame)")
    say(f"load average at the end {os.getloadavg()[0]:.2f} (other processes on the machine distort every row)")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "series.txt").write_text("\n".join(lines) + "\n")
    print(f"wrote {out / 'series.txt'}")


def _png(path):
    from PIL import Image

    with Image.open(path) as im:
        return np.asarray(im)


if __name__ == "__main__":
    main()
