"""The packed record a lit camera pass reads (docs/performance.rst, "Lit record"), and the codes it
shares with a draft frame's (:mod:`.draft`).

A baked lit sample otherwise reads the scalar and the bake's light slots at its eight corners,
from separate arrays: two gathers per corner for a grey slot, four for an rgb one, from two cache
lines. The record holds, per data sample, the scalar and the bake's slot — the in-scattered light
per unit albedo (:func:`.baked.baked_light`) times ``max(d², d2min)`` to a *reference* point, the
slot's point light, or with directional lights alone a constant — as 16-bit codes in 32-bit words
(:func:`pack_slot_nodes`): a grey slot in one word, one gather per corner; an rgb one in two, two
gathers from one cache line. The sample divides by its own ``max(d², d2min)`` to the reference
(:func:`record_light`, :func:`grey_light`) and classifies the interpolated scalar through the
step-corrected table as every table sample does, so the transfer function's albedo and emission
stay post-classified. The codes round the scalar to 3·(n − 1)/65535 of a table entry and the
light to 1.5e-5 of its largest value at the top (0.1 % of a value a thousandth of it). Summed over
more slots, another slot's light would be interpolated times the reference's ``d²``, which
trilinear interpolation overestimates near the reference: a point light's rgb slot beside the
other lights' (diffusion's field with a point light) has a *pair record* of four words instead,
the slots apart (:func:`pack_pair_nodes`, :func:`pair_light`) — four gathers per corner where the
bake takes seven."""

from __future__ import annotations

import math

import numpy as np

from ._jit import driver, prange, scalar
from .baked import point_weight
from .medium import corners32

#: The largest 16-bit code of a packed record's values (:func:`pack_nodes`).
CODE = 65535


@scalar(force_inline=True)
def unpack(rec, i, j, k):
    """The four values of packed record ``rec`` (uint32 ``(m0, m1, m2, 2)``) at sample (i, j, k):
    the scalar's 16-bit code and the squares of the three square-root codes (float32).
    ``np.uint32`` of each word also lets a float32 array type-check here (a dead branch of the other
    models' scalar pass)."""
    w0 = np.uint32(rec[i, j, k, np.uint32(0)])
    w1 = np.uint32(rec[i, j, k, np.uint32(1)])
    low = np.uint32(0xFFFF)
    r = np.float32(w0 >> np.uint32(16))
    g = np.float32(w1 & low)
    b = np.float32(w1 >> np.uint32(16))
    return np.float32(w0 & low), r * r, g * g, b * b


@scalar(force_inline=True)
def lerp4(a, b, f):
    """``a + f·(b − a)`` of two 4-tuples."""
    return (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2]), a[3] + f * (b[3] - a[3]))


@scalar(force_inline=True)
def record_values(rec, x, y, z):
    """The packed record's four values (:func:`unpack`) interpolated trilinearly at the record's
    index-space point (x, y, z) (float32, unsigned indices: the packet driver's lane loop vectorises
    it; two gathers per corner)."""
    i0, i1, fx, j0, j1, fy, k0, k1, fz = corners32(rec.shape[0], rec.shape[1], rec.shape[2], x, y, z)
    c00 = lerp4(unpack(rec, i0, j0, k0), unpack(rec, i1, j0, k0), fx)
    c10 = lerp4(unpack(rec, i0, j1, k0), unpack(rec, i1, j1, k0), fx)
    c01 = lerp4(unpack(rec, i0, j0, k1), unpack(rec, i1, j0, k1), fx)
    c11 = lerp4(unpack(rec, i0, j1, k1), unpack(rec, i1, j1, k1), fx)
    return lerp4(lerp4(c00, c10, fy), lerp4(c01, c11, fy), fz)


@scalar(force_inline=True)
def record_light(rec, ref, x, y, z, wx, wy, wz):
    """The in-scattered light per unit albedo (rgb, float32) of lit record ``rec`` at index-space
    point (x, y, z), world point w: the interpolated codes' squares times the record's scale (the
    power of ``ref``'s light 0, the reference point) over ``max(d², d2min)`` to the reference."""
    _, r, g, b = record_values(rec, x, y, z)
    w = point_weight(ref, 0, np.float32(wx), np.float32(wy), np.float32(wz)) * np.float32(ref.power[0, 0])
    return r * w, g * w, b * w


@scalar(force_inline=True)
def unpack_grey(rec, i, j, k):
    """The two values of a grey record ``rec`` (uint32 ``(m0, m1, m2, 1)``; :func:`pack_grey_nodes`)
    at sample (i, j, k): the scalar's 16-bit code and the square of the light's square-root code
    (float32)."""
    w0 = np.uint32(rec[i, j, k, np.uint32(0)])
    v = np.float32(w0 >> np.uint32(16))
    return np.float32(w0 & np.uint32(0xFFFF)), v * v


@scalar(force_inline=True)
def lerp2(a, b, f):
    """``a + f·(b − a)`` of two 2-tuples."""
    return a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])


@scalar(force_inline=True)
def grey_values(rec, x, y, z):
    """The grey record's two values (:func:`unpack_grey`) interpolated trilinearly at index-space
    point (x, y, z) (float32; one gather per corner, as an emission–absorption sample's)."""
    i0, i1, fx, j0, j1, fy, k0, k1, fz = corners32(rec.shape[0], rec.shape[1], rec.shape[2], x, y, z)
    c00 = lerp2(unpack_grey(rec, i0, j0, k0), unpack_grey(rec, i1, j0, k0), fx)
    c10 = lerp2(unpack_grey(rec, i0, j1, k0), unpack_grey(rec, i1, j1, k0), fx)
    c01 = lerp2(unpack_grey(rec, i0, j0, k1), unpack_grey(rec, i1, j0, k1), fx)
    c11 = lerp2(unpack_grey(rec, i0, j1, k1), unpack_grey(rec, i1, j1, k1), fx)
    return lerp2(lerp2(c00, c10, fy), lerp2(c01, c11, fy), fz)


@scalar(force_inline=True)
def grey_light(rec, ref, x, y, z, wx, wy, wz):
    """The in-scattered light per unit albedo (rgb, float32; the three equal) of grey record ``rec``
    at index-space point (x, y, z), world point w: :func:`record_light` of one channel."""
    _, v = grey_values(rec, x, y, z)
    w = point_weight(ref, 0, np.float32(wx), np.float32(wy), np.float32(wz)) * np.float32(ref.power[0, 0])
    return v * w, v * w, v * w


@scalar(force_inline=True)
def unpack_pair(rec, i, j, k):
    """The seven values of a pair record ``rec`` (uint32 ``(m0, m1, m2, 4)``; :func:`pack_pair_nodes`)
    at sample (i, j, k): the scalar's code, then the squares of the point slot's and of the other
    slot's three square-root codes (float32)."""
    w0 = np.uint32(rec[i, j, k, np.uint32(0)])
    w1 = np.uint32(rec[i, j, k, np.uint32(1)])
    w2 = np.uint32(rec[i, j, k, np.uint32(2)])
    w3 = np.uint32(rec[i, j, k, np.uint32(3)])
    low = np.uint32(0xFFFF)
    pr = np.float32(w0 >> np.uint32(16))
    pg = np.float32(w1 & low)
    pb = np.float32(w1 >> np.uint32(16))
    dr = np.float32(w2 & low)
    dg = np.float32(w2 >> np.uint32(16))
    db = np.float32(w3 & low)
    return np.float32(w0 & low), pr * pr, pg * pg, pb * pb, dr * dr, dg * dg, db * db


@scalar(force_inline=True)
def lerp7(a, b, f):
    """``a + f·(b − a)`` of two 7-tuples."""
    return (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2]), a[3] + f * (b[3] - a[3]),
            a[4] + f * (b[4] - a[4]), a[5] + f * (b[5] - a[5]), a[6] + f * (b[6] - a[6]))


@scalar(force_inline=True)
def pair_values(rec, x, y, z):
    """The pair record's seven values (:func:`unpack_pair`) interpolated trilinearly at index-space
    point (x, y, z) (float32; four gathers per corner, from one cache line)."""
    i0, i1, fx, j0, j1, fy, k0, k1, fz = corners32(rec.shape[0], rec.shape[1], rec.shape[2], x, y, z)
    c00 = lerp7(unpack_pair(rec, i0, j0, k0), unpack_pair(rec, i1, j0, k0), fx)
    c10 = lerp7(unpack_pair(rec, i0, j1, k0), unpack_pair(rec, i1, j1, k0), fx)
    c01 = lerp7(unpack_pair(rec, i0, j0, k1), unpack_pair(rec, i1, j0, k1), fx)
    c11 = lerp7(unpack_pair(rec, i0, j1, k1), unpack_pair(rec, i1, j1, k1), fx)
    return lerp7(lerp7(c00, c10, fy), lerp7(c01, c11, fy), fz)


@scalar(force_inline=True)
def pair_light(rec, ref, x, y, z, wx, wy, wz):
    """The in-scattered light per unit albedo (rgb, float32) of pair record ``rec`` at index-space
    point (x, y, z), world point w: the point slot's codes times its scale (``ref.power[0, 0]``)
    over ``max(d², d2min)`` to the point light (light 0 of ``ref``), plus the other slot's times its
    scale (``ref.power[0, 1]``)."""
    _, pr, pg, pb, dr, dg, db = pair_values(rec, x, y, z)
    w = point_weight(ref, 0, np.float32(wx), np.float32(wy), np.float32(wz)) * np.float32(ref.power[0, 0])
    sd = np.float32(ref.power[0, 1])
    return pr * w + dr * sd, pg * w + dg * sd, pb * w + db * sd


@scalar(inline=True)
def finite_max(best, v):
    """The larger of ``best`` and ``v`` where ``v`` is finite (float64)."""
    v = np.float64(v)
    return v if math.isfinite(v) and v > best else best


@driver
def plane_tops(inc, tops):
    """Per plane ``i``, the largest finite value (at least 0) of bake ``inc``'s channels (float64
    ``tops``, one per plane): a one-slot record's scale, without a float64 copy of the bake."""
    for i in prange(inc.shape[0]):
        best = 0.0
        for j in range(inc.shape[1]):
            for k in range(inc.shape[2]):
                for c in range(inc.shape[3]):
                    best = finite_max(best, inc[i, j, k, c])
        tops[i] = best


@scalar(inline=True)
def scalar_code(s, m, lut_lo, lut_inv):
    """The 16-bit code of scalar ``s``: its table coordinate ``u = (s − lut_lo)·lut_inv`` over
    [−m, 2m] (:func:`pv_ambient.stages.draft.pack_record`)."""
    u = (np.float64(s) - lut_lo) * lut_inv
    c = min(max((u + m) / (3.0 * m), 0.0), 1.0)
    return np.uint32(math.floor(c * CODE + 0.5))


@driver
def pack_slot_nodes(field, inc, m, lut_lo, lut_inv, top, out, codes):
    """Pack the record ``out`` of scalar ``field`` and a bake ``inc`` of one slot on the data samples
    (grey: one channel, ``out`` uint32 ``field.shape + (1,)``, words ``s | v``; rgb: three,
    ``field.shape + (2,)``, words ``s | r``, ``g | b``): :func:`scalar_code` and the slot's
    square-root codes over ``top``. The slot is the record's light as it stands — a point light's
    holds its light times ``max(d², d2min)`` to it, the reference — so nothing is shaded again;
    ``codes`` (float32, ``field.shape``) receives the scalar codes (the scalar pass's field)."""
    if out.shape[3] == 1:
        for i in prange(out.shape[0]):
            for j in range(out.shape[1]):
                for k in range(out.shape[2]):
                    qs = scalar_code(field[i, j, k], m, lut_lo, lut_inv)
                    out[i, j, k, 0] = qs | (_code(inc[i, j, k, 0], top) << np.uint32(16))
                    codes[i, j, k] = np.float32(qs)
    else:
        for i in prange(out.shape[0]):
            for j in range(out.shape[1]):
                for k in range(out.shape[2]):
                    qs = scalar_code(field[i, j, k], m, lut_lo, lut_inv)
                    out[i, j, k, 0] = qs | (_code(inc[i, j, k, 0], top) << np.uint32(16))
                    out[i, j, k, 1] = _code(inc[i, j, k, 1], top) | (_code(inc[i, j, k, 2], top) << np.uint32(16))
                    codes[i, j, k] = np.float32(qs)


@driver
def pack_nodes(rec, m, lut_lo, lut_inv, top, out):
    """Pack the shaded record ``rec`` (float32 ``(m0, m1, m2, 4)``) into ``out`` (uint32
    ``(m0, m1, m2, 2)``; :func:`pv_ambient.stages.draft.pack_record` states the codes): the scalar's
    table coordinate over [−m, 2m], each other channel's square root of its fraction of ``top``."""
    for i in prange(rec.shape[0]):
        for j in range(rec.shape[1]):
            for k in range(rec.shape[2]):
                qs = scalar_code(rec[i, j, k, 0], m, lut_lo, lut_inv)
                qr = _code(rec[i, j, k, 1], top)
                qg = _code(rec[i, j, k, 2], top)
                qb = _code(rec[i, j, k, 3], top)
                out[i, j, k, 0] = qs | (qr << np.uint32(16))
                out[i, j, k, 1] = qg | (qb << np.uint32(16))


@driver
def slot_tops(inc, tops):
    """Per plane ``i``, the largest finite value (at least 0) of bake ``inc``'s channels 0–2 and of
    its channels 3–5 (float64 ``tops``, ``(m0, 2)``): a pair record's two scales, without a float64
    copy of the bake."""
    for i in prange(inc.shape[0]):
        bp = 0.0
        bd = 0.0
        for j in range(inc.shape[1]):
            for k in range(inc.shape[2]):
                for c in range(3):
                    bp = finite_max(bp, inc[i, j, k, c])
                    bd = finite_max(bd, inc[i, j, k, 3 + c])
        tops[i, 0] = bp
        tops[i, 1] = bd


@driver
def pack_pair_nodes(field, inc, m, lut_lo, lut_inv, top_p, top_d, out, codes):
    """Pack a pair record (uint32 ``out``, ``field.shape + (4,)``) from scalar ``field`` and a bake
    ``inc`` of two rgb slots on the data samples (the point light's, channels 0–2; the other's,
    3–5): :func:`scalar_code`, then the point slot's square-root codes over ``top_p`` and the other
    slot's over ``top_d`` — words ``s | Pr``, ``Pg | Pb``, ``Dr | Dg``, ``Db``; ``codes`` (float32,
    ``field.shape``) receives the scalar codes."""
    for i in prange(out.shape[0]):
        for j in range(out.shape[1]):
            for k in range(out.shape[2]):
                qs = scalar_code(field[i, j, k], m, lut_lo, lut_inv)
                out[i, j, k, 0] = qs | (_code(inc[i, j, k, 0], top_p) << np.uint32(16))
                out[i, j, k, 1] = _code(inc[i, j, k, 1], top_p) | (_code(inc[i, j, k, 2], top_p) << np.uint32(16))
                out[i, j, k, 2] = _code(inc[i, j, k, 3], top_d) | (_code(inc[i, j, k, 4], top_d) << np.uint32(16))
                out[i, j, k, 3] = _code(inc[i, j, k, 5], top_d)
                codes[i, j, k] = np.float32(qs)


@scalar(inline=True)
def _code(v, top):
    """The 16-bit square-root code of value ``v`` over ``top`` (0 for a negative or NaN value, the
    top code above ``top``)."""
    f = np.float64(v) / top
    f = f if f > 0.0 else 0.0  # NaN and negatives: 0
    f = f if f < 1.0 else 1.0
    return np.uint32(math.floor(math.sqrt(f) * CODE + 0.5))
