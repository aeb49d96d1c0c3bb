"""Host work of a CUDA camera move, measured without a GPU.

Runs ``backend="cuda"`` in Numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``, set here before
Numba is imported) with every kernel launch replaced by a stand-in (the ray cast's writes a
constant lit image, the others nothing; its time is left out), so what the clock sees is the
Python the host runs around the kernel: the request's checks, the stage-cache lookups, the
kernel's records, the device cache's argument mapping, the memory check, the image download and
the result. Prints, for each case (the ``supernova_table`` scene of benchmarks/scenes.py at n³, one
point light, window w²) and model, the median over ``--repeats`` camera moves (a new camera each,
after warm-up frames that build the stages) of the whole ``render()`` and of its phases in µs, and
per frame: kernel launches, uploads, downloads, free-memory queries, and records mapped to device
arrays (``mapped``: the camera's, which changes; the others are found whole)::

    python benchmarks/gpu_host.py                       # 256³ at 512², EA and SS
    python benchmarks/gpu_host.py --cases 32:64 --repeats 5

``total-dl`` is ``total`` less the download: the simulator's "device" arrays are host arrays, so
its download is a host copy standing for the transfer, which a GPU's DMA does. What the simulator
cannot show (docs/performance.rst, "Host work of a frame"): the driver's own time in a launch
(argument marshalling, ``cuLaunchKernel``) and in a copy. The counts are exact.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import statistics
import sys
import time
import warnings
from pathlib import Path

if "numba" in sys.modules and os.environ.get("NUMBA_ENABLE_CUDASIM") != "1":
    raise SystemExit("gpu_host.py sets NUMBA_ENABLE_CUDASIM=1 itself: run it in a fresh process")
os.environ["NUMBA_ENABLE_CUDASIM"] = "1"

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # run from a checkout
sys.path.insert(0, str(HERE))  # the benchmarks' shared helpers

MODELS = ("emission_absorption", "single_scattering")
SCENE = "supernova_table"
#: The phases timed inside ``render()``: (label, module, attribute); a method as "Class.name".
PHASES = (("request", "pv_ambient.rendering.renderer", "build_request"),
          ("inputs", "pv_ambient.rendering.camera_pass", "gather_inputs"),
          ("records", "pv_ambient.rendering.camera_pass", "raycast_records"),
          ("run_raycast", "pv_ambient.backend", "run_raycast"),
          ("device_args", "pv_ambient.backend", "DeviceCache.args"),
          ("check_fits", "pv_ambient.backend", "check_fits"),
          # the simulator's download is a host copy; on a GPU the transfer (the host waits for it)
          ("download", "numba.cuda.simulator.cudadrv.devicearray", "FakeCUDAArray.copy_to_host"))
#: Per-frame counts: (label, module, attribute).
COUNTS = (("launches", "numba.cuda.simulator.kernel", "FakeCUDAKernel.__call__"),
          ("uploads", "numba.cuda", "to_device"),
          ("downloads", "numba.cuda.simulator.cudadrv.devicearray", "FakeCUDAArray.copy_to_host"),
          ("mem_queries", "pv_ambient.device_cache", "free_device_memory"),
          ("mapped", "pv_ambient._kernels.records", "map_arrays"))


class Probe:
    """Per-frame seconds by phase and counts by event, from wrappers put on module attributes."""

    def __init__(self):
        self.seconds, self.counts, self._depth = {}, {}, {}
        self.undo = []
        self.kernel = 0.0  # seconds of the stand-in kernels, left out of every phase

    def _patch(self, module, attr, make):
        import importlib

        mod = importlib.import_module(module)
        owner, name = mod, attr
        if "." in attr:
            cls, name = attr.split(".")
            owner = getattr(mod, cls, None)
        if owner is None or not hasattr(owner, name):
            return False  # not in this version of the code: its column stays empty
        old = getattr(owner, name)
        setattr(owner, name, make(old))
        self.undo.append((owner, name, old))
        return True

    def time(self, label, module, attr):
        def make(old):
            def timed(*args, **kwargs):
                depth = self._depth.get(label, 0)
                self._depth[label] = depth + 1
                t = time.perf_counter()
                try:
                    return old(*args, **kwargs)
                finally:
                    self._depth[label] = depth
                    if depth == 0:  # a recursive call is timed once, by its outermost call
                        self.seconds[label] = self.seconds.get(label, 0.0) + time.perf_counter() - t
            return timed
        self._patch(module, attr, make)

    def count(self, label, module, attr, call=True):
        def make(old):
            def counted(*args, **kwargs):
                depth = self._depth.get(label, 0)
                if depth == 0:  # a recursive walk counts once
                    self.counts[label] = self.counts.get(label, 0) + 1
                if not call:
                    return None
                self._depth[label] = depth + 1
                try:
                    return old(*args, **kwargs)
                finally:
                    self._depth[label] = depth
            return counted
        self._patch(module, attr, make)

    def blas(self):
        """Time entering and leaving the renderer's BLAS limit (a context manager)."""
        def make(old):
            @contextlib.contextmanager
            def timed():
                t = time.perf_counter()
                cm = old()
                cm.__enter__()
                self.seconds["blas"] = self.seconds.get("blas", 0.0) + time.perf_counter() - t
                try:
                    yield
                finally:
                    t = time.perf_counter()
                    cm.__exit__(None, None, None)
                    self.seconds["blas"] += time.perf_counter() - t
            return timed
        self._patch("pv_ambient.rendering.renderer", "blas_one_thread", make)

    def reset(self):
        self.seconds, self.counts, self.kernel = {}, {}, 0.0


def _stand_in_kernels(probe):
    """Every kernel launch a stand-in: the ray cast's writes a constant image (a lit picture with
    coverage, so what the host does with a real image runs), the others nothing. The fill's time
    is left out of every phase (it stands for the GPU's work)."""
    from numba.cuda.simulator.kernel import FakeCUDAKernel

    from pv_ambient._kernels.cuda import RAYCAST_KERNELS

    raycast = {id(k) for k in RAYCAST_KERNELS.values()}
    counted = FakeCUDAKernel.__call__

    def launch(self, *args):
        counted(self, *args)
        if id(self) in raycast:
            t = time.perf_counter()
            out_rad, out_alpha = args[-4], args[-3]
            out_rad[...] = 0.25
            out_alpha[...] = 0.5
            probe.kernel += time.perf_counter() - t

    FakeCUDAKernel.__call__ = launch


def cameras(cam, count):
    """``count`` cameras: ``cam`` orbited in steps of 0.5° (benchmarks/gpu.py's orbit, finer)."""
    import scenes

    return [scenes.orbit(cam, 0.5 * k) for k in range(count)]


def measure(scene, size, model, repeats, warm_up, probe):
    import pv_ambient as pa

    vol, tf, lights, _, cam = scene
    cams = cameras(cam, warm_up + repeats)  # a new camera every frame
    r = pa.Renderer(vol, transfer_function=tf, lights=list(lights), backend="cuda")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # the stages on the CPU (the simulator's no-op sweeps would leave the light volumes empty, the
        # lights unlit), then on the "GPU": uploads made, a first camera move
        r.render(camera=cams[0], window_size=(8, 8), model=model, backend="cpu", progress_bar=False)
        for k in range(warm_up):
            r.render(camera=cams[k % len(cams)], window_size=size, model=model, progress_bar=False)
    frames = []
    for k in range(repeats):
        probe.reset()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t = time.perf_counter()
            res = r.render(camera=cams[(warm_up + k) % len(cams)], window_size=size, model=model)
            total = time.perf_counter() - t - probe.kernel
        probe.seconds["run_raycast"] = probe.seconds.get("run_raycast", 0.0) - probe.kernel
        assert res.metadata["backend"] == "cuda" and (model == "emission_absorption" or res.metadata["lights"])
        frames.append((total, dict(probe.seconds), dict(probe.counts)))
    return frames


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", nargs="+", default=["256:512"], help="n:w pairs (n³ volume, w² image)")
    ap.add_argument("--models", nargs="+", default=list(MODELS))
    ap.add_argument("--repeats", type=int, default=21)
    ap.add_argument("--warm-up", type=int, default=3)
    args = ap.parse_args(argv)

    from numba.cuda.simulator.kernel import FakeCUDAKernel

    import scenes

    probe = Probe()
    probe.count("launches", "numba.cuda.simulator.kernel", "FakeCUDAKernel.__call__", call=False)
    _stand_in_kernels(probe)
    for label, module, attr in COUNTS[1:]:
        probe.count(label, module, attr)
    for label, module, attr in PHASES:
        probe.time(label, module, attr)
    probe.blas()

    cols = ["total", "request", "blas", "inputs", "records", "run_raycast", "device_args", "check_fits", "download",
            "other", "total-dl"]
    counts = [c[0] for c in COUNTS]
    print("host time of a CUDA camera move (µs, medians; kernels no-ops in the CUDA simulator); "
          "per-frame counts")
    print(f"{'case':>10} {'model':>20} " + " ".join(f"{c:>11}" for c in cols) + "  "
          + " ".join(f"{c:>11}" for c in counts))
    for case in args.cases:
        n, w = (int(x) for x in case.split(":"))
        scene = scenes.scene(SCENE, n)
        for model in args.models:
            frames = measure(scene, (w, w), model, args.repeats, args.warm_up, probe)
            row = {}
            for c in cols:
                if c == "total":
                    vals = [f[0] for f in frames]
                elif c == "total-dl":  # what a GPU's host runs: the simulator's copy stands for the transfer
                    vals = [f[0] - f[1].get("download", 0.0) for f in frames]
                elif c == "other":  # render() outside the timed phases (result, metadata, buffers…)
                    vals = [f[0] - sum(f[1].get(p, 0.0) for p in ("request", "blas", "inputs", "records",
                                                                 "run_raycast")) for f in frames]
                else:
                    vals = [f[1].get(c, 0.0) for f in frames]
                row[c] = 1e6 * statistics.median(vals)
            cnt = {c: statistics.median([f[2].get(c, 0) for f in frames]) for c in counts}
            print(f"{n:>4}³/{w:>4}² {model:>20} " + " ".join(f"{row[c]:>11.1f}" for c in cols) + "  "
                  + " ".join(f"{cnt[c]:>11g}" for c in counts), flush=True)


if __name__ == "__main__":
    main()
