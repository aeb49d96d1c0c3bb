"""Smoke check of a NON-editable install (``make install-check``): run from outside the checkout, so
only the installed copy of pv_ambient can be imported. Renders every model on a tiny volume, through
the accessor entry point, the JSON scene CLI and the table CLI; exits non-zero on any failure."""
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")

import numpy as np  # noqa: E402
import pyvista as pv  # noqa: E402

import pv_ambient as pa  # noqa: E402
from pv_ambient import datasets, metrics  # noqa: E402

here = Path(pa.__file__).resolve()
assert "site-packages" in here.parts, f"pv_ambient imported from {here}, not from the installed copy"
grid = datasets.supernova(n=16)
light = [pa.PointLight((0.0, 0.0, 0.3), 3.0)]
for model in ("emission_absorption", "ambient_occlusion", "single_scattering", "ambient_scattering", "diffusion",
              "path_traced", "auto"):
    res = pa.render(grid, lights=light, model=model, window_size=(12, 10), samples_per_pixel=2)
    assert res.radiance.shape == (10, 12, 3) and np.isfinite(res.radiance).all(), model
    print(f"{model:20s} mean {res.radiance.mean():.4g}")
# the accessor, registered through the pyvista.accessors entry point on a plain pyvista grid
plain = pv.ImageData(dimensions=(8, 8, 8))
plain["s"] = np.linspace(0, 1, plain.n_points)
print("accessor", plain.ambient.render(window_size=(6, 5)).radiance.shape)
assert metrics.relative_rmse(res.radiance, res.radiance) == 0.0
with tempfile.TemporaryDirectory() as tmp:
    scene = Path(tmp) / "scene.json"
    scene.write_text(json.dumps({"volume": {"dataset": "cloud", "n": 16}, "model": "single_scattering",
                                 "lights": [{"kind": "point", "position": [1, 1, 2], "intensity": 4.0}],
                                 "image": {"width": 10, "height": 8}}))
    cli = Path(sys.executable).with_name("pv-ambient")
    subprocess.run([str(cli), "render", str(scene), "-o", str(Path(tmp) / "out.png"), "--radiance",
                    str(Path(tmp) / "out.npy")], check=True)
    assert np.load(Path(tmp) / "out.npy").shape == (8, 10, 3)
subprocess.run([sys.executable, "-m", "pv_ambient.preintegration", "--help"], check=True, capture_output=True)
print("install check: OK", here.parent)
