"""Run by tests/kernels/test_cuda_medium.py in a subprocess with NUMBA_ENABLE_CUDASIM=1 (set before numba
is imported): the medium's per-scene grids on the GPU (Numba's CUDA simulator) against the CPU's —
σt on the data samples and on light grids, the two majorant grids — stage by stage and through
renders. Prints one JSON object."""
import json
import os
import sys
from pathlib import Path

assert os.environ.get("NUMBA_ENABLE_CUDASIM") == "1"
os.environ["PV_AMBIENT_RECORD"] = "0"  # the CPU marches the same ray cast as the GPU (as _cuda_bake_script.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # tests.helpers
import numpy as np  # noqa: E402
import pyvista as pv  # noqa: E402

import pv_ambient as pa  # noqa: E402
from pv_ambient import backend as bk  # noqa: E402
from pv_ambient.inputs.lights import PointLight  # noqa: E402
from pv_ambient.stages import medium as stage_medium  # noqa: E402
from pv_ambient.stages.propagation import make_light_grid, sigma_on_grid  # noqa: E402
from tests.helpers import CAM  # noqa: E402

SIZE = (12, 10)
out = {}


def grid_of(dims):
    """σt a noisy blob on a box of unequal sides and spacings, a scalar ``s`` for a table transfer
    function, an albedo that varies per channel."""
    g = pv.ImageData(dimensions=dims, spacing=(0.2, 0.15, 0.25), origin=(-1.0, -0.8, -1.0))
    rng = np.random.default_rng(4)
    p = g.points
    base = np.clip(1.0 - np.linalg.norm(p, axis=1) / 1.2, 0, None) * (0.4 + rng.random(g.n_points))
    g["sigma_t"] = (6.0 * base).astype(np.float32)
    g["albedo"] = rng.uniform(0.3, 1.0, (g.n_points, 3)).astype(np.float32)
    g["emission"] = np.zeros((g.n_points, 3), np.float32)
    g["s"] = (3.0 * base).astype(np.float32)
    return g


def tf_of(kind):
    """A table transfer function (mode LUT, a non-monotone opacity) or a physical one (mode GRID)."""
    if kind == "physical":
        return pa.TransferFunction.physical()
    return pa.TransferFunction(cmap="viridis", opacity=[0.0, 0.8, 0.1, 0.6], scalars="s")


def rel(a, b):
    return float(np.abs(a - b).max() / max(float(np.abs(b).max()), 1e-30))


ran = []
_medium_grid = bk.medium_grid


def _counting(cache, kind, *a, **k):
    ran.append(kind)
    return _medium_grid(cache, kind, *a, **k)


bk.medium_grid = _counting


def entry(gpu, cpu, cache):
    dev = cache._items.get(id(gpu))
    return {"rel": rel(gpu, cpu), "equal": bool(np.array_equal(gpu, cpu)), "max": float(np.abs(cpu).max()),
            "shape": list(cpu.shape), "dtype": [str(gpu.dtype), str(cpu.dtype)], "device": ran[:],
            "resident": dev is not None and dev[0] is gpu
            and bool(np.array_equal(dev[1].copy_to_host(), gpu))}


# -- stage by stage ----------------------------------------------------------------------------
out["stage"] = {}
for dims in ((9, 11, 7), (16, 16, 16)):
    for kind in ("table", "physical"):
        optics = pa.Renderer(grid_of(dims), transfer_function=tf_of(kind), backend="cpu").optics
        geometry = pa.Renderer(grid_of(dims), transfer_function=tf_of(kind), backend="cpu").geometry
        name = f"{'x'.join(map(str, dims))}/{kind}"
        out["stage"][f"{name}/mode"] = int(optics.mode)
        cache = bk.DeviceCache()
        ran.clear()
        out["stage"][f"{name}/sigma_samples"] = entry(stage_medium.sigma_samples(optics, cache), optics.sigma_grid(),
                                                       cache)
        for f in (1.3, 0.6):
            lg = make_light_grid(geometry, f)
            ran.clear()
            e = entry(sigma_on_grid(optics, lg, cache), sigma_on_grid(optics, lg), cache)
            e["on_samples"] = bool(lg.on_samples(optics.field.shape))
            out["stage"][f"{name}/sigma_nodes/{f}"] = e
        for block in (4, 8):
            ran.clear()
            out["stage"][f"{name}/majorant/{block}"] = entry(stage_medium.majorant_grid(optics, block, cache),
                                                             stage_medium.majorant_grid(optics, block), cache)
            ran.clear()
            out["stage"][f"{name}/cast_majorant/{block}"] = entry(stage_medium.cast_majorant(optics, block, cache),
                                                                  stage_medium.cast_majorant(optics, block), cache)

# -- through renders: the grids made on the device, kept there for the sweeps and the ray cast ----
from numba import cuda as sim_cuda  # noqa: E402

uploaded = []
_to_device = sim_cuda.to_device


def _spy_to_device(arr, *a, **k):
    uploaded.append(arr)
    return _to_device(arr, *a, **k)


sim_cuda.to_device = _spy_to_device
swept = []
_sweep = bk.sweep


def _spy_sweep(cache, sig_l, *a, **k):
    swept.append(sig_l)
    return _sweep(cache, sig_l, *a, **k)


bk.sweep = _spy_sweep
light = [PointLight((0.1, -0.2, 0.05), intensity=(3.0, 2.5, 2.0))]
out["render"] = {}
for kind, lr in (("table", 1.0), ("physical", 1.4)):
    grid = grid_of((10, 12, 9))
    gpu_r = pa.Renderer(grid, transfer_function=tf_of(kind), lights=light, backend="cuda")
    cpu_r = pa.Renderer(grid, transfer_function=tf_of(kind), lights=light, backend="cpu")
    uploaded.clear()
    ran.clear()
    swept.clear()
    kw = dict(camera=CAM, window_size=SIZE, quality="balanced", model="single_scattering", light_resolution=lr)
    b = gpu_r.render(**kw)
    a = cpu_r.render(**kw)
    cache = gpu_r.stages.device_cache
    lgrid = gpu_r.stages.light_grid(lr)
    maj = gpu_r.stages.cast_majorant()
    dev = cache._items.get(id(maj))
    recs = [r for r in cache._records.values() if any(x is maj for x in r[0] if isinstance(x, np.ndarray))]
    # σt on the light grid is dropped from the stages (and the device) before the bake: the sweep's is compared
    sig_cpu = cpu_r.stages.sigma_on_light_grid(lgrid)
    out["render"][f"{kind}/{lr}"] = {
        "image_rel": rel(b.radiance, a.radiance), "backend": b.metadata["backend"], "device": ran[:],
        "max": float(a.radiance.max()), "on_samples": bool(lgrid.on_samples(grid.dimensions)),
        "majorant_rel": rel(maj, cpu_r.stages.cast_majorant()), "majorant_uploaded": any(u is maj for u in uploaded),
        "majorant_resident": dev is not None and dev[0] is maj,
        "ray_cast_reads_majorant": bool(recs) and dev is not None and all(r[1].maj is dev[1] for r in recs),
        "swept": len(swept), "sigma_rel": max(rel(s, sig_cpu) for s in swept),
        "sigma_uploaded": any(u is s for u in uploaded for s in swept),
        "sigma_is_field": any(s is gpu_r.optics.field for s in swept)}
sim_cuda.to_device = _to_device
print("RESULT " + json.dumps(out))
