"""Null-collision tracking through a majorant grid: delta tracking (free-flight sampling) and
ratio tracking (transmittance estimation) — scalar kernels (docs/path_tracer.rst, docs/architecture.rst).

A ray is given in sample index space (``p + t·q``, ``t`` the world distance, as in
:mod:`.raycast`) together with the interval ``[t0, t1)`` to track over (already clipped to the
medium's box). The majorant grid ``maj`` (:func:`.majorant.build_majorant`) bounds σt on each
block of ``block`` samples; the tracker walks the blocks the ray crosses with a 3D DDA
(Amanatides & Woo 1987) and, inside each block, samples tentative collisions of a homogeneous
medium with that block's majorant σ̄:

* **delta tracking** (Woodcock 1965): step ``t += −ln(1 − u)/σ̄``; at a tentative collision
  accept it as real with probability σt(x)/σ̄. The accepted distance has density
  ``σt(t) exp(−∫σt)`` exactly, whatever the (valid) majorant.
* **ratio tracking** (Novák, Selle, Jarosz 2014): the same tentative collisions, but the
  transmittance estimate is multiplied by ``1 − σt(x)/σ̄`` at each; an unbiased estimate of
  ``exp(−∫σt)``. Once it falls below ``rr_below`` it is Russian-rouletted (survive with
  probability ``T/rr_below``, then ``T = rr_below``), still unbiased, so dense media cost a
  bounded number of steps.

Reaching a block's exit restarts the exponential there (memorylessness), so a per-block majorant
changes cost, never the distribution. A block whose majorant is 0 holds no medium at all (σt ≥ 0
and trilinear interpolation of its zero samples is zero) and is crossed in one step, exactly.

Blocks outside the majorant grid: the medium's box can reach half a sample beyond the outermost
samples (cell data) where the lookups clamp to the boundary samples; the first and last block
along each axis are therefore treated as extending to ±∞ (their exit on that side is ``inf``),
which keeps the DDA inside the grid without special cases.

Random numbers: every draw is ``rng.uniform(seed, stream, counter, dim)`` with the caller's
``dim`` counter incremented per draw; the trackers take ``k = rng.key(seed, stream, counter)``
(hashed once per path) and return the advanced ``dim``. :func:`draw` reproduces
``rng.uniform`` bit for bit from ``k``.

The two ``*_array`` drivers at the end are thin serial loops for the tests.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import driver, scalar
from .interp import trilinear
from .majorant import block_of
from .medium import MODE_GRID, lut_coords, lut_value
from .rng import GOLDEN, INV53, key, mix64

INF = math.inf


@scalar
def draw(k, dim):
    """Uniform in [0, 1) for key ``k = rng.key(seed, stream, counter)`` and dimension ``dim``.

    Identical bits to ``rng.uniform(seed, stream, counter, dim)``; the key is hashed once per
    path instead of once per draw.
    """
    z = mix64(k + np.uint64(dim) * GOLDEN)
    return np.float64(z >> np.uint64(11)) * INV53


@scalar
def sigma_lookup(mode, field, table, lut_lo, lut_inv, x, y, z):
    """σt at index-space point (x, y, z), and the table location ``(k0, k1, f)`` that
    :func:`.raycast.medium_albedo_emission` takes (unused in GRID mode)."""
    s = trilinear(field, x, y, z)
    if mode == MODE_GRID:
        return s, 0, 0, 0.0
    k0, k1, f = lut_coords(s, lut_lo, lut_inv, table.shape[0])
    return lut_value(table, k0, k1, f, 0), k0, k1, f


@scalar
def axis_exit(p, q, a, block, m):
    """Ray parameter where ``p + t·q`` leaves slab ``a`` of ``m`` slabs of width ``block``.

    The first slab extends to −∞ and the last to +∞ (lookups clamp there), so the exit on
    those sides, and along an axis the ray does not move on, is ``inf``.
    """
    if q > 0.0:
        if a >= m - 1:
            return INF
        return ((a + 1) * block - p) / q
    if q < 0.0:
        if a <= 0:
            return INF
        return (a * block - p) / q
    return INF


@scalar
def block_span(px, py, pz, qx, qy, qz, a, b, c, block, mx, my, mz, t, t1):
    """Exits of block (a, b, c) along each axis and overall, ``(tx, ty, tz, tb)``; ``tb`` is
    clipped to ``t1`` and never behind ``t``, whatever the rounding."""
    tx = axis_exit(px, qx, a, block, mx)
    ty = axis_exit(py, qy, b, block, my)
    tz = axis_exit(pz, qz, c, block, mz)
    return tx, ty, tz, max(min(min(tx, ty), min(tz, t1)), t)


@scalar
def next_block(a, b, c, tx, ty, tz, tb, qx, qy, qz):
    """The block entered at ``tb``: step every axis whose exit is reached (DDA)."""
    if tx <= tb:
        a += 1 if qx > 0.0 else -1
    if ty <= tb:
        b += 1 if qy > 0.0 else -1
    if tz <= tb:
        c += 1 if qz > 0.0 else -1
    return a, b, c


@scalar
def delta_track(px, py, pz, qx, qy, qz, t0, t1, mode, field, table, lut_lo, lut_inv, maj, block, k, dim):
    """Sample the first real collision on ``[t0, t1)`` by delta tracking.

    Returns ``(hit, t, sigma, k0, k1, f, dim)``: ``hit`` is False when the ray leaves the
    interval (then ``t = t1``); otherwise ``t`` is the collision, ``sigma`` σt there and
    ``(k0, k1, f)`` its table location.
    """
    mx, my, mz = maj.shape
    t = t0
    # Locate the starting block.
    a = block_of(px + t * qx, block, mx)
    b = block_of(py + t * qy, block, my)
    c = block_of(pz + t * qz, block, mz)
    while t < t1:
        tx, ty, tz, tb = block_span(px, py, pz, qx, qy, qz, a, b, c, block, mx, my, mz, t, t1)
        m = maj[a, b, c]
        if m > 0.0:
            # Tentative collisions of the block's homogeneous majorant medium.
            inv = 1.0 / m
            while True:
                u = draw(k, dim)
                dim += 1
                t -= math.log1p(-u) * inv
                if t >= tb:
                    break
                s, k0, k1, f = sigma_lookup(mode, field, table, lut_lo, lut_inv, px + t * qx, py + t * qy,
                                            pz + t * qz)
                u = draw(k, dim)
                dim += 1
                if u * m < s:
                    return True, t, s, k0, k1, f, dim
        # Restart at the block's exit (memoryless) and step into the next block.
        t = tb
        if tb >= t1:
            break
        a, b, c = next_block(a, b, c, tx, ty, tz, tb, qx, qy, qz)
    return False, t1, 0.0, 0, 0, 0.0, dim


@scalar
def ratio_track(px, py, pz, qx, qy, qz, t0, t1, mode, field, table, lut_lo, lut_inv, maj, block, rr_below,
                k, dim):
    """Unbiased estimate of ``exp(−∫_{t0}^{t1} σt)`` by ratio tracking.

    ``rr_below`` > 0 switches on Russian roulette once the estimate drops below it (0: never).
    Returns ``(T, dim)``.
    """
    mx, my, mz = maj.shape
    T = 1.0
    t = t0
    a = block_of(px + t * qx, block, mx)
    b = block_of(py + t * qy, block, my)
    c = block_of(pz + t * qz, block, mz)
    while t < t1:
        tx, ty, tz, tb = block_span(px, py, pz, qx, qy, qz, a, b, c, block, mx, my, mz, t, t1)
        m = maj[a, b, c]
        if m > 0.0:
            inv = 1.0 / m
            while True:
                u = draw(k, dim)
                dim += 1
                t -= math.log1p(-u) * inv
                if t >= tb:
                    break
                s, _, _, _ = sigma_lookup(mode, field, table, lut_lo, lut_inv, px + t * qx, py + t * qy,
                                          pz + t * qz)
                # Weight by the null-collision probability; max() guards rounding above σ̄.
                T *= max(1.0 - s * inv, 0.0)
                if T <= 0.0:
                    return 0.0, dim
                if T < rr_below:
                    # Russian roulette: survive with probability T/rr_below, weight rr_below.
                    u = draw(k, dim)
                    dim += 1
                    if u * rr_below >= T:
                        return 0.0, dim
                    T = rr_below
        t = tb
        if tb >= t1:
            break
        a, b, c = next_block(a, b, c, tx, ty, tz, tb, qx, qy, qz)
    return T, dim


# --- thin serial drivers for the tests ---------------------------------------------------


@driver(parallel=False)
def free_flight_array(px, py, pz, qx, qy, qz, t0, t1, mode, field, table, lut_lo, lut_inv, maj, block, seed,
                      out):
    """``out[n]`` = delta-tracked collision distance of sample ``n`` (``inf`` when it escapes)."""
    for n in range(out.shape[0]):
        hit, t, _, _, _, _, _ = delta_track(px, py, pz, qx, qy, qz, t0, t1, mode, field, table, lut_lo, lut_inv,
                                            maj, block, key(seed, 0, n), 0)
        out[n] = t if hit else INF


@driver(parallel=False)
def transmittance_array(px, py, pz, qx, qy, qz, t0, t1, mode, field, table, lut_lo, lut_inv, maj, block,
                        rr_below, seed, out):
    """``out[n]`` = ratio-tracking estimate ``n`` of the transmittance over ``[t0, t1)``."""
    for n in range(out.shape[0]):
        T, _ = ratio_track(px, py, pz, qx, qy, qz, t0, t1, mode, field, table, lut_lo, lut_inv, maj, block,
                           rr_below, key(seed, 0, n), 0)
        out[n] = T
