"""The CUDA backend: the same scalar kernels on the GPU (docs/architecture.rst), checked on a machine without
a GPU through Numba's CUDA simulator, in a subprocess that sets ``NUMBA_ENABLE_CUDASIM=1`` before
numba is imported (tests/_cuda_sim_script.py); plus the error messages and the array core
without pyvista/vtk."""
import json
import os
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient import backend as bk
from pv_ambient import datasets

HERE = Path(__file__).resolve().parent
#: Simulator vs CPU: the same float64 code (Python floats vs compiled), written as float32.
REL_TOL = 1e-6


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("cudasim")
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    proc = subprocess.run([sys.executable, str(HERE / "_cuda_sim_script.py"), str(tmp)], env=env,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    line = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")][-1]
    return json.loads(line[len("RESULT "):]), proc.stdout


MODELS = ["emission_absorption/cam0", "ambient_occlusion/cam0", "single_scattering/phase=0.5/cam0",
          "ambient_scattering/cam0", "ambient_scattering/cam1", "ambient_scattering/propagation=tube/cam0",
          "diffusion/flux_limited=True/cam0", "path_traced/samples_per_pixel=2,max_depth=4/cam0",
          "progressive/samples_per_pixel=2,max_depth=4/cam0",
          "single_scattering/jitter=True,seed=7/cam0"]


@pytest.mark.parametrize("case", MODELS)
def test_every_model_on_cuda_equals_cpu(sim, case):
    out, _ = sim
    r = out[case]
    assert r["backend"] == "cuda" and r["cpu_backend"] == "cpu"
    assert r["mean"] > 1e-3  # a lit, non-trivial image
    assert r["rel"] <= REL_TOL
    assert r["alpha"] <= REL_TOL
    assert r["device_memory"] > 0


def test_device_resident_caches(sim):
    out, _ = sim
    # a camera move reuses every volume already on the device (no re-upload)
    assert out["camera_move_kept"] >= 5
    assert out["camera_move_reuploads"] == 0


def test_device_memory_error_and_auto_fallback(sim):
    out, _ = sim
    assert out["oom_error"] and "more device memory" in out["oom_error"] and "backend='cpu'" in out["oom_error"]
    assert out["oom_auto_backend"] == "cpu"
    assert out["oom_auto_warning"] and "rendering on the CPU instead" in out["oom_auto_warning"][0]


def test_cli_scene_backend(sim):
    out, stdout = sim
    assert out["cli"]["rc"] == [0, 0]
    assert out["cli"]["mean"] > 1e-4
    assert out["cli"]["rel"] <= REL_TOL
    assert "on cuda" in stdout and "on cpu" in stdout  # the scene's "backend", then --backend cpu


def test_missing_package_error(monkeypatch):
    monkeypatch.delenv("NUMBA_ENABLE_CUDASIM", raising=False)
    monkeypatch.setitem(sys.modules, "numba_cuda", None)  # import numba_cuda -> ImportError
    with pytest.raises(ImportError, match=r"numba-cuda package, which is not installed: pip install \"pv_ambient\[cuda\]\""):
        pa.render(datasets.cloud(n=8), window_size=(4, 4), backend="cuda")
    # auto falls back to the CPU silently and says so in the metadata
    res = pa.render(datasets.cloud(n=8), window_size=(4, 4), backend="auto")
    assert res.metadata["backend"] == "cpu"


def test_no_device_error(monkeypatch):
    from numba import cuda

    monkeypatch.delenv("NUMBA_ENABLE_CUDASIM", raising=False)
    monkeypatch.setitem(sys.modules, "numba_cuda", types.ModuleType("numba_cuda"))
    monkeypatch.setattr(cuda, "is_available", lambda: False)
    with pytest.raises(RuntimeError, match="numba-cuda is installed but no CUDA device is visible"):
        pa.Renderer(datasets.cloud(n=8), backend="cuda").render(window_size=(4, 4))
    assert bk.resolve_backend("auto") == "cpu"


def test_numba_cuda_that_needs_numpy_row_stack(monkeypatch):
    # numba-cuda 0.30.4 compiled kernels through numpy.row_stack, which NumPy 2.5 removed (seen on an
    # H100: benchmarks/results/gpu.txt): backend='cuda' says so before any work, 'auto' takes the CPU
    monkeypatch.delenv("NUMBA_ENABLE_CUDASIM", raising=False)
    fake = types.ModuleType("numba_cuda")
    fake.__version__ = "0.30.4"
    monkeypatch.setitem(sys.modules, "numba_cuda", fake)
    monkeypatch.delattr(np, "row_stack", raising=False)
    with pytest.raises(ImportError, match=r"numba-cuda 0\.30\.4 compiles kernels through numpy\.row_stack.*numpy<2\.5"):
        pa.render(datasets.cloud(n=8), window_size=(4, 4), backend="cuda")
    assert bk.resolve_backend("auto") == "cpu"
    assert bk.numpy_clash("0.31.0") is None and bk.numpy_clash(None) is None


def test_bad_backend_name():
    with pytest.raises(ValueError, match="backend"):
        pa.Renderer(datasets.cloud(n=8), backend="gpu")


def test_array_core_without_pyvista_and_vtk():
    code = r"""
import sys
for name in ("pyvista", "vtk", "vtkmodules"):
    sys.modules[name] = None  # import fails
import numpy as np
import pv_ambient as pa
from pv_ambient.inputs.grid import Volume
x, y, z = np.meshgrid(*(np.linspace(-1, 1, 12),) * 3, indexing="ij")
vol = Volume(np.exp(-4 * (x * x + y * y + z * z)).astype(np.float32), spacing=(2 / 11,) * 3, origin=(-1,) * 3)
tf = pa.TransferFunction.from_table([0.0, 1.0], sigma_t=[0.0, 8.0], albedo=0.9, color=[[0, 0, 0], [1, 1, 1]])
r = pa.Renderer(vol, transfer_function=tf, lights=[pa.PointLight((0, 0, 2.0), 4.0)])
cam = pa.Camera((0, -4, 0), (0, 0, 0), (0, 0, 1))
for model in ("emission_absorption", "single_scattering", "ambient_scattering", "diffusion"):
    res = r.render(camera=cam, window_size=(8, 8), model=model, quality="preview")
    assert res.radiance.max() > 0, model
loaded = sorted(m for m in sys.modules if m.split(".")[0] in ("pyvista", "vtk", "vtkmodules") and sys.modules[m])
print("OK", loaded, hasattr(pa, "add_ambient_volume"))
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.strip() == "OK [] False"


def test_physics_exists_once():
    """Every CUDA driver body only indexes threads and calls the CPU driver's per-pixel scalar."""
    import inspect

    src = (Path(pa.__file__).parent / "_kernels" / "cuda.py").read_text()
    from pv_ambient._kernels import lightvol, pathtrace, raycast

    # the kernels are generated from the scalars' signatures: the source holds no call with arguments
    for scalar in ("raycast_pixel", "pathtrace_pixel", "sweep_node"):
        assert f"{scalar}(" not in src, scalar
    from pv_ambient._kernels.cuda import grid_source

    gen = grid_source(raycast.raycast_pixel, "i", "j", "out_alpha")
    assert gen.count("scalar(") == 1 and "exp" not in gen and ", j, i," in gen

    assert "raycast_pixel(" in inspect.getsource(raycast.raycast_image.py_func)
    assert "pathtrace_pixel(" in inspect.getsource(pathtrace.pathtrace_image.py_func)
    assert "sweep_node(" in inspect.getsource(lightvol.sweep_tau.py_func)
    assert "math." not in src and "exp(" not in src  # no arithmetic of the physics in the drivers
    # the scene travels in the records of _kernels/records.py, not in ~40 positional arguments
    from pv_ambient._kernels import residual

    assert "residual_pixel(" not in src
    assert "residual_pixel(" in inspect.getsource(residual.residual_image.py_func)
    for fn in (raycast.raycast_pixel, pathtrace.pathtrace_pixel):
        assert len(inspect.signature(fn.py_func).parameters) <= 12, fn


def test_records_arrays_and_map_arrays():
    """The kernels' argument records: every array inside nested records is found, and replaced in
    place by map_arrays (DeviceCache.args) with the record types kept."""
    from pv_ambient._kernels import records as K

    a, b, c, d = np.zeros(3), np.ones((2, 2)), np.zeros((1, 1, 1)), np.zeros((2, 1, 1))
    args = (3, K.Diffusion(a, 0.5), (b, 2.0, K.Paths(c, 4, 2, 7, 1, d, 0.5)))
    assert [x is y for x, y in zip(K.arrays(args), (a, b, c, d))] == [True] * 4
    out = K.map_arrays(lambda x: x.shape, args)
    assert out == (3, K.Diffusion((3,), 0.5), ((2, 2), 2.0, K.Paths((1, 1, 1), 4, 2, 7, 1, (2, 1, 1), 0.5)))
    assert type(out[1]) is K.Diffusion and type(out[2][2]) is K.Paths
