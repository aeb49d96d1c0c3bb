"""CUDA kernel launches whose records are marshalled once (docs/performance.rst, "Host work of a frame").

numba-cuda's launch, ``kernel[grid, block](*args)``, types every argument and flattens each record's
arrays into the driver's parameter list at every call. The ray-cast kernel takes seven records
holding about 25 device arrays, so that costs a camera move more host time than the emission–absorption
kernel itself takes on a GPU. A camera move, though, changes one record (the camera's): the device
cache (:class:`pv_ambient.device_cache.DeviceCache`) hands back the same device records for the others.
:func:`launch` keeps each record's Numba type and flattened parameters in a memo that the device cache
owns, keyed by the record object, and passes the kernel's compiled overload straight to the driver's
launch — the same parameters numba-cuda would build, the same ``cuLaunchKernel``.

This leans on numba-cuda's launch internals (``_Kernel._prepare_args``, the compiled overload's
function handle), which the ``cuda`` extra pins (``numba-cuda>=0.30.4,<0.31``). Where they are not
as expected, where an argument is a host array (its copy back would be lost) or where no overload
matches the arguments' exact types yet (the first launch compiles), the launch goes through
numba-cuda's own path. ``PV_AMBIENT_FAST_LAUNCH=0`` always does; so does the CUDA simulator.

This module imports ``numba.cuda`` only when a launch asks for it.
"""

from __future__ import annotations

import os
import warnings

from .device_cache import simulator

#: Off with ``PV_AMBIENT_FAST_LAUNCH=0`` (numba-cuda's own launch every time).
ENABLED = os.environ.get("PV_AMBIENT_FAST_LAUNCH", "1") != "0"

#: Launches by path since import: ``"fast"`` (memoised parameters) and ``"numba"`` (numba-cuda's own).
COUNTS = {"fast": 0, "numba": 0}

_STATE = {}  # "core": (launch, LaunchConfig, stream, cooperative keyword) once found; "broken": why not

#: The compiled overload a kernel's ``overloads`` holds for a tuple of argument types, found by the
#: types' identities: a dict lookup by the tuple hashes every nested record type at every launch
#: (hundreds of ``Type.__hash__`` calls per camera move). Numba interns its types, and each entry
#: keeps its dict and types alive, so an identity seen again is the same type.
_OVERLOADS = {}


def _core():
    """The driver-level pieces of a launch, as numba-cuda's ``_Kernel.launch`` uses them; None
    (and the reason kept in ``_STATE["broken"]``) when this numba-cuda lacks them."""
    if "broken" in _STATE:
        return None
    core = _STATE.get("core")
    if core is None:
        try:
            from numba.cuda import dispatcher as nd
            from numba.cuda._compat import CUDA_CORE_GE_1_0
            from numba.cuda.cudadrv import driver

            nd._Kernel._prepare_args  # noqa: B018  (present, or the fast path is off)
            core = _STATE["core"] = (nd.launch, nd.LaunchConfig, driver._to_core_stream(0),
                                     "is_cooperative" if CUDA_CORE_GE_1_0 else "cooperative_launch")
        except (ImportError, AttributeError) as exc:  # another numba-cuda: its own launch every time
            _STATE["broken"] = f"{type(exc).__name__}: {exc}"
    return core


def _params(kernel, proto, arg, memo, stream):
    """``arg``'s Numba type and flattened launch parameters: from ``memo`` for a record or device
    array seen before (the same object), else built as numba-cuda builds them; None for an
    argument that must go through numba-cuda's launch (a host array, copied back after it)."""
    memo_it = not isinstance(arg, (int, float))
    if memo_it:
        hit = memo.get(id(arg))
        if hit is not None and hit[0] is arg:
            return hit[1], hit[2]
    ty = kernel.typeof_pyval(arg)
    retr, params = [], []
    proto._prepare_args(ty, arg, stream, retr, params)
    if retr:
        return None
    if memo_it:
        memo[id(arg)] = (arg, ty, params)
    return ty, params


def launch(kernel, griddim, blockdim, args, memo):
    """Launch CUDA ``kernel`` (a numba-cuda dispatcher) on ``griddim`` × ``blockdim`` threads with
    ``args``, asynchronously, as ``kernel[griddim, blockdim](*args)`` does.

    ``memo`` (a dict the caller owns and prunes, :meth:`DeviceCache.launch_memo`) keeps each record's
    and device array's type and parameters between launches; a record must not change while it is
    in the memo (records are tuples: they cannot)."""
    core = None if (simulator() or not ENABLED) else _core()
    overloads = getattr(kernel, "overloads", None)
    if core is not None and overloads:
        try:
            if _fast(core, overloads, kernel, griddim, blockdim, args, memo):
                COUNTS["fast"] += 1
                return
        except Exception as exc:  # noqa: BLE001 - numba-cuda's internals other than expected: its own path
            _STATE["broken"] = f"{type(exc).__name__}: {exc}"
            memo.clear()
            warnings.warn("pv_ambient: the memoised CUDA launch failed and is off for this process "
                          f"({_STATE['broken']}); launching through numba-cuda's own path",
                          RuntimeWarning, stacklevel=3)
    kernel[griddim, blockdim](*args)
    COUNTS["numba"] += 1


def _fast(core, overloads, kernel, griddim, blockdim, args, memo):
    """The memoised launch; False (nothing launched) where numba-cuda's own path must launch."""
    core_launch, config_cls, stream, coop = core
    proto = next(iter(overloads.values()))
    types, flat = [], []
    for a in args:
        got = _params(kernel, proto, a, memo, stream)
        if got is None:
            return False
        types.append(got[0])
        flat.extend(got[1])
    overload = _overload(overloads, types)
    if overload is None or overload.debug or overload.cooperative:
        return False
    config = config_cls(grid=griddim, block=blockdim, shmem_size=0, **{coop: False})
    core_launch(stream, config, overload._codelibrary.get_cufunc().kernel, *flat)
    return True


def _overload(overloads, types):
    """``overloads.get(tuple(types))``, remembered by the identities of the dict and of the types
    (:data:`_OVERLOADS`)."""
    key = (id(overloads),) + tuple(map(id, types))
    hit = _OVERLOADS.get(key)
    if hit is not None and hit[0] is overloads and all(a is b for a, b in zip(hit[1], types)):
        return hit[2]
    overload = overloads.get(tuple(types))
    if overload is not None:
        _OVERLOADS[key] = (overloads, tuple(types), overload)
    return overload
