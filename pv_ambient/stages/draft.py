"""The draft level of a scene (docs/performance.rst, "Draft frames"): the scalar field on every
other data sample per axis with its majorant grid, and a lit model's draft record shaded on it
(:mod:`pv_ambient._kernels.draft`). :mod:`pv_ambient.rendering.draft` decides when a frame is a
draft and keeps what this builds."""

from __future__ import annotations

import numpy as np

#: Data samples per level sample along each axis.
FACTOR = 2


def packets_apply(model, medium, grid) -> bool:
    """Whether the CPU's packet driver marches ray-cast ``model`` (an id) on ``medium`` with light
    grid ``grid`` (:func:`pv_ambient._kernels.packet.applies`): the frames a draft replaces."""
    from .._kernels.packet import applies

    return applies(model, medium, grid)


def draft_level(optics, block):
    """The level's scalar field (every FACTOR-th data sample per axis, the last sample closing an axis
    whose length is not a multiple of it) and its majorant grid of ``block``³ level samples."""
    from .._kernels.majorant import build_majorant

    field = optics.field
    idx = [np.minimum(FACTOR * np.arange(-(-(n - 1) // FACTOR) + 1), n - 1) for n in field.shape]
    level = np.ascontiguousarray(field[np.ix_(*idx)], dtype=np.float32)
    shape = tuple(max(1, -(-(n - 1) // block)) for n in level.shape)
    maj = np.zeros(shape, np.float32)
    build_majorant(optics.mode, level, optics.table, optics.lut_lo, optics.lut_inv, block, maj)
    return level, maj


def shade_record(args, index_to_world, shape):
    """The draft record (float32 ``shape + (4,)``: scalar, source rgb) of a frame's ray-cast
    arguments ``args`` (the model id and its records, the data's medium), shaded at the level
    samples' data samples (:func:`pv_ambient._kernels.draft.shade_nodes`)."""
    from .._kernels.draft import shade_nodes

    rec = np.empty(tuple(shape) + (4,), np.float32)
    shade_nodes(*args[:1], *args[2:], np.asarray(index_to_world, np.float64), FACTOR, rec)
    return rec
