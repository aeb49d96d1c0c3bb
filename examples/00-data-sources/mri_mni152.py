"""
.. _mri_mni152_example:

A real MRI volume: the MNI152 brain template
============================================

The MNI152 T1-weighted template (ICBM 2009a, symmetric, 1 mm) ships inside `nilearn
<https://nilearn.github.io>`_'s wheel, so it loads without a download: install the extra with
``pip install "pv_ambient[mri]"``. The template is brain-extracted (skull and skin already
removed). We turn the NIfTI image into a ``pyvista.ImageData`` that keeps its affine (spacing,
origin and direction: world coordinates are millimetres in MNI space), cut a front-left-top
block away to open the brain, and render it with emission–absorption (what VTK's
``add_volume`` shows, no lighting) and with ambient volume scattering lit by one point light.
"""

# %%
import os
import time

import numpy as np
import pyvista as pv

import pv_ambient as pa

try:
    from nilearn.datasets import load_mni152_template
except ImportError as exc:  # the example needs the `mri` extra
    raise SystemExit('this example needs nilearn: pip install "pv_ambient[mri]"') from exc

pv.OFF_SCREEN = True
OUT = os.environ.get("PV_AMBIENT_EXAMPLES_OUT", ".")
FAST = os.environ.get("PV_AMBIENT_EXAMPLES_FAST", "0") not in ("", "0")
FACTOR = 4 if FAST else 2  # block-average f×f×f voxels into one (the template has 1 mm voxels)
SIZE = (128, 128) if FAST else (400, 400)  # pixels per panel


# %%
# From NIfTI to ``ImageData``: :func:`pv_ambient.pyvista.nifti_to_image_data`. The NIfTI affine
# maps voxel indices ``(i, j, k, 1)`` to world (MNI) millimetres, exactly what VTK calls the
# index-to-physical matrix: its column norms are the spacing, the normalised columns the direction
# matrix and its last column the origin. Averaging ``f``-voxel blocks (``factor=``) changes the
# affine too: new voxel ``I`` is the centre of old voxels ``f·I … f·I + f − 1``.
t = time.perf_counter()
img = load_mni152_template()  # a nibabel Nifti1Image, intensities scaled to [0, 1]
grid = pa.pyvista.nifti_to_image_data(img, factor=FACTOR, name="T1")
zooms = tuple(float(v) for v in img.header.get_zooms()[:3])
print(f"MNI152 {img.shape} voxels of {zooms} mm -> {grid.dimensions} points, spacing "
      f"{tuple(round(float(s), 2) for s in grid.spacing)} mm, loaded in {time.perf_counter() - t:.1f} s")
print(f"world bounds (mm): {tuple(round(float(b)) for b in grid.bounds)}")

# %%
# Open the brain: voxels in a front-left-top block (MNI x < −20 is 2 cm into the left
# hemisphere, y > −18 in front of the centre, z > 20 above it) are set to zero, which the
# transfer function maps to empty space. Editing the array keeps the ``ImageData`` (a clip filter would not).
x, y, z = grid.points.T
grid["T1"] = np.where((x < -20) & (y > -18) & (z > 20), 0.0, grid["T1"]).astype(np.float32)

# %%
# The transfer function, as a table of nodes over the T1 intensity: background and
# cerebrospinal fluid (dark in T1, below ≈ 0.35) empty, grey matter (≈ 0.6) a translucent
# pink, white matter (≈ 0.85) a dense cream. ``sigma_t`` is the extinction in 1/mm. The
# scattering albedo is 0.9 times the node colour.
values = [0.0, 0.35, 0.5, 0.62, 0.75, 0.85, 1.0]
sigma_t = [0.0, 0.0, 0.05, 0.15, 0.3, 0.8, 0.8]
color = [(0.0, 0.0, 0.0), (0.6, 0.2, 0.2), (0.85, 0.35, 0.35), (0.9, 0.5, 0.45),
         (0.95, 0.8, 0.7), (1.0, 0.96, 0.88), (1.0, 0.96, 0.88)]
tf = pa.TransferFunction.from_table(values, sigma_t=sigma_t, color=color, albedo=0.9)

# %%
# One warm-white point light above, in front of and to the left of the head (intensity in
# W/sr; 27 cm from the centre of the brain it gives an irradiance of about 0.9 there), and a
# camera from the same side.
centre = np.array([0.0, -18.0, 10.0])
light = pa.PointLight(tuple(centre + (-160.0, 140.0, 160.0)), intensity=(6.5e4, 6.0e4, 5.2e4))
camera = pa.Camera(tuple(centre + (-330.0, 260.0, 200.0)), tuple(centre), (0.0, 0.0, 1.0), view_angle=30.0)
renderer = pa.Renderer(grid, transfer_function=tf, lights=[light])
results = {}
for model in ("emission_absorption", "ambient_scattering"):
    res = renderer.render(camera=camera, window_size=SIZE, model=model)
    results[model] = res
    m = res.metadata
    print(f"{model:20s} {m['time_prepare'] + m['time_render']:5.2f} s, "
          f"{100 * float(np.mean(res.alpha > 0.5)):4.1f} % of pixels more than half opaque")

# %%
# Side by side. Emission–absorption radiance is the TF colour where the brain is opaque, shown
# as VTK shows it (no exposure, clipped); the scattered light gets an exposure that maps the 99th
# percentile of its brightest channel over the brain to 1 before the ACES tone curve.
scattered = results["ambient_scattering"]
white = float(np.percentile(scattered.radiance[scattered.alpha > 0.1].max(axis=-1), 99))
displays = ({}, {"exposure": float(np.log2(0.7 / white)), "tonemap": "aces", "srgb": True})
path = os.path.join(OUT, "mri_mni152.png")
w, h = pa.pyvista.show_panels(results.values(), ("emission-absorption", "ambient scattering"), path,
                                  display=displays, font_size=6 if FAST else 12)
print(f"saved {path} ({w}x{h})")
