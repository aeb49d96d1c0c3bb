"""Draft frames (``render(..., draft=True)``): what an interactive drag renders while the camera
moves (docs/guide.rst, "In a plotter"; docs/performance.rst, "Draft frames").

A draft frame ray-casts a level of the scene with every other data sample per axis: the scalar
there for the opacity (through the same step-corrected table, so the transfer function's edges
stay where the full frame has them) and, for a lit model, its source shaded once at those
samples with the model's own sample function (:mod:`pv_ambient.stages.draft`). Every lit model's
draft then costs one record read per corner, about an emission–absorption sample, and the level's
corners stay in cache at a drag's longer step. It applies where the CPU's packet driver marches
the full frame (a table transfer function; a lit model with baked in-scattering); elsewhere, and
on the GPU, ``draft=True`` renders the full frame.
"""

from __future__ import annotations

import numpy as np

from .._kernels import records as K
from .._kernels.models import DRAFT, EMISSION_ABSORPTION
from ..stages.draft import FACTOR, draft_level, packets_apply, shade_record
from .presets import MAJORANT_BLOCK

#: The level's index space from the data's: level index = data index / FACTOR.
_SCALE = np.diag([1.0 / FACTOR, 1.0 / FACTOR, 1.0 / FACTOR, 1.0])

#: Arrays up to this many elements (the lights' positions and powers, rebuilt every frame) are
#: compared by value; larger ones (grids, tables: cached stages) by identity.
_BY_VALUE = 256


def draft_applies(req, args) -> bool:
    """Whether the ray cast of ``args`` (the model id and its records) renders as a draft for request
    ``req``: asked for, on the CPU, where the packet driver would march the full frame, on a grid
    of at least 2·FACTOR samples per axis."""
    model, _view, _march, medium, _lights, grid = args[:6]
    return (bool(req.draft) and req.backend == "cpu" and min(medium.field.shape) >= 2 * FACTOR
            and packets_apply(model, medium, grid))


def _same(a, b) -> bool:
    """Whether two input tuples hold the same inputs."""
    if isinstance(a, (tuple, list)):
        return isinstance(b, (tuple, list)) and len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, np.ndarray) and isinstance(b, np.ndarray):
        if a is b:
            return True
        return a.size <= _BY_VALUE and a.shape == b.shape and a.dtype == b.dtype and bool(np.array_equal(a, b))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return False
    return a == b


def _record(renderer, args, shape):
    """The lit model's draft record on the level, shaded from the frame's records ``args`` — kept
    while its inputs (the arrays and values it was shaded from) are the same, so a drag shades it
    once."""
    model, view, march, medium, lights, grid, ambient, diffusion = args
    # a point light's 1/d² clamped at one data spacing, whatever the frame's step: the level samples
    # every other data sample, and a drag that changes its step does not shade the record again
    lights = lights._replace(d2min=float(np.min(renderer.geometry.spacing)) ** 2)
    # not the step-corrected table: the source reads its albedo and emission, the same at every step
    inputs = (model, medium.field, medium.table, K.arrays(lights), lights.d2min, grid.inc, diffusion.field,
              K.arrays(ambient))
    cache, key = renderer.stages.cache, ("draft_record",)
    if key in cache and _same(cache[key][0], inputs):
        return cache[key][1]
    rec = shade_record((model, view, march, medium, lights, grid, ambient, diffusion),
                       renderer.geometry.index_to_world, shape)
    cache[key] = (inputs, rec)
    return rec


def draft_args(renderer, args):
    """The ray cast's arguments for the draft of frame ``args`` (:func:`draft_applies` holds): the
    level's view and medium; emission–absorption marches its scalar, a lit model the draft record."""
    model, view, march, medium, lights, grid, ambient, diffusion = args
    level, maj = renderer.stages.cache.get(("draft_level",), lambda: draft_level(renderer.optics, MAJORANT_BLOCK))
    view = view._replace(w2i=_SCALE @ view.w2i, lo=view.lo / FACTOR, hi=view.hi / FACTOR)
    coarse = medium._replace(field=level, maj=maj)
    if model == EMISSION_ABSORPTION:
        return (model, view, march, coarse, lights, grid, ambient, diffusion)
    rec = _record(renderer, args, level.shape)
    return (DRAFT, view, march, coarse, lights, grid, ambient, diffusion._replace(field=rec))
