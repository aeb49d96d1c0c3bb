"""Every gallery example runs headless in its fast mode and produces the pictures it announces.

Each ``examples/**/*.py`` (folders starting with ``_`` excluded) runs
in its own subprocess with ``PV_AMBIENT_EXAMPLES_FAST=1`` (small grids and windows) and
``PV_AMBIENT_EXAMPLES_OUT`` pointing at a temporary folder. Scripts announce each picture with a
line ``saved PATH (WxH)``; the test checks that every announced PNG exists, has that size, is not
blank, that no other PNG was written, and that the output never mentions NaN.

The examples run two at a time (:func:`example_runs`, the 2 cores of a developer's machine and CI's):
on a cold kernel cache each spends most of its time compiling kernels on one core, and the examples
compile different ones (each model's driver, the progressive model's), so a second one runs on the
other core meanwhile. Each is still its own subprocess with its own hang guard, and each test checks
its own example's run.
"""

import os
import re
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = sorted(p for p in (ROOT / "examples").rglob("*.py")
                  if not any(part.startswith("_") for part in p.relative_to(ROOT / "examples").parts))
SAVED = re.compile(r"^saved (?P<path>.+\.png) \((?P<w>\d+)x(?P<h>\d+)\)$", re.MULTILINE)
NAN = re.compile(r"\bnan\b", re.IGNORECASE)
#: A picture is "not blank" when at least this fraction of its pixels is brighter than BRIGHT
#: (8-bit, brightest channel; panel labels alone cover ~2 %, the fast renders 25–50 %) ...
BRIGHT, MIN_BRIGHT_FRACTION = 40, 0.05
#: ... and not uniform: the standard deviation of the brightest channel is at least this.
MIN_STD = 10.0
#: A guard against a hung example, not a speed target. An example that the suite reaches before the
#: tests that compile its kernels compiles them itself (the progressive example: the path tracer's
#: residual kernel and the diffusion sweeps, a few minutes on 2 cores with a cold kernel cache). Two
#: run at once (``WORKERS``): on a machine busy with other work each gets less of it than alone (the
#: progressive example took 228 s alone and over 300 s beside another example at a load of 7 on 2
#: cores), hence twice the 300 s that the examples run one by one had.
TIMEOUT_S = 600
#: Examples running at once (:func:`example_runs`).
WORKERS = 2
#: Started first: the longest on a cold kernel cache (of the examples, only it needs the path
#: tracer's residual kernel, the diffusion sweeps and the diffusion ray cast); the others share the
#: second worker meanwhile.
FIRST = ("progressive_refinement.py",)


def test_examples_found():
    """The gallery's required examples exist (a renamed file must be renamed here too)."""
    names = {p.name for p in EXAMPLES}
    assert len(EXAMPLES) >= 6
    assert {"synthetic_datasets.py", "cloud_phase_sweep.py", "figure1_supernova.py",
            "directional_single_vs_ambient.py", "tf_from_add_volume.py", "ct_two_coloured_lights.py",
            "ambient_vs_path_traced.py", "mri_mni152.py",
            "time_series_and_orbit.py"} <= names
    for folder in {p.parent for p in EXAMPLES}:
        assert (folder / "README.txt").is_file(), f"{folder} has no README.txt (sphinx-gallery section header)"


def run_example(script, out):
    env = {k: v for k, v in os.environ.items() if not k.startswith("PV_AMBIENT_EXAMPLES")}
    env.update(PYVISTA_OFF_SCREEN="true", VTK_DEFAULT_OPENGL_WINDOW="vtkEGLRenderWindow", MPLBACKEND="Agg",
               PV_AMBIENT_EXAMPLES_FAST="1", PV_AMBIENT_EXAMPLES_OUT=str(out))
    # NUMBA_CACHE_DIR and PV_AMBIENT_CACHE are inherited: compiled kernels and table slices are reused
    return subprocess.run([sys.executable, str(script)], cwd=out, env=env, capture_output=True, text=True,
                          timeout=TIMEOUT_S)


@pytest.fixture(scope="module")
def example_runs(request, tmp_path_factory):
    """The examples of the selected ``test_example_runs`` items, started at once on ``WORKERS``
    threads (each waits for its subprocess), those in ``FIRST`` first: ``{script: (future, out
    folder)}``. Pending runs are cancelled when the module's tests end."""
    scripts = [item.callspec.params["script"] for item in request.session.items
               if item.module is sys.modules[__name__] and getattr(item, "originalname", "") == "test_example_runs"]
    scripts.sort(key=lambda p: p.name not in FIRST)  # stable: FIRST, then the collection order
    pool = ThreadPoolExecutor(max_workers=WORKERS)
    runs = {}
    for script in scripts:
        out = tmp_path_factory.mktemp(script.stem)
        runs[script] = (pool.submit(run_example, script, out), out)
    yield runs
    pool.shutdown(wait=True, cancel_futures=True)


@pytest.mark.parametrize("script", EXAMPLES, ids=[str(p.relative_to(ROOT / "examples")) for p in EXAMPLES])
def test_example_runs(script, example_runs):
    future, tmp_path = example_runs[script]
    proc = future.result()
    output = proc.stdout + proc.stderr
    assert proc.returncode == 0, f"{script.name} failed:\n{output[-4000:]}"
    assert not NAN.search(output), f"{script.name} printed NaN:\n{output[-4000:]}"
    saved = [(Path(m["path"]), (int(m["w"]), int(m["h"]))) for m in SAVED.finditer(proc.stdout)]
    assert saved, f"{script.name} announced no picture ('saved PATH (WxH)'):\n{proc.stdout[-2000:]}"
    # every PNG written is announced (and written into PV_AMBIENT_EXAMPLES_OUT, nowhere else)
    written = sorted(p.resolve() for p in tmp_path.rglob("*.png"))
    assert written == sorted({p.resolve() for p, _ in saved}), f"written {written}, announced {saved}"
    for path, size in saved:
        with Image.open(path) as im:
            assert im.size == size, f"{path.name}: {im.size} != announced {size}"
            value = np.asarray(im.convert("RGB")).max(axis=-1)
        bright = float(np.mean(value > BRIGHT))
        assert bright >= MIN_BRIGHT_FRACTION, f"{path.name} is blank: {100 * bright:.2f} % of pixels > {BRIGHT}"
        assert value.std() >= MIN_STD, f"{path.name} is uniform: std {value.std():.1f}"
