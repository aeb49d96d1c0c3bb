"""Run by tests/kernels/test_cuda_bake.py in a subprocess with NUMBA_ENABLE_CUDASIM=1 (set before numba
is imported): the bake of the lights' in-scattering on the GPU (Numba's CUDA simulator) against the
CPU's, stage by stage and through renders. Prints one JSON object."""
import json
import os
import sys
from pathlib import Path

assert os.environ.get("NUMBA_ENABLE_CUDASIM") == "1"
# the GPU marches the bake; the CPU marches it too here, not its lit record (as _cuda_sim_script.py)
os.environ["PV_AMBIENT_RECORD"] = "0"
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # tests.helpers
import numpy as np  # noqa: E402
import pyvista as pv  # noqa: E402

import pv_ambient as pa  # noqa: E402
import pv_ambient.stages.bake as stage_bake  # noqa: E402
from pv_ambient import backend as bk  # noqa: E402
from pv_ambient.inputs.lights import DirectionalLight, PointLight  # noqa: E402
from tests.helpers import CAM  # noqa: E402

SIZE = (12, 10)
out = {}


def grid_of(grey=False, dims=(10, 12, 9)):
    """σt a noisy blob on a box of unequal sides and spacings; the albedo varies per channel (or is
    grey): large enough that every bake is over 4 KiB (the device cache keys smaller arrays by their
    contents, not their identity)."""
    g = pv.ImageData(dimensions=dims, spacing=(0.2, 0.15, 0.25), origin=(-1.0, -0.8, -1.0))
    rng = np.random.default_rng(4)
    p = g.points
    base = np.clip(1.0 - np.linalg.norm(p, axis=1) / 1.2, 0, None) * (0.4 + rng.random(g.n_points))
    g["sigma_t"] = (6.0 * base).astype(np.float32)
    a = np.full((g.n_points, 3), 0.8) if grey else rng.uniform(0.3, 1.0, (g.n_points, 3))
    g["albedo"] = a.astype(np.float32)
    g["emission"] = np.zeros((g.n_points, 3), np.float32)
    return g


POINT_RGB = PointLight((0.1, -0.2, 0.05), intensity=(3.0, 2.5, 2.0))
POINT_GREY = PointLight((0.3, -1.6, 0.9), intensity=2.0)
DIRECTIONAL = DirectionalLight((0.2, 0.3, -1.0), irradiance=0.5)


def captured(grid, lights, model, **kw):
    """The arguments of every stage-level bake of a CPU render."""
    calls = []
    orig = stage_bake.bake_incident

    def spy(*args, **k):
        calls.append((args, {key: v for key, v in k.items() if key != "device_cache"}))
        return orig(*args, **k)

    stage_bake.bake_incident = spy
    try:
        r = pa.Renderer(grid, transfer_function=pa.TransferFunction.physical(), lights=lights, backend="cpu")
        res = r.render(camera=CAM, window_size=SIZE, quality="balanced", model=model, **kw)
    finally:
        stage_bake.bake_incident = orig
    assert res.metadata["baked_lights"], model
    return r, calls


def rel(a, b):
    return float(np.abs(a - b).max() / max(float(np.abs(b).max()), 1e-30))


ran = []
_bake = bk.bake


def _counting(*a, **k):
    ran.append(k.get("fresh"))
    return _bake(*a, **k)


bk.bake = _counting

# -- stage by stage: the device's bake against the CPU's default driver (rows where it applies) -----
CASES = {
    "single_scattering/point/rgb": (grid_of(), [POINT_RGB], "single_scattering", {"light_resolution": 1.0}),
    "single_scattering/point/grey": (grid_of(grey=True), [POINT_GREY], "single_scattering", {"light_resolution": 1.0}),
    "single_scattering/directional": (grid_of(), [DIRECTIONAL], "single_scattering", {"light_resolution": 1.0}),
    "single_scattering/point+directional": (grid_of(), [DIRECTIONAL, POINT_RGB], "single_scattering",
                                            {"light_resolution": 1.0}),
    "single_scattering/finer_grid": (grid_of(dims=(7, 8, 6)), [POINT_RGB, DIRECTIONAL], "single_scattering",
                                     {"light_resolution": 2.0}),
    "ambient_scattering/tube": (grid_of(), [DIRECTIONAL, POINT_RGB], "ambient_scattering",
                                {"light_resolution": 1.0, "propagation": "tube"}),
    "ambient_scattering/grey/finer_grid": (grid_of(grey=True, dims=(7, 8, 6)), [POINT_GREY], "ambient_scattering",
                                           {"light_resolution": 2.0}),
    "diffusion/folded": (grid_of(), [POINT_RGB, DIRECTIONAL], "diffusion", {"light_resolution": 1.0}),
    "diffusion/folded/grey": (grid_of(grey=True), [POINT_GREY], "diffusion", {"light_resolution": 1.0}),
}
out["stage"] = {}
for name, (grid, lights, model, kw) in CASES.items():
    r, calls = captured(grid, lights, model, **kw)
    for i, (args, k) in enumerate(calls):
        cpu, nch = stage_bake.bake_incident(*args, **k)
        ran.clear()
        gpu, nch_g = stage_bake.bake_incident(*args, **k, device_cache=bk.DeviceCache())
        out["stage"][f"{name}/{i}"] = {"rel": rel(gpu, cpu), "nch": [nch, nch_g], "device": bool(ran),
                                       "max": float(np.abs(cpu).max()), "shape": list(cpu.shape),
                                       "fold": args[6] is not None}

# ambient scattering on the data samples: the CPU's row driver reads D per sample in 16 bits, so that
# case stays on the CPU; the GPU's node rule (the ball grid in the records) equals the CPU's node rule
r, calls = captured(grid_of(), [DIRECTIONAL, POINT_RGB], "ambient_scattering", light_resolution=1.0)
args, k = calls[0]
lrec, grec, arec = args[1]
ran.clear()
kept, _ = stage_bake.bake_incident(*args, **k, device_cache=bk.DeviceCache())
out["as_rows_on_cpu"] = {"device": bool(ran), "rel": rel(kept, stage_bake.bake_incident(*args, **k)[0])}
nodes_args = args[:1] + ((lrec, grec, arec._replace(ball=r.stages.ball_grid(arec.radius))),) + args[2:]
nodes_kw = {key: v for key, v in k.items() if key != "dgrid"}
cpu, _ = stage_bake.bake_incident(*nodes_args, **nodes_kw, driver="nodes")
ran.clear()
gpu, _ = stage_bake.bake_incident(*nodes_args, **nodes_kw, driver="nodes", device_cache=bk.DeviceCache())
out["stage"]["ambient_scattering/ball_grid/0"] = {"rel": rel(gpu, cpu), "device": bool(ran), "max": float(cpu.max()),
                                                  "fold": False, "nch": [3, 3], "shape": list(cpu.shape)}
out["as_gpu_nodes_vs_cpu_rows"] = rel(gpu, stage_bake.bake_incident(*args, **k)[0])


# -- through renders: the bake on the GPU, kept there for the ray cast, a relight in place ----------
def bake_of(renderer):
    (key,) = renderer.stages.cache.keys("incident")
    return renderer.stages.cache[key][0]


from numba import cuda as sim_cuda  # noqa: E402

uploaded = []
_to_device = sim_cuda.to_device


def _spy_to_device(arr, *a, **k):
    uploaded.append(arr)
    return _to_device(arr, *a, **k)


sim_cuda.to_device = _spy_to_device
two = [PointLight((0.1, -0.2, 0.05), intensity=(3.0, 2.5, 2.0)), PointLight((-0.4, 0.3, 0.2), intensity=1.5),
       DIRECTIONAL]
moved = [two[0], PointLight((0.35, 0.1, -0.3), intensity=1.5), DIRECTIONAL]
out["render"] = {}
for model, kw in (("single_scattering", {}), ("diffusion", {})):
    grid = grid_of()
    gpu_r = pa.Renderer(grid, transfer_function=pa.TransferFunction.physical(), lights=two, backend="cuda")
    cpu_r = pa.Renderer(grid, transfer_function=pa.TransferFunction.physical(), lights=two, backend="cpu")
    res = {}
    for step, lights in (("first", two), ("relight", moved)):
        gpu_r.set_lights(lights)
        cpu_r.set_lights(lights)
        uploaded.clear()
        ran.clear()
        kw2 = dict(camera=CAM, window_size=SIZE, quality="balanced", model=model, light_resolution=1.0, **kw)
        b = gpu_r.render(**kw2)
        a = cpu_r.render(**kw2)
        inc = bake_of(gpu_r)
        cache = gpu_r.stages.device_cache
        dev = cache._items.get(id(inc))
        in_record = [r for r in cache._records.values() if any(x is inc for x in r[0] if isinstance(x, np.ndarray))]
        res[step] = {"image_rel": rel(b.radiance, a.radiance), "bake_rel": rel(inc, bake_of(cpu_r)),
                     "backend": b.metadata["backend"], "baked": b.metadata["baked_lights"],
                     "device_bake": ran[:], "bake_uploaded": any(u is inc for u in uploaded),
                     "resident": dev is not None and dev[0] is inc,
                     "ray_cast_reads_it": bool(in_record) and dev is not None
                     and all(r[1].inc is dev[1] for r in in_record),
                     "id": id(inc), "max": float(inc.max())}
    # a fresh CPU bake of the moved lights: the relight's in-place rebake equals it
    fresh = pa.Renderer(grid, transfer_function=pa.TransferFunction.physical(), lights=moved, backend="cpu")
    fresh.render(camera=CAM, window_size=SIZE, quality="balanced", model=model, light_resolution=1.0, **kw)
    res["relight_vs_fresh_cpu"] = rel(bake_of(gpu_r), bake_of(fresh))
    res["in_place"] = res["first"]["id"] == res["relight"]["id"]
    out["render"][model] = res
sim_cuda.to_device = _to_device
print("RESULT " + json.dumps(out))
