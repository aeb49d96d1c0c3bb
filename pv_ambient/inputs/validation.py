"""Argument checks whose messages name the argument and say what was received.

The public API validates and converts here; kernels never validate (docs/architecture.rst).
"""

from __future__ import annotations

import math
from numbers import Integral, Real

import numpy as np


def show_value(value) -> str:
    """``repr(value)``, cut to 80 characters: how error messages quote what they received."""
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def check_real(value, name: str, *, lo=None, hi=None, lo_open=False, hi_open=False) -> float:
    """Return ``value`` as a finite float inside the stated interval, or raise naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, (Real, np.floating, np.integer)):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__} {show_value(value)}")
    out = float(value)
    if not math.isfinite(out):
        raise ValueError(f"{name} must be finite, got {out!r}")
    if lo is not None and (out < lo or (lo_open and out == lo)):
        op = ">" if lo_open else ">="
        raise ValueError(f"{name} must be {op} {lo}, got {out!r}")
    if hi is not None and (out > hi or (hi_open and out == hi)):
        op = "<" if hi_open else "<="
        raise ValueError(f"{name} must be {op} {hi}, got {out!r}")
    return out


def check_bool(value, name: str) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {type(value).__name__} {show_value(value)}")
    return bool(value)


def check_int(value, name: str, *, lo=None) -> int:
    if isinstance(value, bool) or not isinstance(value, (Integral, np.integer)):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__} {show_value(value)}")
    out = int(value)
    if lo is not None and out < lo:
        raise ValueError(f"{name} must be >= {lo}, got {out}")
    return out


def check_vector(value, name: str, size: int = 3, *, nonneg=False, nonzero=False) -> np.ndarray:
    """A finite float64 vector of ``size`` entries (a scalar is broadcast when size > 1)."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be {size} numbers, got {show_value(value)}") from None
    if arr.ndim == 0:
        arr = np.full(size, float(arr))
    if arr.shape != (size,):
        raise ValueError(f"{name} must have {size} components, got shape {arr.shape}: {show_value(value)}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {show_value(value)}")
    if nonneg and np.any(arr < 0):
        raise ValueError(f"{name} must be non-negative, got {show_value(value)}")
    if nonzero and not np.any(arr != 0):
        raise ValueError(f"{name} must not be the zero vector, got {show_value(value)}")
    return arr


def check_rgb(value, name: str, *, lo=0.0, hi=None) -> np.ndarray:
    """An RGB triple (a scalar means grey) with every component in [lo, hi]."""
    arr = check_vector(value, name, 3)
    if lo is not None and np.any(arr < lo):
        raise ValueError(f"{name} components must be >= {lo}, got {show_value(value)}")
    if hi is not None and np.any(arr > hi):
        raise ValueError(f"{name} components must be <= {hi}, got {show_value(value)}")
    return arr


def check_window_size(value, name: str = "window_size") -> tuple[int, int]:
    """``(width, height)`` as two positive integers."""
    try:
        w, h = value
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be (width, height), got {show_value(value)}") from None
    out = []
    for v in (w, h):
        if isinstance(v, bool) or not isinstance(v, (Integral, np.integer)):
            if isinstance(v, (float, np.floating)) and float(v).is_integer():
                v = int(v)
            else:
                raise TypeError(f"{name} must be two positive integers, got {show_value(value)}")
        if int(v) <= 0:
            raise ValueError(f"{name} must be two positive integers, got {show_value(tuple(value))}")
        out.append(int(v))
    return out[0], out[1]


def check_choice(value, name: str, choices) -> str:
    if not isinstance(value, str) or value not in choices:
        options = ", ".join(repr(c) for c in choices)
        raise ValueError(f"{name} must be one of {options}; got {show_value(value)}")
    return value


def _array_words(ndim) -> str:
    if ndim is None:
        return "an array"
    dims = (ndim,) if isinstance(ndim, int) else tuple(ndim)
    return "a " + " or ".join(f"{d}-D" for d in dims) + " array"


def check_array(value, name: str, *, ndim=None, dtype=np.float64, finite=True, lo=None, hi=None, nonempty=False,
                promote_scalar=False) -> np.ndarray:
    """``value`` as a C-contiguous numpy array of real numbers, checked, or raise naming ``name``.

    The one array check of the package: stages call it on their array inputs.

    Parameters
    ----------
    value : array_like
    name : str
        The argument's name, as error messages quote it.
    ndim : int or tuple of int, optional
        Allowed numbers of dimensions (any when None).
    dtype : numpy dtype or "float", default: float64
        The result's dtype; ``"float"`` keeps float32/float64 input as it is (others become float64).
    finite : bool or "nan", default: True
        Reject NaN and ±inf (True), only NaN (``"nan"``: infinities pass where the bounds allow
        them), or nothing (False).
    lo, hi : float, optional
        Inclusive bounds on every value.
    nonempty : bool, default: False
        Reject an array with no elements.
    promote_scalar : bool, default: False
        Treat a scalar as a 1-element 1-D array.

    Examples
    --------
    >>> from pv_ambient.inputs.validation import check_array
    >>> check_array([0.5, 1.0], "albedo", ndim=1, lo=0.0, hi=1.0).dtype
    dtype('float64')
    >>> check_array([[1.0]], "sigma", ndim=3)
    Traceback (most recent call last):
    ...
    ValueError: sigma must be a 3-D array, got shape (1, 1)
    """
    try:
        arr = np.asarray(value)
    except Exception:  # noqa: BLE001 - anything numpy cannot read is a type error here
        raise TypeError(f"{name} must be {_array_words(ndim)} of real numbers, got {type(value).__name__}") from None
    if arr.dtype == np.bool_ or arr.dtype.kind not in "iuf":
        raise TypeError(f"{name} must be {_array_words(ndim)} of real numbers, got dtype {arr.dtype} "
                        f"({show_value(value)})")
    if promote_scalar:
        arr = np.atleast_1d(arr)
    if ndim is not None and arr.ndim not in ((ndim,) if isinstance(ndim, int) else tuple(ndim)):
        raise ValueError(f"{name} must be {_array_words(ndim)}, got shape {arr.shape}")
    if nonempty and arr.size == 0:
        raise ValueError(f"{name} must not be empty, got shape {arr.shape}")
    if dtype == "float":
        if arr.dtype not in (np.float32, np.float64):
            arr = arr.astype(np.float64)
    elif arr.dtype != dtype:
        arr = arr.astype(dtype)
    if not arr.flags.c_contiguous:
        arr = np.ascontiguousarray(arr)  # (a 0-d array stays 0-d)
    if arr.size:
        if finite is True and not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} must be finite, got {int(np.count_nonzero(~np.isfinite(arr)))} non-finite values")
        if finite == "nan" and np.any(np.isnan(arr)):
            raise ValueError(f"{name} must not contain NaN")
        if lo is not None or hi is not None:
            amin, amax = float(arr.min()), float(arr.max())
            if hi is None and amin < lo:
                word = "non-negative" if lo == 0 else f">= {lo}"
                raise ValueError(f"{name} must be {word}, got minimum {amin!r}")
            if (lo is not None and amin < lo) or (hi is not None and amax > hi):
                raise ValueError(f"{name} must lie in [{lo}, {hi}], got values from {amin!r} to {amax!r}")
    return arr
