"""Draft frames: the ray cast of an interactive drag on a coarser level of the scene
(docs/guide.rst, "In a plotter"; docs/performance.rst, "Draft frames").

A lit model's sample reads the scalar and its table, each light's baked slot with its ``1/d²`` and,
for diffusion, its field: several arrays at the data's resolution and beyond, for a picture that
is shown for a fraction of a second. A draft frame reads one packed record per corner instead: on
every other data sample per axis (:data:`pv_ambient.stages.draft.FACTOR`; a level of an eighth of
the samples, so the corners a ray touches stay in cache at a drag's longer step) the scalar and
the model's source rgb, shaded once by :func:`shade_nodes` with the model's own per-sample function
(:func:`.raycast.table_source`) at those samples and packed into two 32-bit words of 16-bit codes
(:func:`pv_ambient.stages.draft.pack_record`): two gathers per corner where the unpacked record
takes four. The sample's opacity still comes from the interpolated scalar through the
step-corrected table (:func:`draft_sample`), so opacity and the transfer function's edges are the
full frame's; the source is interpolated between the shaded samples (pre-shaded, as a
pre-classified colour), which blurs the lighting over two data samples and rounds off a point
light's ``1/d²`` peak — but for one point light, the *reference*: the record holds the source
times ``max(d², d2min)`` to it, as a bake's point-light slot does, and the sample divides by its own
(``ref``, a :class:`.records.Lights` whose light 0 is the reference; with no point light a point
whose ``d2min`` exceeds every distance in the box, a constant weight). The packet driver runs it
as model :data:`.models.DRAFT` (:func:`.packet.lanes_sample_draft`); its scalar pass reads the
source with :func:`draft_source`.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import driver, prange, scalar
from .medium import corners32, step_column, step_lookup, table_coords
from .baked import point_weight
from .raycast import table_source

#: The largest 16-bit code of a packed record's values (:func:`pv_ambient.stages.draft.pack_record`).
CODE = 65535


@scalar(force_inline=True)
def unpack(rec, i, j, k):
    """The four values of packed record ``rec`` (uint32 ``(m0, m1, m2, 2)``) at level sample
    (i, j, k): the scalar's 16-bit code and the squares of the source's three square-root codes
    (float32). ``np.uint32`` of each word also lets a float32 array type-check here (a dead branch
    of the other models' scalar pass)."""
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
def draft_values(rec, x, y, z):
    """The packed record's four values (:func:`unpack`) interpolated trilinearly at level index-space
    point (x, y, z) (float32, unsigned indices: the packet driver's lane loop vectorises it; two
    gathers per corner)."""
    i0, i1, fx, j0, j1, fy, k0, k1, fz = corners32(rec.shape[0], rec.shape[1], rec.shape[2], x, y, z)
    c00 = lerp4(unpack(rec, i0, j0, k0), unpack(rec, i1, j0, k0), fx)
    c10 = lerp4(unpack(rec, i0, j1, k0), unpack(rec, i1, j1, k0), fx)
    c01 = lerp4(unpack(rec, i0, j0, k1), unpack(rec, i1, j0, k1), fx)
    c11 = lerp4(unpack(rec, i0, j1, k1), unpack(rec, i1, j1, k1), fx)
    return lerp4(lerp4(c00, c10, fy), lerp4(c01, c11, fy), fz)


@scalar(force_inline=True)
def draft_sample(rec, stab, lut_lo, lut_inv, x, y, z):
    """(opacity of one full step, source rgb over the record's scale) at level index-space point
    (x, y, z) of packed draft record ``rec``: the scalar's code interpolated and looked up in the
    step-corrected table ``stab`` as :func:`.medium.step_lookup` does (:func:`.medium.table_coords`;
    ``lut_lo``, ``lut_inv``: the code's mapping to the table), the source interpolated (float32)."""
    s, r, g, b = draft_values(rec, x, y, z)
    q0, f = table_coords(s, stab, lut_lo, lut_inv)
    return step_column(stab, q0, f, 0), r, g, b


@scalar(force_inline=True)
def draft_source(rec, ref, x, y, z, wx, wy, wz):
    """The source rgb (over the record's scale) of packed draft record ``rec`` at level index-space
    point (x, y, z), world point w: the interpolated record's times ``1/max(d², d2min)`` to the
    reference point, light 0 of ``ref`` (this module's docstring)."""
    _, r, g, b = draft_values(rec, x, y, z)
    w = point_weight(ref, 0, np.float32(wx), np.float32(wy), np.float32(wz))
    return r * w, g * w, b * w


@scalar(inline=True)
def node_of(i, n, factor):
    """The data sample of level sample ``i`` along an axis of ``n`` data samples: ``factor·i``,
    the last sample for a level sample past it."""
    return min(factor * i, n - 1)


@driver
def shade_nodes(model, march, medium, lights, grid, ambient, diffusion, i2w, factor, ref, out):
    """Shade the draft record ``out`` (float32 ``(m0, m1, m2, 4)``) of a level of every ``factor``-th
    data sample: at each level sample's data sample (:func:`node_of`) its scalar and ray-cast
    ``model``'s source there (:func:`.raycast.table_source` with the frame's records, a LUT-mode
    ``medium``) times ``max(d², d2min)`` to the reference point of ``ref`` (a :class:`.records.Lights`
    whose light 0 is it; :func:`pv_ambient.rendering.draft.reference`); ``i2w`` the data's index →
    world affine map (4 × 4), for the lights' distances."""
    field, stab = medium.field, march.opacity
    nx, ny, nz = field.shape
    for i in prange(out.shape[0]):
        a = node_of(i, nx, factor)
        x = np.float64(a)
        for j in range(out.shape[1]):
            b = node_of(j, ny, factor)
            y = np.float64(b)
            for k in range(out.shape[2]):
                c = node_of(k, nz, factor)
                z = np.float64(c)
                wx = i2w[0, 0] * x + i2w[0, 1] * y + i2w[0, 2] * z + i2w[0, 3]
                wy = i2w[1, 0] * x + i2w[1, 1] * y + i2w[1, 2] * z + i2w[1, 3]
                wz = i2w[2, 0] * x + i2w[2, 1] * y + i2w[2, 2] * z + i2w[2, 3]
                q0, fq = step_lookup(field, stab, medium.lut_lo, medium.lut_inv, x, y, z)
                cr, cg, cb = table_source(model, stab, q0, fq, x, y, z, wx, wy, wz, lights, grid, ambient, diffusion)
                w = np.float32(1.0) / point_weight(ref, 0, np.float32(wx), np.float32(wy), np.float32(wz))
                out[i, j, k, 0] = field[a, b, c]
                out[i, j, k, 1] = cr * w
                out[i, j, k, 2] = cg * w
                out[i, j, k, 3] = cb * w


@driver
def pack_nodes(rec, m, lut_lo, lut_inv, top, out):
    """Pack the shaded record ``rec`` (float32 ``(m0, m1, m2, 4)``) into ``out`` (uint32
    ``(m0, m1, m2, 2)``; :func:`pv_ambient.stages.draft.pack_record` states the codes): the scalar's
    table coordinate over [−m, 2m], each source channel's square root of its fraction of ``top``."""
    for i in prange(rec.shape[0]):
        for j in range(rec.shape[1]):
            for k in range(rec.shape[2]):
                u = (np.float64(rec[i, j, k, 0]) - lut_lo) * lut_inv
                c = min(max((u + m) / (3.0 * m), 0.0), 1.0)
                qs = np.uint32(math.floor(c * CODE + 0.5))
                qr = _code(rec[i, j, k, 1], top)
                qg = _code(rec[i, j, k, 2], top)
                qb = _code(rec[i, j, k, 3], top)
                out[i, j, k, 0] = qs | (qr << np.uint32(16))
                out[i, j, k, 1] = qg | (qb << np.uint32(16))


@scalar(inline=True)
def _code(v, top):
    """The 16-bit square-root code of source value ``v`` over ``top`` (0 for a negative or NaN value,
    the top code above ``top``)."""
    f = np.float64(v) / top
    f = f if f > 0.0 else 0.0  # NaN and negatives: 0
    f = f if f < 1.0 else 1.0
    return np.uint32(math.floor(math.sqrt(f) * CODE + 0.5))
