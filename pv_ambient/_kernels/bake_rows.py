"""The bake of one light in vectorised chunks of a row (docs/performance.rst, "Relight: the
bake"): what :func:`.bake.bake_node` computes for a light grid on the data samples, a point or
directional light, the Beer–Lambert front and a D table without an angle axis — the default of an
isotropic phase function — as loops over :data:`CHUNK` nodes of a row that LLVM turns into SIMD
code.

The node's rule is :func:`.bake.bake_node`'s, pass by pass (:func:`bake_rows`):

1. :func:`chunk_direct` — per node its world position, the light's irradiance and direction
   (:func:`.raycast.light_at`), the direct term ``E T p``;
2. :func:`chunk_front` (ambient scattering) — the ball's entry point ``x − s·ω``
   (:func:`.raycast.ball_entry`) and ``E Φ`` with the front ``Φ = e^{−τ}`` there (trilinear,
   clamped as :func:`.interp.cell_coords` clamps: the last cell with fraction 1 where it takes the
   last node);
3. :func:`chunk_store` — ``(E T p + E Φ D)·max(d², d2min)`` added to (or written in) the slot, D
   read per node from :func:`ball_d_rows`' array: D(r σ̄, ā) does not depend on the lights, so it
   is computed once per transfer function, not per light (:func:`.preint.d_lookup3` without θ —
   :func:`.preint.tau_coord` in selects, the albedo node counted instead of searched).

What differs from the scalar rule: ``exp`` and ``log`` are :func:`.expneg.exp_neg` and
:func:`.expneg.log_pos` (relative 1e-13 and 1e-15 of ``math``'s; a libm call keeps a loop scalar),
and a coordinate beyond the last node interpolates the last cell at fraction 1 (a rounding of the
last node's value). Why chunks of a flat per-thread array with constant offsets: LLVM vectorises a
loop only when it can prove that the chunk's fields do not overlap (:mod:`.packet`'s rule). Every
other case — a light grid finer or coarser than the data, the tube front, an angle-dependent D —
runs :func:`.bake.bake_incident` (``tests/kernels/test_bake_rows.py`` compares the two).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ._jit import driver, prange, scalar
from .expneg import exp_neg, log_pos
from .medium import min_index
from .models import AMBIENT_SCATTERING
from .phase import INV_4PI

#: Nodes per chunk: a multiple of every vector width, small enough that a thread's chunk fields stay in L1.
CHUNK = 32

# float64 chunk fields: the direct term per channel, E·Φ per channel, the fall-off undo
# max(d², d2min), D's τ node and fraction, the albedos, each channel's albedo node
SR, SG, SB, FR, FG, FB, D2, IT, TT, AR, AG, AB, NR, NG, NB = range(15)
NF = 15
ZERO = np.uint64(0)
ONE = np.uint64(1)
TWO = np.uint64(2)
THREE = np.uint64(3)


def scratch():
    """The chunk fields of every thread of Numba's pool (float64, flat)."""
    return np.zeros(numba.config.NUMBA_NUM_THREADS * NF * CHUNK, np.float64)


@scalar(force_inline=True)
def light_dir(lights, point, wx, wy, wz):
    """:func:`.raycast.light_at` of light 0 in selects: its irradiance per unit power, direction,
    d² and the fall-off undo ``max(d², d2min)`` (1 for a directional light)."""
    lvec = lights.vec
    vx = wx - lvec[0, 0]
    vy = wy - lvec[0, 1]
    vz = wz - lvec[0, 2]
    d2 = vx * vx + vy * vy + vz * vz
    pos = d2 > 0.0
    inv = 1.0 / math.sqrt(d2 if pos else 1.0)
    d2c = max(d2, lights.d2min)
    if point:
        return 1.0 / d2c, vx * inv if pos else 0.0, vy * inv if pos else 0.0, vz * inv if pos else 1.0, d2, d2c
    return 1.0, lvec[0, 0], lvec[0, 1], lvec[0, 2], d2, 1.0


@scalar(force_inline=True)
def row_origin(i2w, x, y):
    """World position of row (x, y)'s node 0: a node k adds ``k`` times the third column of ``i2w``."""
    return (i2w[0, 0] * x + i2w[0, 1] * y + i2w[0, 3], i2w[1, 0] * x + i2w[1, 1] * y + i2w[1, 3],
            i2w[2, 0] * x + i2w[2, 1] * y + i2w[2, 3])


@scalar(inline=True)
def chunk_direct(lights, point, tau, i2w, p, ui, uj, k0, m2, s, b):
    """Pass 1 of nodes ``k0 … k0 + CHUNK − 1`` of row (i, j) (the last node repeated past the row's
    end), every model: the direct term ``E T p`` per channel and the fall-off undo."""
    lpow = lights.power
    x = float(ui)
    y = float(uj)
    bx, by, bz = row_origin(i2w, x, y)
    last = np.uint64(m2 - 1)
    for q in range(CHUNK):
        k = min_index(np.uint64(k0 + q), last)
        z = float(k)
        wgt, ox, oy, oz, d2, d2c = light_dir(lights, point, bx + i2w[0, 2] * z, by + i2w[1, 2] * z, bz + i2w[2, 2] * z)
        w = exp_neg(tau[ui, uj, k, ZERO]) * p
        s[np.uint64(b + SR * CHUNK + q)] = (lpow[0, 0] * wgt) * w
        s[np.uint64(b + SG * CHUNK + q)] = (lpow[0, 1] * wgt) * w
        s[np.uint64(b + SB * CHUNK + q)] = (lpow[0, 2] * wgt) * w
        s[np.uint64(b + D2 * CHUNK + q)] = d2c


@scalar(inline=True)
def chunk_ball(ball, n_tau, tau1, radius, tau_lo_log, tau_dlog, ui, uj, k0, m2, s, b):
    """Pass 1 of :func:`ball_d_rows`: the ball's albedos and D's τ coordinate
    (:func:`.preint.tau_coord` in selects) at nodes ``k0 … k0 + CHUNK − 1`` of row (i, j)."""
    last = np.uint64(m2 - 1)
    for q in range(CHUNK):
        k = min_index(np.uint64(k0 + q), last)
        s[np.uint64(b + AR * CHUNK + q)] = ball[ui, uj, k, ONE]
        s[np.uint64(b + AG * CHUNK + q)] = ball[ui, uj, k, TWO]
        s[np.uint64(b + AB * CHUNK + q)] = ball[ui, uj, k, THREE]
        tb = radius * ball[ui, uj, k, ZERO]
        u = (log_pos(max(tb, tau1)) - tau_lo_log) / tau_dlog
        uc = min(max(u, 0.0), n_tau - 2.0)
        ku = min_index(np.uint64(np.uint32(uc)), np.uint64(n_tau - 3))
        it = float(ku + np.uint64(1))
        tt = uc - float(ku)
        lin = tb < tau1
        it = 0.0 if lin else it
        tt = tb / tau1 if lin else tt
        nonpos = not (tb > 0.0)
        s[np.uint64(b + IT * CHUNK + q)] = 0.0 if nonpos else it
        s[np.uint64(b + TT * CHUNK + q)] = 0.0 if nonpos else tt


@scalar(inline=True)
def chunk_front(lights, point, tau, w2i, i2w, radius, ui, uj, k0, m2, s, b):
    """Pass 1, ambient scattering: ``E Φ`` per channel, the front Φ read at the ball's entry point
    (:func:`.raycast.ball_entry`; the light grid is the data samples)."""
    lpow = lights.power
    n0 = tau.shape[0]
    n1 = tau.shape[1]
    n2 = tau.shape[2]
    x = float(ui)
    y = float(uj)
    bx, by, bz = row_origin(i2w, x, y)
    last = np.uint64(m2 - 1)
    for q in range(CHUNK):
        k = min_index(np.uint64(k0 + q), last)
        z = float(k)
        wgt, ox, oy, oz, d2, d2c = light_dir(lights, point, bx + i2w[0, 2] * z, by + i2w[1, 2] * z, bz + i2w[2, 2] * z)
        sb = min(radius, math.sqrt(d2)) if point else radius
        lx = min(max(x - sb * (w2i[0, 0] * ox + w2i[0, 1] * oy + w2i[0, 2] * oz), 0.0), n0 - 1.0)
        ly = min(max(y - sb * (w2i[1, 0] * ox + w2i[1, 1] * oy + w2i[1, 2] * oz), 0.0), n1 - 1.0)
        lz = min(max(z - sb * (w2i[2, 0] * ox + w2i[2, 1] * oy + w2i[2, 2] * oz), 0.0), n2 - 1.0)
        i0 = min_index(np.uint64(np.uint32(lx)), np.uint64(n0 - 2))
        j0 = min_index(np.uint64(np.uint32(ly)), np.uint64(n1 - 2))
        c0 = min_index(np.uint64(np.uint32(lz)), np.uint64(n2 - 2))
        fx = lx - float(i0)
        fy = ly - float(j0)
        fz = lz - float(c0)
        i1 = i0 + np.uint64(1)
        j1 = j0 + np.uint64(1)
        c1 = c0 + np.uint64(1)
        c00 = tau[i0, j0, c0, ZERO] + fx * (tau[i1, j0, c0, ZERO] - tau[i0, j0, c0, ZERO])
        c10 = tau[i0, j1, c0, ZERO] + fx * (tau[i1, j1, c0, ZERO] - tau[i0, j1, c0, ZERO])
        c01 = tau[i0, j0, c1, ZERO] + fx * (tau[i1, j0, c1, ZERO] - tau[i0, j0, c1, ZERO])
        c11 = tau[i0, j1, c1, ZERO] + fx * (tau[i1, j1, c1, ZERO] - tau[i0, j1, c1, ZERO])
        e0 = c00 + fy * (c10 - c00)
        e1 = c01 + fy * (c11 - c01)
        f = exp_neg(e0 + fz * (e1 - e0))
        s[np.uint64(b + FR * CHUNK + q)] = (lpow[0, 0] * wgt) * f
        s[np.uint64(b + FG * CHUNK + q)] = (lpow[0, 1] * wgt) * f
        s[np.uint64(b + FB * CHUNK + q)] = (lpow[0, 2] * wgt) * f


@scalar(inline=True)
def chunk_albedo(a_nodes, nch, s, b):
    """Pass 2: each channel's albedo node, the count of nodes ``1 … n − 2`` at or below it (the
    node loop outermost, so the loop over the chunk is the one LLVM vectorises)."""
    for q in range(CHUNK):
        s[np.uint64(b + NR * CHUNK + q)] = 0.0
        s[np.uint64(b + NG * CHUNK + q)] = 0.0
        s[np.uint64(b + NB * CHUNK + q)] = 0.0
    for m in range(1, a_nodes.shape[0] - 1):
        am = a_nodes[m]
        for q in range(CHUNK):
            s[np.uint64(b + NR * CHUNK + q)] += 1.0 if am <= s[np.uint64(b + AR * CHUNK + q)] else 0.0
            if nch == 3:
                s[np.uint64(b + NG * CHUNK + q)] += 1.0 if am <= s[np.uint64(b + AG * CHUNK + q)] else 0.0
                s[np.uint64(b + NB * CHUNK + q)] += 1.0 if am <= s[np.uint64(b + AB * CHUNK + q)] else 0.0


@scalar(force_inline=True)
def d_node(D, a_nodes, it, tt, na, a):
    """D at τ coordinate (it, tt) for albedo ``a`` whose node (counted) is ``na``:
    :func:`.preint.d_lookup3`'s albedo interpolation on a table without θ."""
    ia = np.uint64(np.uint32(na))
    a0 = a_nodes[ia]
    ta = min(max((a - a0) / (a_nodes[ia + 1] - a0), 0.0), 1.0)
    lo = (1.0 - tt) * D[ia, it, ZERO] + tt * D[ia, it + np.uint64(1), ZERO]
    ib = min_index(ia + np.uint64(1), np.uint64(D.shape[0] - 1))
    hi = (1.0 - tt) * D[ib, it, ZERO] + tt * D[ib, it + np.uint64(1), ZERO]
    return (1.0 - ta) * lo + ta * hi


@scalar(inline=True)
def chunk_store(model, dgrid, dscale, nch, q0, add, ui, uj, k0, m2, s, b, out):
    """Pass 2: ``(E T p + E Φ D)·max(d², d2min)`` of the chunk's nodes in the row added to slot
    ``q0`` (``add``), or written there; D = ``dgrid × dscale`` (:func:`ball_d_rows`: one channel
    when the ball's albedo is grey)."""
    n = min(CHUNK, m2 - k0)
    uq0 = np.uint64(q0)
    dg = np.uint64(min(1, dgrid.shape[3] - 1))
    db = np.uint64(min(2, dgrid.shape[3] - 1))
    keep = 1.0 if add else 0.0
    for q in range(n):
        k = np.uint64(k0 + q)
        d2c = s[np.uint64(b + D2 * CHUNK + q)]
        sr = s[np.uint64(b + SR * CHUNK + q)]
        sg = s[np.uint64(b + SG * CHUNK + q)]
        sb = s[np.uint64(b + SB * CHUNK + q)]
        if model == AMBIENT_SCATTERING:
            sr += s[np.uint64(b + FR * CHUNK + q)] * (dscale * float(dgrid[ui, uj, k, ZERO]))
            sg += s[np.uint64(b + FG * CHUNK + q)] * (dscale * float(dgrid[ui, uj, k, dg]))
            sb += s[np.uint64(b + FB * CHUNK + q)] * (dscale * float(dgrid[ui, uj, k, db]))
        out[ui, uj, k, uq0] = keep * out[ui, uj, k, uq0] + sr * d2c
        if nch == 3:
            out[ui, uj, k, uq0 + np.uint64(1)] = keep * out[ui, uj, k, uq0 + np.uint64(1)] + sg * d2c
            out[ui, uj, k, uq0 + np.uint64(2)] = keep * out[ui, uj, k, uq0 + np.uint64(2)] + sb * d2c


@scalar(inline=True)
def chunk_d(D, a_nodes, nch, inv_scale, ui, uj, k0, m2, s, b, out):
    """Pass 3 of :func:`ball_d_rows`: D at each node's τ and albedo per channel, written to ``out``
    in units of ``1 / inv_scale`` (uint16, rounded to the nearest)."""
    n = min(CHUNK, m2 - k0)
    for q in range(n):
        k = np.uint64(k0 + q)
        it = np.uint64(np.uint32(s[np.uint64(b + IT * CHUNK + q)]))
        tt = s[np.uint64(b + TT * CHUNK + q)]
        out[ui, uj, k, ZERO] = d_units(d_node(D, a_nodes, it, tt, s[np.uint64(b + NR * CHUNK + q)],
                                              s[np.uint64(b + AR * CHUNK + q)]), inv_scale)
        if nch == 3:
            out[ui, uj, k, ONE] = d_units(d_node(D, a_nodes, it, tt, s[np.uint64(b + NG * CHUNK + q)],
                                                 s[np.uint64(b + AG * CHUNK + q)]), inv_scale)
            out[ui, uj, k, TWO] = d_units(d_node(D, a_nodes, it, tt, s[np.uint64(b + NB * CHUNK + q)],
                                                 s[np.uint64(b + AB * CHUNK + q)]), inv_scale)


@scalar(inline=True)
def d_units(d, inv_scale):
    """D in the units of :class:`pv_ambient.stages.bake.BallD`, rounded, clamped to [0, 65535]."""
    u = d * inv_scale + 0.5
    u = u if u > 0.0 else 0.0
    return np.uint16(u if u < 65535.0 else 65535.0)


@driver
def ball_d_rows(ball, D, a_nodes, radius, tau_lo_log, tau_dlog, inv_scale, out, s):
    """D(r σ̄, ā) of an isotropic phase function at every data sample, per channel: ``out`` (m0, m1,
    m2, nch) uint16 in units of ``1 / inv_scale`` (:class:`pv_ambient.stages.bake.BallD`), ``nch``
    3 or 1 (a grey ball albedo: the red channel's); ``ball`` (m0, m1, m2,
    4) the ball grid, ``D`` (n_a, n_tau, 1) the table slice (:func:`.preint.d_lookup3` at every
    node, in chunks of a row). It depends on the transfer function and the radius, not on the
    lights: a relight's bake (:func:`bake_rows`) reads it instead of the ball."""
    m0, m1, m2 = out.shape[0], out.shape[1], out.shape[2]
    nch = out.shape[3]
    n_tau = D.shape[1]
    tau1 = math.exp(tau_lo_log)
    nchunk = (m2 + CHUNK - 1) // CHUNK
    for i in prange(m0):
        b = numba.get_thread_id() * (NF * CHUNK)
        ui = np.uint64(i)
        for j in range(m1):
            uj = np.uint64(j)
            for c in range(nchunk):
                k0 = c * CHUNK
                chunk_ball(ball, n_tau, tau1, radius, tau_lo_log, tau_dlog, ui, uj, k0, m2, s, b)
                chunk_albedo(a_nodes, nch, s, b)
                chunk_d(D, a_nodes, nch, inv_scale, ui, uj, k0, m2, s, b, out)


@driver
def bake_rows(model, lights, tau, dgrid, dscale, radius, w2i, i2w, nch, q0, add, out, s):
    """Adds light 0 of ``lights`` (one point or directional light) to slot ``q0`` of ``out`` (m0, m1,
    m2, slots·nch) — or, ``add`` false, writes it there — its nodes the data samples:
    :func:`.bake.bake_incident` for the case of this module's docstring, in chunks of a row. ``tau``
    (m0, m1, m2, 1) the light's optical depth (its front too), ``dgrid × dscale`` ambient
    scattering's D per node (:func:`ball_d_rows`); ``s`` :func:`scratch`."""
    m0, m1, m2 = out.shape[0], out.shape[1], out.shape[2]
    p = INV_4PI  # the isotropic phase function (phase_eval's value for every angle)
    nchunk = (m2 + CHUNK - 1) // CHUNK
    point = lights.kind[0] == 0
    for i in prange(m0):
        b = numba.get_thread_id() * (NF * CHUNK)
        ui = np.uint64(i)
        for j in range(m1):
            uj = np.uint64(j)
            for c in range(nchunk):
                k0 = c * CHUNK
                chunk_direct(lights, point, tau, i2w, p, ui, uj, k0, m2, s, b)
                if model == AMBIENT_SCATTERING:
                    chunk_front(lights, point, tau, w2i, i2w, radius, ui, uj, k0, m2, s, b)
                chunk_store(model, dgrid, dscale, nch, q0, add, ui, uj, k0, m2, s, b, out)
