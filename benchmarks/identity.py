"""Behaviour-preservation check for refactors: every model's image on the trade scenes, saved by one
version of the package and compared by another.

``--save FILE`` renders every model (and a camera move, a relight and the path tracer at a fixed
seed) on the three scenes of ``benchmarks/trade.py`` at a small size and writes the images (radiance
and alpha) to an ``.npz``; ``--compare FILE`` renders the same with the installed package and prints
the largest relative difference per image (``max |new − old| / max |old|``), then exits non-zero if
any exceeds ``--tol`` (default 0: bit-identical).

Usage::

    python benchmarks/identity.py --save benchmarks/results/identity_baseline.npz   # at the old version
    python benchmarks/identity.py --compare benchmarks/results/identity_baseline.npz
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from trade import scenes  # noqa: E402

import pv_ambient as pa  # noqa: E402

#: (label, model, options) rendered on every scene.
CASES = [
    ("ea", "emission_absorption", {}),
    ("ea_jitter", "emission_absorption", {"jitter": True, "seed": 3}),
    ("ao", "ambient_occlusion", {}),
    ("ss", "single_scattering", {}),
    ("ss_preview", "single_scattering", {"quality": "preview"}),
    ("as", "ambient_scattering", {"table_quality": "preview"}),
    ("as_tube", "ambient_scattering", {"propagation": "tube", "table_quality": "preview"}),
    ("diffusion", "diffusion", {}),
    ("diffusion_fl", "diffusion", {"flux_limited": True}),
    ("auto", "auto", {}),
    ("pt4", "path_traced", {"samples_per_pixel": 4, "seed": 7}),
]


def render_all(n=32, size=(48, 40)):
    out = {}
    for name, grid, tf, lights, g, cam in scenes(n):
        r = pa.Renderer(grid, transfer_function=tf, lights=lights)
        for label, model, opts in CASES:
            res = r.render(camera=cam, window_size=size, model=model, phase=g, **opts)
            out[f"{name}/{label}/radiance"] = res.radiance
            out[f"{name}/{label}/alpha"] = res.alpha
        # a camera move and a relight through the same renderer (warm caches)
        cam2 = pa.Camera(tuple(np.array(cam.position) * 1.1), cam.focal_point, cam.view_up, view_angle=cam.view_angle)
        res = r.render(camera=cam2, window_size=size, model="ambient_scattering", phase=g, table_quality="preview")
        out[f"{name}/as_move/radiance"] = res.radiance
        moved = [pa.PointLight(tuple(np.array(lights[0].position) * 0.9), intensity=lights[0].intensity)] + list(lights[1:])
        r.set_lights(moved)
        for label, model in (("ss_relight", "single_scattering"), ("diffusion_relight", "diffusion")):
            res = r.render(camera=cam, window_size=size, model=model, phase=g)
            out[f"{name}/{label}/radiance"] = res.radiance
        print(f"{name}: rendered", flush=True)
    return out


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--save", type=Path)
    g.add_argument("--compare", type=Path)
    p.add_argument("--tol", type=float, default=0.0, help="largest relative difference accepted (default 0)")
    a = p.parse_args(argv)
    imgs = render_all()
    if a.save:
        np.savez_compressed(a.save, **imgs)
        print(f"saved {len(imgs)} images to {a.save}")
        return 0
    ref = np.load(a.compare)
    worst = 0.0
    print(f"{'image':40s} {'max rel diff':>14s}")
    for key in sorted(ref.files):
        old = ref[key].astype(np.float64)
        new = imgs[key].astype(np.float64)
        scale = max(float(np.abs(old).max()), 1e-30)
        d = float(np.abs(new - old).max()) / scale
        worst = max(worst, d)
        print(f"{key:40s} {d:14.3e}")
    missing = sorted(set(imgs) - set(ref.files))
    if missing:
        print("not in the saved file:", missing)
    print(f"worst relative difference: {worst:.3e} (tolerance {a.tol:g}); {len(ref.files)} images")
    return 0 if worst <= a.tol else 1


if __name__ == "__main__":
    raise SystemExit(main())
