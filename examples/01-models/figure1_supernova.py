"""
.. _figure1_example:

The paper's Figure 1: EA | AO | AS
==================================

Ament, Sadlo and Weiskopf open their paper with a supernova shell lit by a point light at its
centre, rendered three ways: emission–absorption (no lighting), ambient occlusion (a uniform
ambient light dimmed by the mean extinction around each sample) and ambient volume scattering
(the light at the centre scattering through the shell, with soft shadows and translucency).
"""

# %%
import os

import pyvista as pv

import pv_ambient as pa
from pv_ambient import datasets

pv.OFF_SCREEN = True
OUT = os.environ.get("PV_AMBIENT_EXAMPLES_OUT", ".")
FAST = os.environ.get("PV_AMBIENT_EXAMPLES_FAST", "0") not in ("", "0")
N = 32 if FAST else 96  # points per axis
SIZE = (96, 96) if FAST else (400, 400)  # pixels per panel

# %%
# The synthetic supernova-like shell and its suggested transfer function, with a scattering
# albedo of 0.9 (the TF colour tints the scattered light).
grid = datasets.supernova(n=N)
tf = pa.TransferFunction(**datasets.suggested_style("supernova"), albedo=0.9)
light = pa.PointLight((0.0, 0.0, 0.0), intensity=3.0)
r = pa.Renderer(grid, transfer_function=tf, lights=[light])
cam = pa.Camera((0.0, -3.6, 0.6), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), view_angle=30.0)

# %%
# Three models, one renderer: the mean-extinction grid is shared by AO and AS; the light's
# volumes and the table slice are computed once.
options = {"emission_absorption": {},
           # a strong ambient light and a wide ball make the occlusion visible next to the TF colour
           "ambient_occlusion": {"ambient_radiance": 10.0, "radius": "8 voxels"},
           "ambient_scattering": {"radius": "4 voxels"}}
results = {m: r.render(camera=cam, window_size=SIZE, model=m, **kw) for m, kw in options.items()}
for m, res in results.items():
    print(f"{m:22s} {res.metadata['time_prepare'] + res.metadata['time_render']:.2f} s")

# %%
# Side by side, each with its own exposure (the models compute different quantities; the lit
# shell of AS is ~8× dimmer than the emission of EA, and the core around the light saturates).
path = os.path.join(OUT, "figure1_supernova.png")
w, h = pa.pyvista.show_panels(results.values(), ("EA", "AO", "AS"), path, font_size=6 if FAST else 12,
                                  display=[{"exposure": exposure, "tonemap": "reinhard", "srgb": True}
                                           for exposure in (0.0, -2.5, 3.0)])
print(f"saved {path} ({w}x{h})")
