"""
.. _jupyter_backends_example:

An ambient volume in a notebook: PyVista's Jupyter backends
===========================================================

A notebook shows a PyVista plotter through one of PyVista's Jupyter backends: ``"static"`` (a
picture), or trame's ``"server"`` (the server renders, the browser shows its images),
``"client"`` (vtk.js draws the scene in the browser) and ``"trame"`` (either, switchable).
:func:`pv_ambient.pyvista.jupyter.show` is ``plotter.show()`` with the ambient volume kept right in
each: on the server it re-renders from the render window's frames; in the browser it re-renders
from the camera the browser reports when a drag ends (docs/jupyter.rst).

Run as a script (and in the gallery) this example plays a drag the way the server view does —
VTK's interactor asks for 15 frames per second while the camera moves — and saves the pictures;
in a notebook the last cell opens the live view.
"""

# %%
import os
import sys
import time

import numpy as np
import pyvista as pv

import pv_ambient as pa
from pv_ambient import datasets

pv.OFF_SCREEN = True
OUT = os.environ.get("PV_AMBIENT_EXAMPLES_OUT", ".")
FAST = os.environ.get("PV_AMBIENT_EXAMPLES_FAST", "0") not in ("", "0")
N = 32 if FAST else 64  # points per axis
SIZE = (160, 80) if FAST else (1000, 500)  # the view's pixels (a notebook cell is wide)

# %%
# The synthetic supernova with ambient scattering, interactive: every frame whose camera (or
# size) changed re-renders the volume.
grid = datasets.supernova(n=N)
pl = pv.Plotter(window_size=SIZE)
vol = pa.add_ambient_volume(pl, grid, model="ambient_scattering", interactive=True,
                            transfer_function=pa.TransferFunction(**datasets.suggested_style("supernova")))
print(f"first picture {vol.volume_result.metadata['time_prepare'] + vol.volume_result.metadata['time_render']:.2f} s "
      f"(its ray cast {vol.rest_seconds:.2f} s)")


def save(name):
    path = os.path.join(OUT, name)
    img = pl.screenshot(path, return_img=True)
    print(f"saved {path} ({img.shape[1]}x{img.shape[0]})")


save("jupyter_before.png")

# %%
# A drag, as the server view plays it: while the render window asks for 15 frames per second
# each frame renders at half the view's resolution, at the ray step its frame time asks for. The
# first drag's step is predicted from the resting picture's ray cast (no slow frames to find it);
# a later drag starts where this one ends. The frame when the camera rests is the sharp picture.
pl.ren_win.SetDesiredUpdateRate(15.0)
for k in range(6):
    pl.camera.azimuth += 5.0
    t = time.perf_counter()
    pl.render()
    print(f"drag frame {k}: {time.perf_counter() - t:.3f} s at {vol.result.window_size}, "
          f"{vol.step_factor} resting steps")
pl.ren_win.SetDesiredUpdateRate(0.0001)
t = time.perf_counter()
pl.render()
print(f"camera at rest: sharp picture {time.perf_counter() - t:.2f} s at {vol.result.window_size}")
save("jupyter_after.png")

# %%
# The picture follows the camera: it equals a render from the plotter's camera at the view's size
# (with the volume's own renderer: its default light rig was placed from the first camera).
ref = vol.renderer.render(model="ambient_scattering", camera=pa.Camera.from_vtk(pl.camera), window_size=SIZE)
print(f"largest difference to a direct render: {np.abs(vol.volume_result.radiance - ref.radiance).max():.2e}")

# %%
# In a notebook (``pip install "pv_ambient[jupyter]"``), the live view. ``"client"`` lets vtk.js
# turn the scene in the browser and re-renders when the drag ends; ``"server"`` streams the server's
# frames during the drag.
if "ipykernel" in sys.modules:
    from pv_ambient.pyvista.jupyter import show

    show(pl, jupyter_backend="client")
