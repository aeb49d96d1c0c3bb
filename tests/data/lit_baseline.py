"""The radiance of every model with lights given explicitly, saved by one version and compared by
another (issue 17, acceptance 2: the physical output does not move when the display and light
defaults change).

``python tests/data/lit_baseline.py --save tests/data/lit_baseline_pre_0.3.0.npz`` was run at the commit
issue 17's changes were merged onto (4b6a28e: pv_ambient 0.2.0 plus issue 16's speed work, whose baked
in-scattering changes lit radiance by design; issue 17's branch had first been checked the same way
against 65d2e28, the 0.2.0 release); ``tests/acceptance/test_lit_baseline.py`` renders the same
cases with the package under test and asserts every array is bit-identical to the saved one. Only
public API is used (``Renderer``, ``render``, the JSON scene through the CLI), so the same cases run
on both versions.
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import numpy as np

SIZE = (24, 20)
N = 16

#: (label, model, options)
CASES = [
    ("ea", "emission_absorption", {}),
    ("ao", "ambient_occlusion", {}),
    ("ss", "single_scattering", {}),
    ("as", "ambient_scattering", {"table_quality": "preview"}),
    ("as_tube", "ambient_scattering", {"propagation": "tube", "table_quality": "preview"}),
    ("diffusion", "diffusion", {}),
    ("diffusion_fl", "diffusion", {"flux_limited": True}),
    ("auto", "auto", {}),
    ("pt", "path_traced", {"samples_per_pixel": 4, "seed": 7}),
]


def scenes():
    """(name, grid, transfer-function dict, lights as JSON dicts, phase g, camera dict)."""
    from pv_ambient import datasets

    st = datasets.suggested_style("supernova")
    sn = {"kind": "colormap", "cmap": st["cmap"], "clim": list(st["clim"]), "opacity": st["opacity"],
          "density_scale": st["density_scale"], "albedo": 0.9}
    st = datasets.suggested_style("cloud")
    cl = {"kind": "colormap", "cmap": st["cmap"], "clim": list(st["clim"]), "opacity": st["opacity"],
          "density_scale": 8.0, "albedo": 0.95}
    cam = {"position": [0.0, -3.6, 0.6], "focal_point": [0, 0, 0], "view_up": [0, 0, 1], "view_angle": 30.0}
    return [
        ("supernova", {"dataset": "supernova", "n": N}, sn,
         [{"kind": "point", "position": [0.0, 0.0, 0.35], "intensity": [3.0, 3.0, 3.0]}], 0.0, cam),
        ("cloud", {"dataset": "cloud", "n": N}, cl,
         [{"kind": "point", "position": [0.4, 0.6, 2.2], "intensity": [6.0, 5.0, 4.0]},
          {"kind": "directional", "direction": [0.3, 0.5, -1.0], "irradiance": [0.5, 0.5, 0.6]}], 0.6, cam),
    ]


def render_all():
    """Every case of every scene through the API (``Renderer``) and the JSON scene → CLI → .npy."""
    import pv_ambient as pa
    from pv_ambient import datasets
    from pv_ambient.cli import main

    out = {}
    for name, vol, tf, lights, g, cam in scenes():
        grid = getattr(datasets, vol["dataset"])(n=vol["n"])
        objs = [pa.PointLight(d["position"], d["intensity"]) if d["kind"] == "point"
                else pa.DirectionalLight(d["direction"], d["irradiance"]) for d in lights]
        r = pa.Renderer(grid, transfer_function=dict(tf), lights=objs)
        for label, model, opts in CASES:
            res = r.render(camera=pa.Camera(**cam), window_size=SIZE, model=model, phase=g, **opts)
            out[f"{name}/{label}/radiance"] = res.radiance
            out[f"{name}/{label}/alpha"] = res.alpha
        res = pa.render(grid, transfer_function=dict(tf), lights=objs, camera=pa.Camera(**cam), window_size=SIZE,
                        model="single_scattering", phase=g)
        out[f"{name}/render_ss/radiance"] = res.radiance
        with tempfile.TemporaryDirectory() as tmp:
            for label, model, opts in CASES:
                scene = {"version": 1, "volume": vol, "transfer_function": tf, "lights": lights, "camera": cam,
                         "phase": {"kind": "hg", "g": g}, "image": {"width": SIZE[0], "height": SIZE[1]},
                         "model": model, **opts}
                path = Path(tmp) / "scene.json"
                path.write_text(json.dumps(scene))
                npy = Path(tmp) / f"{label}.npy"
                rc = main(["render", str(path), "-o", str(Path(tmp) / "out.png"), "--radiance", str(npy)])
                assert rc == 0, (name, label)
                out[f"{name}/cli_{label}/radiance"] = np.load(npy)
    return out


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--save", type=Path, required=True)
    a = p.parse_args()
    imgs = render_all()
    np.savez_compressed(a.save, **imgs)
    print(f"saved {len(imgs)} arrays to {a.save}")
