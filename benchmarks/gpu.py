"""GPU benchmark: every model on ``backend="cuda"`` against ``backend="cpu"`` on all cores, in one run.

Runs on the array core alone — numpy, numba, numba-cuda (and scipy, tqdm: pv_ambient's own
dependencies); no pyvista, vtk or matplotlib — so a GPU node with only those can run it::

    pip install "pv_ambient[cuda]"            # or: PYTHONPATH=/path/to/checkout
    python benchmarks/gpu.py                   # 256³ at 512², 512³ at 1024²; the CPU rows at 256³ only
    python benchmarks/gpu.py --backends cuda --cases 256:512 512:1024    # the GPU rows alone
    python benchmarks/gpu.py --fresh-process --backends cuda             # first frame in a fresh process
    python benchmarks/gpu.py --backends cpu --cases 32:64 --repeats 1 --out -   # no GPU needed
    pv-ambient bench --backend cuda            # the same, from the CLI

For each case (the ``supernova_table`` scene of benchmarks/scenes.py at n³: the supernova as the
array core's Volume with a table transfer function, one point light at the centre; window w²) and
model it prints, for each backend of ``--backends`` measured in the same process (medians of
``--repeats`` after a warm-up that pays compilation):

* first frame: a new renderer (classification, majorant, ball σ̄, light volume, uploads) + render;
* camera move: the camera turns, every cache warm (GPU: one kernel launch + one image download);
* relight: the light moves (its optical depth is swept again — on the GPU for ``cuda``);
* TF change: a new transfer function (new renderer, warm table cache);
* the path tracer's camera paths per second (W·H·spp / time);
* with both backends, GPU/CPU time ratios and the largest relative difference between the two images;
* with ``--stages``, the stage timings of each warm-up frame (``Renderer.timings``: where a first
  frame's time goes, compilation included);
* with ``--profile TOP``, a cProfile of ``--repeats`` more camera moves, its TOP functions by own
  time (host work against the wait for the kernel).

``--measures`` picks the columns (``--measures camera``: the camera moves alone, for a device run
that must be short); the image difference is the warm-up frame's, so it is printed whatever is
measured.

The CPU baseline is measured only up to 256³ (``--cpu-max-n``): it is the reference the GPU rows
are read against, and at 512³ its frames would take most of a device run's time. ``--backends
cuda`` leaves the CPU rows out altogether.

``--fresh-process`` times instead what a user's new process pays for its first frame once the
kernels are in Numba's disk cache: for each case, model and backend a first Python process renders
one frame (filling the cache; its render time is the last column), then a second one times, each
printed apart: ``import pv_ambient`` (NumPy included: nothing is imported before it; Numba is
imported by the next step, or on the CPU by the render), ``from numba import cuda``, the CUDA context's creation (``cuda.current_context()``), and the first
``Renderer`` + ``render()``, with the count of Numba functions that render compiled (a warm cache
should leave none) and of those it loaded from the disk cache. ``total`` is the sum of those four: import and
context creation count, as they do for a user; the scene's construction (the benchmark's
synthetic volume) is printed but not counted, and ``process`` is the second process's whole wall
time, interpreter start included.

Compiling every kernel without a GPU (registers, spills, compile time) is
``benchmarks/gpu_kernels.py``'s job.

The table goes to stdout and to ``benchmarks/results/gpu.txt`` (``--fresh-process``:
``gpu_first_frame.txt``; ``--out`` for another file, ``-`` for none), the command line, commit and
machine at its top.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # run from a checkout
sys.path.insert(0, str(HERE))  # the benchmarks' shared helpers, also when imported

# nothing else is imported here: --fresh-process's timed child imports NumPy and pv_ambient itself

MODELS = ("emission_absorption", "single_scattering", "ambient_scattering", "diffusion", "path_traced")
BACKENDS = ("cuda", "cpu")
SCENE = "supernova_table"  # benchmarks/scenes.py: the array core's Volume and a table TF (no pyvista)
CPU_MAX_N = 256
RESULTS = {"table": HERE / "results" / "gpu.txt", "fresh": HERE / "results" / "gpu_first_frame.txt"}


def cameras(cam):
    """Eight cameras: ``cam`` orbited in steps of 12.3° (the first frame's and the camera moves')."""
    import numpy as np

    import scenes

    return [scenes.orbit(cam, d) for d in np.degrees(np.linspace(0.0, 1.5, 8))]


def render_options(size, model, backend, spp):
    """``Renderer.render``'s options of every frame of a row."""
    opts = dict(window_size=size, model=model, backend=backend)
    if model == "path_traced":
        opts["samples_per_pixel"] = spp
    return opts


def backends_at(n, backends, cpu_max_n):
    """The backends of ``backends`` measured at n³: the CPU only up to ``cpu_max_n``³."""
    return [b for b in backends if b != "cpu" or n <= cpu_max_n]


MEASURES = ("first", "camera", "relight", "tf")


def measure(scene, size, model, backend, repeats, spp, measures=MEASURES, profile=0):
    """The row's times (seconds) of ``measures``, the warm-up frame's stages and image; with
    ``profile`` > 0, the cProfile table (the ``profile`` heaviest functions by own time) of
    ``repeats`` further camera moves: where a frame's host time goes."""
    import pv_ambient as pa
    import scenes
    from timing import median_time

    vol, tf, (light,), _, cam = scene
    cams = cameras(cam)
    opts = render_options(size, model, backend, spp)
    out = {}
    r = pa.Renderer(vol, transfer_function=tf, lights=[light], backend=backend)
    out["image"] = r.render(camera=cams[0], **opts).radiance  # warm-up: compilation, table slice on disk
    out["stages"] = dict(r.timings)  # the warm-up frame's stages (compilation included)

    def first(k):
        rr = pa.Renderer(vol, transfer_function=tf, lights=[light], backend=backend)
        rr.render(camera=cams[0], **opts)
    if "first" in measures:
        out["first"] = median_time(first, repeats)
    if "camera" in measures:
        out["camera"] = median_time(lambda k: r.render(camera=cams[k % len(cams)], **opts), repeats)
    if profile:
        out["profile"] = camera_profile(r, cams, opts, repeats, profile)

    def relight(k):
        r.set_lights([pa.PointLight((0.05 * (k + 1), 0.0, 0.0), light.intensity)])
        r.render(camera=cams[0], **opts)
    if "relight" in measures:
        out["relight"] = median_time(relight, repeats)

    def tf_change(k):
        rr = pa.Renderer(vol, transfer_function=scenes.table_tf(1.0 + 0.1 * (k + 1)), lights=[light], backend=backend)
        rr.render(camera=cams[0], **opts)
    if "tf" in measures:
        out["tf"] = median_time(tf_change, repeats)
    if model == "path_traced" and "camera" in out:
        out["paths_per_s"] = size[0] * size[1] * spp / out["camera"]
    return out


def camera_profile(r, cams, opts, repeats, top):
    """cProfile of ``repeats`` camera moves: the ``top`` functions by own time, one line each
    (a CUDA frame's wait for its kernel shows as the download's or the synchronisation's own time)."""
    import cProfile
    import io
    import pstats

    prof = cProfile.Profile()
    prof.enable()
    for k in range(repeats):
        r.render(camera=cams[(k + 1) % len(cams)], **opts)
    prof.disable()
    buf = io.StringIO()
    stats = pstats.Stats(prof, stream=buf)
    stats.sort_stats("tottime").print_stats(top)
    lines = [ln for ln in buf.getvalue().splitlines() if ln.strip()]
    start = next((i for i, ln in enumerate(lines) if ln.lstrip().startswith("ncalls")), 0)
    return [f"per {repeats} frames: {lines[0].strip()}"] + lines[start:start + top + 1]


def device_name():
    """The current GPU's name (the simulator's in the simulator)."""
    if os.environ.get("NUMBA_ENABLE_CUDASIM") == "1":
        return "Numba CUDA simulator"
    from numba import cuda

    name = cuda.get_current_device().name
    return name.decode() if isinstance(name, bytes) else str(name)


def compile_counts():
    """(compiled, loaded from the disk cache): the compilations of every Numba dispatcher in this
    process, CPU and CUDA, from their ``stats`` (a cache miss is a compilation)."""
    import gc

    from numba.core.dispatcher import Dispatcher

    kinds = [Dispatcher]
    if "numba.cuda" in sys.modules:
        try:
            from numba.cuda.dispatcher import CUDADispatcher

            kinds.append(CUDADispatcher)
        except ImportError:  # the simulator's dispatchers compile nothing
            pass
    compiled = loaded = 0
    kinds = tuple(kinds)
    for obj in gc.get_objects():
        try:
            found = isinstance(obj, kinds)
        except AttributeError:  # an object whose __class__ lookup raises (NumPy's NpzFile.f, a BagObj)
            continue
        if found:
            stats = obj.stats
            compiled += sum(stats.cache_misses.values())
            loaded += sum(stats.cache_hits.values())
    return compiled, loaded


def first_frame(model, backend, n, w, spp):
    """The timed steps of a fresh process's first frame (run as this script's ``--_first-frame`` child,
    in which nothing else has been imported yet), as a dict of seconds and counts."""
    out = {}
    t = time.perf_counter()
    import pv_ambient as pa
    out["import"] = time.perf_counter() - t
    if backend == "cuda":
        t = time.perf_counter()
        from numba import cuda
        out["import_cuda"] = time.perf_counter() - t
        t = time.perf_counter()
        cuda.current_context()
        out["context"] = time.perf_counter() - t
        out["device"] = device_name()
    t = time.perf_counter()
    import scenes

    vol, tf, (light,), _, cam = scenes.scene(SCENE, n)
    cam0 = cameras(cam)[0]
    out["scene"] = time.perf_counter() - t
    before = compile_counts()
    t = time.perf_counter()
    r = pa.Renderer(vol, transfer_function=tf, lights=[light], backend=backend)
    r.render(camera=cam0, **render_options((w, w), model, backend, spp))
    out["render"] = time.perf_counter() - t
    after = compile_counts()
    out["compiled"], out["loaded"] = after[0] - before[0], after[1] - before[1]
    return out


def fresh_child(model, backend, n, w, spp, timeout):
    """:func:`first_frame` in a new Python process (this script, ``--_first-frame``): its result,
    with ``process`` its whole wall time."""
    cmd = [sys.executable, str(Path(__file__).resolve()), "--_first-frame", model, backend, str(n), str(w),
           "--spp", str(spp)]
    t = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    wall = time.perf_counter() - t
    if proc.returncode != 0:
        raise RuntimeError(f"the fresh process ({model}, {backend}, {n}³/{w}²) failed (exit {proc.returncode}):\n"
                           f"{proc.stderr[-3000:]}")
    return {**json.loads(proc.stdout.strip().splitlines()[-1]), "process": wall}


FRESH_HEAD = (f"{'case':10s} {'model':20s} {'':4s} {'import':>8s} {'numba.cuda':>10s} {'context':>8s} "
              f"{'render()':>9s} {'total':>8s} {'compiled':>8s} {'loaded':>6s} {'scene*':>7s} {'process':>8s} "
              f"{'filling render()':>16s}")


def fresh_row(case, model, backend, fill, m):
    """One row of the fresh-process table (seconds)."""
    def sec(key, width):
        return f"{m[key]:{width - 1}.2f}s" if key in m else f"{'-':>{width}s}"

    total = sum(m.get(k, 0.0) for k in ("import", "import_cuda", "context", "render"))
    return (f"{case:10s} {model:20s} {'gpu' if backend == 'cuda' else 'cpu':4s} {sec('import', 8)} "
            f"{sec('import_cuda', 10)} {sec('context', 8)} {sec('render', 9)} {total:7.2f}s {m['compiled']:8d} "
            f"{m['loaded']:6d} {sec('scene', 7)} {sec('process', 8)} {fill['render']:15.2f}s")


def run_fresh(args, emit):
    emit("# first frame in a fresh process with a warm kernel cache: per row, one process renders a frame "
         "(filling Numba's cache; its render() is the last column), then a second one times each step")
    emit("# total = import + numba.cuda + context + render(): import and context creation count; "
         "scene* (the benchmark's volume) does not")
    emit(FRESH_HEAD)
    device = None
    for case in args.cases:
        n, w = case
        for model in args.models:
            for backend in backends_at(n, args.backends, args.cpu_max_n):
                fill = fresh_child(model, backend, n, w, args.spp, args.timeout)
                timed = fresh_child(model, backend, n, w, args.spp, args.timeout)
                device = device or timed.get("device")
                emit(fresh_row(f"{n}³/{w}²", model, backend, fill, timed))
    if device:
        emit(f"# GPU: {device}")


def run_table(args, emit):
    import numpy as np

    import numba

    import scenes

    if "cuda" in args.backends:
        from pv_ambient.backend import resolve_backend

        resolve_backend("cuda")  # a clear error when numba-cuda or the GPU is missing
        emit(f"# GPU: {device_name()}")
    emit(f"# CPU: {os.cpu_count()} cores, numba threads {numba.get_num_threads()}; medians of {args.repeats}; "
         f"CPU rows up to {args.cpu_max_n}³")
    emit(f"{'case':10s} {'model':20s} {'':4s} {'first':>9s} {'camera':>9s} {'relight':>9s} {'TF':>9s} "
         f"{'paths/s':>10s} {'max rel diff':>12s}")
    for n, w in args.cases:
        here = backends_at(n, args.backends, args.cpu_max_n)
        if not here:
            emit(f"{f'{n}³/{w}²':10s} no backend here (the CPU rows stop at --cpu-max-n {args.cpu_max_n})")
            continue
        scene = scenes.scene(SCENE, n)
        for model in args.models:
            res = {b: measure(scene, (w, w), model, b, args.repeats, args.spp, args.measures, args.profile)
                   for b in here}
            both = len(res) == 2
            if both:
                g, c = res["cuda"], res["cpu"]
                diff = float(np.abs(g["image"] - c["image"]).max() / max(np.abs(c["image"]).max(), 1e-30))
            for b, m in res.items():
                pps = f"{m['paths_per_s']:10.3g}" if "paths_per_s" in m else f"{'':10s}"
                emit(f"{f'{n}³/{w}²':10s} {model:20s} {'gpu' if b == 'cuda' else 'cpu':4s} "
                     + " ".join(f"{1e3 * m[k]:7.1f}ms" if k in m else f"{'-':>9s}" for k in MEASURES)
                     + f" {pps} {diff if both and b == 'cuda' else '':>12}")
            if both:
                ratio = " ".join(f"{c[k] / g[k]:8.3g}×" if k in g else f"{'-':>9s}" for k in MEASURES)
                pr = f"{g['paths_per_s'] / c['paths_per_s']:9.3g}×" if "paths_per_s" in g else ""
                emit(f"{'':10s} {'':20s} {'cpu/gpu':4s} {ratio} {pr}")
            if args.stages:
                for b, m in res.items():
                    emit(f"{'':10s} {'':20s} {'gpu' if b == 'cuda' else 'cpu':4s} warm-up frame's stages (s): "
                         + ", ".join(f"{k} {v:.2f}" for k, v in m["stages"].items()))
            for b, m in res.items():
                for line in m.get("profile", ()):
                    emit(f"# {model} {'gpu' if b == 'cuda' else 'cpu'} camera-move profile | {line}")


def machine():
    """The header's machine line: cores and the versions of the packages that time the kernels."""
    from importlib.metadata import PackageNotFoundError, version

    def v(name):
        try:
            return version(name)
        except PackageNotFoundError:
            return "not installed"

    return (f"# machine: {os.cpu_count()} CPU cores; python {platform.python_version()}, numba {v('numba')}, "
            f"numba-cuda {v('numba-cuda')}, numpy {v('numpy')}; NUMBA_CACHE_DIR "
            f"{os.environ.get('NUMBA_CACHE_DIR', 'unset (beside the sources)')}")


def case(text):
    """``n:w`` → (n, w), for argparse."""
    try:
        n, w = (int(x) for x in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"a case is n:window, two integers such as 256:512; got {text!r}") from None
    if n < 2 or w < 1:
        raise argparse.ArgumentTypeError(f"a case needs n >= 2 and window >= 1; got {text!r}")
    return n, w


def parser():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--cases", nargs="+", type=case, default=[(256, 512), (512, 1024)], metavar="N:W",
                   help="n³ volume at window W² (default: 256:512 512:1024)")
    p.add_argument("--models", nargs="+", default=list(MODELS), choices=MODELS)
    p.add_argument("--backends", nargs="+", default=list(BACKENDS), choices=BACKENDS,
                   help="the backends measured (default: both; 'cuda' alone skips the CPU rows)")
    p.add_argument("--cpu-max-n", type=int, default=CPU_MAX_N,
                   help="the CPU rows only for cases up to this n³ (default: %(default)s)")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--measures", nargs="+", default=list(MEASURES), choices=MEASURES,
                   help="the columns measured (default: all; the image difference comes from the warm-up frame)")
    p.add_argument("--profile", type=int, default=0, metavar="TOP",
                   help="also profile --repeats camera moves: the TOP functions by own time")
    p.add_argument("--spp", type=int, default=4, help="path tracer samples per pixel per frame")
    p.add_argument("--fresh-process", action="store_true",
                   help="time the first frame in a fresh process with a warm kernel cache, each step apart")
    p.add_argument("--timeout", type=float, default=1800, help="seconds per fresh process (--fresh-process)")
    p.add_argument("--out", help=f"where the table is written (default: {RESULTS['table'].relative_to(HERE.parent)}, "
                                 f"with --fresh-process {RESULTS['fresh'].relative_to(HERE.parent)}; '-' for none)")
    p.add_argument("--stages", action="store_true", help="also print each warm-up frame's stage timings")
    p.add_argument("--_first-frame", nargs=4, metavar=("MODEL", "BACKEND", "N", "W"), help=argparse.SUPPRESS)
    return p


def main(argv=None):
    args = parser().parse_args(argv)
    if args._first_frame:
        model, backend, n, w = args._first_frame
        print(json.dumps(first_frame(model, backend, int(n), int(w), args.spp)))
        return 0
    args.backends = [b for b in BACKENDS if b in args.backends]  # each once, the GPU first
    from gpu_kernels import commit

    lines = []

    def emit(line):
        print(line, flush=True)
        lines.append(line)

    emit(f"# $ python benchmarks/gpu.py {' '.join(sys.argv[1:] if argv is None else argv)} | commit {commit()}")
    emit(machine())
    (run_fresh if args.fresh_process else run_table)(args, emit)
    out = args.out or str(RESULTS["fresh" if args.fresh_process else "table"])
    if out != "-":
        Path(out).parent.mkdir(parents=True, exist_ok=True)
        Path(out).write_text("\n".join(lines) + "\n")
        print(f"written to {out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
