"""GPU benchmark: every model on ``backend="cuda"`` against ``backend="cpu"`` on all cores, in one run.

Runs on the array core alone — numpy, numba, numba-cuda (and scipy, tqdm: pv_ambient's own
dependencies); no pyvista, vtk or matplotlib — so a GPU node with only those can run it::

    pip install "pv_ambient[cuda]"            # or: PYTHONPATH=/path/to/checkout
    python benchmarks/gpu.py                   # 256³ at 512², 512³ at 1024²
    python benchmarks/gpu.py --cases 256:512 --repeats 5
    python benchmarks/gpu.py --compile-only    # no GPU needed: compile every kernel to PTX
    pv-ambient bench --backend cuda            # the same, from the CLI

For each case (the ``supernova_table`` scene of benchmarks/scenes.py at n³: the supernova as the
array core's Volume with a table transfer function, one point light at the centre; window w²) and
model it prints, for the GPU and the CPU backend measured in the same process (medians of ``--repeats``
after a warm-up that pays compilation):

* first frame: a new renderer (classification, majorant, ball σ̄, light volume, uploads) + render;
* camera move: the camera turns, every cache warm (GPU: one kernel launch + one image download);
* relight: the light moves (its optical depth is swept again — on the GPU for ``cuda``);
* TF change: a new transfer function (new renderer, warm table cache);
* the path tracer's camera paths per second (W·H·spp / time);
* GPU/CPU time ratios, and the largest relative difference between the two images;
* with ``--stages``, the stage timings of each warm-up frame (``Renderer.timings``: where a first
  frame's time goes, compilation included — the question benchmarks/results/gpu.txt leaves open).

``--compile-only`` compiles the ray-cast, path-tracing and light-sweep kernels to PTX for a
compute capability (default 9.0, H100) with numba-cuda's NVVM, without a driver or a GPU: it shows
that the shared scalar functions type-check and compile for the CUDA target (the test suite checks
them in Numba's simulator, which does not compile).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # run from a checkout

import pv_ambient as pa  # noqa: E402
import scenes  # noqa: E402  (benchmarks/: the script's directory is on sys.path)
from timing import median_time  # noqa: E402

MODELS = ("emission_absorption", "single_scattering", "ambient_scattering", "diffusion", "path_traced")
SCENE = "supernova_table"  # benchmarks/scenes.py: the array core's Volume and a table TF (no pyvista)


def cameras(cam):
    """Eight cameras: ``cam`` orbited in steps of 12.3° (the first frame's and the camera moves')."""
    return [scenes.orbit(cam, d) for d in np.degrees(np.linspace(0.0, 1.5, 8))]


def measure(scene, size, model, backend, repeats, spp):
    vol, tf, (light,), _, cam = scene
    cams = cameras(cam)
    opts = dict(window_size=size, model=model, backend=backend)
    if model == "path_traced":
        opts["samples_per_pixel"] = spp
    out = {}
    r = pa.Renderer(vol, transfer_function=tf, lights=[light], backend=backend)
    r.render(camera=cams[0], **opts)  # warm-up: compilation, table slice on disk
    out["stages"] = dict(r.timings)  # the warm-up frame's stages (compilation included)

    def first(k):
        rr = pa.Renderer(vol, transfer_function=tf, lights=[light], backend=backend)
        out["image"] = rr.render(camera=cams[0], **opts).radiance
    out["first"] = median_time(first, repeats)
    out["camera"] = median_time(lambda k: r.render(camera=cams[k % len(cams)], **opts), repeats)

    def relight(k):
        r.set_lights([pa.PointLight((0.05 * (k + 1), 0.0, 0.0), light.intensity)])
        r.render(camera=cams[0], **opts)
    out["relight"] = median_time(relight, repeats)

    def tf_change(k):
        rr = pa.Renderer(vol, transfer_function=scenes.table_tf(1.0 + 0.1 * (k + 1)), lights=[light], backend=backend)
        rr.render(camera=cams[0], **opts)
    out["tf"] = median_time(tf_change, repeats)
    if model == "path_traced":
        out["paths_per_s"] = size[0] * size[1] * spp / out["camera"]
    return out


def compile_only(cc):
    """Compile the three CUDA kernels to PTX for compute capability ``cc`` (no GPU needed): each
    kernel's arguments are those its CPU driver got on a tiny scene, matched by name."""
    import inspect
    import types

    import numba
    from numba import cuda

    import numba.cuda.dispatcher as disp

    disp.get_current_device = lambda: types.SimpleNamespace(compute_capability=cc)  # no driver here
    from pv_ambient._kernels import cuda as kc
    from pv_ambient._kernels import lightvol, pathtrace, raycast

    # kernel name → the CPU driver whose arguments it takes
    drivers = {"raycast": (raycast, "raycast_image"), "pathtrace": (pathtrace, "pathtrace_image"),
               "sweep_layer": (lightvol, "sweep_tau")}
    captured = {}
    for name, (mod, attr) in drivers.items():
        def spy(*args, _name=name, _orig=getattr(mod, attr)):
            captured.setdefault(_name, inspect.signature(_orig.py_func).bind(*args).arguments)
            return _orig(*args)
        setattr(mod, attr, spy)
    vol, tf, _, _, cam = scenes.scene(SCENE, 12)
    r = pa.Renderer(vol, transfer_function=tf, lights=[pa.PointLight((0, 0, 0.3), 3.0)], backend="cpu")
    r.render(camera=cam, window_size=(8, 8), model="ambient_scattering", quality="preview", progress_bar=False)
    r.render(camera=cam, window_size=(8, 8), model="path_traced", samples_per_pixel=1, progress_bar=False)
    # a sweep kernel runs one layer k of axis a, reading the layer J back (prev) and writing cur
    sweep = captured["sweep_layer"]
    sweep.update(k=sweep["a"], J=sweep["a"], prev=sweep["hist"][0], cur=sweep["hist"][0])
    print(f"compiling the CUDA kernels to PTX for compute capability {cc[0]}.{cc[1]} (no GPU used)")
    for name in drivers:
        scalar, x_name, y_name, _ = kc.KERNELS[name]
        # kernel arguments: the scalar's without the thread indices, then row0, row1
        params = [p for p in inspect.signature(scalar.py_func).parameters if p not in (x_name, y_name)]
        sig = tuple(numba.typeof(v) for v in [captured[name][p] for p in params] + [0, 1])
        t = time.perf_counter()
        ptx, _ = cuda.compile_ptx(getattr(kc, f"{name}_kernel").py_func, sig, device=False, cc=cc)
        print(f"  {name:12s} {len(ptx):8d} bytes of PTX in {time.perf_counter() - t:5.1f} s")
    return 0


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--cases", nargs="+", default=["256:512", "512:1024"], help="n:window pairs")
    p.add_argument("--models", nargs="+", default=list(MODELS), choices=MODELS)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--spp", type=int, default=4, help="path tracer samples per pixel per frame")
    p.add_argument("--compile-only", action="store_true")
    p.add_argument("--cc", default="9.0", help="compute capability for --compile-only")
    p.add_argument("--stages", action="store_true", help="also print each warm-up frame's stage timings")
    args = p.parse_args(argv)
    if args.compile_only:
        return compile_only(tuple(int(c) for c in args.cc.split(".")))
    from pv_ambient.backend import resolve_backend

    resolve_backend("cuda")  # a clear error when numba-cuda or the GPU is missing
    import numba
    from numba import cuda

    name = "Numba CUDA simulator" if os.environ.get("NUMBA_ENABLE_CUDASIM") == "1" else cuda.get_current_device().name
    print(f"GPU: {name.decode() if isinstance(name, bytes) else name}; CPU: {os.cpu_count()} cores, "
          f"numba threads {numba.get_num_threads()}; medians of {args.repeats}")
    head = (f"{'case':10s} {'model':20s} {'':4s} {'first':>9s} {'camera':>9s} {'relight':>9s} {'TF':>9s} "
            f"{'paths/s':>10s} {'max rel diff':>12s}")
    print(head)
    for case in args.cases:
        n, w = (int(x) for x in case.split(":"))
        scene = scenes.scene(SCENE, n)
        for model in args.models:
            res = {b: measure(scene, (w, w), model, b, args.repeats, args.spp) for b in ("cuda", "cpu")}
            g, c = res["cuda"], res["cpu"]
            diff = float(np.abs(g["image"] - c["image"]).max() / max(np.abs(c["image"]).max(), 1e-30))
            for b, m in (("gpu", g), ("cpu", c)):
                pps = f"{m['paths_per_s']:10.3g}" if "paths_per_s" in m else f"{'':10s}"
                print(f"{n}³/{w}² {model:20s} {b:4s} " + " ".join(f"{1e3 * m[k]:7.1f}ms" for k in
                                                             ("first", "camera", "relight", "tf"))
                      + f" {pps} {diff if b == 'gpu' else '':>12}")
            ratio = " ".join(f"{c[k] / g[k]:8.3g}×" for k in ("first", "camera", "relight", "tf"))
            pr = f"{g['paths_per_s'] / c['paths_per_s']:9.3g}×" if "paths_per_s" in g else ""
            print(f"{'':10s} {'':20s} {'cpu/gpu':4s} {ratio} {pr}")
            if args.stages:
                for b, m in (("gpu", g), ("cpu", c)):
                    print(f"{'':10s} {'':20s} {b:4s} warm-up frame's stages (s): "
                          + ", ".join(f"{k} {v:.2f}" for k, v in m["stages"].items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
