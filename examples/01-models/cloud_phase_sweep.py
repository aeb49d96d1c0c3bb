"""
.. _cloud_phase_sweep_example:

A cloud seen against the light: g = −0.5, 0, 0.6
================================================

The phase function decides how much light a cloud sends toward a camera that looks toward the
light. Forward scattering (g > 0, Henyey–Greenstein) brightens the silver lining; backward
scattering (g < 0) darkens it.
"""

# %%
import os

import pyvista as pv

import pv_ambient as pa
from pv_ambient import datasets

pv.OFF_SCREEN = True
OUT = os.environ.get("PV_AMBIENT_EXAMPLES_OUT", ".")
FAST = os.environ.get("PV_AMBIENT_EXAMPLES_FAST", "0") not in ("", "0")
N = 32 if FAST else 80  # points per axis
SIZE = (96, 96) if FAST else (360, 360)  # pixels per panel

grid = datasets.cloud(n=N)
tf = pa.TransferFunction(**{**datasets.suggested_style("cloud"), "density_scale": 8.0}, albedo=0.95)
# the light is behind the cloud, slightly above: the camera looks toward it
light = pa.PointLight((0.2, 2.6, 0.9), intensity=8.0)
r = pa.Renderer(grid, transfer_function=tf, lights=[light])
cam = pa.Camera((0.0, -3.6, 0.3), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), view_angle=30.0)

# %%
# One renderer, three phase functions: the light volume is computed once; each g needs its own
# preintegrated table slice (shipped for g = 0 and 0.6, computed once and cached on disk for
# g = −0.5). One exposure for all three panels, so brightness compares across them.
results = {}
for g in (-0.5, 0.0, 0.6):
    res = r.render(camera=cam, window_size=SIZE, model="ambient_scattering", phase=g)
    print(f"g = {g:+.1f}: mean radiance {res.radiance.mean():.4f}")
    results[f"g = {g:+.1f}"] = res
path = os.path.join(OUT, "cloud_phase_sweep.png")
w, h = pa.pyvista.show_panels(results.values(), list(results), path, font_size=6 if FAST else 12,
                                  display={"exposure": 3.5, "tonemap": "reinhard", "srgb": True})
print(f"saved {path} ({w}x{h})")
