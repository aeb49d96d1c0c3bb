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
    scale, lut)``. The march keeps the data's majorant grid: its empty blocks, and so the samples
    a ray takes, stay those of the frame the record replaces."""
    rec = light_record(medium.field, lights, grid, index_to_world, ref)
    return pack_record(rec, medium.table.shape[0], medium.lut_lo, medium.lut_inv)
