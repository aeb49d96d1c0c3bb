"""Run by tests/kernels/test_cuda.py in a subprocess with NUMBA_ENABLE_CUDASIM=1 (set before numba is
imported): every model on backend="cuda" (Numba's CUDA simulator) against backend="cpu", through
the API and through the CLI's JSON scene. Prints one JSON object."""
import json
import os
import sys
import warnings
from pathlib import Path

assert os.environ.get("NUMBA_ENABLE_CUDASIM") == "1"
# The GPU marches the bake; the CPU marches it too here, not its lit record (docs/performance.rst,
# "Lit record": the light to 16-bit codes, within 2e-4 of the bake's image, which
# tests/rendering/test_record.py checks)
os.environ["PV_AMBIENT_RECORD"] = "0"
import numpy as np  # noqa: E402

import pv_ambient as pa  # noqa: E402
from pv_ambient import backend as bk  # noqa: E402
from pv_ambient import device_cache as dc  # noqa: E402
from pv_ambient import datasets  # noqa: E402
from pv_ambient.cli import main  # noqa: E402

out = {}
grid = datasets.supernova(n=10)
tf = {"kind": "colormap", "cmap": "magma", "clim": [0.0, 1.0], "opacity": "linear", "albedo": 0.9,
      "emission": 0.1, "opacity_unit_distance": 0.3}
lights = [pa.PointLight((0.15, 0.05, 0.0), 3.0), pa.DirectionalLight((1.0, -0.5, -0.3), 0.5)]
cams = [None, {"position": (3.0, -2.0, 1.5), "focal_point": (0, 0, 0), "view_up": (0, 0, 1)}]
cpu = pa.Renderer(grid, transfer_function=tf, lights=lights, backend="cpu")
gpu = pa.Renderer(grid, transfer_function=tf, lights=lights, backend="cuda")
CASES = [("emission_absorption", {}), ("ambient_occlusion", {}), ("single_scattering", {"phase": 0.5}),
         ("ambient_scattering", {}), ("ambient_scattering", {"propagation": "tube"}),
         ("diffusion", {"flux_limited": True}), ("ambient_scattering", {"phase": 0.5}), ("diffusion", {"phase": 0.5}), ("path_traced", {"samples_per_pixel": 2, "max_depth": 4}),
         ("progressive", {"samples_per_pixel": 2, "max_depth": 4}),
         ("single_scattering", {"jitter": True, "seed": 7})]
from numba.cuda.simulator.kernel import FakeCUDAKernel  # noqa: E402

from pv_ambient._kernels import cuda as kc  # noqa: E402

out["raycast_kernels"] = sorted(kc.RAYCAST_KERNELS)
# the float32 switch: False where the CPU compiles a scalar function, True in its device version
from pv_ambient._kernels import raycast as kr  # noqa: E402
from pv_ambient._kernels._jit import ON_GPU, cuda_device  # noqa: E402

out["on_gpu"] = [ON_GPU, kr.direct_light_with.py_func.__globals__["ON_GPU"],
                 cuda_device(kr.direct_light_with).fn.__globals__["ON_GPU"]]
spec_of = {id(k): list(spec) for spec, k in kc.RAYCAST_KERNELS.items()}
_launches = []
_call = FakeCUDAKernel.__call__


def _recording_call(self, *args):
    if id(self) in spec_of:
        _launches.append(spec_of[id(self)])
    return _call(self, *args)


FakeCUDAKernel.__call__ = _recording_call
out["launched"] = {}
for model, opts in CASES:
    for c, cam in enumerate(cams[:2] if model == "ambient_scattering" and not opts else cams[:1]):
        kw = dict(window_size=(12, 10), model=model, quality="preview", camera=cam, **opts)
        a = cpu.render(**kw)
        _launches.clear()
        b = gpu.render(**kw)
        scale = max(float(np.abs(a.radiance).max()), 1e-30)
        name = f"{model}{'/' + ','.join(f'{k}={v}' for k, v in opts.items()) if opts else ''}/cam{c}"
        out[name] = {"rel": float(np.abs(a.radiance - b.radiance).max() / scale),
                     "alpha": float(np.abs(a.alpha - b.alpha).max()), "backend": b.metadata["backend"],
                     "cpu_backend": a.metadata["backend"], "mean": float(a.radiance.mean()),
                     "device_memory": int(b.metadata.get("device_memory", 0))}
        out["launched"][name] = sorted({tuple(x) for x in _launches})
# device-resident: a camera move uploads no new volume (the same device arrays are reused)
cache = gpu.device_cache
before = {k: id(d) for k, (h, d, t) in cache._items.items() if h.nbytes > 4096}
gpu.render(window_size=(12, 10), model="ambient_scattering", quality="preview", camera=cams[1])
after = {k: id(d) for k, (h, d, t) in cache._items.items() if h.nbytes > 4096}
out["camera_move_reuploads"] = sum(1 for k in before if k in after and after[k] != before[k])
out["camera_move_kept"] = sum(1 for k in before if k in after)

# host work of a camera move (docs/performance.rst, "Host work of a frame"): the records already on
# the device are found whole (only the camera's, which moved, is mapped), one upload (the camera's
# parameters), one download, no free-memory query, no BLAS limit; a first frame computes stages
# on the CPU and enters the BLAS limit once
from numba import cuda as sim_cuda  # noqa: E402
from numba.cuda.simulator.cudadrv.devicearray import FakeCUDAArray  # noqa: E402

from pv_ambient._kernels import records as krec  # noqa: E402

events = {"mapped": [], "uploads": 0, "downloads": 0, "mem_queries": 0, "blas": 0}
real = {"map_arrays": krec.map_arrays, "to_device": sim_cuda.to_device, "copy_to_host": FakeCUDAArray.copy_to_host,
        "free": dc.free_device_memory, "blas": bk.blas_one_thread}


def _mapped(fn, record, _depth=[0]):
    if _depth[0] == 0:
        events["mapped"].append(type(record).__name__)
    _depth[0] += 1
    try:
        return real["map_arrays"](fn, record)
    finally:
        _depth[0] -= 1


def _counted(name, key):
    def call(*a, **k):
        events[key] += 1
        return real[name](*a, **k)
    return call


krec.map_arrays = _mapped
sim_cuda.to_device = _counted("to_device", "uploads")
FakeCUDAArray.copy_to_host = _counted("copy_to_host", "downloads")
dc.free_device_memory = _counted("free", "mem_queries")
bk.blas_one_thread = _counted("blas", "blas")
fresh = pa.Renderer(grid, transfer_function=tf, lights=lights, backend="cuda")
fresh.render(window_size=(12, 10), model="emission_absorption", quality="preview")
out["first_frame"] = dict(events, mapped=sorted(set(events["mapped"])))
moved = {"position": (2.5, -2.5, 2.0), "focal_point": (0, 0, 0), "view_up": (0, 0, 1)}
for cam in (cams[1], moved):  # the second: a camera no render has used
    events.update(mapped=[], uploads=0, downloads=0, mem_queries=0, blas=0)
    res = gpu.render(window_size=(12, 10), model="single_scattering", quality="preview", camera=cam)
out["camera_move"] = dict(events)
ref = cpu.render(window_size=(12, 10), model="single_scattering", quality="preview", camera=moved)
out["camera_move"]["rel"] = float(np.abs(ref.radiance - res.radiance).max() / np.abs(ref.radiance).max())
krec.map_arrays, sim_cuda.to_device, FakeCUDAArray.copy_to_host = real["map_arrays"], real["to_device"], real["copy_to_host"]
dc.free_device_memory, bk.blas_one_thread = real["free"], real["blas"]

# memory: a scene that does not fit -> clear error with "cuda", CPU fallback with a warning under "auto"
dc.free_device_memory = lambda: 1000.0
small = pa.Renderer(grid, transfer_function=tf)
try:
    small.render(window_size=(8, 8), backend="cuda")
    out["oom_error"] = None
except bk.DeviceMemoryError as exc:
    out["oom_error"] = str(exc)
with warnings.catch_warnings(record=True) as w:
    warnings.simplefilter("always")
    res = small.render(window_size=(8, 8), backend="auto")
out["oom_auto_backend"] = res.metadata["backend"]
out["oom_auto_warning"] = [str(x.message) for x in w if "CPU" in str(x.message)]
dc.free_device_memory = lambda: float("inf")

# CLI: the JSON scene's "backend" and --backend
tmp = Path(sys.argv[1])
scene = {"version": 1, "volume": {"dataset": "cloud", "n": 10}, "model": "ambient_scattering",
         "transfer_function": tf, "lights": [{"kind": "point", "position": [0.2, 0.1, 0.0], "intensity": 2.0}],
         "image": {"width": 10, "height": 8}, "quality": "preview", "backend": "cuda"}
(tmp / "scene.json").write_text(json.dumps(scene))
rc1 = main(["render", str(tmp / "scene.json"), "-o", str(tmp / "gpu.png"), "--radiance", str(tmp / "gpu.npy")])
rc2 = main(["render", str(tmp / "scene.json"), "-o", str(tmp / "cpu.png"), "--radiance", str(tmp / "cpu.npy"),
            "--backend", "cpu"])
g_img, c_img = np.load(tmp / "gpu.npy"), np.load(tmp / "cpu.npy")
out["cli"] = {"rc": [rc1, rc2], "rel": float(np.abs(g_img - c_img).max() / max(np.abs(c_img).max(), 1e-30)),
              "mean": float(c_img.mean())}
print("RESULT " + json.dumps(out))
