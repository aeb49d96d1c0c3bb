"""Tests pv_ambient/backend.py: the one check of a backend's name, the CUDA backend's errors and
``auto``'s fallback when CUDA cannot run (no package, no device, a NumPy clash: silent without the
package, one warning per process with it), BLAS held to one thread during a render."""
import sys
import types
import warnings

import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient import backend as bk
from pv_ambient import datasets

from .helpers import physical_grid, render, renderer


@pytest.fixture(autouse=True)
def fresh_cuda_state(monkeypatch):
    """Each test sees a process that has not yet asked about CUDA (the answer and ``auto``'s one
    warning are kept per process) and leaves the real process's state as it was."""
    monkeypatch.setattr(bk, "_CUDA_STATE", {})


def numba_cuda_0_30_4_on_numpy_2_5(monkeypatch, device=True):
    """Stand-in for a machine holding NumPy >= 2.5 and numba-cuda 0.30.4 (this machine's Python tops out
    at NumPy 2.4): numpy.row_stack gone, a numba_cuda module of that version, a device or none."""
    import numba.np.arrayobj  # noqa: F401  (these read numpy.row_stack when imported on NumPy 2.4 and check the
    import scipy.linalg  # noqa: F401  version on 2.5: imported before the stand-in removes it)
    from numba import cuda

    monkeypatch.delenv("NUMBA_ENABLE_CUDASIM", raising=False)
    fake = types.ModuleType("numba_cuda")
    fake.__version__ = "0.30.4"
    monkeypatch.setitem(sys.modules, "numba_cuda", fake)
    monkeypatch.delattr(np, "row_stack", raising=False)
    monkeypatch.setattr(np, "__all__", [name for name in np.__all__ if name != "row_stack"])  # as 2.5's
    monkeypatch.setattr(cuda, "is_available", lambda: device)


def test_bad_backend_name():
    with pytest.raises(ValueError, match="backend"):
        pa.Renderer(datasets.cloud(n=8), backend="gpu")


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
    with pytest.warns(RuntimeWarning, match="no CUDA device is visible"):
        assert bk.resolve_backend("auto") == "cpu"


def test_numba_cuda_that_needs_numpy_row_stack(monkeypatch):
    # numba-cuda 0.30.4 compiled kernels through numpy.row_stack, which NumPy 2.5 removed (seen on an
    # H100: benchmarks/results/gpu.txt): backend='cuda' says so before any work, 'auto' takes the CPU
    numba_cuda_0_30_4_on_numpy_2_5(monkeypatch)
    with pytest.raises(ImportError, match=r"numba-cuda 0\.30\.4 compiles kernels through numpy\.row_stack.*numpy<2\.5"):
        pa.render(datasets.cloud(n=8), window_size=(4, 4), backend="cuda")
    with pytest.warns(RuntimeWarning, match="numpy<2.5"):
        assert bk.resolve_backend("auto") == "cpu"
    assert bk.numpy_clash("0.31.0") is None and bk.numpy_clash(None) is None


def test_renders_run_blas_on_one_thread_and_restore_it(monkeypatch):
    """A multi-threaded BLAS keeps its workers spinning after each call; during a render they would
    compete with the Numba kernels (pv_ambient.backend.blas_one_thread). The solve's BLAS calls see
    one thread; the caller's count is back afterwards."""
    import scipy.linalg  # noqa: F401  (SciPy's BLAS loaded: the libraries below are those of the render)
    from threadpoolctl import threadpool_info, threadpool_limits

    import pv_ambient.stages.diffusion as diffusion_stage

    seen = []
    solve = diffusion_stage.solve_for_light

    def spy(*args, **kwargs):
        seen.extend(lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas")
        return solve(*args, **kwargs)

    monkeypatch.setattr(diffusion_stage, "solve_for_light", spy)
    with threadpool_limits(limits=2, user_api="blas"):
        before = [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]
        render(renderer(physical_grid(n=9)), "diffusion", flux_limited=True)
        after = [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]
    assert seen and set(seen) == {1}  # one solve per light, each on one BLAS thread
    assert after == before and max(before) == 2  # (a BLAS that had 2 threads: the limit is visible)


@pytest.mark.parametrize("bad", ["gpu", None, 1])
def test_check_backend_is_the_one_check_and_names_the_argument(bad):
    assert bk.BACKENDS == ("auto", "cpu", "cuda") and bk.check_backend("cuda") == "cuda"
    with pytest.raises(ValueError, match=rf"^scene backend must be one of 'auto', 'cpu', 'cuda'; got {bad!r}$"):
        bk.check_backend(bad, "scene backend")
    assert bk.resolve_backend("cpu") == "cpu"  # never asks CUDA


def test_tiles_cover_every_row_once():
    assert [tuple(map(int, t)) for t in bk.tiles(10, 3)] == [(0, 3), (3, 6), (6, 10)]
    assert [tuple(map(int, t)) for t in bk.tiles(2, 5)] == [(0, 1), (1, 2)]  # at most one tile per row


def test_auto_warns_once_per_process_when_numba_cuda_cannot_compile(monkeypatch):
    numba_cuda_0_30_4_on_numpy_2_5(monkeypatch)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")  # the once is the backend's, not the warnings filter's
        assert bk.resolve_backend("auto") == "cpu"
        res = pa.render(datasets.cloud(n=8), window_size=(4, 4), backend="auto")
        assert bk.resolve_backend("auto") == "cpu"
    assert res.metadata["backend"] == "cpu"
    assert [w.category for w in seen] == [RuntimeWarning]
    assert "backend='auto' renders on the CPU" in str(seen[0].message)
    assert "numpy.row_stack" in str(seen[0].message) and "numpy<2.5" in str(seen[0].message)
    assert seen[0].filename == __file__  # points at the caller, not into the package
    with pytest.raises(ImportError, match=r"numba-cuda 0\.30\.4 .*numpy<2\.5"):
        bk.resolve_backend("cuda")  # 'cuda' still raises after auto has warned


def test_auto_warns_once_when_numba_cuda_sees_no_device(monkeypatch):
    numba_cuda_0_30_4_on_numpy_2_5(monkeypatch, device=False)
    monkeypatch.setattr(np, "row_stack", np.vstack, raising=False)  # a NumPy it compiles with
    with pytest.warns(RuntimeWarning, match="no CUDA device is visible") as seen:
        res = pa.render(datasets.cloud(n=8), window_size=(4, 4), backend="auto")
        pa.render(datasets.cloud(n=8), window_size=(4, 4), backend="auto")
    assert res.metadata["backend"] == "cpu"
    assert len([w for w in seen if w.category is RuntimeWarning]) == 1
    assert seen[0].filename == __file__


def test_auto_is_silent_without_numba_cuda(monkeypatch):
    monkeypatch.delenv("NUMBA_ENABLE_CUDASIM", raising=False)
    monkeypatch.setitem(sys.modules, "numba_cuda", None)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert bk.resolve_backend("auto") == "cpu"
        assert bk.resolve_backend("auto") == "cpu"
    with pytest.raises(ModuleNotFoundError, match=r"pip install \"pv_ambient\[cuda\]\""):
        bk.resolve_backend("cuda")


def test_cuda_problem_asks_the_device_once_per_process(monkeypatch):
    numba_cuda_0_30_4_on_numpy_2_5(monkeypatch, device=False)
    monkeypatch.setattr(np, "row_stack", np.vstack, raising=False)
    from numba import cuda

    calls = []
    monkeypatch.setattr(cuda, "is_available", lambda: calls.append(1) or False)
    first, second = bk.cuda_problem(), bk.cuda_problem()
    assert calls == [1]
    assert isinstance(first, RuntimeError) and str(first) == str(second)
    assert first is not second  # raised again and again, one instance would keep every raise's frames
