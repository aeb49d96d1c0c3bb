"""The diffusion model's transport sweeps (docs/diffusion.rst §5) against path tracing on six scenes:
the trade benchmark's three (supernova shell lit from its centre, forward-scattering cloud under a
point light, CT-like phantom with two coloured point lights; 96², 8192 spp or 1 % standard
error) and three it does not use (smoke plume, Marschner–Lobb lit from its centre, the cloud
under a directional light seen from the sun's side; 64², 4096 spp or 1 %). The scenes are those
of ``benchmarks/trade.py`` and the diffusion floor's (``benchmarks/scenes.py``).

For each scene and configuration: 4×4-block relative RMSE and relative bias of the image mean
against the reference (light windows masked, ``metrics.light_mask``), and the first-frame time
(light volumes shared, Numba compiled). Then, with ``--move-size``, the camera-move time (every
cache warm) of single scattering, plain diffusion and the sweeps at that image size, the median
of interleaved rounds.

Usage: ``python benchmarks/diffusion_sweeps.py [--scenes a,b] [--ref-cache DIR] [--move-size 256]``
(``--ref-cache`` keeps the references as ``DIR/<scene>_ref.npz``: they take most of the time).
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")

import numpy as np  # noqa: E402

import pv_ambient as pa  # noqa: E402
from pv_ambient import metrics  # noqa: E402

import references as refs  # noqa: E402  (benchmarks/: the script's directory is on sys.path)
import scenes as scene_registry  # noqa: E402

#: (label, options) of the configurations compared; the last is ``auto``'s with "accurate".
CONFIGS = [
    ("plain", {}),
    ("flux-limited", {"flux_limited": True}),
    ("sweeps 3 + FL", {"sweep_orders": 3, "flux_limited": True}),
    ("sweeps 4", {"sweep_orders": 4}),
    ("sweeps 4 + FL", {"sweep_orders": 4, "flux_limited": True}),
]


def scene(name, n=64):
    """(grid, transfer function, lights, phase g, camera, image size, reference seed, max spp): the
    scene of benchmarks/scenes.py with its benchmark's image size and reference settings (the
    trade's: 96², seed 12345, 8192 spp; the diffusion floor's: 64², seed 99, 4096 spp)."""
    size, seed, spp = (96, 12345, 8192) if scene_registry.group_of(name) == "trade" else (64, 99, 4096)
    return (*scene_registry.scene(name, n), size, seed, spp)


SCENES = scene_registry.GROUPS["trade"] + scene_registry.GROUPS["floor"]


def reference(name, renderer, g, cam, size, seed, spp, cache):
    path = None if cache is None else Path(cache) / f"{name}_ref.npz"
    if path is not None and path.exists():
        z = np.load(path)
        return z["rad"], z["se"]
    res = renderer.render(camera=cam, window_size=(size, size), model="path_traced", phase=g, seed=seed,
                          samples_per_pixel=spp, target_error=0.01)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez(path, rad=res.radiance, se=res.std_error)
    return res.radiance, res.std_error


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--ref-cache", default=None)
    ap.add_argument("--move-size", type=int, default=0, help="image size of the camera-move timing (0: skip)")
    ap.add_argument("--rounds", type=int, default=7)
    args = ap.parse_args(argv)
    for name in args.scenes.split(","):
        grid, tf, lights, g, cam, size, seed, spp = scene(name)
        base = pa.Renderer(grid, transfer_function=tf, lights=lights)
        ref, se = reference(name, base, g, cam, size, seed, spp, args.ref_cache)
        mask = metrics.light_mask((size, size), cam, (size, size), lights)
        noise = refs.block_noise(ref, se, mask)
        print(f"{name} ({size}², reference block noise {noise:.4f})", flush=True)
        base.render(camera=cam, window_size=(size, size), model="single_scattering", phase=g)  # light volumes
        for label, opts in CONFIGS:
            r = pa.Renderer(grid, transfer_function=tf, lights=lights)
            r.cache.share(base.cache)
            t = time.perf_counter()
            img = r.render(camera=cam, window_size=(size, size), model="diffusion", phase=g, **opts).radiance
            t = time.perf_counter() - t
            print(f"  {label:15s} block {metrics.block_relative_rmse(img, ref, mask):.3f}"
                  f"  bias {metrics.relative_bias(img, ref, mask):+.3f}  first frame {t:5.2f} s", flush=True)
        if args.move_size:
            S = (args.move_size, args.move_size)
            cfgs = [("single_scattering", {}), ("diffusion", {}), ("diffusion", CONFIGS[-1][1])]
            rs = []
            for model, opts in cfgs:
                r = pa.Renderer(grid, transfer_function=tf, lights=lights)
                r.render(camera=cam, window_size=S, model=model, phase=g, **opts)
                rs.append(r)
            ts = [[] for _ in cfgs]
            for _ in range(args.rounds):
                for k, ((model, opts), r) in enumerate(zip(cfgs, rs)):
                    t = time.perf_counter()
                    r.render(camera=cam, window_size=S, model=model, phase=g, **opts)
                    ts[k].append(time.perf_counter() - t)
            m = [float(np.median(t)) for t in ts]
            print(f"  camera move at {S[0]}²: single scattering {m[0] * 1e3:.0f} ms, plain diffusion "
                  f"{m[1] / m[0]:.2f}×, {CONFIGS[-1][0]} {m[2] / m[0]:.2f}×", flush=True)


if __name__ == "__main__":
    main()
