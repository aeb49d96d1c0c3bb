"""Drag frames with and without jittered ray starts: the error of every noise-free model's
interactive drag frame (``add_ambient_volume(..., interactive=True)`` while the camera moves)
against the path-traced reference, on the nine scenes of benchmarks/noise_free.py.

A drag frame (``add_ambient_volume``'s interactive mode while the camera moves) is rendered at half
the window per axis and, while frames are slower than the window asks for, at 2, 4, … times the
resting ray step; it is shown on the full-size plane, upsampled linearly by the texture. Marched
from the same place on every ray, a long step samples thin layers (a skull, a shell) at a fixed
phase: the picture's mean shifts by a few per cent and wood-grain bands appear — a bias no model
term can undo. Jittered starts (``jitter=True``: each ray's first segment offset by its own random
fraction of the step) turn that bias into per-pixel noise that the 4×4 blocks and the texture's
interpolation average.

For each scene (64×64 pixels, 64³ data points; the cached ``path_traced`` references of
benchmarks/noise_free.py) and each noise-free model (single scattering, ambient scattering,
diffusion plain / flux-limited / with ``AUTO_SWEEP_ORDERS`` transport sweeps), the drag frame at
1, 2 and 4 resting steps, upsampled as benchmarks/progressive.py does: the 4×4-block relative RMSE
(:func:`pv_ambient.metrics.block_relative_rmse`, lights' projections masked) without jitter and
with it (mean over seeds 0–3, and their range). Prints the table, then per step the number of
(scene, model) cells where jitter lowers the error and the median change.

Writes ``benchmarks/results/drag_frame.txt`` (first line the command) unless ``--out`` names another
directory. Usage::

    python benchmarks/drag_frame.py [--scenes NAME ...] [--seeds 4] [--out DIR]
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

import pv_ambient as pa
import references as refs  # (benchmarks/: the script's directory is on sys.path)
import scenes as scene_registry
from progressive import NOISE_FREE, upsampled
from pv_ambient import metrics

SCENES = scene_registry.GROUPS["trade"] + scene_registry.GROUPS["floor"] + scene_registry.GROUPS["new"]
STEPS = (1, 2, 4)


def run_scene(name, seeds, log):
    grid, tf, lights, g, cam = scene_registry.scene(name, refs.N)
    r = pa.Renderer(grid, transfer_function=tf, lights=lights)
    size = refs.SIZE
    half = (size[0] // 2, size[1] // 2)
    mask = metrics.light_mask(size[::-1], cam, size, lights)
    ref, info, how = refs.reference(name, r, lights, g, cam, mask, False, size)
    step = r.default_step()
    rows = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # unconverged solves etc.: benchmarks/noise_free.py prints them
        for label, model, opts in NOISE_FREE:
            cells = []
            for k in STEPS:
                def err(jitter, seed):
                    res = r.render(camera=cam, window_size=half, model=model, phase=g, progress_bar=False,
                                   step=k * step, jitter=jitter, seed=seed, **opts)
                    return metrics.block_relative_rmse(upsampled(res.radiance, size, half), ref, mask)
                plain = err(False, 0)
                jit = [err(True, s) for s in range(seeds)]
                cells.append((plain, float(np.mean(jit)), min(jit), max(jit)))
            rows.append((label, cells))
    log(f"\n{name}: {scene_registry.DESCRIPTIONS[name]}  (reference {how}, block noise {info['block_noise']:.4f})")
    log(f"    {'model':24s} " + "  ".join(f"{'step ×' + str(k) + ': fixed → jittered (range)':>36s}" for k in STEPS))
    for label, cells in rows:
        log(f"    {label:24s} " + "  ".join(f"{p:8.3f} → {m:.3f} ({lo:.3f}–{hi:.3f})".rjust(36)
                                          for p, m, lo, hi in cells))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    refs.add_scene_options(ap, SCENES, "drag_frame")
    ap.add_argument("--seeds", type=int, default=4)
    args = ap.parse_args(argv)
    log = refs.results_log("drag_frame", args.out, argv)
    log(f"pv_ambient at {refs.commit()}; drag frames at {refs.SIZE[0] // 2}×{refs.SIZE[1] // 2} pixels shown at "
        f"{refs.SIZE[0]}×{refs.SIZE[1]}, {refs.N}³ data points; 4×4-block relative RMSE; jittered: mean over "
        f"{args.seeds} seeds")
    allrows = {name: run_scene(name, args.seeds, log) for name in args.scenes}
    log("\nsummary: (scene, model) cells where the jittered drag frame's mean error is lower than the fixed one's; "
        "median and largest relative change of the error")
    for i, k in enumerate(STEPS):
        for group, names in (("the six", [n for n in args.scenes if n not in scene_registry.GROUPS["new"]]),
                             ("the new three", [n for n in args.scenes if n in scene_registry.GROUPS["new"]])):
            ch = np.array([cells[i][1] / cells[i][0] - 1.0 for n in names for _, cells in allrows[n]])
            if ch.size == 0:
                continue
            log(f"  step ×{k}, {group}: lower in {int(np.sum(ch < 0))} of {ch.size}; median change "
                f"{np.median(ch):+.1%}, largest increase {ch.max():+.1%}, largest decrease {ch.min():+.1%}")


if __name__ == "__main__":
    main()
