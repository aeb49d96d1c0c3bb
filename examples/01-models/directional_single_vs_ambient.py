"""
.. _directional_single_vs_ambient_example:

Sunlight on a cloud: single vs ambient scattering
=================================================

A directional light (parallel rays, like the sun) falls on a cloud from the upper left. Single
scattering follows each light ray to one scattering event and no further: the parts of the cloud
in its own shadow go dark. Ambient scattering adds the light scattered many times inside a ball
around each sample (the paper's preintegrated multiple scattering), which brightens the cloud
and softens its shadows. The third panel shows what single scattering misses.
"""

# %%
import os

import numpy as np
import pyvista as pv

import pv_ambient as pa
from pv_ambient import datasets

pv.OFF_SCREEN = True
OUT = os.environ.get("PV_AMBIENT_EXAMPLES_OUT", ".")
FAST = os.environ.get("PV_AMBIENT_EXAMPLES_FAST", "0") not in ("", "0")
N = 32 if FAST else 96  # points per axis
SIZE = (96, 96) if FAST else (360, 360)  # pixels per panel

# %%
# A dense, bright cloud (albedo 0.95, forward scattering g = 0.6) and a white directional
# light from the upper left, travelling down and to the right; its irradiance is 1 (per unit
# area perpendicular to the rays).
grid = datasets.cloud(n=N)
tf = pa.TransferFunction(**{**datasets.suggested_style("cloud"), "density_scale": 12.0}, albedo=0.95)
sun = pa.DirectionalLight(direction=(1.0, 0.3, -0.8), irradiance=1.0)
renderer = pa.Renderer(grid, transfer_function=tf, lights=[sun])
camera = pa.Camera((0.0, -3.6, 0.5), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), view_angle=30.0)

# %%
# Both models share the light's optical-depth volume; ambient scattering also needs the
# ball-mean extinction grid and a preintegrated table slice (shipped for g = 0.6).
results = {}
for model in ("single_scattering", "ambient_scattering"):
    res = renderer.render(camera=camera, window_size=SIZE, model=model, phase=0.6)
    results[model] = res
    m = res.metadata
    print(f"{model:20s} {m['time_prepare'] + m['time_render']:5.2f} s, "
          f"mean radiance over the cloud {res.radiance[res.alpha > 0.1].mean():.4f}")
ss, amb = results["single_scattering"], results["ambient_scattering"]
inside = amb.alpha > 0.1
ratio = amb.radiance[inside].mean() / ss.radiance[inside].mean()
print(f"ambient / single scattering, mean over the cloud: {ratio:.2f}")

# %%
# The difference is a radiance image too: wrap it in a :class:`pv_ambient.RenderResult` to
# display it the same way. One exposure for all panels (the 99th percentile of the ambient
# scattering image maps to ½ before the ACES tone curve).
missing = pa.RenderResult(np.maximum(amb.radiance - ss.radiance, 0.0), amb.alpha, amb.camera)
white = float(np.percentile(amb.radiance[inside].max(axis=-1), 99))
display = {"exposure": float(np.log2(0.5 / white)), "tonemap": "aces", "srgb": True}
path = os.path.join(OUT, "directional_single_vs_ambient.png")
w, h = pa.pyvista.show_panels((ss, amb, missing), ("single", "ambient", "ambient - single"), path,
                                  display=display, font_size=6 if FAST else 12)
print(f"saved {path} ({w}x{h})")
