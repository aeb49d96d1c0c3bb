"""Draft frames: the ray cast of an interactive drag on a coarser level of the scene
(docs/guide.rst, "In a plotter"; docs/performance.rst, "Draft frames").

A lit model's sample reads the scalar and its table, each light's baked slot with its ``1/d²`` and,
for diffusion, its field: several arrays at the data's resolution and beyond, for a picture that
is shown for a fraction of a second. A draft frame reads one record per corner instead,
``(scalar, source rgb)`` float32 on every other data sample per axis
(:data:`pv_ambient.stages.draft.FACTOR`) (a level of an eighth of the
samples, so the corners a ray touches stay in cache at a drag's longer step), shaded once by
:func:`shade_nodes` with the model's own per-sample function (:func:`.raycast.table_source`) at
those samples. The sample's opacity still comes from the interpolated scalar through the
step-corrected table (:func:`draft_sample`), so opacity and the transfer function's edges are the
full frame's; the source is interpolated between the shaded samples (pre-shaded, as a
pre-classified colour), which blurs the lighting over two data samples and rounds off a point
light's ``1/d²`` peak. The packet driver runs it as model :data:`.models.DRAFT`
(:func:`.packet.lanes_sample_draft`); its scalar pass reads the source with :func:`draft_source`.
"""

from __future__ import annotations

import numpy as np

from ._jit import driver, prange, scalar
from .medium import clamp32, corner32, corners32, min_index, step_column, step_lookup
from .raycast import table_source

@scalar(force_inline=True)
def draft_sample(rec, stab, lut_lo, lut_inv, x, y, z):
    """(opacity of one full step, source rgb) at level index-space point (x, y, z) of draft record
    ``rec`` (float32 ``(m0, m1, m2, 4)``: scalar, source rgb): the scalar interpolated and looked up
    in the step-corrected table ``stab`` as :func:`.medium.step_lookup` does, the source
    interpolated (float32, unsigned indices: the packet driver's lane loop vectorises it)."""
    i0, i1, fx, j0, j1, fy, k0, k1, fz = corners32(rec.shape[0], rec.shape[1], rec.shape[2], x, y, z)
    nt = stab.shape[0]
    s = corner32(rec, i0, i1, fx, j0, j1, fy, k0, k1, fz, 0)
    u = clamp32((s - np.float32(lut_lo)) * np.float32(lut_inv), np.float32(nt - 1))
    q0 = min_index(np.uint64(np.uint32(u)), np.uint64(nt - 2))
    return (step_column(stab, q0, u - np.float32(q0), 0), corner32(rec, i0, i1, fx, j0, j1, fy, k0, k1, fz, 1),
            corner32(rec, i0, i1, fx, j0, j1, fy, k0, k1, fz, 2), corner32(rec, i0, i1, fx, j0, j1, fy, k0, k1, fz, 3))


@scalar(force_inline=True)
def draft_source(rec, x, y, z):
    """The source rgb of draft record ``rec`` at level index-space point (x, y, z)."""
    i0, i1, fx, j0, j1, fy, k0, k1, fz = corners32(rec.shape[0], rec.shape[1], rec.shape[2], x, y, z)
    return (corner32(rec, i0, i1, fx, j0, j1, fy, k0, k1, fz, 1), corner32(rec, i0, i1, fx, j0, j1, fy, k0, k1, fz, 2),
            corner32(rec, i0, i1, fx, j0, j1, fy, k0, k1, fz, 3))


@scalar(inline=True)
def node_of(i, n, factor):
    """The data sample of level sample ``i`` along an axis of ``n`` data samples: ``factor·i``,
    the last sample for a level sample past it."""
    return min(factor * i, n - 1)


@driver
def shade_nodes(model, march, medium, lights, grid, ambient, diffusion, i2w, factor, out):
    """Shade the draft record ``out`` (float32 ``(m0, m1, m2, 4)``) of a level of every ``factor``-th
    data sample: at each level sample's data sample (:func:`node_of`) its scalar and ray-cast ``model``'s source there (:func:`.raycast.table_source`
    with the frame's records, a LUT-mode ``medium``); ``i2w`` the data's index → world affine map
    (4 × 4), for the lights' distances."""
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
                out[i, j, k, 0] = field[a, b, c]
                out[i, j, k, 1] = cr
                out[i, j, k, 2] = cg
                out[i, j, k, 3] = cb
