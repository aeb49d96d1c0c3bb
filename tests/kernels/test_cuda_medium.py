"""Tests the medium's per-scene grids on the GPU (pv_ambient/_kernels/cuda.py's MEDIUM_KERNELS,
pv_ambient.backend.medium_grid, pv_ambient.stages.medium.on_device): σt on the data samples and on
light grids not on them, the path tracer's and the ray cast's majorant grids, each equal to the
CPU's, for a table transfer function (mode LUT) and a physical one (mode GRID) on non-cubic and
cubic tiny grids; and renders with backend="cuda" whose sweeps and ray cast read those grids' device
copies without uploading them. On a machine without a GPU through Numba's CUDA simulator, in a
subprocess that sets ``NUMBA_ENABLE_CUDASIM=1`` before numba is imported
(tests/kernels/_cuda_medium_script.py)."""
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
#: Simulator vs CPU (tests/kernels/test_cuda.py's tolerance).
REL_TOL = 1e-6

STAGE_CASES = [f"{d}/{k}" for d in ("9x11x7", "16x16x16") for k in ("table", "physical")]


@pytest.fixture(scope="module")
def sim():
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    proc = subprocess.run([sys.executable, str(HERE / "_cuda_medium_script.py")], env=env, capture_output=True,
                          text=True, timeout=900)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    line = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")][-1]
    return json.loads(line[len("RESULT "):])


def _checked(r, kind):
    assert r["device"] == [kind]  # computed on the device, not the CPU's fallback
    assert r["resident"]  # the cache holds its device copy, equal to the download
    assert r["dtype"] == ["float32", "float32"]
    assert r["max"] > 0.0


@pytest.mark.parametrize("case", STAGE_CASES)
def test_sigma_equals_cpu(sim, case):
    st = sim["stage"]
    assert st[f"{case}/mode"] == (0 if case.endswith("table") else 1)
    r = st[f"{case}/sigma_samples"]
    if case.endswith("table"):
        _checked(r, "sigma_samples")
        assert r["rel"] <= REL_TOL
    else:  # mode GRID: σt on the samples is the field itself, nothing computed
        assert r["device"] == [] and r["equal"]
    for f in ("1.3", "0.6"):
        r = st[f"{case}/sigma_nodes/{f}"]
        _checked(r, "sigma_nodes")
        assert not r["on_samples"]
        assert r["rel"] <= REL_TOL, (f, r["rel"])


@pytest.mark.parametrize("case", STAGE_CASES)
@pytest.mark.parametrize("block", [4, 8])
def test_majorants_equal_cpu(sim, case, block):
    for kind in ("majorant", "cast_majorant"):
        r = sim["stage"][f"{case}/{kind}/{block}"]
        _checked(r, kind)
        assert r["rel"] <= REL_TOL, (kind, r["rel"])
    # the path tracer's bound takes table entries as they are: exactly the CPU's
    assert sim["stage"][f"{case}/majorant/{block}"]["equal"]


@pytest.mark.parametrize("case", ["table/1.0", "physical/1.4"])
def test_render_keeps_the_grids_on_the_device(sim, case):
    r = sim["render"][case]
    assert r["backend"] == "cuda"
    assert r["image_rel"] <= REL_TOL and r["max"] > 0.0
    assert r["majorant_rel"] <= REL_TOL
    assert r["majorant_resident"] and r["ray_cast_reads_majorant"] and not r["majorant_uploaded"]
    assert r["swept"] >= 1 and r["sigma_rel"] <= REL_TOL and not r["sigma_uploaded"]
    assert not r["sigma_is_field"]
    assert r["on_samples"] == case.endswith("1.0")
    assert sorted(r["device"]) == sorted(["cast_majorant", "sigma_samples" if r["on_samples"] else "sigma_nodes"])
