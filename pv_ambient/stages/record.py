"""The lit record of a scene (docs/performance.rst, "Lit record"): per data sample the scalar and
the lights' baked in-scattered light times the reference point's ``max(d², d2min)``, shaded and
packed (:mod:`pv_ambient._kernels.record`). :mod:`pv_ambient.rendering.record` decides when a
camera pass reads it and keeps what this builds."""

from __future__ import annotations

import numpy as np

from .draft import pack_record


def table_medium(medium) -> bool:
    """Whether ``medium`` (a :class:`pv_ambient._kernels.records.Medium`) classifies through a table
    (LUT mode): what the record's scalar codes index."""
    from .._kernels.medium import MODE_LUT

    return int(medium.mode) == MODE_LUT


def light_record(field, lights, grid, index_to_world, ref):
    """The lit record (float32 ``field.shape + (4,)``: scalar, light rgb) of scalar ``field`` with
    the frame's Lights record ``lights`` and baked light grid ``grid`` (its nodes the data samples),
    times the weight of reference ``ref`` (:func:`pv_ambient.rendering.draft.reference`)
    (:func:`pv_ambient._kernels.record.light_nodes`)."""
    from .._kernels.record import light_nodes

    rec = np.empty(tuple(field.shape) + (4,), np.float32)
    light_nodes(field, lights, grid, np.asarray(index_to_world, np.float64), ref, rec)
    return rec


def packed_light_record(medium, lights, grid, index_to_world, ref):
    """:func:`light_record` packed (:func:`pv_ambient.stages.draft.pack_record`): ``(words, codes,
    scale, lut)``. The march keeps the frame's majorant grid: its empty blocks, and so the samples
    a ray takes, stay those of the frame the record replaces."""
    rec = light_record(medium.field, lights, grid, index_to_world, ref)
    return pack_record(rec, medium.table.shape[0], medium.lut_lo, medium.lut_inv)


def _top(values) -> float:
    """The largest finite value of ``values``, 1 where none is positive (the codes' scale)."""
    top = float(np.where(np.isfinite(values), values, 0.0).max()) if np.size(values) else 0.0
    return top if top > 0.0 else 1.0


def packed_pair_record(medium, grid):
    """The pair record of scalar ``medium.field`` and a bake ``grid.inc`` of two rgb slots on the
    data samples (a point light's, then the other lights' with diffusion's field), packed
    (:func:`pv_ambient._kernels.record.pack_pair_nodes`): ``(words, codes, (scale_p, scale_d),
    lut)`` as :func:`pv_ambient.stages.draft.pack_record` returns them, a scale per slot."""
    from .._kernels.record import CODE, pack_pair_nodes

    inc = grid.inc
    m = float(medium.table.shape[0] - 1)
    top_p, top_d = _top(inc[..., 0:3]), _top(inc[..., 3:6])
    words = np.empty(tuple(medium.field.shape) + (4,), np.uint32)
    pack_pair_nodes(medium.field, inc, m, float(medium.lut_lo), float(medium.lut_inv), top_p, top_d, words)
    codes = (words[..., 0] & np.uint32(0xFFFF)).astype(np.float32)
    lut = (CODE / 3.0, 3.0 * m / CODE)
    return words, codes, (top_p / float(CODE) ** 2, top_d / float(CODE) ** 2), lut
