"""A point light inside a dense medium (docs/path_tracer.rst, "Point lights inside the medium"): the
path tracer with and without equiangular distance sampling, against a converged reference.

Scene: ``light_in_core`` of benchmarks/scenes.py — the synthetic supernova (n³) with the trade
benchmark's transfer function (albedo 0.9, isotropic phase), its point light (intensity 3) at the
centre of the dense core (radius ≈ 0.1 at the origin), the trade's camera. Next-event estimation from vertices next to a point light has unbounded
weights ``I/d²``: free-flight sampling alone leaves isolated pixels many times their value;
equiangular sampling (combined with it by MIS) cancels the ``1/d²``.

Printed, per estimator at ``--spp`` samples per pixel over ``--seeds`` seeds (timed, medians):

* the largest pixel / reference ratio outside a 13×13 window around the light's projection, over
  the pixels whose reference is ≥ 10 % of the image mean (mean over channels): fireflies; and how
  many seeds have a pixel above 5× its reference;
* the 4×4-block relative RMSE against the reference (the same window masked), its median and
  largest value over the seeds and their ratio (how much one unlucky seed costs);
* for free flight alone, the same at equal time: the sample count that takes as long as the
  equiangular frame.

The reference is the equiangular estimator at ``--ref-spp`` (≥ 16384; its estimator is checked
against 1-D quadrature of the single-scattering integral with the light inside a homogeneous
medium in tests/stages/test_reference.py); its 4×4-block noise is printed and must stay well below the
errors measured. ``--ref-cache FILE`` keeps it between runs.

Usage: ``python benchmarks/light_in_core.py [--n 64] [--size 96] [--spp 64] [--seeds 8] [--ref-spp 16384]``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import pv_ambient as pa  # noqa: E402
from pv_ambient import metrics  # noqa: E402

import references as refs  # noqa: E402  (benchmarks/: the script's directory is on sys.path)
import scenes  # noqa: E402

WINDOW_HALF = 6  # 13×13 pixels around the light's projection


def scene(n):
    """(renderer, camera, lights) of the registry's ``light_in_core`` scene."""
    grid, tf, lights, _, cam = scenes.scene("light_in_core", n)
    return pa.Renderer(grid, transfer_function=tf, lights=lights), cam, lights


def reference(r, cam, size, spp, cache):
    key = dict(spp=spp, size=size[0])
    if cache and os.path.exists(cache):
        d = np.load(cache)
        if all(int(d[k]) == v for k, v in key.items()):
            return d["radiance"], d["std_error"], float(d["time"])
    t = time.perf_counter()
    ref = r.path_trace(cam, size, samples_per_pixel=spp, seed=987654, batch=256, progress_bar=True)
    t = time.perf_counter() - t
    if cache:
        np.savez(cache, radiance=ref.radiance, std_error=ref.std_error, time=t, **key)
    return ref.radiance, ref.std_error, t


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--size", type=int, default=96)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--ref-spp", type=int, default=16384)
    ap.add_argument("--ref-cache", default=None, help="an .npz to keep the reference in between runs")
    args = ap.parse_args(argv)
    size = (args.size, args.size)
    r, cam, lights = scene(args.n)
    r.path_trace(cam, (8, 8), samples_per_pixel=1)  # compile
    r.path_trace(cam, (8, 8), samples_per_pixel=1, equiangular=False)
    ref, ref_se, t_ref = reference(r, cam, size, args.ref_spp, args.ref_cache)
    mask = metrics.light_mask(size[::-1], cam, size, lights, half=WINDOW_HALF)
    lum = ref.mean(axis=2)
    bright = mask & (lum >= 0.1 * lum[mask].mean())
    noise = refs.block_noise(ref, ref_se, mask)
    print(f"supernova {args.n}³, {size[0]}x{size[1]}, point light (intensity 3) at the centre of the dense core,"
          f" albedo 0.9, isotropic; {pa.__version__}")
    print(f"reference: equiangular, {args.ref_spp} spp in {t_ref:.0f} s; 4x4-block noise {noise:.4f};"
          f" {WINDOW_HALF * 2 + 1}x{WINDOW_HALF * 2 + 1} window around the light masked;"
          f" {bright.sum()} pixels ≥ 10 % of the image mean")

    def runs(spp, eq):
        out = []
        for s in range(args.seeds):
            t = time.perf_counter()
            img = r.path_trace(cam, size, samples_per_pixel=spp, seed=s + 1, batch=spp, equiangular=eq).radiance
            t = time.perf_counter() - t
            ratio = float(np.max(img.mean(axis=2)[bright] / lum[bright]))
            out.append((t, metrics.block_relative_rmse(img, ref, mask), ratio, metrics.relative_bias(img, ref, mask)))
        return np.array(out)

    rows = [("equiangular + free flight (MIS)", args.spp, runs(args.spp, True)),
            ("free flight alone", args.spp, runs(args.spp, False))]
    t_eq, t_ff = np.median(rows[0][2][:, 0]), np.median(rows[1][2][:, 0])
    spp_same = max(1, int(round(args.spp * t_eq / t_ff)))
    rows.append(("free flight alone, equal time", spp_same, runs(spp_same, False)))
    print(f"\n{args.seeds} seeds each; block = 4x4-block relative RMSE; ratio = largest pixel / reference")
    print(f"  {'estimator':32s} {'spp':>5} {'time s':>7} {'ratio max':>9} {'block med':>9} {'block max':>9}"
          f" {'max/med':>7} {'mean err med':>12}")
    for name, spp, a in rows:
        med = np.median(a[:, 1])
        print(f"  {name:32s} {spp:>5} {np.median(a[:, 0]):>7.3f} {a[:, 2].max():>9.1f} {med:>9.3f}"
              f" {a[:, 1].max():>9.3f} {a[:, 1].max() / med:>7.2f} {np.median(a[:, 3]):>+12.3f}")
    print(f"  seeds with a pixel above 5× its reference: "
          + ", ".join(f"{name} {int(np.sum(a[:, 2] > 5))} of {len(a)}" for name, _, a in rows[:2]))
    eq, same = rows[0][2], rows[2][2]
    gain = np.median(same[:, 1]) / np.median(eq[:, 1])
    print("\ntargets (issue 19, acceptance 1):")
    print(f"  largest pixel / reference ratio over the seeds ≤ 5:        {eq[:, 2].max():.2f}"
          f"  {'met' if eq[:, 2].max() <= 5 else 'NOT met'}")
    print(f"  block error, largest / median over the seeds ≤ 1.5:         {eq[:, 1].max() / np.median(eq[:, 1]):.2f}"
          f"  {'met' if eq[:, 1].max() <= 1.5 * np.median(eq[:, 1]) else 'NOT met'}")
    print(f"  block error at equal time ≥ 3× lower than free flight alone: {gain:.2f}×"
          f"  {'met' if gain >= 3 else 'NOT met'}")


if __name__ == "__main__":
    main()
