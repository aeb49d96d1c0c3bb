"""The ``progressive`` model's thresholded picture at few samples against its base (docs/progressive.rst,
"The picture shown"): the measurement behind ``REFINE_MIN_SAMPLES``.

For each scene of ``benchmarks/noise_free.py`` (64×64 pixels, 64³ data points, its cached 4096-spp
references) and each sample count, ``--seeds`` independent residual renders (``unbiased=True``,
seeds 5000 + 100·s) are thresholded as the model does *without* a minimum
(:func:`pv_ambient.stages.refine.threshold_correction` with the samples' own variances) and the
picture's 4×4-block relative RMSE (light windows masked) is compared with the base's (0 samples):
how many seeds made it worse (by more than 10⁻⁵), how many better, the largest loss and gain, and
the unbiased picture's mean error for scale.

Usage: ``python benchmarks/refine_min.py [--scenes NAME ...] [--seeds 4] [--out PATH]``
(output ``benchmarks/results/refine_min.txt``, first line the command).
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

import pv_ambient as pa
import references as refs  # (benchmarks/: the script's directory is on sys.path)
import scenes as scene_registry
from pv_ambient import metrics
from pv_ambient.stages.refine import REFINE_MIN_SAMPLES
from pv_ambient.stages.refine import threshold_correction

SPPS = (2, 4, 8, 16, 32, 64)
TOL = 1e-5


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenes", nargs="+", default=list(scene_registry.OLD + scene_registry.NEW))
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "refine_min.txt"))
    a = ap.parse_args(argv)
    log = refs.Log(Path(a.out), "python benchmarks/refine_min.py"
                 + "".join(f" {x}" for x in (argv if argv is not None else sys.argv[1:])))
    log(f"pv_ambient at {refs.commit()}; 64×64 pixels, 64³ data points; the thresholded picture without a minimum "
        f"(the model's REFINE_MIN_SAMPLES = {REFINE_MIN_SAMPLES}) against its base, {a.seeds} seeds per count")
    size = (64, 64)
    warnings.simplefilter("ignore")
    for name in a.scenes:
        grid, tf, lights, g, cam = scene_registry.scene(name, 64)
        r = pa.Renderer(grid, transfer_function=tf, lights=lights)
        mask = metrics.light_mask(size[::-1], cam, size, lights)
        ref, _, _ = refs.reference(name, r, lights, g, cam, mask, False, size)
        kw = dict(camera=cam, window_size=size, model="progressive", phase=g, progress_bar=False)
        base = r.render(samples_per_pixel=0, **kw).radiance.astype(np.float64)
        e0 = metrics.block_relative_rmse(base, ref, mask)
        log(f"\n{name} [{scene_registry.group_of(name)}]: base block error {e0:.4f}")
        log(f"  {'spp':>4}  {'worse':>5}  {'better':>6}  {'largest loss':>12}  {'largest gain':>12}  {'mean':>7}  {'unbiased':>8}")
        for spp in SPPS:
            errs, eps = [], []
            for s in range(a.seeds):
                u = r.render(samples_per_pixel=spp, seed=5000 + 100 * s, unbiased=True, **kw)
                est = u.radiance.astype(np.float64)
                corr, _ = threshold_correction(est - base, u.std_error.astype(np.float64) ** 2, samples=spp)
                errs.append(metrics.block_relative_rmse(base + corr, ref, mask))
                eps.append(metrics.block_relative_rmse(est, ref, mask))
            d = np.array(errs) - e0
            log(f"  {spp:4d}  {int(np.sum(d > TOL)):5d}  {int(np.sum(d < -TOL)):6d}  {max(d.max(), 0.0):+12.4f}  "
                f"{min(d.min(), 0.0):+12.4f}  {np.mean(errs):7.4f}  {np.mean(eps):8.3f}")
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
