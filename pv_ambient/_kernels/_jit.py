"""The one place that decides how kernels are compiled (docs/architecture.rst, STYLE "Numba projects").

Two kinds of compiled functions exist:

``scalar``
    Per-ray, per-voxel and per-path work: plain code on scalars and arrays passed in, no
    allocation, no ``prange``, no Python objects, random numbers from ``rng`` (a counter-based
    hash of arguments). The physics lives only here. On the CPU a scalar function is an
    ``njit`` dispatcher; a CUDA backend compiles the same functions as device functions.

``driver``
    Thin loops that run scalar functions over an image or a grid: a ``prange`` loop on the CPU;
    for CUDA, a one-thread-per-pixel (or per-node) kernel in :mod:`pv_ambient._kernels.cuda`.

The CUDA target compiles the *same* Python source of every scalar function: :func:`cuda_device`
takes the function's code and rebinds the names of the scalar functions it calls to their CUDA
device versions (recursively), so the physics exists once and only the drivers differ.

Policy (one place, never copied): ``cache=True`` so compilation is paid once per machine,
``error_model="numpy"`` (no exception checks on division), and an explicit fastmath *set* that
keeps ``nnan``/``ninf`` off — the trackers and the ray/box clipping rely on ``inf``. The CUDA
kernels take the same set and the same disk cache (:func:`cuda_options`).
"""

from __future__ import annotations

import os

import numba

FASTMATH = frozenset({"nsz", "arcp", "contract", "afn", "reassoc"})

_COMMON = dict(cache=True, error_model="numpy", fastmath=set(FASTMATH), nogil=True)


#: ``False`` in every scalar function the CPU compiles, ``True`` in their CUDA device versions
#: (:func:`cuda_device` binds it): the one switch by which a scalar function computes in float32 on
#: the GPU a value that the CPU computes in float64 (``if ON_GPU: ... else: ...``). Why: a GPU
#: thread holds a float64 in two registers and runs a float64 square root, division or ``exp`` as a
#: long sequence (a square root and a division call a slow path whose registers every thread of a
#: launch pays for), where the CPU pays neither — and the CPU's images must not move. Numba prunes
#: the branch not taken (a global constant), so each target compiles only its own arithmetic. Used
#: only where float32 keeps the GPU within the accuracy the CUDA tests hold it to
#: (docs/architecture.rst, "One kernel per model").
ON_GPU = False

_SCALARS = {}  # py_func -> CPU dispatcher of every scalar function
_INLINE = set()  # py_funcs of the scalar functions inlined into their callers
_CUDA = {}  # py_func -> CUDA device function (built on first use)


def scalar(fn=None, *, inline=False, force_inline=False):
    """Compile a scalar (per-ray / per-voxel / per-path) function for the CPU target.

    ``inline=True`` inlines it into its callers at Numba's IR level (``inline="always"``): for the
    small functions of the per-sample path (interpolation, classification, the baked lookup). Why:
    LLVM does not always inline across dispatchers, and the calls left cost a sizeable part of an
    emission–absorption frame. ``force_inline=True`` has LLVM inline it instead (``forceinline``):
    for a function returning a tuple into a vectorised lane loop, where Numba's IR inlining would
    leave tuple copies that cost the loop its ``noalias`` (:mod:`.packet`), and for any function
    with a deep call tree of its own or many call sites (the light lookups, the light sweep's node
    functions): Numba's IR inlining re-types and re-lowers the callee's body at every call site,
    nested inlines multiply, and a kernel's cold compile grows several-fold, where LLVM compiles the
    callee once and inlines its optimised body (docs/performance.rst, "Compile time"). The returned
    dispatcher is also registered for :func:`cuda_device`; either kind is force-inlined there."""

    def wrap(f):
        opts = dict(_COMMON, inline="always") if inline else dict(_COMMON, forceinline=True) if force_inline else _COMMON
        disp = numba.njit(**opts)(f)
        _SCALARS[f] = disp
        if inline or force_inline:
            _INLINE.add(f)
        return disp

    return wrap(fn) if fn is not None else wrap


def is_scalar(obj) -> bool:
    """Whether ``obj`` is a dispatcher made by :func:`scalar`."""
    return getattr(obj, "py_func", None) in _SCALARS


def _simulator() -> bool:
    return os.environ.get("NUMBA_ENABLE_CUDASIM", "0") == "1"


def cuda_options(device=False, inline=False) -> dict:
    """``numba.cuda.jit``'s options for a kernel (``device=False``: Numba's disk cache on) or a device
    function (``inline``: inlined by NVVM, ``forceinline``): the CPU's fastmath set, so the GPU
    computes what the CPU computes (docs/architecture.rst, "One kernel per model"), the float32
    branches of :data:`ON_GPU` aside. The simulator takes neither ``forceinline`` nor a cache."""
    opts = dict(fastmath=set(FASTMATH))
    if device:
        opts["device"] = True
        if not _simulator():
            opts["forceinline"] = bool(inline)
    elif not _simulator():
        opts["cache"] = True
    return opts


def with_globals(fn, names):
    """``fn`` with the globals ``names`` (a dict) added or replaced: how a compiled loop is specialised
    by the functions it calls. Not by a closure over them: Numba's disk cache keys a closure on a
    pickle of its cells, and a dispatcher's pickle holds an id drawn anew in every process, so a
    closure over a dispatcher is compiled again in each (docs/architecture.rst, "One kernel per
    model"); a closure over plain constants (a model id) keeps a stable key."""
    import types

    return types.FunctionType(fn.__code__, {**fn.__globals__, **names}, fn.__name__, fn.__defaults__, fn.__closure__)


def _rebind(fn):
    """``fn`` with its global names of scalar functions bound to their CUDA device versions, and
    :data:`ON_GPU` bound to ``True``."""
    names = {name: cuda_device(fn.__globals__[name]) for name in fn.__code__.co_names
             if is_scalar(fn.__globals__.get(name))}
    if "ON_GPU" in fn.__code__.co_names:
        names["ON_GPU"] = True
    return with_globals(fn, names)


def cuda_device(disp):
    """The CUDA device function compiled from scalar dispatcher ``disp``'s Python source."""
    fn = disp.py_func
    dev = _CUDA.get(fn)
    if dev is None:
        from numba import cuda

        dev = cuda.jit(**cuda_options(device=True, inline=fn in _INLINE))(_rebind(fn))
        _CUDA[fn] = dev
    return dev


def cuda_kernel(fn):
    """Compile driver ``fn`` (plain Python using ``numba.cuda.grid``, defined in a module file) as a
    CUDA kernel whose calls of scalar functions go to their device versions, cached on disk like
    the CPU drivers (:func:`cuda_options`); a closure's constants (a ray-cast specialisation's
    model) are part of the cache's key."""
    from numba import cuda

    return cuda.jit(**cuda_options())(_rebind(fn))


def driver(fn=None, *, parallel=True):
    """Compile a driver loop; ``parallel=True`` makes ``numba.prange`` run over threads."""

    def wrap(f):
        return numba.njit(parallel=parallel, **_COMMON)(f)

    return wrap(fn) if fn is not None else wrap


prange = numba.prange
