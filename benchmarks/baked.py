"""The error of baking the lights' in-scattered light on the light grid (issue 16): every model
that bakes it, with and without baking, against the converged path-traced reference of the trade
benchmark's scenes (``benchmarks/trade.py``; same cameras, lights, masks and metrics).

For an isotropic phase function the light scattered toward the camera does not depend on the view:
single scattering's ``Σ_j E_j T_j p`` and ambient scattering's ``Σ_j E_j Φ_j D(rσ̄, ā)`` are baked at
the light-grid nodes once per light change (``bake_lights`` of the quality presets ``preview`` and
``balanced``) and the ray cast interpolates them, instead of evaluating every light at every sample.
That interpolates the product ``E·T`` (and ``E·Φ·D``) where the exact path interpolates ``τ`` and
evaluates ``E = I/d²`` and ``D`` at the sample. Printed per scene and configuration: the 4×4-block
relative RMSE against the reference baked and exact, its change (the issue allows ≤ 0.01), the
relative bias of the mean both ways, and the block RMSE between the baked and exact images. The cloud
(g = 0.6) is not baked and is skipped; the CT phantom (two coloured point lights, g = 0.3 in the
trade) is rendered with g = 0 here.

Usage (from the repository root)::

    python benchmarks/baked.py [--n 64] [--size 96] [--ref-error 0.01]
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
sys.path.insert(0, str(Path(__file__).resolve().parent))

import pv_ambient as pa  # noqa: E402
from pv_ambient import metrics  # noqa: E402
from pv_ambient.rendering import presets  # noqa: E402

import references as refs  # noqa: E402  (benchmarks/: on sys.path above)
import scenes  # noqa: E402
from trade import REF_SEED, reference_options  # noqa: E402

CONFIGS = [
    ("single_scattering", "preview", {"quality": "preview"}),
    ("single_scattering", "balanced", {"quality": "balanced"}),
    ("ambient_scattering", "preview", {"quality": "preview"}),
    ("ambient_scattering", "balanced (BL r=8)", {"quality": "balanced"}),
    ("ambient_scattering", "tube r=8", {"quality": "balanced", "propagation": "tube"}),
    ("diffusion", "plain", {"quality": "balanced"}),
    ("diffusion", "flux-limited", {"quality": "balanced", "flux_limited": True}),
]


def render(r, cam, size, g, model, opts, bake):
    """One render with the preset's ``bake_lights`` forced to ``bake``."""
    q = opts.get("quality", presets.DEFAULT_QUALITY)
    saved = presets.QUALITY_PRESETS[q]["bake_lights"]
    presets.QUALITY_PRESETS[q]["bake_lights"] = bake
    try:
        res = r.render(camera=cam, window_size=size, model=model, phase=g, **opts)
    finally:
        presets.QUALITY_PRESETS[q]["bake_lights"] = saved
    assert res.metadata["baked_lights"] == bake, res.metadata["baked_lights"]
    return res.radiance


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    reference_options(ap)
    args = ap.parse_args(argv)
    size = (args.size, args.size)
    print(f"# python benchmarks/baked.py --n {args.n} --size {args.size} --ref-error {args.ref_error}")
    worst = 0.0
    for name, grid, tf, lights, g, cam in scenes.of_group("trade", args.n):
        if name == "ct_phantom":  # two coloured point lights: rendered isotropic here, to be baked
            name, g = "ct_phantom with g = 0 (the trade uses 0.3)", 0.0
        if g != 0.0:
            print(f"\n{name}: phase g = {g} (anisotropic): not baked, skipped")
            continue
        r = pa.Renderer(grid, transfer_function=tf, lights=lights)
        ref, mask, noise, t = refs.trace(r, cam, size, g, lights, seed=REF_SEED, spp=args.ref_max_spp,
                                         target_error=args.ref_error)
        print(f"\n{name}: reference {ref.metadata['spp']} spp in {t:.1f} s, block noise {noise:.4f}")
        print(f"  {'model':20s} {'preset':18s} {'block exact':>11} {'block baked':>11} {'change':>7}"
              f" {'bias exact':>10} {'bias baked':>10} {'baked vs exact':>14}")
        for model, preset, opts in CONFIGS:
            exact = render(r, cam, size, g, model, opts, False)
            baked = render(r, cam, size, g, model, opts, True)
            be = metrics.block_relative_rmse(exact, ref.radiance, mask)
            bb = metrics.block_relative_rmse(baked, ref.radiance, mask)
            worst = max(worst, bb - be)
            print(f"  {model:20s} {preset:18s} {be:>11.4f} {bb:>11.4f} {bb - be:>+7.4f}"
                  f" {metrics.relative_bias(exact, ref.radiance, mask):>+10.4f}"
                  f" {metrics.relative_bias(baked, ref.radiance, mask):>+10.4f}"
                  f" {metrics.block_relative_rmse(baked, exact, mask):>14.4f}", flush=True)
    print(f"\nlargest increase of the block error by baking: {worst:+.4f} (allowed: +0.01)")


if __name__ == "__main__":
    main()
