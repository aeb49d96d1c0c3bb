"""GPU benchmark: every model on ``backend="cuda"`` against ``backend="cpu"`` on all cores, in one run.

Runs on the array core alone — numpy, numba, numba-cuda (and scipy, tqdm: pv_ambient's own
dependencies); no pyvista, vtk or matplotlib — so a GPU node with only those can run it::

    pip install "pv_ambient[cuda]"            # or: PYTHONPATH=/path/to/checkout
    python benchmarks/gpu.py                   # 256³ at 512², 512³ at 1024²
    python benchmarks/gpu.py --cases 256:512 --repeats 5
    python benchmarks/gpu.py --compile-only    # no GPU needed: compile every kernel to PTX
    pv-ambient bench --backend cuda            # the same, from the CLI

For each case (supernova volume of n³, window w², one point light at the centre) and model it
prints, for the GPU and the CPU backend measured in the same process (medians of ``--repeats``
after a warm-up that pays compilation):

* first frame: a new renderer (classification, majorant, ball σ̄, light volume, uploads) + render;
* camera move: the camera turns, every cache warm (GPU: one kernel launch + one image download);
* relight: the light moves (its optical depth is swept again — on the GPU for ``cuda``);
* TF change: a new transfer function (new renderer, warm table cache);
* the path tracer's camera paths per second (W·H·spp / time);
* GPU/CPU time ratios, and the largest relative difference between the two images.

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

import datasets_synthetic as ds  # noqa: E402
import pv_ambient as pa  # noqa: E402
from pv_ambient.inputs.grid import Volume  # noqa: E402
from _timing import median_time  # noqa: E402

MODELS = ("emission_absorption", "single_scattering", "ambient_scattering", "diffusion", "path_traced")


def make_volume(n):
    v = ds.load("supernova", n=n)
    return Volume(v.values, spacing=v.spacing, origin=v.origin)


def make_tf(scale=1.0):
    # a table TF (no matplotlib): σt up to 40/world unit on the shell, albedo 0.9, faint emission
    return pa.TransferFunction.from_table([0.0, 0.15, 0.5, 1.0], sigma_t=[0.0, 0.0, 20.0 * scale, 40.0 * scale],
                                          albedo=0.9, color=[[0, 0, 0], [0.2, 0.05, 0.0], [0.9, 0.4, 0.1],
                                                             [1.0, 0.9, 0.6]])


def cameras():
    return [pa.Camera((3.0 * np.cos(a), 3.0 * np.sin(a), 1.2), (0, 0, 0), (0, 0, 1), view_angle=30.0)
            for a in np.linspace(0.3, 1.8, 8)]


def measure(vol, size, model, backend, repeats, spp):
    cams = cameras()
    light = pa.PointLight((0.0, 0.0, 0.0), 3.0)
    opts = dict(window_size=size, model=model, backend=backend)
    if model == "path_traced":
        opts["samples_per_pixel"] = spp
    out = {}
    r = pa.Renderer(vol, transfer_function=make_tf(), lights=[light], backend=backend)
    r.render(camera=cams[0], **opts)  # warm-up: compilation, table slice on disk

    def first(k):
        rr = pa.Renderer(vol, transfer_function=make_tf(), lights=[light], backend=backend)
        out["image"] = rr.render(camera=cams[0], **opts).radiance
    out["first"] = median_time(first, repeats)
    out["camera"] = median_time(lambda k: r.render(camera=cams[k % len(cams)], **opts), repeats)

    def relight(k):
        r.set_lights([pa.PointLight((0.05 * (k + 1), 0.0, 0.0), 3.0)])
        r.render(camera=cams[0], **opts)
    out["relight"] = median_time(relight, repeats)

    def tf_change(k):
        rr = pa.Renderer(vol, transfer_function=make_tf(1.0 + 0.1 * (k + 1)), lights=[light], backend=backend)
        rr.render(camera=cams[0], **opts)
    out["tf"] = median_time(tf_change, repeats)
    if model == "path_traced":
        out["paths_per_s"] = size[0] * size[1] * spp / out["camera"]
    return out


def compile_only(cc):
    """Compile the three CUDA kernels to PTX for compute capability ``cc`` (no GPU needed)."""
    import types

    import numba
    from numba import cuda

    import numba.cuda.dispatcher as disp

    disp.get_current_device = lambda: types.SimpleNamespace(compute_capability=cc)  # no driver here
    from pv_ambient._kernels import _jit, lightvol, pathtrace, raycast
    from pv_ambient._kernels import cuda as kc

    captured = {}

    def capture(name, mod, attr):
        orig = getattr(mod, attr)

        def f(*args):
            captured.setdefault(name, args)
            return orig(*args)
        setattr(mod, attr, f)
    capture("raycast", raycast, "raycast_image")
    capture("pathtrace", pathtrace, "pathtrace_image")
    capture("sweep", lightvol, "sweep_tau")
    r = pa.Renderer(make_volume(12), transfer_function=make_tf(), lights=[pa.PointLight((0, 0, 0.3), 3.0)],
                    backend="cpu")
    r.render(camera=cameras()[0], window_size=(8, 8), model="ambient_scattering", quality="preview")
    r.render(camera=cameras()[0], window_size=(8, 8), model="path_traced", samples_per_pixel=1)
    sig_l, B, is_point, lx, ly, lz, ax, sign, jump, out, hist = captured["sweep"]
    rc, pt = captured["raycast"], captured["pathtrace"]
    # kernel argument order: the scalar's arguments without the thread indices, then row0, row1
    kargs = {"raycast": rc[:8] + rc[10:] + rc[8:10], "pathtrace": pt[:-5] + pt[-3:] + pt[-5:-3],
             "sweep_layer": (sig_l, B, is_point, lx, ly, lz, ax, ax, ax, hist[0], out, hist[0], 0, 1)}
    sigs = {name: (kc.grid_function(*kc.KERNELS[name]), tuple(numba.typeof(v) for v in kargs[name]))
            for name in kargs}
    print(f"compiling the CUDA kernels to PTX for compute capability {cc[0]}.{cc[1]} (no GPU used)")
    for name, (fn, sig) in sigs.items():
        t = time.perf_counter()
        ptx, _ = cuda.compile_ptx(_jit._rebind(fn), sig, device=False, cc=cc)
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
        vol = make_volume(n)
        for model in args.models:
            res = {b: measure(vol, (w, w), model, b, args.repeats, args.spp) for b in ("cuda", "cpu")}
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
    return 0


if __name__ == "__main__":
    sys.exit(main())
