"""The lit record of a scene (docs/performance.rst, "Lit record"): per data sample the scalar and
the lights' baked in-scattered light times the reference point's ``max(d², d2min)``, shaded and
packed (:mod:`pv_ambient._kernels.record`). :mod:`pv_ambient.rendering.record` decides when a
camera pass reads it and keeps what this builds."""

from __future__ import annotations

import numpy as np

def table_medium(medium) -> bool:
    """Whether ``medium`` (a :class:`pv_ambient._kernels.records.Medium`) classifies through a table
    (LUT mode): what the record's scalar codes index."""
    from .._kernels.medium import MODE_LUT

    return int(medium.mode) == MODE_LUT


def _scale(tops) -> float:
    """The codes' scale from per-plane maxima ``tops``: their largest, 1 where none is positive."""
    top = float(np.max(tops)) if np.size(tops) else 0.0
    return top if top > 0.0 else 1.0


def packed_light_record(medium, lights, grid, ref):
    """The lit record of scalar ``medium.field`` and light grid ``grid``, whose bake ``grid.inc`` is
    one slot on the data samples (grey or rgb), for the frame's Lights record ``lights`` and
    reference ``ref`` (:func:`pv_ambient.rendering.draft.reference`), packed in one pass
    (:func:`pv_ambient._kernels.record.pack_slot_nodes`; its scale from a first pass,
    :func:`pv_ambient._kernels.record.plane_tops`): ``(words, codes, scale, lut)`` as
    :func:`pv_ambient.stages.draft.pack_record` returns them, one word per sample for a grey slot,
    two for an rgb one. The slot is the record's light: a point light's (the reference) holds its
    light times ``max(d², d2min)`` already; directional lights' is read under the reference's
    constant weight ``1/d2min``, which the scale takes back. No shaded copy is held: the first
    frame's peak memory grows by the words and the codes only. The march keeps the frame's majorant
    grid: its empty blocks, and so the samples a ray takes, stay those of the frame the record
    replaces."""
    from .._kernels.record import CODE, pack_slot_nodes, plane_tops

    field, inc = medium.field, grid.inc
    m = float(medium.table.shape[0] - 1)
    tops = np.zeros(field.shape[0], np.float64)
    plane_tops(inc, tops)
    top = _scale(tops)
    # the sample multiplies the record by its weight to the reference, 1/max(d², d2min) in float32:
    # with no point light a constant, 1/d2min, which the scale divides out
    points = bool(np.any(np.asarray(lights.kind) == 0))
    undo = 1.0 if points else 1.0 / float(np.float32(1.0) / np.float32(ref.d2min))
    words = np.empty(tuple(field.shape) + ((1,) if inc.shape[3] == 1 else (2,)), np.uint32)
    codes = np.empty(field.shape, np.float32)
    pack_slot_nodes(field, inc, m, float(medium.lut_lo), float(medium.lut_inv), top, words, codes)
    return words, codes, top * undo / float(CODE) ** 2, (CODE / 3.0, 3.0 * m / CODE)


def packed_pair_record(medium, grid):
    """The pair record of scalar ``medium.field`` and a bake ``grid.inc`` of two rgb slots on the
    data samples (a point light's, then the other lights' with diffusion's field), packed
    (:func:`pv_ambient._kernels.record.pack_pair_nodes`): ``(words, codes, (scale_p, scale_d),
    lut)`` as :func:`pv_ambient.stages.draft.pack_record` returns them, a scale per slot."""
    from .._kernels.record import CODE, pack_pair_nodes, slot_tops

    inc, field = grid.inc, medium.field
    m = float(medium.table.shape[0] - 1)
    tops = np.zeros((field.shape[0], 2), np.float64)
    slot_tops(inc, tops)
    top_p, top_d = _scale(tops[:, 0]), _scale(tops[:, 1])
    words = np.empty(tuple(field.shape) + (4,), np.uint32)
    codes = np.empty(field.shape, np.float32)
    pack_pair_nodes(field, inc, m, float(medium.lut_lo), float(medium.lut_inv), top_p, top_d, words, codes)
    return words, codes, (top_p / float(CODE) ** 2, top_d / float(CODE) ** 2), (CODE / 3.0, 3.0 * m / CODE)
