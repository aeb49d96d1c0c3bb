"""Cold compile time of the CPU kernels: what a user's first process (and ``make test`` on a fresh
clone) pays before Numba's disk cache holds the kernels.

Each package tree is timed in a fresh process with an empty Numba cache and one thread: every model
rendered once on a 16³ cloud at 24² pixels (emission–absorption, single and ambient scattering,
diffusion, ``auto`` at ``quality="accurate"``, the path tracer, the progressive model, single
scattering and diffusion with an anisotropic phase function), under a directional and then a point
light. It prints each render's wall time (the second light's renders mostly reuse the first's
kernels) and the kernels that took longest to compile, with Numba's ``numba:compile`` events:
``exclusive`` is a kernel's own compile time, nested compiles of the functions it calls (those not
inlined) subtracted. The rule this guards (docs/performance.rst, "Compile time"): a function with
a deep call tree or many call sites is inlined by LLVM (``force_inline``), not at Numba's IR level.

Usage::

    python benchmarks/compile_time.py                        # the installed package
    python benchmarks/compile_time.py --root /tmp/old /tmp/new --top 30   # two trees, one after the other
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path


def child(out: str) -> None:
    """Render the workload with a compile-event listener; write the timings to ``out`` (JSON)."""
    from numba.core import event

    kernels: dict[str, list] = {}
    stack = threading.local()

    class Listener(event.Listener):
        def on_start(self, ev):
            if not hasattr(stack, "frames"):
                stack.frames = []
            stack.frames.append([time.perf_counter(), 0.0])

        def on_end(self, ev):
            t0, nested = stack.frames.pop()
            dt = time.perf_counter() - t0
            if stack.frames:
                stack.frames[-1][1] += dt
            f = ev.data["dispatcher"].py_func
            row = kernels.setdefault(f"{f.__module__}.{f.__qualname__}", [0, 0.0, 0.0])
            row[0] += 1
            row[1] += dt - nested
            row[2] += dt

    event.register("numba:compile", Listener())
    import pv_ambient as pa
    from pv_ambient import datasets

    grid = datasets.cloud(n=16)
    tf = pa.TransferFunction(**{**datasets.suggested_style("cloud"), "density_scale": 8.0}, albedo=0.95)
    cam = pa.Camera((0.0, -3.6, 0.8), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), view_angle=30.0)
    runs = [("emission_absorption", {}), ("single_scattering", {}), ("ambient_scattering", {}), ("diffusion", {}),
            ("auto", {"quality": "accurate"}), ("path_traced", {"samples_per_pixel": 4}),
            ("progressive", {"samples_per_pixel": 4}), ("single_scattering", {"phase": 0.6}),
            ("diffusion", {"phase": 0.6})]
    renders = []
    t_all = time.perf_counter()
    for light in (pa.DirectionalLight((0.3, 0.4, -1.0), irradiance=2.0), pa.PointLight((0.1, 0.2, 0.3), intensity=2.0)):
        r = pa.Renderer(grid, transfer_function=tf, lights=[light])
        for model, kw in runs:
            t = time.perf_counter()
            r.render(camera=cam, window_size=(24, 24), model=model, **kw)
            label = f"{type(light).__name__[:-5].lower()} {model}" + "".join(f" {k}={v}" for k, v in kw.items())
            renders.append((label, time.perf_counter() - t))
    Path(out).write_text(json.dumps({"renders": renders, "kernels": kernels, "total": time.perf_counter() - t_all,
                                     "package": pa.__file__}))


def run_tree(root: str | None) -> dict:
    """The workload in a fresh process (``root``'s package first on the path when given), empty cache."""
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=os.path.join(tmp, "cache"), NUMBA_NUM_THREADS="1", TQDM_DISABLE="1")
        if root:
            env["PYTHONPATH"] = os.pathsep.join([root, env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
        out = os.path.join(tmp, "times.json")
        subprocess.run([sys.executable, __file__, "--child", out], env=env, check=True, stdout=subprocess.DEVNULL)
        return json.loads(Path(out).read_text())


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--root", nargs="*", default=[None], help="package trees to time (default: the installed package)")
    ap.add_argument("--top", type=int, default=20, help="kernels listed (default 20)")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        child(args.child)
        return
    roots = args.root or [None]
    res = []
    for root in roots:
        print(f"timing {root or 'the installed package'} ...", file=sys.stderr, flush=True)
        res.append(run_tree(root))
    names = [Path(r["package"]).parent.parent.name for r in res]
    w = max(12, *(len(n) for n in names))
    print("Cold compile, one thread, empty Numba cache: wall time per render (s)")
    print(f"{'render':48s}" + "".join(f" {n:>{w}s}" for n in names))
    for i, (label, _) in enumerate(res[0]["renders"]):
        print(f"{label:48s}" + "".join(f" {r['renders'][i][1]:{w}.1f}" for r in res))
    print(f"{'all renders':48s}" + "".join(f" {r['total']:{w}.1f}" for r in res))
    print()
    print("Kernels by exclusive compile time (s; n = specialisations compiled)")
    keys = sorted({k for r in res for k in r["kernels"]}, key=lambda k: -max(r["kernels"].get(k, [0, 0.0])[1] for r in res))
    print(f"{'kernel':60s}" + "".join(f" {'n':>3s} {n:>{w}s}" for n in names))
    for k in keys[: args.top]:
        cells = "".join(f" {r['kernels'].get(k, [0, 0.0])[0]:3d} {r['kernels'].get(k, [0, 0.0])[1]:{w}.1f}" for r in res)
        print(f"{k.removeprefix('pv_ambient._kernels.')[-60:]:60s}{cells}")
    print(f"{'all kernels':60s}" + "".join(f" {'':3s} {sum(v[1] for v in r['kernels'].values()):{w}.1f}" for r in res))


if __name__ == "__main__":
    main()
