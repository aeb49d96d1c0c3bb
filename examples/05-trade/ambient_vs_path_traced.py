"""
.. _ambient_vs_path_traced_example:

Speed against accuracy: ambient scattering vs the path tracer
=============================================================

``model="path_traced"`` is the unbiased Monte Carlo reference: its error is pure noise, reported
per pixel in ``RenderResult.std_error``, and it shrinks as 1/√spp. Ambient scattering is
noise-free but biased (it keeps only the light scattered inside a ball around each sample). This
example renders one scene both ways, prints what each costs, and measures the ambient model's
bias against the path tracer's mean, whose own uncertainty is known from ``std_error``.
(``benchmarks/trade.py`` runs the full study against a converged reference.)
"""

# %%
import os

import matplotlib.pyplot as plt
import numpy as np
import pyvista as pv

import pv_ambient as pa
from pv_ambient import datasets

pv.OFF_SCREEN = True
OUT = os.environ.get("PV_AMBIENT_EXAMPLES_OUT", ".")
FAST = os.environ.get("PV_AMBIENT_EXAMPLES_FAST", "0") not in ("", "0")
N = 32 if FAST else 64  # points per axis
SIZE = (96, 96) if FAST else (256, 256)  # pixels per panel
SPP = (4, 16, 64) if FAST else (4, 16, 64, 256)  # path-tracer samples per pixel

# %%
# The cloud scene of ``benchmarks/trade.py``: a forward-scattering cloud (g = 0.6, albedo 0.95)
# under a point light above it.
grid = datasets.cloud(n=N)
tf = pa.TransferFunction(**{**datasets.suggested_style("cloud"), "density_scale": 8.0}, albedo=0.95)
light = pa.PointLight((0.4, 0.6, 2.2), intensity=6.0)
renderer = pa.Renderer(grid, transfer_function=tf, lights=[light])
camera = pa.Camera((0.0, -3.6, 0.8), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), view_angle=30.0)
options = {"camera": camera, "window_size": SIZE, "phase": 0.6}

# %%
# Ambient scattering: the first frame builds the light volume, the ball grid and the table
# slice; a second frame (here the same view) re-runs only the ray cast, as a camera move would.
ambient = renderer.render(model="ambient_scattering", **options)
first = ambient.metadata["time_prepare"] + ambient.metadata["time_render"]
ambient = renderer.render(model="ambient_scattering", **options)
again = ambient.metadata["time_prepare"] + ambient.metadata["time_render"]
print(f"ambient scattering: first frame {first:.2f} s, next frame {again:.2f} s")

# %%
# The path tracer at a few sample counts, each with its own seed. ``metadata["relative_error"]``
# is the image's mean standard error over its mean radiance (over pixels that hit the cloud).
traced = {}
for k, spp in enumerate(SPP):
    res = renderer.render(model="path_traced", samples_per_pixel=spp, seed=k + 1, **options)
    traced[spp] = res
    print(f"path traced {spp:4d} spp: {res.metadata['time']:6.2f} s, "
          f"relative standard error {res.metadata['relative_error']:.3f}")

# %%
# The ambient model's bias: its mean radiance against the best path-traced image's, over the
# pixels that see the cloud. The path tracer's mean is known to ± its standard error (pixels are
# independent, so the standard error of a mean over n pixels is √(Σ se²)/n).
best = traced[SPP[-1]]
inside = (best.alpha > 0.1) & (ambient.alpha > 0.1)
mean_pt = float(best.radiance[inside].mean())
se_mean = float(np.sqrt(np.sum(best.std_error[inside] ** 2)) / best.std_error[inside].size)
bias = float(ambient.radiance[inside].mean()) / mean_pt - 1.0
print(f"ambient scattering bias of the mean: {100 * bias:+.1f} % "
      f"(path-traced mean known to ±{100 * se_mean / mean_pt:.2f} %)")

# %%
# All images under one exposure (the 99th percentile of the ambient image maps to ½); "PT" is
# the path tracer.
white = float(np.percentile(ambient.radiance[ambient.alpha > 0.1].max(axis=-1), 99))
display = {"exposure": float(np.log2(0.5 / white)), "tonemap": "aces", "srgb": True}
path = os.path.join(OUT, "ambient_vs_path_traced.png")
w, h = pa.pyvista.show_panels([ambient, *traced.values()], ["ambient"] + [f"PT {spp} spp" for spp in traced],
                                  path, display=display, font_size=6 if FAST else 12)
print(f"saved {path} ({w}x{h})")

# %%
# The path tracer's noise against its time, on log axes, next to the ideal slope −½ (four times
# the samples halve the error; at few samples the estimated error is itself noisy and tends to be
# low), with the ambient model's frame times and bias for comparison. The right panel maps
# the best image's per-pixel relative standard error.
fig, (ax, ax_map) = plt.subplots(1, 2, figsize=(8.0, 3.2), dpi=100)
times = [res.metadata["time"] for res in traced.values()]
errors = [res.metadata["relative_error"] for res in traced.values()]
ax.loglog(times, errors, "o-", label="path traced: relative std. error")
t_ideal = np.array([times[0], times[-1]])
ax.loglog(t_ideal, errors[-1] * np.sqrt(times[-1] / t_ideal), color="grey", lw=0.8, label="∝ 1/√time")
for spp, t, e in zip(SPP, times, errors):
    ax.annotate(f"{spp} spp", (t, e), textcoords="offset points", xytext=(-12, -12), fontsize=7)
ax.axvline(first, color="C1", ls="--", label=f"ambient, first frame (bias {100 * bias:+.0f} %)")
ax.axvline(again, color="C1", ls=":", label="ambient, next frame")
ax.set_xlabel("time per frame (s)")
ax.set_ylabel("relative error")
ax.legend(fontsize=7, loc="upper right")
rel = np.where(best.radiance > 0, best.std_error / np.maximum(best.radiance, 1e-12), 0.0).mean(axis=-1)
im = ax_map.imshow(np.where(best.alpha > 0.1, rel, np.nan), cmap="viridis", vmin=0.0,
                   vmax=float(np.nanpercentile(np.where(best.alpha > 0.1, rel, np.nan), 99)))
ax_map.set_title(f"std. error / radiance, {SPP[-1]} spp", fontsize=9)
ax_map.set_axis_off()
fig.colorbar(im, ax=ax_map, shrink=0.8)
fig.tight_layout()
path = os.path.join(OUT, "ambient_vs_path_traced_error.png")
fig.savefig(path, dpi=100)
w, h = fig.canvas.get_width_height()
print(f"saved {path} ({w}x{h})")
