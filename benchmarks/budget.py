"""The front at small budgets (docs/trade.rst, "At a time budget"): ``model="auto"`` with a
``time_budget`` against the project's own path tracer + OIDN given the same wall time, and against
the noise-free presets' first frames, on the nine referenced scenes.

For each scene (benchmarks/scenes.py, 64³ data points, 64×64 pixels: the cached references of
benchmarks/references.py) and each budget, every row is a first frame of a fresh
:class:`pv_ambient.Renderer` in this process (Numba's kernels compiled and loaded by a warm-up;
the scene's stages cold), timed by wall clock:

``auto``
    ``model="auto", time_budget=B``: what it chose, its wall time and 4×4-block error;
``path_traced+OIDN``
    ``model="path_traced", denoise=True`` with the samples per pixel that fit in auto's wall time
    (found from a calibration frame: the path tracer's time per sample on the scene), when
    ``pyoidn`` is installed — the peer the budget is judged against;
``path_traced``
    the same samples, not denoised;
``auto balanced``, ``auto accurate``
    the noise-free presets' first frames (no budget; the second of two fresh renderers, the first
    compiling what the warm-up's tiny scene did not need): the error a budget of at least their
    wall time could buy without noise.

Block errors are :func:`pv_ambient.metrics.block_relative_rmse` against the reference (7×7 windows
around point lights masked), averaged over ``--seeds`` seeds for the Monte Carlo rows, with
their spread. A row ``auto ≤ peer`` says whether auto's error is at or below the denoised path
tracer's within the two seeds' spread.

Usage::

    python benchmarks/budget.py [--budgets 0.3 1 3] [--seeds 2] [--scenes NAME ...] [--out DIR]

Output: ``benchmarks/results/budget.txt`` (first line: the command).
"""

from __future__ import annotations

import argparse
import os
import time
import warnings

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np  # noqa: E402

import pv_ambient as pa  # noqa: E402
from pv_ambient import metrics  # noqa: E402
from pv_ambient.stages.denoise import available  # noqa: E402

import references as refs  # noqa: E402  (benchmarks/: the script's directory is on sys.path)
import scenes as scene_registry  # noqa: E402
from references import N, SIZE  # noqa: E402

BUDGETS = (0.3, 1.0, 3.0)
CALIBRATION_SPP = 8


def first_frame(scene, shared, keep=True, **kw):
    """(result, wall seconds) of a fresh renderer's first frame of ``scene`` (its stages cold; the
    preintegrated tables shared through ``shared``, the disk cache's role; what it made is kept
    there only with ``keep``: a kept diffusion solution would warm-start the next frame)."""
    grid, tf, lights, g, cam = scene
    r = pa.Renderer(grid, transfer_function=tf, lights=lights)
    r.cache.share(shared.cache)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = time.perf_counter()
        res = r.render(camera=cam, window_size=SIZE, phase=g, progress_bar=False, **kw)
        wall = time.perf_counter() - t
    if keep:
        shared.cache.share(r.cache)
    return res, wall


def seconds_per_sample(scene, shared) -> float:
    """The path tracer's wall seconds per sample per pixel on ``scene`` (a fresh renderer's frame of
    ``CALIBRATION_SPP`` samples, less one of a single sample: the fixed cost apart)."""
    _, one = first_frame(scene, shared, model="path_traced", samples_per_pixel=1, seed=7)
    _, many = first_frame(scene, shared, model="path_traced", samples_per_pixel=CALIBRATION_SPP, seed=7)
    return max(many - one, 1e-6) / (CALIBRATION_SPP - 1)


def chosen(meta) -> str:
    """What ``auto`` rendered, from its metadata."""
    model = meta["model"]
    if model == "path_traced":
        return f"path_traced {meta['spp']} spp" + ("+OIDN" if meta.get("denoised") else "")
    if model == "diffusion":
        k, fl = meta.get("sweep_orders", 0), meta.get("flux_limited", False)
        return "diffusion" + (f" {k} sweeps" if k else "") + ("+FL" if fl else "")
    return model


def warm_up(scene):
    """Every kernel the rows run, compiled and loaded on a tiny copy of ``scene``."""
    grid, tf, lights, g, cam = scene
    r = pa.Renderer(grid, transfer_function=tf, lights=lights)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for kw in (dict(model="auto", time_budget=0.05), dict(model="auto"), dict(model="auto", quality="accurate"),
                   dict(model="path_traced", samples_per_pixel=2, denoise=available())):
            r.render(camera=cam, window_size=(8, 8), phase=g, progress_bar=False, **kw)


def score(res, ref, mask) -> float:
    img = res.radiance
    return metrics.block_relative_rmse(img, ref, mask) if np.all(np.isfinite(img)) else float("nan")


def run_scene(name, budgets, seeds, log):
    """Log scene ``name``'s rows; return [(budget, auto mean, peer mean or None, spread)]."""
    scene = scene_registry.scene(name, N)
    grid, tf, lights, g, cam = scene
    shared = pa.Renderer(grid, transfer_function=tf, lights=lights)
    mask = metrics.light_mask(SIZE[::-1], cam, SIZE, lights)
    ref, info, how = refs.reference(name, shared, lights, g, cam, mask, False)
    warm_up(scene_registry.scene(name, 8))
    per_sample = seconds_per_sample(scene, shared)
    log(f"\n{name} [{scene_registry.group_of(name)}]: reference {how}, {info['spp']} spp, block noise "
        f"{info['block_noise']:.4f}; path tracer {per_sample * 1e3:.1f} ms per sample per pixel")
    log(f"  {'row':22s} {'budget s':>8} {'wall s':>7} {'block':>7} {'spread':>7}  renders")
    for label, kw in (("auto balanced", {}), ("auto accurate", {"quality": "accurate"})):
        first_frame(scene, shared, keep=False, model="auto", **kw)  # compiles what the tiny warm-up did not need
        res, wall = first_frame(scene, shared, keep=False, model="auto", **kw)
        log(f"  {label:22s} {'—':>8} {wall:>7.2f} {score(res, ref, mask):>7.3f} {'':>7}  {chosen(res.metadata)}")
    out = []
    for budget in budgets:
        rows = {"auto": [], "path_traced": [], "path_traced+OIDN": []}
        walls, what = {k: [] for k in rows}, ""
        for seed in range(1, seeds + 1):
            res, wall = first_frame(scene, shared, model="auto", time_budget=budget, seed=seed)
            rows["auto"].append(score(res, ref, mask))
            walls["auto"].append(wall)
            what = chosen(res.metadata)
            spp = max(1, int(res.metadata.get("spp", 0)) or int(wall / per_sample))
            for label, denoise in (("path_traced", False), ("path_traced+OIDN", True)):
                if denoise and not available():
                    continue
                res, wall = first_frame(scene, shared, model="path_traced", samples_per_pixel=spp, seed=100 + seed,
                                        denoise=denoise)
                rows[label].append(score(res, ref, mask))
                walls[label].append(wall)
        for label, errs in rows.items():
            if errs:
                log(f"  {label:22s} {budget:>8.1f} {np.mean(walls[label]):>7.2f} {np.mean(errs):>7.3f}"
                    f" {np.ptp(errs):>7.3f}  " + (what if label == "auto" else f"{spp} spp, seeds 101…"))
        peer = rows["path_traced+OIDN"]
        out.append((budget, float(np.mean(rows["auto"])), float(np.mean(peer)) if peer else None,
                    float(max(np.ptp(rows["auto"]), np.ptp(peer) if peer else 0.0))))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budgets", nargs="+", type=float, default=list(BUDGETS), help="seconds (default: %(default)s)")
    ap.add_argument("--seeds", type=int, default=2, help="seeds per Monte Carlo row (default: %(default)s)")
    refs.add_scene_options(ap, scene_registry.REFERENCED, "budget")
    args = ap.parse_args(argv)
    log = refs.results_log("budget", args.out, argv)
    log(f"pv_ambient at {refs.commit()}; {SIZE[0]}×{SIZE[1]} pixels, {N}³ data points; pyoidn "
        f"{'installed' if available() else 'NOT installed (no path_traced+OIDN peer; auto does not denoise)'}; "
        f"wall time in this process, first frames of fresh renderers, kernels warm")
    summary = {name: run_scene(name, args.budgets, args.seeds, log) for name in args.scenes}
    log("\nauto against path_traced+OIDN at the same wall time (block error; ≤: at or below within the seeds' spread):")
    log(f"  {'scene':16s} " + " ".join(f"{b:>16.1f}s" for b in args.budgets))
    for name, rows in summary.items():
        cells = []
        for _budget, a, p, spread in rows:
            cells.append(f"{a:.3f}/—" if p is None else f"{a:.3f}/{p:.3f} {'≤' if a <= p + spread else '>'}")
        log(f"  {name:16s} " + " ".join(f"{c:>17s}" for c in cells))


if __name__ == "__main__":
    main()
