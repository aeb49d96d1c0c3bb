"""Run by tests/kernels/test_cuda_ball.py in a subprocess with NUMBA_ENABLE_CUDASIM=1 (set before numba
is imported): ambient scattering's ball grid on the GPU (Numba's CUDA simulator) against the CPU's —
stage by stage (grids, transfer functions, albedos, radii) and through renders whose ray cast or
bake reads it. Prints one JSON object."""
import json
import os
import sys
import time
from pathlib import Path

assert os.environ.get("NUMBA_ENABLE_CUDASIM") == "1"
os.environ["PV_AMBIENT_RECORD"] = "0"  # the CPU marches the same ray cast as the GPU (as _cuda_bake_script.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # tests.helpers
import numpy as np  # noqa: E402
import pyvista as pv  # noqa: E402

import pv_ambient as pa  # noqa: E402
import pv_ambient.device_stages as dev_stages  # noqa: E402
from pv_ambient import backend as bk  # noqa: E402
from pv_ambient.inputs.lights import PointLight  # noqa: E402
from pv_ambient.stages.ball import ball_on_device  # noqa: E402
from tests.helpers import CAM  # noqa: E402

SIZE = (12, 10)
out = {}


def grid_of(dims, grey=False):
    """σt a noisy blob on a box of unequal sides and spacings, a scalar ``s`` for a table transfer
    function, an albedo that varies per channel (or a grey one)."""
    g = pv.ImageData(dimensions=dims, spacing=(0.2, 0.15, 0.25), origin=(-1.0, -0.8, -1.0))
    rng = np.random.default_rng(4)
    p = g.points
    base = np.clip(1.0 - np.linalg.norm(p, axis=1) / 1.2, 0, None) * (0.4 + rng.random(g.n_points))
    g["sigma_t"] = (6.0 * base).astype(np.float32)
    alb = rng.uniform(0.3, 1.0, (g.n_points, 3)).astype(np.float32)
    g["albedo"] = np.repeat(alb[:, :1], 3, axis=1) if grey else alb
    g["emission"] = np.zeros((g.n_points, 3), np.float32)
    g["s"] = (3.0 * base).astype(np.float32)
    return g


def tf_of(kind, grey=False):
    """A table transfer function (mode LUT: albedo the colour map's, or a grey constant) or a
    physical one (mode GRID, the grid's albedo)."""
    if kind == "physical":
        return pa.TransferFunction.physical()
    return pa.TransferFunction(cmap="viridis", opacity=[0.0, 0.8, 0.1, 0.6], scalars="s",
                               albedo=(0.7, 0.7, 0.7) if grey else 1.0)


def rel(a, b):
    return float(np.abs(a - b).max() / max(float(np.abs(b).max()), 1e-30))


def ball_diff(gpu, cpu):
    """σ̄'s relative difference; the mean scattering σ̄·ā per channel relative to the largest σ̄ (what
    the ball's albedo stands for: a ratio whose own relative error grows as ε·max σ̄/σ̄ at the medium's
    fringe, where the box means' rounding is a larger part of σ̄); ā's largest absolute difference,
    everywhere and where σ̄ is at least 1 % of its largest."""
    top = max(float(cpu[..., 0].max()), 1e-30)
    dense = cpu[..., 0] >= 0.01 * top
    return {"sbar_rel": rel(gpu[..., 0], cpu[..., 0]),
            "ms_rel": max(float(np.abs(gpu[..., 0] * gpu[..., c] - cpu[..., 0] * cpu[..., c]).max()) / top
                          for c in (1, 2, 3)),
            "albedo_abs": float(np.abs(gpu[..., 1:] - cpu[..., 1:]).max()),
            "albedo_abs_dense": float(np.abs(gpu[..., 1:] - cpu[..., 1:])[dense].max()) if dense.any() else 0.0}


ran = []
_ball_grid = dev_stages.ball_grid


def _counting(cache, *a, **k):
    ran.append(1)
    return _ball_grid(cache, *a, **k)


dev_stages.ball_grid = _counting

t0 = time.perf_counter()
# -- stage by stage ----------------------------------------------------------------------------
out["stage"] = {}
for dims in ((9, 11, 7),):  # 16³ adds minutes in the simulator and nothing the small grid misses
    for kind in ("table", "physical"):
        for albedo in ("rgb", "grey"):
            grey = albedo == "grey"
            cpu_r = pa.Renderer(grid_of(dims, grey), transfer_function=tf_of(kind, grey), backend="cpu")
            optics = cpu_r.optics
            for radius in (0.37, 1.1):
                cache = bk.DeviceCache()
                ran.clear()
                sigma = cpu_r.stages.sigma_samples()
                gpu = ball_on_device(optics, sigma, cpu_r.geometry.spacing, radius, cache)
                cpu = cpu_r.stages.ball_grid(radius)
                dev = cache._items.get(id(gpu))
                out["stage"][f"{'x'.join(map(str, dims))}/{kind}/{albedo}/{radius}"] = {
                    **ball_diff(gpu, cpu), "equal_grey": bool(np.array_equal(gpu[..., 1], gpu[..., 3])),
                    "max": float(cpu[..., 0].max()), "device": len(ran), "dtype": str(gpu.dtype),
                    "shape": list(gpu.shape) == list(cpu.shape), "mode": int(optics.mode),
                    "same": list(optics.albedo_same_as_previous()),
                    "resident": dev is not None and dev[0] is gpu and bool(np.array_equal(dev[1].copy_to_host(), gpu))}

out["stage_s"] = time.perf_counter() - t0
# -- through renders: the ball grid made on the device, read there by the ray cast or the bake ---
from numba import cuda as sim_cuda  # noqa: E402

uploaded = []
_to_device = sim_cuda.to_device


def _spy_to_device(arr, *a, **k):
    uploaded.append(arr)
    return _to_device(arr, *a, **k)


sim_cuda.to_device = _spy_to_device
light = [PointLight((0.1, -0.2, 0.05), intensity=(3.0, 2.5, 2.0))]
RENDERS = {  # name: (transfer function, phase, light resolution)
    "aniso/table": ("table", 0.5, 1.0),  # the ray cast reads the ball per sample
    "aniso/physical": ("physical", 0.5, 1.0),
    "iso/physical/finer": ("physical", 0.0, 2.0),  # the bake reads the ball on a finer light grid
}
out["render"] = {}
for name, (kind, g, lr) in RENDERS.items():
    grid = grid_of((10, 12, 9))
    gpu_r = pa.Renderer(grid, transfer_function=tf_of(kind), lights=light, backend="cuda")
    cpu_r = pa.Renderer(grid, transfer_function=tf_of(kind), lights=light, backend="cpu")
    uploaded.clear()
    ran.clear()
    kw = dict(camera=CAM, window_size=SIZE, quality="balanced", model="ambient_scattering", light_resolution=lr,
              phase=g, radius=0.3)
    b = gpu_r.render(**kw)
    a = cpu_r.render(**kw)
    cache = gpu_r.stages.device_cache
    ball = gpu_r.stages.cache[("ball", 0.3)]
    dev = cache._items.get(id(ball))
    recs = [r for r in cache._records.values() if any(x is ball for x in r[0] if isinstance(x, np.ndarray))]
    out["render"][name] = {
        "image_rel": rel(b.radiance, a.radiance), "backend": b.metadata["backend"], "max": float(a.radiance.max()),
        "baked": b.metadata["baked_lights"], "device": len(ran),
        **ball_diff(ball, cpu_r.stages.cache[("ball", 0.3)]), "ball_uploaded": any(u is ball for u in uploaded),
        "ball_resident": dev is not None and dev[0] is ball,
        "read_on_device": bool(recs) and dev is not None and all(r[1].ball is dev[1] for r in recs)}
sim_cuda.to_device = _to_device
out["render_s"] = time.perf_counter() - t0 - out["stage_s"]
print("RESULT " + json.dumps(out))
