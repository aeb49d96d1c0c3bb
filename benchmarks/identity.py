"""Behaviour-preservation check for refactors: every model's image on the trade scenes, saved by one
version of the package and compared by another.

``--save FILE`` renders every model (and a camera move, a relight and the path tracer at a fixed
seed) on the three scenes of ``benchmarks/trade.py`` at a small size — also the progressive model
(base picture and residual samples), diffusion with transport sweeps and flux limiting, the
accurate preset, opaque geometry (``ray_end``), a two-step time series (``render_series``) and the
``pv-ambient render`` command — and writes the images (radiance and alpha) to an ``.npz``; ``--compare FILE`` renders the same with the installed package and prints
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
import scenes as scene_registry  # noqa: E402

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
    ("diffusion_sweeps_fl", "diffusion", {"flux_limited": True, "sweep_orders": 8}),
    ("auto_accurate", "auto", {"quality": "accurate"}),
    ("as_accurate", "ambient_scattering", {"quality": "accurate", "table_quality": "preview"}),
    ("progressive_base", "progressive", {"samples_per_pixel": 0}),
    ("progressive16", "progressive", {"samples_per_pixel": 16, "seed": 5}),
    ("progressive_ss_unbiased", "progressive", {"base_model": "single_scattering", "samples_per_pixel": 16,
                                                "unbiased": True, "seed": 2}),
]
#: Cases rendered with opaque geometry: each pixel's ray stops at a distance (``ray_end``).
RAY_END_CASES = [
    ("ea_ray_end", "emission_absorption", {}),
    ("ss_ray_end", "single_scattering", {}),
    ("diffusion_ray_end", "diffusion", {}),
]


def scenes(n):
    """(name, grid, transfer function, lights, phase, camera) of the trade's scenes."""
    return [(name, *scene_registry.scene(name, n)) for name in scene_registry.GROUPS["trade"]]


def ray_end_for(cam, size):
    """A ray-end image: the far half of the image (columns right of the middle) stopped at the
    camera's distance to the focal point, a band of rows at 0.9 of it; infinite elsewhere."""
    w, h = size
    d = float(np.linalg.norm(np.subtract(cam.position, cam.focal_point)))
    t = np.full((h, w), np.inf)
    t[:, w // 2:] = d
    t[h // 3: h // 2, :] = 0.9 * d
    return t


def render_series_images(n, size):
    """Two steps of the supernova through ``render_series`` (synchronous) and one orbit of two
    cameras: the frames' radiance as written to ``frame_*.npy``."""
    import tempfile

    from pv_ambient import datasets

    out = {}
    steps = [datasets.supernova(n=n, seed=s) for s in range(2)]
    lights = [pa.PointLight((0.0, 0.0, 0.35), intensity=3.0)]
    with tempfile.TemporaryDirectory() as tmp:
        pa.render_series(steps, out_dir=tmp, client="synchronous", window_size=size, model="single_scattering",
                         lights=lights, radiance=True, progress_bar=False)
        for i in range(2):
            out[f"series/step{i}/radiance"] = np.load(Path(tmp) / f"frame_{i:04d}.npy")
    with tempfile.TemporaryDirectory() as tmp:
        pa.render_series(steps[0], out_dir=tmp, client="synchronous", window_size=size, model="diffusion",
                         cameras=pa.orbit(steps[0], 2), radiance=True, progress_bar=False)
        for i in range(2):
            out[f"series/orbit{i}/radiance"] = np.load(Path(tmp) / f"frame_{i:04d}.npy")
    return out


def render_cli_images(n, size):
    """``pv-ambient render SCENE.json -o OUT.png --radiance OUT.npy`` (in a subprocess, as users
    run it) on a dataset scene, for three models; the radiance it writes."""
    import json
    import subprocess
    import tempfile

    out = {}
    w, h = size
    with tempfile.TemporaryDirectory() as tmp:
        for model in ("emission_absorption", "ambient_scattering", "diffusion"):
            scene = {"version": 1, "volume": {"dataset": "cloud", "n": n, "seed": 1},
                     "transfer_function": {"kind": "colormap", "cmap": "bone", "clim": [0, 1], "opacity": "linear",
                                           "opacity_unit_distance": 0.1, "albedo": 0.9},
                     "phase": {"kind": "hg", "g": 0.3},
                     "lights": [{"kind": "point", "position": [0.5, 0.5, 2.0], "intensity": [4, 4, 4]}],
                     "camera": {"position": [0, -3.5, 0.8], "focal_point": [0, 0, 0], "view_up": [0, 0, 1],
                                "view_angle": 30.0},
                     "image": {"width": w, "height": h}, "model": model, "table_quality": "preview"}
            path = Path(tmp) / f"{model}.json"
            path.write_text(json.dumps(scene))
            npy = Path(tmp) / f"{model}.npy"
            subprocess.run([sys.executable, "-m", "pv_ambient.cli", "render", str(path), "-o",
                            str(Path(tmp) / f"{model}.png"), "--radiance", str(npy)], check=True)
            out[f"cli/{model}/radiance"] = np.load(npy)
    return out


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
        # opaque geometry in front of part of the volume
        t_end = ray_end_for(cam, size)
        r = pa.Renderer(grid, transfer_function=tf, lights=lights)
        for label, model, opts in RAY_END_CASES:
            res = r.render(camera=cam, window_size=size, model=model, phase=g, ray_end=t_end, **opts)
            out[f"{name}/{label}/radiance"] = res.radiance
            out[f"{name}/{label}/alpha"] = res.alpha
        print(f"{name}: rendered", flush=True)
    out.update(render_series_images(16, size))
    out.update(render_cli_images(16, size))
    print("series and cli: rendered", flush=True)
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
