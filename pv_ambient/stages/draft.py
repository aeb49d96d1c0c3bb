"""The draft level of a scene (docs/performance.rst, "Draft frames"): a model's draft record on
every other data sample per axis — the scalar and the model's source there, shaded and packed
(:mod:`pv_ambient._kernels.draft`) — and the majorant grid of its scalar codes.
:mod:`pv_ambient.rendering.draft` decides when a frame is a draft and keeps what this builds."""

from __future__ import annotations

import numpy as np

#: Data samples per level sample along each axis.
FACTOR = 2


def packets_apply(model, medium, grid) -> bool:
    """Whether the CPU's packet driver marches ray-cast ``model`` (an id) on ``medium`` with light
    grid ``grid`` (:func:`pv_ambient._kernels.packet.applies`): the frames a draft replaces."""
    from .._kernels.packet import applies

    return applies(model, medium, grid)


def pack_record(rec, table_size, lut_lo, lut_inv):
    """Pack draft record ``rec`` (float32 ``(m0, m1, m2, 4)``: scalar, source rgb) into two 32-bit
    words of 16-bit codes per level sample (:mod:`pv_ambient._kernels.draft`): the scalar's table
    coordinate ``u = (s − lut_lo)·lut_inv`` over [−(n−1), 2(n−1)] for a table of ``n`` entries
    (clamped there: beyond a table's length on either side the clamp moves where a sample between
    two such corners crosses the table's end, by a fraction of a level sample at the worst), and
    each channel's source as the square root of its fraction of the largest (precision 1.5e-5 of
    the largest at the top, 0.1 % of a value a thousandth of it). Returns ``(words, level, scale,
    lut)``: uint32 ``(m0, m1, m2, 2)``; the scalar codes as a float32 field (the scalar pass's
    partial segments) with ``lut = (lut_lo, lut_inv)`` mapping a code to the table; the source is
    the codes' squares times ``scale``."""
    from .._kernels.record import CODE, pack_nodes

    m = float(table_size - 1)
    src = rec[..., 1:4]
    top = float(np.where(np.isfinite(src), src, 0.0).max()) if src.size else 0.0
    top = top if top > 0.0 else 1.0
    words = np.empty(rec.shape[:3] + (2,), np.uint32)
    pack_nodes(rec, m, float(lut_lo), float(lut_inv), top, words)
    lut = (CODE / 3.0, 3.0 * m / CODE)
    return words, (words[..., 0] & np.uint32(0xFFFF)).astype(np.float32), top / float(CODE) ** 2, lut


def code_majorant(optics, level, lut, block):
    """The majorant grid of the scalar codes ``level`` (:func:`pack_record`) in ``block``³ level samples."""
    from .._kernels.majorant import build_majorant

    shape = tuple(max(1, -(-(n - 1) // block)) for n in level.shape)
    maj = np.zeros(shape, np.float32)
    build_majorant(optics.mode, level, optics.table, lut[0], lut[1], block, maj)
    return maj


def shade_record(args, index_to_world, shape, ref):
    """The draft record (float32 ``shape + (4,)``: scalar, source rgb) of a frame's ray-cast
    arguments ``args`` (the model id and its records, the data's medium), shaded at the level
    samples' data samples (:func:`pv_ambient._kernels.draft.shade_nodes`), times the weight of
    reference ``ref`` (:func:`pv_ambient.rendering.draft.reference`)."""
    from .._kernels.draft import shade_nodes

    rec = np.empty(tuple(shape) + (4,), np.float32)
    shade_nodes(*args[:1], *args[2:], np.asarray(index_to_world, np.float64), FACTOR, ref, rec)
    return rec
