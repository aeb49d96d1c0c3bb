"""Summed-area table and the ball's mean extinction σ̄ (docs/ambient_scattering.rst §1).

Ambient scattering replaces the medium inside a ball of radius ``r`` around every sample by its
mean extinction ``σ̄``. As in the paper (Ament, Sadlo & Weiskopf 2013) the ball is approximated
by the axis-aligned box of equal volume, edge ``e = r·(4π/3)^{1/3}``, whose integral comes from a
3D summed-area table (SAT) by inclusion–exclusion over its eight corners.

Conventions (shared with the kernels in :mod:`pv_ambient._kernels.sat`):

* ``sigma`` is an ``(nx, ny, nz)`` array of σt at the grid samples; sample ``(i, j, k)`` sits at
  index point ``(i, j, k)`` and owns the unit cell ``[i−½, i+½] × …`` (a piecewise-constant
  field); outside ``[−½, n−½]`` per axis is vacuum.
* The SAT is float64 with a zero guard plane: ``S[i, j, k] = Σ sigma[:i, :j, :k]``, shape
  ``(nx+1, ny+1, nz+1)``. A float32 table would lose ~7 digits to the running sums of a large
  grid (the tests show a 256³ grid's total off by far more than 1e-6); the table is read at
  fractional corners by trilinear interpolation, which is exact for a piecewise-constant field.
* :func:`mean_extinction` takes the same box integral one axis at a time
  (:func:`box_mean_separable`): the box is a product of intervals, so three passes of 1-D
  prefix sums replace the 3-D table (no float64 copy of the grid, one pass per axis).
* ``σ̄`` divides by the *full* box volume: vacuum outside the grid counts as zero, so σ̄ drops
  near the boundary (light escapes there).

Departures from the paper: none in substance; the box is read at fractional corners (exact
integral of the cell-constant field) rather than snapped to whole voxels, so σ̄ is continuous in
``r``, and ``r`` smaller than half a cell returns σ itself.

This module imports only numpy and the kernels (no pyvista), like the rest of the array core.
"""

from __future__ import annotations

import math

import numpy as np

from ..inputs.validation import check_array, check_real, check_vector, show_value

__all__ = ["BOX_EDGE_PER_RADIUS", "build_sat", "box_sum", "box_mean", "box_half_edges", "mean_extinction",
           "box_mean_separable"]

BOX_EDGE_PER_RADIUS = (4.0 * math.pi / 3.0) ** (1.0 / 3.0)
"""Edge of the cube with the volume of the unit ball, ``(4π/3)^{1/3} ≈ 1.612``."""


def _check_sat(sat) -> np.ndarray:
    arr = np.asarray(sat)
    if arr.dtype != np.float64 or arr.ndim != 3:
        raise TypeError(f"sat must be a float64 3-D array from build_sat, got {arr.dtype} with shape {arr.shape}")
    if min(arr.shape) < 2:
        raise ValueError(f"sat must come from a non-empty grid (every axis ≥ 2 entries), got shape {arr.shape}")
    return np.ascontiguousarray(arr)


def build_sat(sigma) -> np.ndarray:
    """Summed-area table of a 3D field, accumulated in float64.

    Parameters
    ----------
    sigma : array_like, shape (nx, ny, nz)
        Finite real values (float32 or float64 are used as they are; integers are converted).

    Returns
    -------
    numpy.ndarray
        float64 array of shape ``(nx+1, ny+1, nz+1)`` with ``S[i, j, k] = sigma[:i, :j, :k].sum()``
        (so index 0 along each axis is a zero guard plane).

    Examples
    --------
    >>> import numpy as np
    >>> from pv_ambient.stages.sat import build_sat
    >>> S = build_sat(np.ones((2, 3, 4), np.float32))
    >>> S.shape, S.dtype, float(S[-1, -1, -1]), float(S[1, 2, 2])
    ((3, 4, 5), dtype('float64'), 24.0, 4.0)
    """
    from .._kernels.sat import build_sat_into

    arr = check_array(sigma, "sigma", ndim=3, dtype="float")
    S = np.zeros(tuple(n + 1 for n in arr.shape), np.float64)
    if arr.size:
        build_sat_into(arr, S)
    return S


def box_sum(sat, lo, hi) -> float:
    """Integral of the piecewise-constant field over the box ``[lo, hi]`` (sample index units).

    Parameters
    ----------
    sat : numpy.ndarray
        Table from :func:`build_sat` (of a non-empty grid).
    lo, hi : array_like of 3 floats
        Box corners in index units, ``lo ≤ hi`` per axis. Sample ``i`` owns ``[i−½, i+½]``; the
        parts of the box outside ``[−½, n−½]`` are vacuum.

    Returns
    -------
    float
        ``∫ σ`` over the box in index units (multiply by ``hx·hy·hz`` for a world integral).

    Examples
    --------
    >>> import numpy as np
    >>> from pv_ambient.stages.sat import build_sat, box_sum
    >>> S = build_sat(np.full((4, 4, 4), 2.0))
    >>> box_sum(S, (-0.5, -0.5, -0.5), (1.5, 1.5, 1.5))     # 2×2×2 whole cells
    16.0
    >>> box_sum(S, (0.0, 0.0, 0.0), (0.5, 0.5, 0.5))        # ⅛ of one cell of value 2
    0.25
    >>> box_sum(S, (-9.0, 0.0, 0.0), (0.0, 1.0, 1.0))       # half of it lies in vacuum
    1.0
    """
    from .._kernels.sat import box_sum as _box_sum

    S = _check_sat(sat)
    lo = check_vector(lo, "lo", 3)
    hi = check_vector(hi, "hi", 3)
    if np.any(hi < lo):
        raise ValueError(f"hi must be >= lo on every axis, got lo={lo.tolist()} hi={hi.tolist()}")
    return float(_box_sum(S, lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]))


def box_mean(sat, center, half_edges) -> float:
    """Mean of the field over a box, counting vacuum outside the grid as zero.

    Parameters
    ----------
    sat : numpy.ndarray
        Table from :func:`build_sat` (of a non-empty grid).
    center : array_like of 3 floats
        Box centre in sample index units (any point, inside the grid or not).
    half_edges : array_like of 3 floats
        Half-edges in index units, ≥ 0 (a zero half-edge takes the point value on that axis).

    Returns
    -------
    float
        Box integral divided by the full box volume.

    Examples
    --------
    >>> import numpy as np
    >>> from pv_ambient.stages.sat import build_sat, box_mean
    >>> S = build_sat(np.full((5, 5, 5), 3.0))
    >>> box_mean(S, (2, 2, 2), (1.5, 1.5, 1.5))
    3.0
    >>> box_mean(S, (0, 2, 2), (1.0, 1.0, 1.0))             # a quarter of the box is outside
    2.25
    """
    from .._kernels.sat import box_mean as _box_mean

    S = _check_sat(sat)
    c = check_vector(center, "center", 3)
    a = check_vector(half_edges, "half_edges", 3, nonneg=True)
    return float(_box_mean(S, c[0], c[1], c[2], a[0], a[1], a[2]))


def box_half_edges(spacing, radius) -> np.ndarray:
    """Half-edges, in index units per axis, of the box with the volume of a ball of world
    ``radius``: ``r·(4π/3)^{1/3} / (2 h_axis)``.

    Examples
    --------
    >>> from pv_ambient.stages.sat import box_half_edges
    >>> box_half_edges((1.0, 0.5, 2.0), 1.0).round(3).tolist()
    [0.806, 1.612, 0.403]
    """
    h = _check_spacing(spacing)
    r = check_real(radius, "radius", lo=0.0)
    return r * BOX_EDGE_PER_RADIUS / (2.0 * h)


def _check_spacing(spacing) -> np.ndarray:
    h = check_vector(spacing, "spacing", 3)
    if np.any(h <= 0):
        raise ValueError(f"spacing must be three positive numbers, got {show_value(spacing)}")
    return h


def mean_extinction(sigma, spacing, radius) -> np.ndarray:
    """Mean extinction σ̄ over the ball of world ``radius`` around every sample (docs/ambient_scattering.rst §1).

    The ball is replaced by the box of equal volume (edge ``radius·(4π/3)^{1/3}``) centred on the
    sample; its integral, the summed-area table's box integral computed one axis at a time
    (:func:`box_mean_separable`: float64 prefix sums per line, no float64 copy of the grid), is
    divided by the full box volume, so vacuum outside the grid counts as zero and σ̄ drops near
    the boundary.

    Parameters
    ----------
    sigma : array_like, shape (nx, ny, nz)
        Extinction σt at the samples: finite and ≥ 0 (float32 or float64).
    spacing : array_like of 3 floats
        World spacing ``(hx, hy, hz)``, positive (a single number means isotropic).
    radius : float
        Ball radius in world units, ≥ 0. ``0`` (or any radius whose box stays inside a sample's
        own cell, i.e. all half-edges ≤ ½) returns ``sigma`` itself.

    Returns
    -------
    numpy.ndarray
        float32 array of the same shape as ``sigma`` (a new array; empty if ``sigma`` is).

    Examples
    --------
    >>> import numpy as np
    >>> from pv_ambient.stages.sat import mean_extinction
    >>> sigma = np.full((9, 9, 9), 2.0, np.float32)
    >>> m = mean_extinction(sigma, (1.0, 1.0, 1.0), 2.0)
    >>> m.dtype, float(m[4, 4, 4])                     # box well inside: σ̄ = σ
    (dtype('float32'), 2.0)
    >>> bool(m[0, 0, 0] < m[0, 4, 4] < m[4, 4, 4])     # less medium near faces and corners
    True
    """
    arr = check_array(sigma, "sigma", ndim=3, dtype="float", lo=0.0)
    h = _check_spacing(spacing)
    r = check_real(radius, "radius", lo=0.0)
    a = r * BOX_EDGE_PER_RADIUS / (2.0 * h)
    out = np.array(arr, dtype=np.float32, copy=True)
    if arr.size and r > 0.0:
        box_mean_separable(out, a, out)
    return out


def axis_weights(n, a):
    """Where one axis of a box mean reads its line's cumulative integral: for every sample ``c`` of
    an axis of ``n`` cells, the cell and fraction ``(i, f)`` of ``c − a + ½`` and of ``c + a + ½``
    clamped to ``[0, n]`` (the integral ``C(x) = (1 − f)·P[i] + f·P[i+1]`` from the prefix sums
    ``P`` is exact for the piecewise-constant field; clamping makes the vacuum outside count as
    zero). Returns ``i0, f0, i1, f1`` (int64, float64 arrays of length n)."""
    c = np.arange(n, dtype=np.float64)
    out = []
    for u in (np.clip(c - a + 0.5, 0.0, n), np.clip(c + a + 0.5, 0.0, n)):
        i = np.minimum(np.floor(u), n - 1).astype(np.int64)
        out += [i, u - i]
    return out


def box_mean_separable(src, half_edges, dst):
    """Mean over the box of ``half_edges`` (index units per axis) around every sample of the 3-D
    float32 field ``src`` into ``dst`` (float32, same shape; may be ``src``), vacuum outside the
    grid counting as zero — the same value as :func:`box_mean` on the summed-area table.

    Why separable: the box is a product of intervals, so its mean is three 1-D interval means in
    turn, each from a line's float64 prefix sums; the summed-area table's 64-term contraction per
    sample and its float64 copy of the grid (twice the float32 volume) are not needed. An axis
    whose half-edge is at most ½ keeps every sample's own cell: that pass is the identity and is
    skipped."""
    from .._kernels.sat import box_mean_plane, box_mean_z

    cur = src
    for ax in range(3):
        a = float(half_edges[ax])
        if a <= 0.5:
            continue
        i0, f0, i1, f1 = axis_weights(src.shape[ax], a)
        if ax < 2:
            box_mean_plane(cur, dst, ax, i0, f0, i1, f1, 1.0 / (2.0 * a))
        else:
            box_mean_z(cur, dst, i0, f0, i1, f1, 1.0 / (2.0 * a))
        cur = dst
    if cur is not dst:
        dst[...] = src
    return dst
