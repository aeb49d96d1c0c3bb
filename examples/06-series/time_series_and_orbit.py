"""
.. _time_series_and_orbit_example:

A drifting cloud and an orbit: many frames with render_series
=============================================================

A small "simulation" writes one ``.vti`` file per time step: a cloud drifting with the wind.
:func:`pv_ambient.render_series` renders every step into ``frame_0000.png``, … with the same
transfer function, light and camera; then one step is seen from cameras on a circle around it
(:func:`pv_ambient.orbit`). Each frame equals what ``pv-ambient render`` gives for that step.

The gallery renders in this process (``client="synchronous"``). On a machine with several cores,
``client=None`` (the default) renders on a dask ``LocalCluster`` of one worker per core — in a
script, under ``if __name__ == "__main__":``, since the workers are new processes that import
it — and ``client="tcp://scheduler:8786"`` on an existing cluster; the frames are the same.
"""

# %%
import os
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

import pv_ambient as pa
from pv_ambient import datasets

OUT = os.environ.get("PV_AMBIENT_EXAMPLES_OUT", ".")
FAST = os.environ.get("PV_AMBIENT_EXAMPLES_FAST", "0") not in ("", "0")
N = 32 if FAST else 96  # points per axis
SIZE = (96, 96) if FAST else (240, 240)  # pixels per frame
STEPS = 4 if FAST else 6  # time steps
ORBIT = 6 if FAST else 12  # orbit cameras
QUALITY = "preview" if FAST else "balanced"

# %%
# The time steps: the cloud carried along x by the wind, a few voxels per step (what leaves the box
# is gone, what enters is clear air), each written to its own file as a simulation would.
# ``render_series`` takes the files by glob (or a list, or a ``.pvd`` collection); workers read them
# themselves.
work = Path(tempfile.mkdtemp(prefix="pv_ambient_series_"))
base = datasets.cloud(n=N, seed=3)
density = base.point_data["density"].reshape((N, N, N), order="F")
(work / "steps").mkdir()
for t in range(STEPS):
    step = base.copy()
    shift = t * max(1, N // 8)
    moved = np.zeros_like(density)
    moved[shift:] = density[:N - shift]
    step.point_data["density"] = moved.ravel(order="F")
    step.save(work / "steps" / f"step_{t:02d}.vti")

tf = pa.TransferFunction(**{**datasets.suggested_style("cloud"), "density_scale": 10.0}, albedo=0.9)
light = pa.PointLight((0.0, 0.6, 1.8), intensity=4.0)
camera = pa.Camera((0.5, -3.8, 1.2), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), view_angle=30.0)
display = {"exposure": 1.0, "tonemap": "aces", "srgb": True}

options = {"model": "ambient_scattering", "window_size": SIZE, "quality": QUALITY, "display": display}
series = pa.render_series(str(work / "steps" / "step_*.vti"), out_dir=work / "series", transfer_function=tf,
                          lights=[light], camera=camera, client="synchronous", progress_bar=False, **options)
print(series.summary())
for f in series.frames:
    print(f"  frame {f.index}: {Path(f.volume).name}, {f.times['total']:.2f} s "
          f"(read {f.times['load']:.2f} s, render {f.times['render']:.2f} s)")

# %%
# The orbit: step 0 from cameras 30° apart on a circle through the first camera, 20° above the
# centre. One renderer serves every frame (``reused``): its light volume and ball grid are built
# for the first frame only, the others cost a ray cast each.
cameras = pa.orbit(None, ORBIT, start=camera, elevation=20.0)
orbit = pa.render_series(str(work / "steps" / "step_00.vti"), cameras=cameras, out_dir=work / "orbit",
                         transfer_function=tf, lights=[light], client="synchronous", progress_bar=False, **options)
print(orbit.summary())
first, rest = orbit.frames[0], orbit.frames[1:]
print(f"  first frame {first.times['total']:.2f} s; the next {len(rest)}: "
      f"{np.mean([f.times['total'] for f in rest]):.3f} s each (renderer reused: {all(f.reused for f in rest)})")


# %%
# Strips of the frames (and the orbit as an animated GIF, written with Pillow).
def strip(paths, path, per_row):
    images = [np.asarray(Image.open(p).convert("RGB")) for p in paths]
    rows = [np.concatenate(images[i:i + per_row], axis=1) for i in range(0, len(images), per_row)]
    rows[-1] = np.pad(rows[-1], ((0, 0), (0, rows[0].shape[1] - rows[-1].shape[1]), (0, 0)))
    Image.fromarray(np.concatenate(rows, axis=0)).save(path)
    h, w = rows[0].shape[0] * len(rows), rows[0].shape[1]
    print(f"saved {path} ({w}x{h})")


strip(series.paths, os.path.join(OUT, "time_series_strip.png"), per_row=STEPS)
strip(orbit.paths, os.path.join(OUT, "orbit_strip.png"), per_row=ORBIT // 2)
frames = [Image.open(p).convert("RGB") for p in orbit.paths]
frames[0].save(os.path.join(OUT, "orbit.gif"), save_all=True, append_images=frames[1:], duration=150, loop=0)
print(f"wrote {os.path.join(OUT, 'orbit.gif')}")
