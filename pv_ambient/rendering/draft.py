"""Draft frames (``render(..., draft=True)``): what an interactive drag renders while the camera
moves (docs/guide.rst, "In a plotter"; docs/performance.rst, "Draft frames").

A draft frame ray-casts a level of the scene with every other data sample per axis: at each, the
scalar and the model's source (the colour for emission–absorption), shaded once per scene and
light set with the model's own sample function and packed into two 32-bit words
(:mod:`pv_ambient.stages.draft`). The opacity comes from the interpolated scalar through the same
step-corrected table, so the transfer function's edges stay where the full frame has them. Every
model's draft then costs two gathers per corner, less than an emission–absorption sample of the
full frame, and the level's corners stay in cache at a drag's longer step. It applies where the
CPU's packet driver marches the full frame (a table transfer function; a lit model with baked
in-scattering); elsewhere, and on the GPU, ``draft=True`` renders the full frame.
"""

from __future__ import annotations

import weakref

import numpy as np

from .._kernels import records as K
from .._kernels.models import DRAFT
from ..stages.draft import FACTOR, code_majorant, pack_record, packets_apply, shade_record
from .presets import MAJORANT_BLOCK

#: The level's index space from the data's: level index = data index / FACTOR.
_SCALE = np.diag([1.0 / FACTOR, 1.0 / FACTOR, 1.0 / FACTOR, 1.0])

#: Arrays up to this many elements (the lights' positions and powers, rebuilt every frame) are
#: compared by value; larger ones (grids, tables: cached stages) by identity, through weak references.
_BY_VALUE = 256


def draft_applies(req, args) -> bool:
    """Whether the ray cast of ``args`` (the model id and its records) renders as a draft for request
    ``req``: asked for, on the CPU, where the packet driver would march the full frame, on a grid
    of at least 2·FACTOR samples per axis."""
    model, _view, _march, medium, _lights, grid = args[:6]
    return (bool(req.draft) and req.backend == "cpu" and min(medium.field.shape) >= 2 * FACTOR
            and packets_apply(model, medium, grid))


def held_inputs(inputs):
    """``inputs`` as the record's cache entry keeps them: a large array by a weak reference (the
    entry must not keep a replaced bake or field alive), a small one (the lights' positions and
    powers, rebuilt every frame) as it is."""
    if isinstance(inputs, (tuple, list)):
        return tuple(held_inputs(x) for x in inputs)
    if isinstance(inputs, np.ndarray) and inputs.size > _BY_VALUE:
        return weakref.ref(inputs)
    return inputs


def same_inputs(held, b) -> bool:
    """Whether inputs ``b`` are those kept as ``held`` (:func:`held_inputs`): large arrays the same
    objects, small ones equal, other values equal."""
    if isinstance(held, tuple):
        return isinstance(b, (tuple, list)) and len(held) == len(b) and all(same_inputs(x, y) for x, y in zip(held, b))
    if isinstance(held, weakref.ref):
        return held() is b
    if isinstance(held, np.ndarray) and isinstance(b, np.ndarray):
        return held.shape == b.shape and held.dtype == b.dtype and bool(np.array_equal(held, b))
    if isinstance(held, np.ndarray) or isinstance(b, np.ndarray):
        return False
    return held == b


def reference(lights, geometry, d2min=None):
    """The reference point of a draft or lit record (:mod:`pv_ambient._kernels.record`) as a
    :class:`Lights` record whose light 0 it is: the first point light of ``lights`` (the frame's
    records) with ``d2min`` (default: one data spacing squared), or, with no point light, the box's
    centre with a ``d2min`` larger than any distance in the box squared (a constant weight)."""
    kind, vec = np.asarray(lights.kind), np.asarray(lights.vec, np.float64)
    points = np.flatnonzero(kind == 0)
    if points.size:
        pos = vec[points[0]]
        d2min = float(np.min(geometry.spacing)) ** 2 if d2min is None else float(d2min)
    else:
        corners = geometry.corners
        pos, d2min = corners.mean(axis=0), 4.0 * geometry.diagonal ** 2 + 1.0
    return lights._replace(kind=np.zeros(1, kind.dtype), vec=np.asarray(pos, np.float64).reshape(1, 3),
                           power=np.zeros((1, 3), np.asarray(lights.power).dtype), d2min=d2min)


def _record(renderer, args, shape):
    """The model's packed draft record on the level of ``shape`` and what reads it (:func:`pack_record`:
    ``(words, level, scale, lut)``, and the level's majorant grid), shaded from the frame's records
    ``args`` — kept while its inputs (the arrays and values it was shaded from) are the same, so a
    drag shades it once."""
    model, view, march, medium, lights, grid, ambient, diffusion = args
    # a point light's 1/d² clamped at one data spacing, whatever the frame's step: the level samples
    # every other data sample, and a drag that changes its step does not shade the record again
    lights = lights._replace(d2min=float(np.min(renderer.geometry.spacing)) ** 2)
    # not the step-corrected table: the source reads its albedo and emission, the same at every step
    inputs = (model, medium.field, medium.table, K.arrays(lights), lights.d2min, grid.inc, diffusion.field,
              K.arrays(ambient))
    cache, key = renderer.stages.cache, ("draft_record",)
    if key in cache and same_inputs(cache[key][0], inputs):
        return cache[key][1]
    rec = shade_record((model, view, march, medium, lights, grid, ambient, diffusion),
                       renderer.geometry.index_to_world, shape, reference(lights, renderer.geometry))
    words, level, scale, lut = pack_record(rec, medium.table.shape[0], medium.lut_lo, medium.lut_inv)
    packed = (words, level, scale, lut, code_majorant(renderer.optics, level, lut, MAJORANT_BLOCK))
    cache[key] = (held_inputs(inputs), packed)
    return packed


def draft_args(renderer, args):
    """The ray cast's arguments for the draft of frame ``args`` (:func:`draft_applies` holds), and
    the factor its radiance takes afterwards: the level's view, the packed draft record and the
    level's scalar codes as the medium. The record's source is stored over a scale: the ray cast
    composites it over the background divided by the scale, and the picture is multiplied by it."""
    model, view, march, medium, lights, grid, ambient, diffusion = args
    view = view._replace(w2i=_SCALE @ view.w2i, lo=view.lo / FACTOR, hi=view.hi / FACTOR)
    shape = tuple(-(-(n - 1) // FACTOR) + 1 for n in medium.field.shape)
    words, level, scale, lut, maj = _record(renderer, args, shape)
    coarse = medium._replace(field=level, lut_lo=lut[0], lut_inv=lut[1], maj=maj)
    march = march._replace(bg=np.asarray(march.bg, np.float64) / scale)
    ref = reference(lights, renderer.geometry)
    return (DRAFT, view, march, coarse, ref, grid, ambient, diffusion._replace(field=words)), scale
