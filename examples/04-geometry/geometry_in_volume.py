"""
.. _geometry_in_volume_example:

Meshes inside a cloud: VTK | emission–absorption | ambient scattering
=====================================================================

:func:`pv_ambient.add_ambient_volume` lets the plotter's opaque meshes occlude the volume: the
meshes are drawn with the plotter's camera and lights, their depth buffer becomes the distance
along each pixel's ray at which the volume stops (``ray_end``), and the volume in front of them
is composited over their picture (``L + T·G``, VTK's own blend). Left, VTK's ``add_volume``
with the same transfer function and the same meshes; middle, our emission–absorption; right,
ambient scattering lit by a point light above the cloud.

The meshes occlude the volume but do not shadow it: the volume's light passes through them.
"""

# %%
import os
import time

import numpy as np
import pyvista as pv

import pv_ambient as pa
from pv_ambient import datasets
from pv_ambient.pyvista.vtk_bridge import add_vtk_volume

pv.OFF_SCREEN = True
OUT = os.environ.get("PV_AMBIENT_EXAMPLES_OUT", ".")
FAST = os.environ.get("PV_AMBIENT_EXAMPLES_FAST", "0") not in ("", "0")
N = 32 if FAST else 96  # points per axis
SIZE = (96, 96) if FAST else (400, 400)  # pixels per panel

# %%
# The synthetic cloud with a scattering albedo, a point light above and in front of it, and
# three meshes: a sphere in the cloud's core, a pole through it and a ring around it.
grid = datasets.cloud(n=N)
tf = pa.TransferFunction(**datasets.suggested_style("cloud"), albedo=0.9)
light = pa.PointLight((0.5, -1.5, 2.5), intensity=12.0)
r = pa.Renderer(grid, transfer_function=tf, lights=[light])
cam = pa.Camera((2.6, -3.4, 1.4), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), view_angle=30.0)
meshes = [(pv.Sphere(radius=0.3, center=(0.05, 0.0, 0.0), theta_resolution=48, phi_resolution=48), "orange"),
          (pv.Cylinder(center=(0.45, 0.2, 0.0), direction=(0.2, 0.1, 1.0), radius=0.06, height=2.2,
                       resolution=32), "steelblue"),
          (pv.ParametricTorus(ringradius=0.75, crosssectionradius=0.05).rotate_x(25.0, inplace=False), "seagreen")]
step = r.default_step()
# the scattered light is dimmer than the TF colour: an exposure for the ambient-scattering panel
# (the meshes keep their VTK colours under any display setting)
DISPLAY = {"exposure": 2.5, "tonemap": "reinhard", "srgb": True}


def add_meshes(pl):
    for mesh, colour in meshes:
        pl.add_mesh(mesh, color=colour, smooth_shading=True, reset_camera=False)


# %%
# Three panels, each with its own copy of the meshes. ``add_ambient_volume`` finds the opaque
# meshes of its subplot, hides them and shows volume and meshes together on one textured plane.
font = 6 if FAST else 12
pl = pv.Plotter(shape=(1, 3), window_size=(3 * SIZE[0], SIZE[1]), border=False)
pl.set_background("black")
titles = ("VTK add_volume + meshes", "EA + meshes", "ambient scattering + meshes")
volumes = {}
for k, title in enumerate(titles):
    pl.subplot(0, k)
    add_meshes(pl)
    cam.to_vtk(pl.camera)
    pl.camera_set = True
    t = time.perf_counter()
    if k == 0:
        add_vtk_volume(pl, grid, r, step=step, mapper="gpu")
    elif k == 1:
        volumes["emission_absorption"] = pa.add_ambient_volume(pl, renderer=r, step=step)
    else:
        volumes["ambient_scattering"] = pa.add_ambient_volume(
            pl, renderer=r, model="ambient_scattering", step=step, radius="4 voxels",
            display=DISPLAY)
    print(f"{title:28s} {time.perf_counter() - t:.2f} s")
    pl.add_text(title, position=(4, SIZE[1] - 2 * font), font_size=font, color="white")

vol = volumes["emission_absorption"]
covered = np.isfinite(vol.ray_end)
print(f"meshes cover {100 * covered.mean():.0f} % of a panel; "
      f"volume in front of them: mean alpha {vol.volume_result.alpha[covered].mean():.2f}")
path = os.path.join(OUT, "geometry_in_volume.png")
w, h = pl.window_size
pl.show(screenshot=path, auto_close=False)
print(f"saved {path} ({w}x{h})")

# %%
# How close is our emission–absorption panel to VTK's? Both panels hold the same scene.
img = pl.screenshot()[3 * font:]  # below the labels
d = np.abs(img[:, SIZE[0]:2 * SIZE[0]].astype(int) - img[:, :SIZE[0]].astype(int))
print(f"EA vs VTK: mean |d| {d.mean():.2f}, p99 {np.percentile(d, 99):.0f} (uint8)")

# %%
# Interactive mode re-renders on every camera move (only the ray cast and the mesh pass run
# again: the light volume and the table slice are cached). Off-screen here, so we move the
# camera ourselves.
pl.close()
pl = pv.Plotter(window_size=SIZE)
pl.set_background("black")
add_meshes(pl)
cam.to_vtk(pl.camera)
pl.camera_set = True
live = pa.add_ambient_volume(pl, renderer=r, model="ambient_scattering", step=step, radius="4 voxels",
                             display=DISPLAY, interactive=True)
pl.show(auto_close=False)
for azimuth in (30, 30, 30):
    t = time.perf_counter()
    pl.camera.Azimuth(azimuth)
    pl.render()
    print(f"camera move: re-rendered in {time.perf_counter() - t:.2f} s (picture {live.renders})")
live.remove_observer()
pl.close()
