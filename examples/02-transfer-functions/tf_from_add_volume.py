"""
.. _tf_from_add_volume_example:

Reuse the transfer function of an ``add_volume`` actor
======================================================

A PyVista user has usually tuned a transfer function already, by calling
:meth:`pyvista.Plotter.add_volume` with a colormap, colour limits and an opacity. The actor it
returns carries a ``vtkVolumeProperty``; :meth:`pv_ambient.TransferFunction.from_volume_property`
reads it back (colour function, scalar opacity, opacity unit distance) so our renders classify
every scalar exactly as VTK does. Only the scattering albedo is new.
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
# The usual PyVista call. The opacity is PyVista's ``"sigmoid"`` ramp; its unit distance is
# PyVista's default (about one voxel). PyVista interpolates the volume nearest-neighbour by
# default; linear interpolation is what our ray marcher does.
grid = datasets.supernova(n=N)
volume_options = {"cmap": "magma", "clim": (0.0, 1.0), "opacity": "sigmoid", "show_scalar_bar": False}
camera = [(0.0, -3.8, 1.2), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0)]  # a PyVista camera_position
pl_vtk = pv.Plotter(window_size=SIZE)
pl_vtk.set_background("black")
actor = pl_vtk.add_volume(grid, **volume_options)
actor.prop.interpolation_type = "linear"
pl_vtk.camera_position = camera
pl_vtk.show()

# %%
# The same transfer function, read back from the actor's property. An albedo of 0.9 makes the
# scattering colour 0.9 × the TF colour.
tf = pa.TransferFunction.from_volume_property(actor.prop, albedo=0.9)
renderer = pa.Renderer(grid, transfer_function=tf)
print(f"opacity unit distance {actor.prop.GetScalarOpacityUnitDistance():.4f}, "
      f"largest extinction {renderer.optics.sigma_max:.1f} per unit length")

# %%
# Emission–absorption with that TF is what VTK draws; ambient scattering adds a point light to
# the left of the shell, a little behind it: the left side is lit, the right side lies in the
# shell's own shadow, and light scattered inside the shell softens the terminator.
light = pa.PointLight((-2.4, 0.3, 1.0), intensity=4.0)
ea = renderer.render(camera=camera, window_size=SIZE, model="emission_absorption")
renderer.set_lights([light])
sc = renderer.render(camera=camera, window_size=SIZE, model="ambient_scattering")
for res in (ea, sc):
    m = res.metadata
    print(f"{m['model']:20s} {m['time_prepare'] + m['time_render']:5.2f} s, "
          f"mean radiance {res.radiance.mean():.4f}")

# %%
# Side by side: VTK (the same ``add_volume`` call), our emission–absorption, and our ambient
# scattering. Scattered light is far dimmer than the TF's emission: the AS panel is exposed so
# the 99th percentile of the lit medium maps to 1 before the ACES tone curve. The last lines
# measure how close the first two panels are, in 8-bit display values (VTK's mapper and
# PyVista's default sample distance differ a little from our ray marcher's half-voxel step).
white = float(np.percentile(sc.radiance[sc.alpha > 0.1].max(axis=-1), 99))
exposure = float(np.log2(1.0 / white))
print(f"AS exposure {exposure:+.1f} stops")
font = 5 if FAST else 12
pl = pv.Plotter(shape=(1, 3), window_size=(3 * SIZE[0], SIZE[1]), border=False)
pl.set_background("black")
pl.subplot(0, 0)
pl.add_volume(grid, **volume_options).prop.interpolation_type = "linear"
pl.camera_position = camera
pl.add_text("VTK add_volume", position=(4, SIZE[1] - 2 * font), font_size=font, color="white")
for k, (res, label, display) in enumerate([
        (ea, "pv_ambient EA", {}),  # VTK's display convention: no exposure, no tone map
        (sc, "pv_ambient AS", {"exposure": exposure, "tonemap": "aces", "srgb": True})], start=1):
    pl.subplot(0, k)
    pa.pyvista.add_result_plane(pl, res, **display)
    pl.add_text(label, position=(4, SIZE[1] - 2 * font), font_size=font, color="white")
image = pl.screenshot(return_img=True)
vtk_panel = image[:, :SIZE[0]].astype(float)
ea_panel = image[:, SIZE[0]:2 * SIZE[0]].astype(float)
print(f"VTK vs pv_ambient EA: mean |difference| {np.abs(vtk_panel - ea_panel).mean():.2f} of 255")
path = os.path.join(OUT, "tf_from_add_volume.png")
w, h = pl.window_size
pl.show(screenshot=path)
print(f"saved {path} ({w}x{h})")
