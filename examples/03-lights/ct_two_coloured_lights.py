"""
.. _ct_two_coloured_lights_example:

Two coloured point lights on a CT-like phantom
==============================================

A warm light on the right and a cool light on the left of the synthetic head phantom, cut open,
each light alone and then both. :meth:`pv_ambient.Renderer.set_lights` relights the scene: the optical-depth
volume of a light is computed once and kept while that light stays, so the third render, with
both lights, reuses the two volumes the first two built. Scattering is linear in the light, so
the third image is the sum of the first two.
"""

# %%
import os
import time

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
# The phantom, cut open: the half facing the camera (y < −0.05) is set to zero, which the
# transfer function maps to empty space, so the lights reach the cut face and we see the brain,
# the ventricles and the dense inclusions instead of the skull. (Clip filters would turn the
# ``ImageData`` into an unstructured grid; editing the array keeps the grid.)
grid = datasets.ct_phantom(n=N)
y = grid.points[:, 1]
grid["attenuation"] = np.where(y < -0.05, 0.0, grid["attenuation"]).astype(np.float32)

# %%
# The suggested bone colormap with an opacity that favours soft tissue (≈ 0.2) over the skull
# (1.0), a scattering albedo of 0.8 and a mildly forward-scattering Henyey–Greenstein phase
# function (g = 0.3). The opacity list is spread evenly over ``clim``, as in ``add_volume``.
# Light intensities are RGB, in W/sr.
opacity = [0.0, 0.02, 0.6, 0.8, 0.6, 0.2, 0.1, 0.1, 0.3, 0.15, 0.1]
tf = pa.TransferFunction(**{**datasets.suggested_style("ct_phantom"), "opacity": opacity}, albedo=0.8)
warm = pa.PointLight((1.6, -1.2, 0.8), intensity=(5.0, 2.0, 1.0))
cool = pa.PointLight((-1.6, -1.2, -0.4), intensity=(1.0, 2.0, 5.0))
renderer = pa.Renderer(grid, transfer_function=tf)
camera = pa.Camera((0.0, -3.6, 0.4), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), view_angle=30.0)

# %%
# Three renders with one renderer, relit between them.
results = {}
for label, lights in (("warm", [warm]), ("cool", [cool]), ("warm + cool", [warm, cool])):
    renderer.set_lights(lights)
    t = time.perf_counter()
    results[label] = renderer.render(camera=camera, window_size=SIZE, model="ambient_scattering", phase=0.3)
    rgb = results[label].radiance[results[label].alpha > 0.1].mean(axis=0)
    print(f"{label:12s} {time.perf_counter() - t:5.2f} s, mean RGB over the head "
          f"({rgb[0]:.4f}, {rgb[1]:.4f}, {rgb[2]:.4f})")
both = results["warm + cool"].radiance
gap = np.abs(both - results["warm"].radiance - results["cool"].radiance).max() / both.max()
print(f"superposition: max |both - (warm + cool)| = {gap:.1e} of the brightest pixel")

# %%
# One exposure for all three panels (the 99th percentile of the two-light image maps to 1), so
# brightness and colour compare across them.
white = float(np.percentile(both[results["warm + cool"].alpha > 0.1].max(axis=-1), 99))
display = {"exposure": float(np.log2(1.0 / white)), "tonemap": "aces", "srgb": True}
path = os.path.join(OUT, "ct_two_coloured_lights.png")
w, h = pa.pyvista.show_panels(results.values(), list(results), path, display=display,
                                  font_size=6 if FAST else 12)
print(f"saved {path} ({w}x{h})")
