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
from pv_ambient import device_cache as dcache
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


class _Dev:
    """Stand-in device copy (a numpy array by another name)."""

    def __init__(self, arr):
        self.arr, self.nbytes = arr, arr.nbytes


def _device_stand_in(monkeypatch):
    """numba.cuda's uploads replaced by stand-ins, and the free-memory queries counted."""
    from numba import cuda

    seen = {"uploads": [], "queries": 0}

    def to_device(arr):
        seen["uploads"].append(arr.nbytes)
        return _Dev(arr)

    def free():
        seen["queries"] += 1
        return float("inf")

    monkeypatch.setattr(cuda, "to_device", to_device)
    monkeypatch.setattr(dcache, "free_device_memory", free)
    return seen


def test_device_cache_maps_a_record_once_and_asks_for_memory_only_to_upload(monkeypatch):
    """Until 0.4.0 every launch walked every record's arrays and asked the GPU for its free memory
    (docs/performance.rst, "Host work of a frame"). Records seen before are found whole; an array
    of at most SMALL_BYTES is known by its contents (each frame builds the camera anew)."""
    from pv_ambient._kernels.records import LightGrid, View

    seen = _device_stand_in(monkeypatch)
    cache = bk.DeviceCache(keep=2)
    big = np.ones((32, 32, 32), np.float32)
    grid = LightGrid(np.zeros(3), np.ones(3), big, big, big[:1, :1, :1, None], 0)

    def view(x):
        return View(np.full(16, x), np.eye(4), np.zeros(3), np.ones(3))

    a = cache.args((view(1.0), grid), extra_bytes=64)
    assert seen["queries"] == 1 and sorted(seen["uploads"]) == [4, 24, 24, 128, 128, big.nbytes]
    b = cache.args((view(1.0), LightGrid(*grid)))  # the same values, new records and small arrays
    assert b[1] is a[1] and b[0] is a[0] and seen["queries"] == 1 and len(seen["uploads"]) == 6
    c = cache.args((view(2.0), grid))  # the camera moved: its 16 numbers uploaded, nothing asked
    assert c[1] is a[1] and seen["uploads"][6:] == [128] and seen["queries"] == 1
    assert c[0].w2i is a[0].w2i and c[0].cam is not a[0].cam
    # the GPU recomputed the big array: the records holding the old copy are mapped again
    cache.put(big, _Dev(big.copy()))
    assert cache.args((view(2.0), grid))[1].tau is cache.get(big)
    # unused for `keep` launches: dropped at the next sweep, with the records that used it
    for _ in range(4):
        cache.tick()
    assert cache._items == {} and cache._records == {}
    cache.args((view(2.0), grid))
    assert seen["queries"] == 2  # a new upload: asked again


def test_device_cache_forgets_an_array_changed_in_place(monkeypatch):
    # a relight rebakes the in-scattered light in place (SceneStages.incident): the device copy
    # and the records holding it must go, and the next use uploads the new contents
    from pv_ambient._kernels.records import LightGrid

    seen = _device_stand_in(monkeypatch)
    cache = bk.DeviceCache()
    big = np.ones((32, 32, 32), np.float32)
    grid = LightGrid(np.zeros(3), np.ones(3), big, big, big[:1, :1, :1, None], 0)
    first = cache.args((grid,))[0]
    uploads = len(seen["uploads"])
    big[...] = 2.0
    cache.forget(big)
    again = cache.args((grid,))[0]
    assert again is not first and seen["uploads"][uploads:].count(big.nbytes) == 1  # uploaded once more
    cache.forget(np.ones(3))  # an array it never held: nothing happens


def test_device_cache_refuses_before_uploading(monkeypatch):
    seen = _device_stand_in(monkeypatch)
    monkeypatch.setattr(dcache, "free_device_memory", lambda: 1000.0)
    with pytest.raises(bk.DeviceMemoryError, match="more device memory"):
        bk.DeviceCache().args((np.ones(1000),))
    assert seen["uploads"] == []


def test_image_buffers_are_one_host_buffer_laid_out_as_the_device_output():
    """The CUDA backend brings radiance and alpha home in one copy when they are views of one
    buffer in the device output's layout; other buffers (the progressive model's) in two."""
    rad, alpha = bk.image_buffers(5, 7)
    assert rad.shape == (5, 7, 3) and alpha.shape == (5, 7) and rad.flags.c_contiguous and alpha.flags.c_contiguous
    assert rad.dtype == alpha.dtype == np.float32 and not rad.any() and not alpha.any()
    flat = bk.host_flat(rad, alpha)
    assert flat is not None and flat.shape == (5 * 7 * 4,)
    flat[:] = np.arange(flat.size)
    assert rad[0, 0, 2] == 2 and alpha[0, 0] == 5 * 7 * 3
    assert bk.host_flat(np.zeros((5, 7, 3), np.float32), np.zeros((5, 7), np.float32)) is None
    other_rad, other_alpha = bk.image_buffers(5, 7)
    assert bk.host_flat(rad, other_alpha) is None and bk.host_flat(other_rad, alpha) is None


def test_blas_limit_on_demand_is_entered_by_the_first_stage_only(monkeypatch):
    """A CUDA camera move computes no stage on the CPU: it does not pay threadpoolctl's calls."""
    import contextlib

    log = []

    @contextlib.contextmanager
    def limit():
        log.append("enter")
        yield
        log.append("exit")

    monkeypatch.setattr(bk, "blas_one_thread", limit)
    with bk.blas_on_demand():
        pass
    assert log == []
    with bk.blas_on_demand():
        bk.blas_before_stage()
        bk.blas_before_stage()
        assert log == ["enter"]
    assert log == ["enter", "exit"]
    bk.blas_before_stage()  # outside a render: nothing
    assert log == ["enter", "exit"]
