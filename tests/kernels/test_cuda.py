"""Tests pv_ambient/_kernels/cuda.py: the same scalar kernels on the GPU (docs/architecture.rst), checked on
a machine without a GPU through Numba's CUDA simulator, in a subprocess that sets
``NUMBA_ENABLE_CUDASIM=1`` before numba is imported (tests/kernels/_cuda_sim_script.py): every model
equal to the CPU's through the API and the CLI, device-resident caches, the drivers holding no
physics. The backend's errors and fallback: tests/test_backend.py."""
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import pv_ambient as pa

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
          "diffusion/flux_limited=True/cam0", "ambient_scattering/phase=0.5/cam0", "diffusion/phase=0.5/cam0", "path_traced/samples_per_pixel=2,max_depth=4/cam0",
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


def test_camera_move_host_work(sim):
    """A camera move's host work is what the frame needs (docs/performance.rst, "Host work of a
    frame"): until 0.4.0 every launch walked every record's arrays, asked the GPU for its free
    memory, downloaded radiance and alpha apart and entered threadpoolctl's BLAS limit."""
    out, _ = sim
    move = out["camera_move"]
    assert move["mapped"] == ["View"]  # the camera's record; the volume's, lights' and tables' found whole
    assert move["uploads"] == 1  # the camera's 16 parameters
    assert move["downloads"] == 1 and move["mem_queries"] == 0 and move["blas"] == 0
    assert move["rel"] <= REL_TOL
    # a new scene: uploads, after asking whether they fit; the ray cast's majorant grid made on the
    # device (its own fit check, and its host copy downloaded: tests/kernels/test_cuda_medium.py)
    first = out["first_frame"]
    assert first["mem_queries"] == 2 and first["uploads"] > 1 and first["blas"] == 1 and first["downloads"] == 2
    assert "Medium" in first["mapped"]


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


def test_physics_exists_once():
    """Every CUDA kernel body only finds its thread's pixel and calls the CPU driver's per-pixel
    scalar: the physics exists once. The kernels are written in the module file (no generated
    source: Numba's disk cache keeps them), and the ray cast has one kernel per specialisation, as
    the CPU has one driver per specialisation."""
    import ast
    import inspect

    src = (Path(pa.__file__).parent / "_kernels" / "cuda.py").read_text()
    assert "exec(" not in src and "math." not in src and "exp(" not in src
    kernels = {n.name: n for n in ast.walk(ast.parse(src)) if isinstance(n, ast.FunctionDef)
               and any(isinstance(c, ast.Attribute) and c.attr == "grid" for c in ast.walk(n))
               and not any(isinstance(c, ast.FunctionDef) for c in ast.walk(n) if c is not n)}
    scalars = {"raycast": "raycast_pixel", "pathtrace_kernel": "pathtrace_pixel", "residual_kernel": "residual_pixel",
               "sweep_layer_kernel": "sweep_node", "bake": "bake_node", "fold_kernel": "fold_node",
               "clear_kernel": "clear_node", "sigma_samples_kernel": "sigma_sample_node",
               "sigma_nodes_kernel": "sigma_node", "majorant_kernel": "majorant_block",
               "cast_majorant_kernel": "cast_majorant_block", "scattering_kernel": "scattering_sample",
               "box_mean_kernel": "box_mean_line", "ball_channel_kernel": "ball_channel_node"}
    assert set(kernels) == set(scalars)
    for name, node in kernels.items():
        called = [c.func.id if isinstance(c.func, ast.Name) else c.func.attr for c in ast.walk(node)
                  if isinstance(c, ast.Call)]
        assert sorted(called) == sorted(["grid", scalars[name]]), (name, called)
        # no arithmetic but the thread's row offset (none in the bake's node kernels: a 3-D grid)
        rows = 0 if scalars[name] not in ("raycast_pixel", "pathtrace_pixel", "residual_pixel", "sweep_node") else 1
        assert sum(isinstance(b, ast.BinOp) for b in ast.walk(node)) == rows, name

    from pv_ambient._kernels import lightvol, majorant, medium, pathtrace, raycast, residual, sat

    assert "raycast_pixel(" in inspect.getsource(raycast.raycast_driver)
    assert "pathtrace_pixel(" in inspect.getsource(pathtrace.pathtrace_image.py_func)
    assert "sweep_node(" in inspect.getsource(lightvol.sweep_tau.py_func)
    assert "residual_pixel(" in inspect.getsource(residual.residual_image.py_func)
    # the medium's grids (tests/kernels/test_cuda_medium.py): the CPU drivers' loop bodies
    assert "sigma_node(" in inspect.getsource(lightvol.sample_sigma_grid.py_func)
    assert "table_column(" in inspect.getsource(medium.classify_columns.py_func)
    assert "table_column(" in inspect.getsource(medium.sigma_sample_node.py_func)
    # the ball grid (tests/kernels/test_cuda_ball.py): the CPU passes' and albedo's loop bodies
    assert "interval_mean(" in inspect.getsource(sat.box_mean_plane.py_func)
    assert "interval_mean(" in inspect.getsource(sat.box_mean_z.py_func)
    assert "interval_mean(" in inspect.getsource(sat.box_mean_line.py_func)
    assert "ball_albedo_value(" in inspect.getsource(sat.ball_albedo_into.py_func)
    assert "ball_albedo_value(" in inspect.getsource(sat.ball_channel_node.py_func)
    assert "scattering_lut(" in inspect.getsource(medium.scattering_column.py_func)
    assert "scattering_lut(" in inspect.getsource(medium.scattering_sample.py_func)
    assert "majorant_block(" in inspect.getsource(majorant.build_majorant.py_func)
    assert "cast_majorant_block(" in inspect.getsource(majorant.build_cast_majorant.py_func)
    # the scene travels in the records of _kernels/records.py, not in ~40 positional arguments
    for fn in (raycast.raycast_pixel, pathtrace.pathtrace_pixel):  # besides a specialisation's constants
        params = [p for p in inspect.signature(fn.py_func).parameters if p not in ("model", "baked", "mode")]
        assert len(params) <= 11, fn


def test_float32_switch_is_bound_on_the_gpu_only(sim):
    """``_jit.ON_GPU`` is False in the scalar functions the CPU compiles and True in their CUDA device
    versions (the simulator's here): the GPU's float32 branches (the per-light phase function,
    transmittance and ball term) run only there, and the CPU's images are those of its float64 branch."""
    out, _ = sim
    assert out["on_gpu"] == [False, False, True]


def test_one_kernel_per_specialisation(sim):
    """The CUDA side compiles one ray-cast kernel per specialisation (model, baked lights, medium
    mode), the CPU one driver per model, and each model's render launched its own kernel."""
    from pv_ambient._kernels import raycast
    from pv_ambient._kernels.models import RECORD, RECORD_GREY, RECORD_PAIR

    out, _ = sim
    assert [tuple(k) for k in out["raycast_kernels"]] == sorted(raycast.SPECIALISATIONS)
    # the CPU: one driver per model, and one per lit record's march (the scalar fallback reads them)
    assert sorted(raycast.RAYCAST_DRIVERS) == sorted(raycast.RAYCAST_MODELS + (RECORD, RECORD_PAIR, RECORD_GREY))
    launched = out["launched"]
    assert launched["emission_absorption/cam0"] == [[0, 0, 0]]
    assert launched["ambient_occlusion/cam0"] == [[1, 0, 0]]
    assert launched["single_scattering/phase=0.5/cam0"] == [[2, 0, 0]]  # anisotropic: not baked
    assert launched["ambient_scattering/cam0"] == [[2, 1, 0]]  # isotropic: baked, marched as baked SS
    assert launched["diffusion/flux_limited=True/cam0"] in ([[4, 1, 0]], [[2, 1, 0]])
    assert launched["ambient_scattering/phase=0.5/cam0"] == [[3, 0, 0]]
    assert launched["diffusion/phase=0.5/cam0"] == [[4, 0, 0]]
