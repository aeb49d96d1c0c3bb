"""The ``progressive`` model's control march (docs/progressive.rst): the quadrature error its picture
converges to, against the ray step the control's picture is marched at.

The progressive picture tends to :math:`L + N' - N_c` — the transfer equation's answer plus the
quadrature error of the control's march :math:`N'` (``CONTROL_STEP_FRACTION`` of the ray step).
For each of the six scenes of benchmarks/progressive.py (64×64 pixels, 64³ data points) and the
default base (diffusion with ``AUTO_SWEEP_ORDERS`` transport sweeps and flux limiting), the base
model is marched at 1, ½, ¼ of the default step and at 1/16 of it, the stand-in for the exact
integral :math:`N_c`; printed per fraction:

* ``quad``: the 4×4-block relative RMSE of the march against the 1/16 march, relative to the
  reference's mean, scored as benchmarks/progressive.py scores pictures (a 7×7 window at each
  light's projection masked): the block error the converged picture carries besides the
  reference's own noise;
* ``mean``: the relative shift of the image mean it carries;
* ``cost``: the march's time (median of 5, caches warm) in marches at the default step.

Usage: ``python benchmarks/control_step.py [--scenes NAME ...] [--out DIR]`` (writes
``control_step.txt`` to ``benchmarks/results`` unless ``--out`` names another directory).
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

import pv_ambient as pa
import references as refs  # (benchmarks/: the script's directory is on sys.path)
import scenes as scene_registry
from pv_ambient import metrics
from pv_ambient.rendering.presets import AUTO_SWEEP_ORDERS, CONTROL_STEP_FRACTION
from timing import median_time

SCENES = scene_registry.GROUPS["trade"] + scene_registry.GROUPS["floor"]
FRACTIONS = (1.0, 0.5, 0.25)
EXACT = 1.0 / 16.0
BASE = {"flux_limited": True, "sweep_orders": AUTO_SWEEP_ORDERS}


def march(r, cam, g, fraction, repeats=5):
    """The base model's picture at ``fraction`` of the default step, and the median time of ``repeats``
    (benchmarks/timing.py's rule)."""
    kw = dict(camera=cam, window_size=refs.SIZE, model="diffusion", phase=g, progress_bar=False,
              step=fraction * r.default_step(), **BASE)
    img = r.render(**kw).radiance.astype(np.float64)
    return img, median_time(lambda k: r.render(**kw), repeats)


def run_scene(name, log):
    grid, tf, lights, g, cam = scene_registry.scene(name, refs.N)
    r = pa.Renderer(grid, transfer_function=tf, lights=lights)
    mask = metrics.light_mask(refs.SIZE[::-1], cam, refs.SIZE, lights)
    ref, info, how = refs.reference(name, r, lights, g, cam, mask, False)
    ref = ref.astype(np.float64)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        exact, _ = march(r, cam, g, EXACT, repeats=1)
        rows = {f: march(r, cam, g, f) for f in FRACTIONS}
    m = mask[..., None] & np.ones(3, bool)
    ref_mean = float(np.mean(ref[m]))
    t1 = rows[1.0][1]
    log(f"\n{name}: reference ({how}), block noise {info['block_noise']:.4f}")
    log(f"    {'step':>6s} {'quad':>8s} {'mean':>8s} {'cost':>6s}")
    for f, (img, t) in rows.items():
        # the quadrature error's block RMSE, relative to the reference's mean (not to the march's)
        quad = metrics.block_relative_rmse(ref + img - exact, ref, mask)
        shift = float(np.mean((img - exact)[m])) / ref_mean
        tag = "  (default)" if f == CONTROL_STEP_FRACTION else ""
        log(f"    {f:>6g} {quad:8.4f} {shift:+8.2%} {t / t1:6.2f}{tag}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    refs.add_scene_options(ap, SCENES, "control_step")
    args = ap.parse_args(argv)
    log = refs.results_log("control_step", args.out, argv)
    log(f"pv_ambient at {refs.commit()}; {refs.SIZE[0]}×{refs.SIZE[1]} pixels, {refs.N}³ data points; base: diffusion, "
        f"{AUTO_SWEEP_ORDERS} sweeps + FL; the exact integral stood in by the march at 1/16 of the step; "
        f"CONTROL_STEP_FRACTION = {CONTROL_STEP_FRACTION}")
    for name in args.scenes:
        run_scene(name, log)


if __name__ == "__main__":
    main()
