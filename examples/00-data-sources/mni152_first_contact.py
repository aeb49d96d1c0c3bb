"""
.. _mni152_first_contact_example:

First contact: a real MRI, lit, with no tuning
==============================================

The README's first example. nilearn's MNI152 template (1 mm voxels, brain-extracted) averaged to
2 mm voxels, in its own world units — millimetres — with PyVista's ``bone`` colormap and no
light or exposure argument: the lit models then get the default light rig (a key and a fill
light placed from the camera, after VTK's light kit, docs/lights.rst) and the PNG gets
``exposure="auto"`` (the 99th percentile of the luminance mapped to 0.8, docs/display.rst).
Lights given explicitly stay physical: the second panel has one ``PointLight`` of the default
intensity (1 W/sr) 300 mm above the brain — an irradiance of about 1e-5, a radiance of about
1e-6 — and ``exposure="auto"`` still shows it. The radiance arrays are never rescaled.

Install the extra with ``pip install "pv_ambient[mri]"`` (``make test`` does).
"""

# %%
import os

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

# %%
# The README's snippet, as it is (the default 512 × 512 window; a smaller one in the fast run):
grid = pa.pyvista.nifti_to_image_data(load_mni152_template(), factor=4 if FAST else 2, name="T1")
tf = pa.TransferFunction(cmap="bone")
size = (128, 128) if FAST else (512, 512)
res = pa.render(grid, transfer_function=tf, model="ambient_scattering", window_size=size)
print(res)


# %%
# How well exposed is it? The share of the brain's pixels (alpha > 0.5) above 10 % luminance and
# the share with a saturated channel, in the default 8-bit image (the acceptance figures).
def shares(result):
    img = result.to_uint8()
    covered = result.alpha > 0.5
    lum = (img.astype(np.float64) / 255.0) @ np.array([0.2126, 0.7152, 0.0722])
    return float(np.mean(lum[covered] > 0.1)), float(np.mean((img == 255).any(axis=-1)[covered]))


# %%
# One point light of the default intensity, 300 mm above the centre of the brain.
top = np.reshape(grid.bounds, (3, 2)).mean(axis=1) + (0.0, 0.0, 300.0)
lit = pa.render(grid, transfer_function=tf, model="ambient_scattering", window_size=size,
                lights=[pa.PointLight(tuple(top))])
for label, r in (("default rig", res), ("PointLight 300 mm above", lit)):
    bright, saturated = shares(r)
    print(f"{label:24s} radiance max {float(r.radiance.max()):.3g}, exposure {r.display_exposure():+.1f} stops: "
          f"{100 * bright:.1f} % of the brain above 10 % luminance, {100 * saturated:.2f} % saturated")

# %%
path = os.path.join(OUT, "mni152_first_contact.png")
w, h = pa.pyvista.show_panels([res, lit], ["default light rig", "PointLight 300 mm above"], path,
                              font_size=6 if FAST else 12)
print(f"saved {path} ({w}x{h})")
