"""The one place that decides how kernels are compiled (DESIGN §5b, STYLE "Numba projects").

Two kinds of compiled functions exist:

``scalar``
    Per-ray, per-voxel and per-path work: plain code on scalars and arrays passed in, no
    allocation, no ``prange``, no Python objects, random numbers from ``rng`` (a counter-based
    hash of arguments). The physics lives only here. On the CPU a scalar function is an
    ``njit`` dispatcher; a CUDA backend compiles the same functions as device functions.

``driver``
    Thin loops that run scalar functions over an image or a grid: a ``prange`` loop on the CPU.

Policy (one place, never copied): ``cache=True`` so compilation is paid once per machine,
``error_model="numpy"`` (no exception checks on division), and an explicit fastmath *set* that
keeps ``nnan``/``ninf`` off — the trackers and the ray/box clipping rely on ``inf``.
"""

from __future__ import annotations

import numba

FASTMATH = frozenset({"nsz", "arcp", "contract", "afn", "reassoc"})

_COMMON = dict(cache=True, error_model="numpy", fastmath=set(FASTMATH), nogil=True)


def scalar(fn):
    """Compile a scalar (per-ray / per-voxel / per-path) function for the CPU target."""
    return numba.njit(**_COMMON)(fn)


def driver(fn=None, *, parallel=True):
    """Compile a driver loop; ``parallel=True`` makes ``numba.prange`` run over threads."""

    def wrap(f):
        return numba.njit(parallel=parallel, **_COMMON)(f)

    return wrap(fn) if fn is not None else wrap


prange = numba.prange
