"""Summed-area table of a piecewise-constant 3D field and box integrals from it (docs/ambient_scattering.rst §1).

Index-space convention (the same as :mod:`.interp`): sample ``(i, j, k)`` sits at index point
``(i, j, k)`` and owns the unit cell ``[i−½, i+½] × [j−½, j+½] × [k−½, k+½]``; the field is
constant on each cell and zero (vacuum) outside ``[−½, n−½]`` per axis.

The table ``S`` has shape ``(nx+1, ny+1, nz+1)`` with a zero guard plane at index 0 per axis:
``S[i, j, k] = Σ sigma[:i, :j, :k]`` (float64). The integral of the field over
``[−½, x] × [−½, y] × [−½, z]`` is multilinear inside a cell, so it equals the trilinear
interpolation of ``S`` at ``(x+½, y+½, z+½)`` (clamped to ``[0, n]``) — exact, not an
approximation. A box integral is the inclusion–exclusion of eight such corners; because the
corner function is a tensor product, that sum factors into one 1-D difference stencil per axis
(:func:`axis_stencil`), which :func:`box_sum` and :func:`box_mean` contract with ``S``.

Scalar functions here allocate nothing and never validate (the Python layer,
:mod:`pv_ambient.stages.sat`, does); drivers are thin ``prange`` loops.
"""

from __future__ import annotations

import numpy as np

from ._jit import driver, prange, scalar


@driver
def build_sat_into(sigma, S):
    """Fill ``S`` (float64, shape ``sigma.shape + 1`` per axis, zero-initialised) with the
    summed-area table of ``sigma``: three prefix passes, each parallel over the other two axes."""
    nx, ny, nz = sigma.shape
    # pass along z (copy + running sum), parallel over the (i, j) rows
    for r in prange(nx * ny):
        i = r // ny
        j = r - i * ny
        acc = 0.0
        for k in range(nz):
            acc += sigma[i, j, k]
            S[i + 1, j + 1, k + 1] = acc
    # pass along y, parallel over i (the inner loop over k is contiguous)
    for i in prange(1, nx + 1):
        for j in range(2, ny + 1):
            for k in range(1, nz + 1):
                S[i, j, k] += S[i, j - 1, k]
    # pass along x, parallel over j
    for j in prange(1, ny + 1):
        for i in range(2, nx + 1):
            for k in range(1, nz + 1):
                S[i, j, k] += S[i - 1, j, k]


@scalar
def _node(u, n):
    """Cell ``i`` (clamped to ``[0, n−1]``) and fraction ``f = u − i`` of SAT coordinate ``u``
    already clamped to ``[0, n]``."""
    i = int(u)
    if i > n - 1:
        i = n - 1
    return i, u - i


@scalar
def _clamp(u, n):
    if u < 0.0:
        return 0.0
    if u > n:
        return float(n)
    return u


@scalar
def sat_corner(S, x, y, z):
    """Integral of the field over ``[−½, x] × [−½, y] × [−½, z]`` (sample index units).

    Trilinear interpolation of ``S`` at ``(x+½, y+½, z+½)`` clamped to the table; exact for the
    piecewise-constant field. Needs every axis of the grid non-empty."""
    nx = S.shape[0] - 1
    ny = S.shape[1] - 1
    nz = S.shape[2] - 1
    i, fx = _node(_clamp(x + 0.5, nx), nx)
    j, fy = _node(_clamp(y + 0.5, ny), ny)
    k, fz = _node(_clamp(z + 0.5, nz), nz)
    c00 = S[i, j, k] + fx * (S[i + 1, j, k] - S[i, j, k])
    c10 = S[i, j + 1, k] + fx * (S[i + 1, j + 1, k] - S[i, j + 1, k])
    c01 = S[i, j, k + 1] + fx * (S[i + 1, j, k + 1] - S[i, j, k + 1])
    c11 = S[i, j + 1, k + 1] + fx * (S[i + 1, j + 1, k + 1] - S[i, j + 1, k + 1])
    c0 = c00 + fy * (c10 - c00)
    c1 = c01 + fy * (c11 - c01)
    return c0 + fz * (c1 - c0)


@scalar
def axis_stencil(x0, x1, n):
    """1-D difference stencil of the interval ``[x0, x1]`` (sample index units, ``x0 ≤ x1``) on an
    axis of ``n ≥ 1`` cells.

    Returns ``(i0, i1, w0, w1, w2, w3)`` such that, along this axis,
    ``C(x1) − C(x0) = w0·S[i0] + w1·S[i0+1] + w2·S[i1] + w3·S[i1+1]`` where ``C`` is the
    (linearly interpolated) cumulative integral. Both ends are clamped to the grid, so the parts
    of the interval in vacuum contribute nothing. The weights are the cells' overlap lengths
    written so that a short interval straddling one cell face keeps its relative precision: the
    shared node's weight is ``(1 − f0) − f1``, a difference of the two small overlaps, never of
    two numbers near 1 (the literal eight-corner sum loses ~2e-6 relative on a 2e-9 box)."""
    u0 = _clamp(x0 + 0.5, n)
    u1 = _clamp(x1 + 0.5, n)
    i0, f0 = _node(u0, n)
    i1, f1 = _node(u1, n)
    if i0 == i1:
        if u0 == x0 + 0.5 and u1 == x1 + 0.5:
            d = x1 - x0  # not clamped: the length exactly as given
        else:
            d = f1 - f0
        return i0, i1, -d, d, 0.0, 0.0
    if i1 == i0 + 1:
        # nodes i0, i0+1 (= i1), i1+1: overlaps (1 − f0) with cell i0 and f1 with cell i1
        return i0, i1, f0 - 1.0, (1.0 - f0) - f1, 0.0, f1
    return i0, i1, f0 - 1.0, -f0, 1.0 - f1, f1


@scalar
def _line(S, i, j, k0, k1, c0, c1, c2, c3):
    return c0 * S[i, j, k0] + c1 * S[i, j, k0 + 1] + c2 * S[i, j, k1] + c3 * S[i, j, k1 + 1]


@scalar
def _plane(S, i, j0, j1, b0, b1, b2, b3, k0, k1, c0, c1, c2, c3):
    return (
        b0 * _line(S, i, j0, k0, k1, c0, c1, c2, c3)
        + b1 * _line(S, i, j0 + 1, k0, k1, c0, c1, c2, c3)
        + b2 * _line(S, i, j1, k0, k1, c0, c1, c2, c3)
        + b3 * _line(S, i, j1 + 1, k0, k1, c0, c1, c2, c3)
    )


@scalar
def _contract(S, i0, i1, a0, a1, a2, a3, j0, j1, b0, b1, b2, b3, k0, k1, c0, c1, c2, c3):
    """``Σ a_p b_q c_r S[i_p, j_q, k_r]`` over the three 4-node stencils: 64 fused multiply-adds.

    Branch-free on purpose: zero weights are multiplied (their nodes are valid indices), because
    a branch that skips them costs more on the CPU than the multiplications it saves."""
    return (
        a0 * _plane(S, i0, j0, j1, b0, b1, b2, b3, k0, k1, c0, c1, c2, c3)
        + a1 * _plane(S, i0 + 1, j0, j1, b0, b1, b2, b3, k0, k1, c0, c1, c2, c3)
        + a2 * _plane(S, i1, j0, j1, b0, b1, b2, b3, k0, k1, c0, c1, c2, c3)
        + a3 * _plane(S, i1 + 1, j0, j1, b0, b1, b2, b3, k0, k1, c0, c1, c2, c3)
    )


@scalar
def box_sum(S, x0, x1, y0, y1, z0, z1):
    """Integral of the field over the box ``[x0, x1] × [y0, y1] × [z0, z1]`` (sample index units,
    lower ≤ upper per axis; parts outside the grid are vacuum).

    Equal to the inclusion–exclusion ``Σ ± sat_corner`` over the box's eight corners, evaluated
    as the product of the three per-axis stencils of :func:`axis_stencil`."""
    i0, i1, a0, a1, a2, a3 = axis_stencil(x0, x1, S.shape[0] - 1)
    j0, j1, b0, b1, b2, b3 = axis_stencil(y0, y1, S.shape[1] - 1)
    k0, k1, c0, c1, c2, c3 = axis_stencil(z0, z1, S.shape[2] - 1)
    return _contract(S, i0, i1, a0, a1, a2, a3, j0, j1, b0, b1, b2, b3, k0, k1, c0, c1, c2, c3)


@scalar
def _mean_stencil(c, a, n):
    """Stencil of ``[c − a, c + a]`` divided by its full length ``2a`` (vacuum counts as zero);
    for ``a = 0`` (or an ``a`` too small to change ``c``) the point value: the cell holding ``c``,
    or nothing outside the grid."""
    x0 = c - a
    x1 = c + a
    length = x1 - x0
    if length > 0.0:
        i0, i1, w0, w1, w2, w3 = axis_stencil(x0, x1, n)
        if w2 == 0.0 and w3 == 0.0 and w1 == length:
            return i0, i1, -1.0, 1.0, 0.0, 0.0  # inside one cell, not clamped: exactly that cell
        return i0, i1, w0 / length, w1 / length, w2 / length, w3 / length
    u = c + 0.5
    if u < 0.0 or u > n:
        return 0, 0, 0.0, 0.0, 0.0, 0.0
    i, _ = _node(u, n)
    return i, i, -1.0, 1.0, 0.0, 0.0


@scalar
def box_mean(S, cx, cy, cz, ax, ay, az):
    """Mean of the field over the box centred at ``(cx, cy, cz)`` with half-edges
    ``(ax, ay, az) ≥ 0`` (sample index units): the box integral divided by the *full* box volume,
    so the vacuum outside the grid lowers the mean near the boundary. A zero half-edge takes the
    point value along that axis."""
    i0, i1, a0, a1, a2, a3 = _mean_stencil(cx, ax, S.shape[0] - 1)
    j0, j1, b0, b1, b2, b3 = _mean_stencil(cy, ay, S.shape[1] - 1)
    k0, k1, c0, c1, c2, c3 = _mean_stencil(cz, az, S.shape[2] - 1)
    return _contract(S, i0, i1, a0, a1, a2, a3, j0, j1, b0, b1, b2, b3, k0, k1, c0, c1, c2, c3)


@driver
def mean_extinction_grid(S, ax, ay, az, out):
    """``out[i, j, k] = max(0, box_mean(S, i, j, k, ax, ay, az))`` at every sample.

    The clamp removes the rounding of the table's differences next to empty regions. The x and y
    stencils are formed once per (i, j) row (the same arithmetic as :func:`box_mean`)."""
    nx, ny, nz = out.shape
    for r in prange(nx * ny):
        i = r // ny
        j = r - i * ny
        i0, i1, a0, a1, a2, a3 = _mean_stencil(float(i), ax, nx)
        j0, j1, b0, b1, b2, b3 = _mean_stencil(float(j), ay, ny)
        for k in range(nz):
            k0, k1, c0, c1, c2, c3 = _mean_stencil(float(k), az, nz)
            m = _contract(S, i0, i1, a0, a1, a2, a3, j0, j1, b0, b1, b2, b3, k0, k1, c0, c1, c2, c3)
            out[i, j, k] = m if m > 0.0 else 0.0


@scalar(inline=True)
def interval_mean(p0, p0n, g0, p1, p1n, g1, inv_len):
    """One sample of a separable box mean along a line: ``(C(c + a) − C(c − a)) / 2a``, clamped at 0,
    where ``C(x) = (1 − g)·P[i] + g·P[i+1]`` is the line's cumulative integral read from its float64
    prefix sums — ``p0, p0n`` = ``P[i0], P[i0+1]`` with fraction ``g0`` (the interval's start), ``p1,
    p1n`` at its end — and ``inv_len = 1/2a`` (:func:`pv_ambient.stages.sat.axis_weights`). The clamp
    removes the rounding of the difference next to empty regions. The CPU's passes
    (:func:`box_mean_plane`, :func:`box_mean_z`) and the GPU's (:func:`box_mean_line`) share it."""
    v = (((1.0 - g1) * p1 + g1 * p1n) - ((1.0 - g0) * p0 + g0 * p0n)) * inv_len
    return v if v > 0.0 else 0.0


@scalar(inline=True)
def line_at(src, axis, a, p, q):
    """Entry ``a`` of the line of 3-D array ``src`` along ``axis`` through ``(p, q)`` (the other two
    indices in order)."""
    if axis == 0:
        return src[a, p, q]
    if axis == 1:
        return src[p, a, q]
    return src[p, q, a]


@scalar
def box_mean_line(src, dst, axis, i0, f0, i1, f1, inv_len, p, q):
    """One line of a separable box mean along ``axis`` (through ``(p, q)``, :func:`line_at`) from
    ``src`` into ``dst`` (another array): :func:`interval_mean` at every sample, the loop body of
    the GPU's pass (one thread per line).

    Without a buffer of prefix sums: each end of the interval walks the line with a running float64
    sum ``P[i+1] = P[i] + src[i]``, from 0, and both ends only move forward as the sample does. The
    sums are the CPU's, term by term and in its order, so the means equal the CPU's but for the
    rounding of :func:`interval_mean` itself; and the pass needs no float64 copy of the grid."""
    n = src.shape[axis]
    b0 = 0  # the start's cell and P[b0], P[b0 + 1]
    s0 = 0.0
    s0n = 0.0 + line_at(src, axis, 0, p, q)
    b1 = 0  # the end's
    s1 = 0.0
    s1n = s0n
    for c in range(n):
        a0 = i0[c]
        a1 = i1[c]
        while b0 < a0:
            b0 += 1
            s0 = s0n
            s0n = s0n + line_at(src, axis, b0, p, q)
        while b1 < a1:
            b1 += 1
            s1 = s1n
            s1n = s1n + line_at(src, axis, b1, p, q)
        v = interval_mean(s0, s0n, f0[c], s1, s1n, f1[c], inv_len)
        if axis == 0:
            dst[c, p, q] = v
        elif axis == 1:
            dst[p, c, q] = v
        else:
            dst[p, q, c] = v


@scalar(inline=True)
def ball_albedo_value(s, m):
    """The ball's mean albedo of one channel, ``clip(m / s, 0, 1)`` from its mean scattering ``m``
    and mean extinction ``s`` = σ̄, 0 where σ̄ = 0 (no medium in the ball: nothing scatters)."""
    v = m / s if s > 0.0 else 0.0
    return min(max(v, 0.0), 1.0)


@scalar(inline=True)
def ball_channel_node(src, c, ball, i, j, k):
    """Channel ``c`` of the (nx, ny, nz, 4) ball grid at sample (i, j, k) from the box mean ``src``:
    σ̄ itself for ``c = 0``, else the ball's mean albedo (:func:`ball_albedo_value`) from the mean
    scattering ``src`` and channel 0's σ̄ — what :func:`pv_ambient.stages.ball.ball_grid` writes on
    the CPU (:func:`ball_albedo_into`), the loop body of the GPU's kernel."""
    if c == 0:
        ball[i, j, k, 0] = src[i, j, k]
    else:
        ball[i, j, k, c] = ball_albedo_value(ball[i, j, k, 0], src[i, j, k])


@driver
def box_mean_plane(src, dst, axis, i0, f0, i1, f1, inv_len):
    """One axis of a separable box mean (:func:`pv_ambient.stages.sat.box_mean_separable`) along
    ``axis`` 0 or 1: ``dst[c] = (C(c + a) − C(c − a)) / 2a`` per line, ``C`` the line's cumulative
    integral (float64 prefix sums, linear inside a cell) read at the precomputed ``(i0, f0)`` /
    ``(i1, f1)`` of :func:`pv_ambient.stages.sat.axis_weights`; ``inv_len = 1/2a``. ``dst`` may be
    ``src``: each plane across the other of axes 0 and 1 is buffered before it is written. Parallel
    over those planes, the inner loop over the contiguous last axis."""
    nx, ny, nz = src.shape
    n = nx if axis == 0 else ny
    planes = ny if axis == 0 else nx
    for m in prange(planes):
        P = np.empty((n + 1, nz), np.float64)
        for k in range(nz):
            P[0, k] = 0.0
        for a in range(n):
            for k in range(nz):
                P[a + 1, k] = P[a, k] + (src[a, m, k] if axis == 0 else src[m, a, k])
        for c in range(n):
            a0 = i0[c]
            a1 = i1[c]
            g0 = f0[c]
            g1 = f1[c]
            for k in range(nz):
                v = interval_mean(P[a0, k], P[a0 + 1, k], g0, P[a1, k], P[a1 + 1, k], g1, inv_len)
                if axis == 0:
                    dst[c, m, k] = v
                else:
                    dst[m, c, k] = v


@driver
def box_mean_z(src, dst, i0, f0, i1, f1, inv_len):
    """:func:`box_mean_plane` along the last axis (parallel over i, a line buffer per (i, j))."""
    nx, ny, nz = src.shape
    for i in prange(nx):
        P = np.empty(nz + 1, np.float64)
        for j in range(ny):
            P[0] = 0.0
            for k in range(nz):
                P[k + 1] = P[k] + src[i, j, k]
            for c in range(nz):
                a0 = i0[c]
                a1 = i1[c]
                g0 = f0[c]
                g1 = f1[c]
                dst[i, j, c] = interval_mean(P[a0], P[a0 + 1], g0, P[a1], P[a1 + 1], g1, inv_len)


@driver
def ball_albedo_into(sbar, ms, ball, c):
    """``ball[..., c] = clip(ms / sbar, 0, 1)`` where σ̄ = ``sbar`` > 0, else 0 (:func:`ball_albedo`
    written into one channel of the (nx, ny, nz, 4) ball grid)."""
    nx, ny, nz = sbar.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                ball[i, j, k, c] = ball_albedo_value(sbar[i, j, k], ms[i, j, k])


@driver
def ball_albedo(sbar, ms, out):
    """``out = clip(ms / sbar, 0, 1)`` where σ̄ = ``sbar`` > 0, else 0: the ball's mean albedo of one
    channel from its mean scattering ``ms`` (float32 arrays of one shape; one pass, no temporaries)."""
    nx, ny, nz = out.shape
    for r in prange(nx * ny):
        i = r // ny
        j = r - i * ny
        for k in range(nz):
            out[i, j, k] = ball_albedo_value(sbar[i, j, k], ms[i, j, k])


@driver
def positive_range(ball):
    """(min, max) of channels 1–3 of ``ball`` (nx, ny, nz, 4) over the samples whose channel 0 is
    positive; (inf, −inf) when there are none."""
    nx, ny, nz = ball.shape[0], ball.shape[1], ball.shape[2]
    lo = np.full(nx, np.inf)
    hi = np.full(nx, -np.inf)
    for i in prange(nx):
        a = np.inf
        b = -np.inf
        for j in range(ny):
            for k in range(nz):
                if ball[i, j, k, 0] > 0.0:
                    for c in range(1, 4):
                        v = ball[i, j, k, c]
                        a = min(a, v)
                        b = max(b, v)
        lo[i] = a
        hi[i] = b
    return lo.min(), hi.max()
