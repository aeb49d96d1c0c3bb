"""The diffusion solve's profile and the diffusion frames' stage times (issue 44), 1 and 2 threads.

Scene: benchmarks/speed.py's (``supernova_centre`` of benchmarks/scenes.py at ``--n``³, one point
light at the centre; its :class:`speed.Frames` builds it). Two tables, each from subprocesses with
``NUMBA_NUM_THREADS`` = each of ``--threads``:

* **profile** — one light's diffusion solve as the scene stage runs it (``solve_in_medium`` on the
  stage's medium and first-collision source), each phase timed by wrapping the functions and
  kernels it calls: the medium's coefficients per channel (what ``solve_in_medium`` computes
  itself), the system's assembly, the multigrid hierarchy, the V-cycle's kernels on the finest
  level and on the coarser ones, the conjugate-gradient vector kernels, the flux at the nodes and
  the power balance; ``other`` is the solve's wall time less these. The light's sweep, the
  irradiance and the source are timed before it (they are the first frame's, not the solve's).
  The first call compiles; the table is the median of ``--repeats`` calls after it.
* **frames** (``--frames``) — the first diffusion frame (a new ``Renderer`` and its frame, speed.py's
  "first frame" row) and a diffusion relight (the light moved by 0.02, speed.py's "relight" row
  for the diffusion model) at ``--size``², the medians of ``--repeats`` after a warm-up frame, and
  the stage time: the frame less the camera pass (the median of camera moves by 1°, caches warm).
* **tolerance** (``--tols``) — per solver tolerance (set as the balanced preset's ``diffusion_tol``),
  in one process with the most threads: the CG iterations, the diffusion stage's seconds (medians of
  ``--repeats``, the tolerances interleaved) and the frame's 4×4-block error and bias against the one
  solved to the first tolerance (docs/diffusion.rst, "Solver tolerance").

Usage (from the repository root)::

    python benchmarks/diffusion_solve.py [--n 256] [--size 512] [--repeats 3] [--threads 1,2] [--frames]
        [--compare OTHER_CHECKOUT] [--skip-profile] [--tols 1e-6,1e-4,1e-3,1e-2]
        [--out benchmarks/results/diffusion_profile.txt]

``--compare``: the largest difference of one light's φ (``solve_for_light`` as the stage calls
it) between another checkout of the project (e.g. ``git worktree add /tmp/old <commit>``) and
this one.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))

#: (module, function names) wrapped by the profile, by phase; names a module lacks are skipped.
SOLVE_FUNCS = {"pv_ambient.stages.diffusion.solve": ("assemble", "hierarchy", "node_flux", "power_balance",
                                                     "flux_and_power")}
KERNEL_MODULES = ("pv_ambient._kernels.diffusion_operator", "pv_ambient._kernels.diffusion_multigrid",
                  "pv_ambient._kernels.diffusion_cg", "pv_ambient._kernels.diffusion_system")
#: Kernels of the conjugate-gradient iteration itself (the rest of the V-cycle modules' kernels
#: are the preconditioner's).
CG_KERNELS = {"matvec_dot", "cg_step", "cg_direction", "dot_parts", "jacobi", "residual", "scaled_start"}
#: Kernels counted in the phase of the function that calls them, not on their own.
INNER = {"assemble_faces", "make_diag", "diagonal", "coarsen", "limiter_coefficients", "node_flux_power"}
#: Kernels with a phase of their own.
KERNEL_PHASE = {"medium_coefficients": "medium coefficients"}
#: Phase order of the table.
#: The phase function's mean cosine of speed.py's frames (the renderer's default, isotropic).
G = 0.0
PHASES = ["light sweep (τ)", "irradiance", "first-collision source", "medium coefficients", "assemble",
          "hierarchy", "V-cycle, finest level", "V-cycle, coarser levels", "CG vector kernels",
          "node flux + power balance", "other (solve's own NumPy, copies)", "solve total"]


def _timer(acc, name, fn, phase_of=None):
    @functools.wraps(fn)
    def wrapped(*a, **k):
        t = time.perf_counter()
        out = fn(*a, **k)
        acc[phase_of(a) if phase_of else name] += time.perf_counter() - t
        return out

    wrapped.__wrapped_timer__ = True
    return wrapped


def profile_child(n, repeats):
    """Phase → median seconds of one light's solve at n³ (this process's thread count)."""
    import importlib

    import numba

    import speed
    from pv_ambient.stages.diffusion import DiffusionMedium, direct_irradiance, solve_in_medium, source_in_medium

    fr = speed.Frames(n, (64, 64))
    st = fr.renderer.stages
    lgrid = st.light_grid(None)
    t = time.perf_counter()
    tau = st.optical_depth(fr.light, lgrid)
    t_tau = time.perf_counter() - t
    medium = DiffusionMedium.from_arrays(st.optics.sigma_grid(), st.optics.albedo_grid())
    fine = medium.sigma_t.size
    acc = defaultdict(float)

    def level_phase(name):
        def phase_of(a):
            size = next((x.size for x in a if isinstance(x, np.ndarray) and x.ndim == 3), 0)
            if name in KERNEL_PHASE:
                return KERNEL_PHASE[name]
            if name in CG_KERNELS:
                return "CG vector kernels"
            return "V-cycle, finest level" if size >= fine else "V-cycle, coarser levels"
        return phase_of

    for mod_name in KERNEL_MODULES:
        mod = importlib.import_module(mod_name)
        for name in dir(mod):
            obj = getattr(mod, name)
            # drivers only (parallel dispatchers): a scalar function is a global of the kernels that call it
            if (name in INNER or not hasattr(obj, "py_func") or getattr(obj, "__module__", "") != mod_name
                    or not getattr(obj, "targetoptions", {}).get("parallel")):
                continue
            if not getattr(mod.__dict__.get(name), "__wrapped_timer__", False):
                setattr(mod, name, _timer(acc, name, obj, level_phase(name)))
    labels = {"assemble": "assemble", "hierarchy": "hierarchy", "node_flux": "node flux + power balance",
              "power_balance": "node flux + power balance", "flux_and_power": "node flux + power balance"}
    for mod_name, names in SOLVE_FUNCS.items():
        mod = importlib.import_module(mod_name)
        for name in names:
            if hasattr(mod, name):
                setattr(mod, name, _timer(acc, labels[name], getattr(mod, name)))
    runs = []
    for rep in range(repeats + 1):
        acc.clear()
        t = time.perf_counter()
        E, om = direct_irradiance(fr.light, st.geometry, tau, lgrid)
        t_e = time.perf_counter() - t
        t = time.perf_counter()
        try:  # as the stage calls it (Q1 None where g = 0), where the code has that option
            q0, q1 = source_in_medium(medium, G, E, om, first_moment=False)
        except TypeError:
            q0, q1 = source_in_medium(medium, G, E, om)
        t_q = time.perf_counter() - t
        del E, om
        t = time.perf_counter()
        sol = solve_in_medium(medium, G, st.geometry.spacing, q0, q1)
        total = time.perf_counter() - t
        d = dict(acc)
        d["light sweep (τ)"] = t_tau
        d["irradiance"] = t_e
        d["first-collision source"] = t_q
        d["solve total"] = total
        d["other (solve's own NumPy, copies)"] = total - sum(v for k, v in acc.items())
        d["iterations"] = sol.iterations
        d["solves"] = sol.solves
        d["residual"] = sol.residual
        if rep:
            runs.append(d)
        del q0, q1, sol
    out = {k: float(np.median([r.get(k, 0.0) for r in runs])) for k in set().union(*runs)}
    out["threads"] = numba.get_num_threads()
    return out


def frames_child(n, size, repeats):
    """First diffusion frame and diffusion relight: frame and stage seconds (medians)."""
    import numba

    import scenes
    import speed

    fr = speed.Frames(n, (size, size))
    first = fr.frame_fn("first", "diffusion")
    relight = fr.frame_fn("relight", "diffusion")

    def timed(fn, k):
        t = time.perf_counter()
        fn(k)
        return time.perf_counter() - t

    first(0)  # compiles
    t_first = [timed(first, k) for k in range(1, repeats + 1)]
    r = fr.renderer
    fr.render(r, "diffusion", fr.cam)  # the shared renderer's caches warm
    cam = [timed(lambda k: fr.render(r, "diffusion", scenes.orbit(fr.cam, k)), k) for k in range(1, repeats + 1)]
    relight(0)
    iters = []
    t_relight = []
    for k in range(1, repeats + 1):
        t_relight.append(timed(relight, k))
    for key, (part, info) in r.stages.cache.items("diffusion"):
        iters.append(info["iterations"])
    camera = float(np.median(cam))
    out = dict(threads=numba.get_num_threads(), camera=camera, first=float(np.median(t_first)),
               relight=float(np.median(t_relight)), relight_iterations=iters[-repeats:],
               first_iterations=iters[0])
    out["first stage"] = out["first"] - camera
    out["relight stage"] = out["relight"] - camera
    return out


def tols_child(n, size, tols, repeats):
    """Per solver tolerance (the quality preset's ``diffusion_tol``, set on the balanced preset): CG
    iterations, the diffusion stage's seconds (median of ``repeats`` new renderers, the tolerances
    interleaved) and the 4×4-block error of the frame against the one solved to the first tolerance
    (the point light's window masked, as the trade's errors are)."""
    import scenes
    import speed

    import pv_ambient as pa
    from pv_ambient import metrics
    from pv_ambient.rendering.presets import QUALITY_PRESETS

    fr = speed.Frames(n, (size, size))
    fr.render(fr.renderer, "SS", fr.cam)  # light volumes, compiled kernels
    mask = metrics.light_mask((size, size), fr.cam, (size, size), [fr.light])
    out, ref, secs = {}, None, {tol: [] for tol in tols}
    for _ in range(repeats):
        for tol in tols:
            QUALITY_PRESETS["balanced"]["diffusion_tol"] = tol
            r = pa.Renderer(fr.grid, backend="cpu", transfer_function=speed.transfer_function(), lights=[fr.light])
            r.cache.share(fr.renderer.cache, kinds=("majorant", "light_grid", "sigma_l", "tau", "reaches", "scatters",
                                                    "scattering_nodes"))
            res = fr.render(r, "diffusion", fr.cam)
            img = np.asarray(res.radiance, np.float64)
            ref = img if ref is None else ref
            secs[tol].append(sum(v for k, v in r.timings.items() if k.startswith("diffusion")))
            out[tol] = dict(tol=tol, iterations=res.metadata["diffusion_solver"]["iterations"],
                            block=metrics.block_relative_rmse(img, ref, mask),
                            bias=metrics.relative_bias(img, ref, mask))
    del scenes
    return [dict(out[tol], seconds=float(np.median(secs[tol]))) for tol in tols]


def tols_table(rows, tols):
    lines = [f"  {'tol':>8s} {'CG its':>7s} {'solve s':>8s} {'block err':>10s} {'bias':>9s}   (against tol {tols[0]:g})"]
    lines += [f"  {r['tol']:>8g} {r['iterations']:>7d} {r['seconds']:>8.2f} {r['block']:>10.5f} {r['bias']:>+9.5f}"
              for r in rows]
    return lines


def phi_child(n, path):
    """One light's solve as the stage runs it (``solve_for_light``); φ saved to ``path``."""
    import speed
    from pv_ambient.stages.diffusion import DiffusionMedium, solve_for_light

    fr = speed.Frames(n, (64, 64))
    st = fr.renderer.stages
    lgrid = st.light_grid(None)
    medium = DiffusionMedium.from_arrays(st.optics.sigma_grid(), st.optics.albedo_grid())
    sol = solve_for_light(fr.light, G, medium=medium, geometry=st.geometry, tau=st.optical_depth(fr.light, lgrid),
                          light_grid=lgrid)
    np.save(path, sol.phi)
    import pv_ambient

    return dict(iterations=sol.iterations, residual=sol.residual, package=str(Path(pv_ambient.__file__).parent))


def compare_phi(args):
    """Lines: the largest difference of φ between ``--compare`` (another checkout's pv_ambient)
    and this one, relative to the largest φ and node by node where φ > 10⁻³ of it."""
    import tempfile

    out = []
    with tempfile.TemporaryDirectory() as tmp:
        paths = {}
        for label, root in (("reference", args.compare), ("this", str(Path(__file__).parent.parent))):
            paths[label] = os.path.join(tmp, f"{label}.npy")
            info = run_child(args, 2, "phi", pythonpath=root, extra=["--phi-path", paths[label]])
            out.append(f"  {label} ({info['package']}): {info['iterations']} CG iterations, residual "
                       f"{info['residual']:.2e}")
        a, b = np.load(paths["reference"]), np.load(paths["this"])
    d = np.abs(b - a)
    top = np.abs(a).max(axis=(0, 1, 2))
    lit = a > 1e-3 * top
    out.append(f"  max |Δφ| / max φ per channel: {', '.join(f'{v:.2e}' for v in d.max(axis=(0, 1, 2)) / top)}; "
               f"max |Δφ|/φ where φ > 1e-3 max φ: {float((d[lit] / a[lit]).max()):.2e}")
    return out


def run_child(args, threads, what, pythonpath=None, extra=()):
    cmd = [sys.executable, __file__, "--n", str(args.n), "--size", str(args.size), "--repeats", str(args.repeats),
           f"--child-{what}", *extra]
    env = {**os.environ, "NUMBA_NUM_THREADS": str(threads)}
    if pythonpath:
        env["PYTHONPATH"] = pythonpath
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if proc.returncode:
        raise RuntimeError(f"child ({what}, {threads} threads) failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _header(sets, counts, first):
    cols = "".join(f" {f'{label} {t}t s':>{W}}" for label, _ in sets for t in counts)
    ups = "".join(f" {f'{label} 1→{t}':>{W}}" for label, _ in sets for t in counts[1:])
    return f"  {first:38s}{cols}{ups}"


#: Column width of the tables.
W = 12


def _row(name, sets, counts, key):
    vals = [[runs[t].get(key, 0.0) for t in counts] for _, runs in sets]
    row = f"  {name:38s}" + "".join(f" {v:>{W}.3f}" for vs in vals for v in vs)
    row += "".join((f" {vs[0] / v:>{W}.2f}" if v > 0 else f" {'':>{W}}") for vs in vals for v in vs[1:])
    return row


def profile_table(sets, counts):
    """``sets``: (label, {threads: phase seconds}) per checkout."""
    lines = [_header(sets, counts, "phase")]
    lines += [_row(ph, sets, counts, ph) for ph in PHASES]
    for label, runs in sets:
        r = runs[counts[0]]
        lines.append(f"  {label}: CG iterations (all channels) {int(r['iterations'])}, linear solves "
                     f"{int(r['solves'])}, final relative residual {r['residual']:.2e}")
    return lines


def frames_table(sets, counts):
    lines = [_header(sets, counts, "frame")]
    for key, label in (("first", "first frame, diffusion"), ("first stage", "  stage (frame − camera pass)"),
                       ("relight", "relight, diffusion"), ("relight stage", "  stage (frame − camera pass)"),
                       ("camera", "camera pass (camera move)")):
        lines.append(_row(label, sets, counts, key))
    for label, runs in sets:
        r = runs[counts[0]]
        lines.append(f"  {label}: CG iterations, first frame {r['first_iterations']}, relights "
                     f"{r['relight_iterations']}")
    return lines


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--frames", action="store_true", help="also the first-frame and relight stage times")
    ap.add_argument("--out", default=None, help="write the tables there too")
    ap.add_argument("--compare", help="another checkout's root: print the largest difference of φ against it")
    ap.add_argument("--skip-profile", action="store_true", help="no profile table")
    ap.add_argument("--child-profile", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--child-phi", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--phi-path", help=argparse.SUPPRESS)
    ap.add_argument("--child-frames", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--tols", help="comma-separated solver tolerances: the tolerance table (the first is the reference)")
    ap.add_argument("--child-tols", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child_tols:
        print(json.dumps(tols_child(args.n, args.size, [float(t) for t in args.tols.split(",")], args.repeats)))
        return
    if args.child_profile:
        print(json.dumps(profile_child(args.n, args.repeats)))
        return
    if args.child_phi:
        print(json.dumps(phi_child(args.n, args.phi_path)))
        return
    if args.child_frames:
        print(json.dumps(frames_child(args.n, args.size, args.repeats)))
        return
    import pv_ambient

    counts = sorted({int(t) for t in args.threads.split(",")})
    lines = ["$ python " + " ".join(sys.argv), "",
             f"pv_ambient from {Path(pv_ambient.__file__).parent}; supernova_centre {args.n}³ (speed.py's scene), "
             f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at the start; medians of "
             f"{args.repeats} after a compiling run", ""]
    here = str(Path(__file__).parent.parent)
    roots = ([("before", args.compare)] if args.compare else []) + [("after" if args.compare else "this", here)]
    if args.compare:
        lines += [f"before: {args.compare}; after: {here}", ""]
    if not args.skip_profile:
        sets = [(label, {t: run_child(args, t, "profile", pythonpath=root) for t in counts}) for label, root in roots]
        lines += ["one light's diffusion solve, by phase (s; 1→t: the speed-up):"] + profile_table(sets, counts)
        print("\n".join(lines), flush=True)
    if args.tols:
        tols = [float(t) for t in args.tols.split(",")]
        rows = run_child(args, counts[-1], "tols", extra=["--tols", args.tols])
        lines += ["", f"the solver's tolerance, diffusion at {args.size}², {counts[-1]} threads (one process, light "
                  "volumes shared, medians of --repeats):"] + tols_table(rows, tols)
        print("\n".join(lines[-len(rows) - 2:]), flush=True)
    if args.frames:
        sets = [(label, {t: run_child(args, t, "frames", pythonpath=root) for t in counts}) for label, root in roots]
        lines += ["", f"diffusion frames at {args.size}² (s):"] + frames_table(sets, counts)
    if args.compare:
        lines += ["", "φ of one light's solve (solve_for_light, 2 threads) against another checkout:"]
        lines += compare_phi(args)
    lines.append(f"load average at the end {os.getloadavg()[0]:.2f}")
    print("\n".join(lines))
    if args.out:
        Path(args.out).write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
