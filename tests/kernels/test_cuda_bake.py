"""Tests the bake of the lights' in-scattering on the GPU (pv_ambient/_kernels/cuda.py's bake kernels,
pv_ambient.backend.bake, pv_ambient.stages.bake.bake_incident's ``device_cache``), on a machine without
a GPU through Numba's CUDA simulator, in a subprocess that sets ``NUMBA_ENABLE_CUDASIM=1`` before numba
is imported (tests/kernels/_cuda_bake_script.py): every baked model's bake equal to the CPU's, grey
and rgb, point and directional lights; ambient scattering's per-sample D kept on the CPU; a relight
rebaking in place on the device; the ray cast reading the device copy without uploading it."""
import ast
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import pv_ambient as pa

HERE = Path(__file__).resolve().parent
#: Simulator vs CPU (tests/kernels/test_cuda.py's tolerance).
REL_TOL = 1e-6


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    proc = subprocess.run([sys.executable, str(HERE / "_cuda_bake_script.py")], env=env, capture_output=True,
                          text=True, timeout=900)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    line = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")][-1]
    return json.loads(line[len("RESULT "):])


STAGE_CASES = ["single_scattering/point/rgb", "single_scattering/point/grey", "single_scattering/directional",
               "single_scattering/point+directional", "single_scattering/finer_grid", "ambient_scattering/tube",
               "ambient_scattering/grey/finer_grid", "ambient_scattering/ball_grid", "diffusion/folded",
               "diffusion/folded/grey"]


@pytest.mark.parametrize("case", STAGE_CASES)
def test_device_bake_equals_cpu(sim, case):
    runs = {k: v for k, v in sim["stage"].items() if k.rsplit("/", 1)[0] == case}
    assert runs, case
    for r in runs.values():
        assert r["device"]  # baked on the device, not the CPU's fallback
        assert r["nch"][0] == r["nch"][1]
        assert r["max"] > 0.0
        assert r["rel"] <= REL_TOL
        assert r["fold"] == case.startswith("diffusion")


def test_grey_and_rgb_bakes_both_covered(sim):
    nch = {r["nch"][0] for r in sim["stage"].values()}
    assert nch == {1, 3}
    # a point light with a directional one: a slot for each (rgb: 2 × 3 channels)
    assert sim["stage"]["single_scattering/point+directional/0"]["shape"][3] == 6


def test_ambient_scattering_on_samples_stays_on_the_cpu(sim):
    """The CPU's row driver reads D per sample in 16 bits (stages.bake.BallD): 1e-5 of its largest
    value from the node rule's exact lookup, beyond the GPU's tolerance, so that bake stays the CPU's."""
    assert not sim["as_rows_on_cpu"]["device"]
    assert sim["as_rows_on_cpu"]["rel"] == 0.0
    assert sim["as_gpu_nodes_vs_cpu_rows"] <= 1e-5


@pytest.mark.parametrize("model", ["single_scattering", "diffusion"])
def test_render_bakes_on_the_device_and_keeps_it_there(sim, model):
    for step in ("first", "relight"):
        r = sim["render"][model][step]
        assert r["backend"] == "cuda" and r["baked"]
        assert len(r["device_bake"]) == 1  # the bake ran on the device
        assert r["resident"] and r["ray_cast_reads_it"]  # the ray cast reads the bake's device copy
        assert not r["bake_uploaded"]  # ... and never uploads the bake
        assert r["bake_rel"] <= REL_TOL and r["max"] > 0.0
        assert r["image_rel"] <= REL_TOL
    assert sim["render"][model]["first"]["device_bake"] == [True]  # a new device array
    assert sim["render"][model]["relight"]["device_bake"] == [False]  # rebaked in its device copy
    assert sim["render"][model]["in_place"]


def test_relight_equals_a_fresh_cpu_bake(sim):
    """One point light of two moved (and a directional light): only its slot and the directional
    lights' are rebaked, in place on the device, and the bake equals a new CPU renderer's. (Diffusion's
    relight starts its solve warm, so a fresh renderer's field differs by the solver's tolerance; its
    relight is compared with the CPU's relight above.)"""
    assert sim["render"]["single_scattering"]["relight_vs_fresh_cpu"] <= REL_TOL


def test_bake_kernels_hold_no_physics():
    """The bake's kernels find their node and call the CPU driver's per-node scalar
    (pv_ambient/_kernels/bake.py): the physics exists once."""
    src = (Path(pa.__file__).parent / "_kernels" / "cuda.py").read_text()
    scalars = {"bake": "bake_node", "fold_kernel": "fold_node", "clear_kernel": "clear_node"}
    kernels = {n.name: n for n in ast.walk(ast.parse(src)) if isinstance(n, ast.FunctionDef) and n.name in scalars}
    assert set(kernels) == set(scalars)
    for name, node in kernels.items():
        called = [c.func.id if isinstance(c.func, ast.Name) else c.func.attr for c in ast.walk(node)
                  if isinstance(c, ast.Call)]
        assert sorted(called) == sorted(["grid", scalars[name]]), (name, called)
        assert not any(isinstance(b, ast.BinOp) for b in ast.walk(node)), name
