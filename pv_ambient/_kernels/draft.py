"""Draft frames: the ray cast of an interactive drag on a coarser level of the scene
(docs/guide.rst, "In a plotter"; docs/performance.rst, "Draft frames").

A lit model's sample reads the scalar and its table, each light's baked slot with its ``1/d²`` and,
for diffusion, its field: several arrays at the data's resolution and beyond, for a picture that
is shown for a fraction of a second. A draft frame reads one packed record per corner instead: on
every other data sample per axis (:data:`pv_ambient.stages.draft.FACTOR`; a level of an eighth of
the samples, so the corners a ray touches stay in cache at a drag's longer step) the scalar and
the model's source rgb, shaded once by :func:`shade_nodes` with the model's own per-sample function
(:func:`.raycast.table_source`) at those samples and packed into two 32-bit words of 16-bit codes
(:func:`pv_ambient.stages.draft.pack_record`, the codes of :mod:`.record`): two gathers per
corner where the unpacked record takes four. The sample's opacity still comes from the interpolated scalar through the
step-corrected table (:func:`draft_sample`), so opacity and the transfer function's edges are the
full frame's; the source is interpolated between the shaded samples (pre-shaded, as a
pre-classified colour), which blurs the lighting over two data samples and rounds off a point
light's ``1/d²`` peak — but for one point light, the *reference*: the record holds the source
times ``max(d², d2min)`` to it, as a bake's point-light slot does, and the sample divides by its own
(``ref``, a :class:`.records.Lights` whose light 0 is the reference; with no point light a point
whose ``d2min`` exceeds every distance in the box, a constant weight). The packet driver runs it
as model :data:`.models.DRAFT` (:func:`.packet_records.lanes_sample_draft`); its scalar pass reads the
source with :func:`draft_source`.
"""

from __future__ import annotations

import numpy as np

from ._jit import driver, prange, scalar
from .medium import step_column, step_lookup, table_coords
from .baked import point_weight
from .raycast import table_source
from .record import record_values

@scalar(force_inline=True)
def draft_sample(rec, stab, lut_lo, lut_inv, x, y, z):
    """(opacity of one full step, source rgb over the record's scale) at level index-space point
    (x, y, z) of packed draft record ``rec``: the scalar's code interpolated and looked up in the
    step-corrected table ``stab`` as :func:`.medium.step_lookup` does (:func:`.medium.table_coords`;
    ``lut_lo``, ``lut_inv``: the code's mapping to the table), the source interpolated (float32)."""
    s, r, g, b = record_values(rec, x, y, z)
    q0, f = table_coords(s, stab, lut_lo, lut_inv)
    return step_column(stab, q0, f, 0), r, g, b


@scalar(force_inline=True)
def draft_source(rec, ref, x, y, z, wx, wy, wz):
    """The source rgb (over the record's scale) of packed draft record ``rec`` at level index-space
    point (x, y, z), world point w: the interpolated record's times ``1/max(d², d2min)`` to the
    reference point, light 0 of ``ref`` (this module's docstring)."""
    _, r, g, b = record_values(rec, x, y, z)
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
