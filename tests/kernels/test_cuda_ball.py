"""Tests ambient scattering's ball grid on the GPU (pv_ambient/_kernels/cuda.py's scattering, box-mean
and ball-channel kernels, pv_ambient.device_stages.ball_grid, pv_ambient.stages.ball.ball_on_device):
σ̄ and the ball's mean albedo equal to the CPU's on non-cubic and cubic tiny grids, for a table and a
physical transfer function, rgb and grey albedos and two radii; and ambient scattering renders with
backend="cuda" — an anisotropic phase, whose ray cast reads the ball grid, and an isotropic one on a
finer light grid, whose bake reads it — that read its device copy without uploading it. On a machine
without a GPU through Numba's CUDA simulator, in a subprocess that sets ``NUMBA_ENABLE_CUDASIM=1``
before numba is imported (tests/kernels/_cuda_ball_script.py)."""
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
#: Simulator vs CPU (tests/kernels/test_cuda.py's tolerance).
REL_TOL = 1e-6

STAGE_CASES = [f"{d}/{k}/{a}/{r}" for d in ("9x11x7",) for k in ("table", "physical")
               for a in ("rgb", "grey") for r in ("0.37", "1.1")]


@pytest.fixture(scope="module")
def sim():
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    proc = subprocess.run([sys.executable, str(HERE / "_cuda_ball_script.py")], env=env, capture_output=True,
                          text=True, timeout=1200)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    line = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")][-1]
    return json.loads(line[len("RESULT "):])


def _equal_to_cpu(r):
    # σ̄, and the mean scattering σ̄·ā relative to the largest σ̄: the ball's albedo is a ratio whose
    # relative error grows as the box means' rounding over σ̄ at the medium's fringe (σ̄ → 0), so it
    # is held to the tolerance where σ̄ is at least 1 % of its largest, and bounded everywhere
    assert r["sbar_rel"] <= REL_TOL, r
    assert r["ms_rel"] <= REL_TOL, r
    assert r["albedo_abs_dense"] <= 1e-5, r
    assert r["albedo_abs"] <= 1e-3, r


@pytest.mark.parametrize("case", STAGE_CASES)
def test_ball_grid_equals_cpu(sim, case):
    r = sim["stage"][case]
    assert r["device"] == 1  # computed on the device, not the CPU's fallback
    assert r["resident"]  # the cache holds its device copy, equal to the download
    assert r["dtype"] == "float32" and r["shape"] and r["max"] > 0.0
    assert r["mode"] == (0 if "/table/" in case else 1)
    assert r["same"] == ([False, True, True] if "/grey/" in case else [False, False, False])
    if "/grey/" in case:  # one box mean serves every channel
        assert r["equal_grey"]
    _equal_to_cpu(r)


@pytest.mark.parametrize("case", ["aniso/table", "aniso/physical", "iso/physical/finer"])
def test_render_reads_the_ball_grid_on_the_device(sim, case):
    r = sim["render"][case]
    assert r["backend"] == "cuda"
    assert r["baked"] == case.startswith("iso")  # the bake reads the ball; else the ray cast does
    assert r["image_rel"] <= REL_TOL and r["max"] > 0.0
    assert r["device"] == 1
    assert r["ball_resident"] and r["read_on_device"] and not r["ball_uploaded"]
    _equal_to_cpu(r)
