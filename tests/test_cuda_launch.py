"""Tests pv_ambient/cuda_launch.py and the launch memo of pv_ambient/device_cache.py: a record is typed
and marshalled once and the parameters handed to the driver are the ones a full marshal builds;
numba-cuda's own launch where it must be (no exact overload, a debug or cooperative kernel, a host
array, the path switched off, the simulator, numba-cuda's internals missing, a failed launch: warned
once, then off for the process); the device cache drops memo entries with what it drops.

CI has no GPU and numba-cuda's launch cannot run here, so numba-cuda is played by fakes: a dispatcher
(``overloads``, ``typeof_pyval``, ``kernel[grid, block](*args)`` recorded), a compiled overload whose
``_prepare_args`` records what it marshals, and a driver launch that records its parameters. On a GPU,
benchmarks/gpu_frame.py compares the images of the two paths (``--numba-launch``)."""
import sys
from types import SimpleNamespace

import numpy as np
import pytest

from pv_ambient import cuda_launch as cl
from pv_ambient import device_cache as dcache

STREAM = "stream 0"
SIG = ("Rec", "Rec", "int", "int")  # two records, then the rows (as the ray cast's launch)


def marshalled(ty, val):
    """The fake overload's parameters for ``val``: one per field of a record."""
    return [(ty, id(val), i) for i in range(len(val) if isinstance(val, tuple) else 1)]


class Rec(tuple):
    """A record (the kernels' are namedtuples)."""


class Host:
    """A host array: numba-cuda copies it back after the launch."""


class Dev:
    """A device copy (known by identity, as numba-cuda's device arrays)."""

    def __init__(self, nbytes):
        self.nbytes = nbytes


class DevArray(np.ndarray):
    """A device array (numba-cuda's have copy_to_host): DeviceCache.output's buffers."""

    def copy_to_host(self):
        return np.asarray(self)


class Overload:
    debug = cooperative = False

    def __init__(self):
        self.prepared = []  # the arguments _prepare_args marshalled, in order
        self._codelibrary = SimpleNamespace(get_cufunc=lambda: SimpleNamespace(kernel="cufunc"))

    def _prepare_args(self, ty, val, stream, retr, params):
        assert stream == STREAM
        self.prepared.append(val)
        if isinstance(val, Host):
            retr.append(val)
        params += marshalled(ty, val)


class Kernel:
    """A numba-cuda dispatcher compiled for ``signatures``; ``numba`` records its own launches."""

    def __init__(self, *signatures):
        self.overloads = {sig: Overload() for sig in signatures}
        self.numba = []

    def typeof_pyval(self, val):
        return sys.intern(type(val).__name__)  # one object per type, as Numba interns its types

    def __getitem__(self, config):
        return lambda *args: self.numba.append((config, args))

    @property
    def prepared(self):  # cuda_launch marshals with the first overload
        return next(iter(self.overloads.values())).prepared if self.overloads else []


@pytest.fixture(autouse=True)
def driver(monkeypatch):
    """The driver's launch (recorded; returned), a fresh process state, the path on, no simulator."""
    launches = []
    monkeypatch.setenv("NUMBA_ENABLE_CUDASIM", "0")
    monkeypatch.setattr(cl, "ENABLED", True)
    monkeypatch.setattr(cl, "COUNTS", {"fast": 0, "numba": 0})
    # the real _core hands back _STATE["core"] unless _STATE["broken"]
    monkeypatch.setattr(cl, "_STATE", {"core": (lambda *a: launches.append(a), dict, STREAM, "is_cooperative")})
    return launches


def test_a_camera_move_marshals_the_camera_record_alone(driver):
    kernel, view, grid, memo = Kernel(SIG), Rec((1, 2)), Rec((3, 4, 5)), {}
    cl.launch(kernel, (4, 2), 64, (view, grid, 0, 8), memo)
    assert kernel.prepared == [view, grid, 0, 8]
    cam = Rec((1, 3))
    cl.launch(kernel, (4, 2), 64, (cam, grid, 0, 8), memo)
    assert kernel.prepared[4:] == [cam, 0, 8]  # grid from the memo; the ints every time
    assert driver[1][:3] == (STREAM, dict(grid=(4, 2), block=64, shmem_size=0, is_cooperative=False), "cufunc")
    cl.launch(kernel, (4, 2), 64, (cam, grid, 0, 8), {})  # a full marshal
    assert driver[1] == driver[2]
    assert list(driver[1][3:]) == [p for ty, a in zip(SIG, (cam, grid, 0, 8)) for p in marshalled(ty, a)]
    assert cl.COUNTS == {"fast": 3, "numba": 0} and kernel.numba == []


def test_the_memo_knows_a_record_by_identity_not_value():
    kernel, memo = Kernel(SIG), {}
    cl.launch(kernel, 1, 1, (Rec((1,)), Rec((2,)), 0, 8), memo)
    cl.launch(kernel, 1, 1, (Rec((1,)), Rec((2,)), 0, 8), memo)  # equal records, built anew
    assert len(kernel.prepared) == 8 and len(memo) == 4
    view = Rec((1,))
    memo[id(view)] = (Rec((1,)), "Rec", ["stale"])  # another object once had view's id
    cl.launch(kernel, 1, 1, (view, Rec((2,)), 0, 8), memo)
    assert kernel.prepared[8] is view and memo[id(view)][0] is view


@pytest.mark.parametrize("case", ["not compiled yet", "other types", "debug", "cooperative"])
def test_without_an_exact_plain_overload_numba_launches(driver, case):
    kernel = Kernel() if case == "not compiled yet" else Kernel(("Rec", "Rec", "int", "float") if case == "other types" else SIG)
    if case in ("debug", "cooperative"):
        setattr(kernel.overloads[SIG], case, True)
    args = (Rec((1,)), Rec((2,)), 0, 8)
    cl.launch(kernel, (4, 2), 64, args, {})
    assert driver == [] and kernel.numba == [(((4, 2), 64), args)] and cl.COUNTS == {"fast": 0, "numba": 1}


def test_a_host_array_goes_through_numba_unmemoised(driver):
    kernel, view, host, memo = Kernel(("Rec", "Host", "int", "int")), Rec((1,)), Host(), {}
    for _ in range(2):
        cl.launch(kernel, 1, 1, (view, host, 0, 8), memo)
    assert kernel.prepared == [view, host, host] and id(host) not in memo  # its copy back needs numba-cuda
    assert driver == [] and len(kernel.numba) == 2 and cl.COUNTS == {"fast": 0, "numba": 2}


def test_a_failed_launch_warns_once_and_turns_the_path_off(driver):
    kernel, memo, args = Kernel(SIG), {}, (Rec((1,)), Rec((2,)), 0, 8)
    cl.launch(kernel, 1, 1, args, memo)
    assert len(memo) == 2

    def fail(*a):
        driver.append(a)
        raise RuntimeError("CUDA_ERROR_INVALID_VALUE")

    cl._STATE["core"] = (fail, dict, STREAM, "is_cooperative")
    with pytest.warns(RuntimeWarning, match="off for this process.*CUDA_ERROR_INVALID_VALUE"):
        cl.launch(kernel, 1, 1, args, memo)
    assert cl._STATE["broken"] == "RuntimeError: CUDA_ERROR_INVALID_VALUE" and memo == {}
    cl.launch(kernel, 1, 1, args, memo)  # no warning (pytest's filterwarnings: error), no driver
    assert len(driver) == 2 and len(kernel.numba) == 2 and memo == {}
    assert cl.COUNTS == {"fast": 1, "numba": 2}


@pytest.mark.parametrize("off", ["PV_AMBIENT_FAST_LAUNCH=0", "simulator", "numba-cuda without the internals"])
def test_numba_launches_when_the_path_is_off(monkeypatch, driver, off):
    if off == "PV_AMBIENT_FAST_LAUNCH=0":
        monkeypatch.setattr(cl, "ENABLED", False)
    elif off == "simulator":
        monkeypatch.setenv("NUMBA_ENABLE_CUDASIM", "1")
    else:  # the real _core, finding no numba.cuda._compat
        monkeypatch.setattr(cl, "_STATE", {})
        monkeypatch.setitem(sys.modules, "numba.cuda._compat", None)
    kernel, memo = Kernel(SIG), {}
    cl.launch(kernel, 1, 1, (Rec((1,)), Rec((2,)), 0, 8), memo)
    assert memo == {} and kernel.prepared == [] and driver == [] and len(kernel.numba) == 1
    assert ("numba.cuda._compat" in cl._STATE.get("broken", "")) == (off == "numba-cuda without the internals")


def test_the_device_cache_prunes_the_memo_with_what_it_drops(monkeypatch):
    from numba import cuda

    from pv_ambient._kernels.records import LightGrid, View

    monkeypatch.setattr(cuda, "to_device", lambda a: Dev(a.nbytes))
    monkeypatch.setattr(cuda, "device_array", lambda n, dtype: np.zeros(n, dtype).view(DevArray))
    monkeypatch.setattr(dcache, "free_device_memory", lambda: float("inf"))
    cache, kernel = dcache.DeviceCache(keep=2), Kernel(("View", "LightGrid", "Dev", "Dev", "DevArray"))
    memo = cache.launch_memo
    big, bare, small = np.ones((32, 32, 32), np.float32), np.ones(1000), np.ones(3)  # bare arrays: large, small
    grid = LightGrid(np.zeros(3), np.ones(3), big, big, big[:1, :1, :1, None], 0)

    def frame(x):
        view = View(np.full(16, x), np.eye(4), np.zeros(3), np.ones(3))
        args = cache.args((view, grid, bare, small)) + cache.output(2, 2)[1:2]
        cl.launch(kernel, 1, 1, args, memo)
        cache.tick()
        return args

    v1, g, *arrays, rad = frame(1.0)
    v2 = [frame(2.0) for _ in range(3)][0][0]  # the sweep after the 4th launch drops v1 (unused for 2)
    kept = {id(v2), *map(id, arrays)}
    assert set(memo) == kept | {id(g), id(rad)} and sum(a is v2 for a in kernel.prepared) == 1
    cache.put(big, Dev(big.nbytes))  # the GPU recomputed big: grid's record goes
    assert set(memo) == kept | {id(rad)}
    cache.output(3, 2), cache.output(4, 2)  # two other image sizes: the 2×2 buffers go
    assert set(memo) == kept
    cache.clear()
    assert memo == {} and cache.launch_memo is memo


def test_the_overload_is_found_by_identity_once(driver):
    """Why: looking the overload up by a tuple of Numba types hashed every nested record type at every
    launch (about 230 ``Type.__hash__`` calls per camera move on an H200). After the first launch the
    same kernel and argument types find their overload without a dict lookup by value; the launch is
    the same."""

    class Counting(dict):
        gets = 0

        def get(self, key, default=None):
            Counting.gets += 1
            return super().get(key, default)

    kernel, view, grid, memo = Kernel(SIG), Rec((1, 2)), Rec((3, 4, 5)), {}
    kernel.overloads = Counting(kernel.overloads)
    cl.launch(kernel, (4, 2), 64, (view, grid, 0, 8), memo)
    assert Counting.gets == 1
    for cam in (Rec((1, 3)), Rec((2, 3))):
        cl.launch(kernel, (4, 2), 64, (cam, grid, 0, 8), memo)
    assert Counting.gets == 1 and driver[1][:3] == driver[2][:3] == driver[0][:3]
    other = Kernel(("Rec", "Rec", "int", "int", "int"))  # another kernel, other types: its own lookup
    assert cl._overload(other.overloads, ["Rec", "Rec", "int", "int"]) is None
    assert cl.COUNTS == {"fast": 3, "numba": 0}
