"""
.. _synthetic_datasets_example:

The seven synthetic volumes
===========================

:mod:`pv_ambient.datasets` generates seven volumes on the cube [−1, 1]³ with numpy alone: no
download, deterministic for a given ``seed``, and resolution independent (a coarse grid's values
equal a fine grid's at shared points). Each comes with a suggested transfer-function style.
Here each is rendered with the emission–absorption model (what VTK's ``add_volume`` shows) from
PyVista's default isometric camera.
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
SIZE = (96, 96) if FAST else (320, 320)  # pixels per panel

# %%
# Every volume is a ``pyvista.ImageData`` with one float32 point array in [0, 1], set active.
# ``datasets.suggested_style(name)`` gives ``cmap``, ``clim``, ``opacity`` and
# ``density_scale``, the keywords of :class:`pv_ambient.TransferFunction`.
grids = {name: datasets.load(name, n=N, seed=0) for name in datasets.NAMES}
for name, grid in grids.items():
    values = grid.active_scalars
    print(f"{name:15s} {grid.dimensions} {grid.active_scalars_name!r:14s} "
          f"range [{values.min():.2f}, {values.max():.2f}], mean {values.mean():.3f}")

# %%
# One panel per volume, one camera for all (a closer view than PyVista's default, which fits the
# whole cube). The emission–absorption model needs no light: each sample emits its
# transfer-function colour in proportion to its extinction.
camera = pa.Camera(position=(2.5, -3.2, 1.7), focal_point=(0.0, 0.0, 0.0), view_up=(0.0, 0.0, 1.0))
results = []
for name, grid in grids.items():
    tf = pa.TransferFunction(**datasets.suggested_style(name))
    t = time.perf_counter()
    res = pa.render(grid, transfer_function=tf, camera=camera, window_size=SIZE)
    elapsed = time.perf_counter() - t
    covered = float(np.mean(res.alpha > 0.5))
    print(f"{name:15s} EA {elapsed:5.2f} s, {100 * covered:4.1f} % of pixels more than half opaque")
    results.append(res)
# one labelled panel per volume, in VTK's display convention (no exposure, clipped)
path = os.path.join(OUT, "synthetic_datasets.png")
w, h = pa.pyvista.show_panels(results, list(grids), path, font_size=6 if FAST else 12)
print(f"saved {path} ({w}x{h})")
