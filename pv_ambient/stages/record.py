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


def packed_light_record(medium, lights, grid, index_to_world, ref, grey=False):
    """The lit record of scalar ``medium.field`` with the frame's Lights record ``lights`` and baked
    light grid ``grid`` (its nodes the data samples), times the weight of reference ``ref``
    (:func:`pv_ambient.rendering.draft.reference`), shaded and packed in one pass
    (:func:`pv_ambient._kernels.record.pack_light_nodes`; its scale from a first pass,
    :func:`pv_ambient._kernels.record.light_tops`): ``(words, codes, scale, lut)`` as
    :func:`pv_ambient.stages.draft.pack_record` returns them. No shaded copy is held: the first
    frame's peak memory grows by the words and the codes only. The march keeps the frame's majorant
    grid: its empty blocks, and so the samples a ray takes, stay those of the frame the record
    replaces. ``grey``: the bake's one grey slot in one word per sample
    (:func:`pv_ambient._kernels.record.pack_grey_nodes`)."""
    from .._kernels.record import CODE, light_tops, pack_grey_nodes, pack_light_nodes

    field, i2w = medium.field, np.asarray(index_to_world, np.float64)
    m = float(medium.table.shape[0] - 1)
    tops = np.zeros(field.shape[0], np.float64)
    light_tops(field, lights, grid, i2w, ref, tops)
    top = _scale(tops)
    words = np.empty(tuple(field.shape) + ((1,) if grey else (2,)), np.uint32)
    codes = np.empty(field.shape, np.float32)
    (pack_grey_nodes if grey else pack_light_nodes)(field, lights, grid, i2w, ref, m, float(medium.lut_lo), float(medium.lut_inv), top, words, codes)
    return words, codes, top / float(CODE) ** 2, (CODE / 3.0, 3.0 * m / CODE)


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
