"""Where a CUDA camera move's time goes, on a GPU: the host's work, the kernel, the download.

For each model (the ``supernova_table`` scene of benchmarks/scenes.py at n³, one point light at the
centre, window w², ``backend="cuda"``) the renderer is built and warmed up, then ``--frames``
camera moves are timed with the ray-cast launch instrumented (:func:`timed_raycast`, the same steps
as ``pv_ambient.backend.raycast`` with clocks between them). Medians, in ms:

* ``render()``: the whole call, as a user times it;
* ``args``: the device cache's records for the launch (``DeviceCache.args``, the output buffer);
* ``dispatch``: the kernel call's return on the host (:func:`pv_ambient.cuda_launch.launch`: the
  changed records' typing and marshalling, ``cuLaunchKernel``; ``--numba-launch``: numba-cuda's own
  launch, every argument typed and marshalled); the GPU starts meanwhile;
* ``wait``: the host waiting for the kernel after the dispatch;
* ``download``: the image's one copy to the host (pageable memory, as the renderer does);
  ``pinned``: the same copy into page-locked memory, for comparison;
* ``kernel``: the kernel alone, ``--frames`` launches back to back between two CUDA events
  (the next launch's dispatch hidden behind the running kernel);
* ``other``: ``render()`` less args, dispatch, wait and download — the request, the stage-cache
  lookups, the records, the result;
* ``regs``/``local``: registers and local memory per thread of the kernel as the driver loaded it;
* with ``--blocks``, the kernel alone launched in thread blocks of other shapes.

Run on a machine with a GPU and numba-cuda (no pyvista, vtk or matplotlib needed)::

    python benchmarks/gpu_frame.py                          # EA, SS, AS, diffusion at 256³/512²
    python benchmarks/gpu_frame.py --case 512:1024 --models emission_absorption
    ncu --kernel-name regex:raycast --launch-skip 1 --launch-count 1 \\
        python benchmarks/gpu_frame.py --models diffusion --frames 1     # one camera move's kernel in Nsight Compute

``benchmarks/gpu.py`` gives the frames against the CPU's; ``benchmarks/gpu_host.py`` the host's
phases without a GPU (the simulator).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # run from a checkout
sys.path.insert(0, str(HERE))  # the benchmarks' shared helpers

MODELS = ("emission_absorption", "single_scattering", "ambient_scattering", "diffusion")
CHOICES = MODELS + ("ambient_occlusion",)
COLUMNS = ("render", "args", "dispatch", "wait", "download", "pinned", "kernel", "other")


def timed_raycast(clock):
    """A stand-in for ``pv_ambient.backend.raycast`` (a whole image) that adds its steps' times
    to ``clock`` (a dict of lists, seconds) and keeps the last launch for :func:`kernel_time`."""
    from numba import cuda

    from pv_ambient._kernels.cuda import BLOCK, grid_for, raycast_kernel_for
    from pv_ambient.cuda_launch import launch
    from pv_ambient.device_cache import host_flat

    def raycast(cache, args, row0, row1, rad, alpha):
        t0 = time.perf_counter()
        h, w = alpha.shape
        kernel = raycast_kernel_for(args[0], args[5].baked, args[3].mode)
        dev_args = cache.args(args[1:], extra_bytes=cache.output_bytes(h, w))
        flat, d_rad, d_alpha = cache.output(h, w)
        t1 = time.perf_counter()
        launch(kernel, grid_for(w, row1 - row0), BLOCK, (*dev_args, d_rad, d_alpha, row0, row1), cache.launch_memo)
        t2 = time.perf_counter()
        cuda.synchronize()
        t3 = time.perf_counter()
        host = host_flat(rad, alpha)
        assert host is not None and (row0, row1) == (0, h), "a whole image in the renderer's buffers"
        flat.copy_to_host(host)
        t4 = time.perf_counter()
        if "pinned_buf" not in clock:
            clock["pinned_buf"] = cuda.pinned_array(host.shape, host.dtype)
        flat.copy_to_host(clock["pinned_buf"])
        t5 = time.perf_counter()
        cache.tick()
        for key, dt in (("args", t1 - t0), ("dispatch", t2 - t1), ("wait", t3 - t2), ("download", t4 - t3),
                        ("pinned", t5 - t4)):
            clock.setdefault(key, []).append(dt)
        clock["last"] = (kernel, kernel[grid_for(w, row1 - row0), BLOCK], (*dev_args, d_rad, d_alpha, row0, row1))

    return raycast


def kernel_time(clock, n, block=None):
    """Seconds per launch of the last kernel, ``n`` launches back to back between two events;
    with ``block`` (x, y), launched in blocks of that shape instead of the renderer's."""
    from numba import cuda

    from pv_ambient._kernels.cuda import grid_for

    kernel, launch, args = clock["last"]
    if block is not None:
        h, w = args[-3].shape  # d_alpha
        launch = kernel[grid_for(w, h, block), block]
    start, end = cuda.event(), cuda.event()
    launch(*args)  # the first launch of a burst pays nothing extra, but the clocks start warm
    start.record()
    for _ in range(n):
        launch(*args)
    end.record()
    end.synchronize()
    return start.elapsed_time(end) / 1e3 / n  # ms


def kernel_resources(kernel):
    """(registers, local bytes) per thread of ``kernel``'s one compiled specialisation, as loaded."""
    try:
        (sig,) = list(kernel.overloads)
        k = kernel.overloads[sig]
        return k.regs_per_thread, k.local_mem_per_thread
    except Exception:  # noqa: BLE001 - older or newer numba-cuda: not essential
        return None, None


def measure(scene, size, model, frames, blocks=()):
    import pv_ambient as pa
    import pv_ambient.backend as backend
    from gpu import cameras

    vol, tf, (light,), _, cam = scene
    cams = cameras(cam)
    r = pa.Renderer(vol, transfer_function=tf, lights=[light], backend="cuda")
    r.render(camera=cams[0], window_size=size, model=model, progress_bar=False)  # stages, compilation
    clock = {}
    real = backend.raycast
    backend.raycast = timed_raycast(clock)
    try:
        r.render(camera=cams[1], window_size=size, model=model, progress_bar=False)  # the timed path warm
        for key in list(clock):
            if key not in ("pinned_buf", "last"):
                clock[key] = []
        totals = []
        for k in range(frames):
            t = time.perf_counter()
            r.render(camera=cams[k % len(cams)], window_size=size, model=model, progress_bar=False)
            totals.append(time.perf_counter() - t)
    finally:
        backend.raycast = real
    out = {key: statistics.median(clock[key]) for key in ("args", "dispatch", "wait", "download", "pinned")}
    out["render"] = statistics.median(totals)
    out["other"] = out["render"] - sum(out[k] for k in ("args", "dispatch", "wait", "download"))
    out["kernel"] = kernel_time(clock, frames)
    out["blocks"] = {b: kernel_time(clock, frames, b) for b in blocks}
    out["regs"], out["local"] = kernel_resources(clock["last"][0])
    out["launch check"] = launch_check(r, cams[1], size, model)
    return out


def launch_check(r, cam, size, model):
    """The largest absolute difference between a frame launched by :func:`pv_ambient.cuda_launch.launch`
    and the same frame launched by numba-cuda's own path (0 when the two pass the same parameters);
    None when the fast path is off."""
    import numpy as np

    import pv_ambient.cuda_launch as cl

    if not cl.ENABLED:
        return None
    fast = r.render(camera=cam, window_size=size, model=model, progress_bar=False).radiance.copy()
    cl.ENABLED = False
    try:
        slow = r.render(camera=cam, window_size=size, model=model, progress_bar=False).radiance
    finally:
        cl.ENABLED = True
    return float(np.max(np.abs(fast.astype(np.float64) - slow)))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--case", default="256:512", help="n:w, the n³ volume at window w² (default: %(default)s)")
    p.add_argument("--models", nargs="+", default=list(MODELS), choices=CHOICES)
    p.add_argument("--frames", type=int, default=7, help="camera moves timed per model (default: %(default)s)")
    p.add_argument("--blocks", nargs="*", default=[], metavar="XxY",
                   help="also time the kernel alone in thread blocks of these shapes (e.g. 8x8 32x4)")
    p.add_argument("--numba-launch", action="store_true",
                   help="launch through numba-cuda's own path (PV_AMBIENT_FAST_LAUNCH=0), for comparison")
    args = p.parse_args(argv)
    if args.numba_launch:
        import pv_ambient.cuda_launch

        pv_ambient.cuda_launch.ENABLED = False
    blocks = [tuple(int(v) for v in b.split("x")) for b in args.blocks]
    n, w = (int(x) for x in args.case.split(":"))

    import scenes
    from gpu import device_name, machine

    print(machine(), flush=True)
    print(f"# GPU: {device_name()}; {n}³/{w}², medians of {args.frames} camera moves (ms)", flush=True)
    print(f"{'model':20s} " + " ".join(f"{c:>9s}" for c in COLUMNS) + f" {'regs':>5s} {'local':>6s}", flush=True)
    scene = scenes.scene("supernova_table", n)
    from pv_ambient.cuda_launch import COUNTS

    for model in args.models:
        m = measure(scene, (w, w), model, args.frames, blocks)
        print(f"{model:20s} " + " ".join(f"{1e3 * m[c]:9.3f}" for c in COLUMNS)
              + f" {m['regs'] if m['regs'] is not None else '-':>5} {m['local'] if m['local'] is not None else '-':>6}"
              + "".join(f"  kernel in {b[0]}x{b[1]} blocks {1e3 * t:.3f}" for b, t in m["blocks"].items())
              + f"  launches so far {COUNTS}, fast vs numba-cuda launch max |diff| {m['launch check']}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
