"""The lit record a CPU camera pass reads (docs/performance.rst, "Lit record"): where a lit model's
in-scattering is baked on the data samples, the frame reads the scalar and the baked light from one
packed record per data sample (:mod:`pv_ambient._kernels.record`) instead of the scalar field and
the bake — one gather per corner instead of two for a grey slot, two instead of four for an rgb
slot, four instead of seven for two — the transfer function's albedo and emission still
classified at the sample. It applies on
the CPU where the packet driver marches the frame (and to its scalar fallback,
``PV_AMBIENT_PACKETS=0``), for the bakes :func:`record_kind` names; ``PV_AMBIENT_RECORD=0``
marches the bake as it is.
"""

from __future__ import annotations

import os

import numpy as np

from .._kernels import records as K
from .._kernels.models import AMBIENT_SCATTERING, RECORD, RECORD_GREY, RECORD_PAIR, SINGLE_SCATTERING
from ..stages.record import packed_light_record, packed_pair_record, table_medium
from .draft import held_inputs, reference, same_inputs


def enabled() -> bool:
    """Whether a camera pass reads the lit record where it applies (``PV_AMBIENT_RECORD=0``: never)."""
    return os.environ.get("PV_AMBIENT_RECORD", "1") != "0"


def _on_samples(grid, shape) -> bool:
    """Whether light-grid record ``grid``'s nodes are the data samples of a grid of ``shape``."""
    return (tuple(np.shape(grid.inc)[:3]) == tuple(shape) and bool(np.all(np.asarray(grid.lo) == 0.0))
            and bool(np.all((np.asarray(grid.inv_step) == 1.0) | (np.asarray(shape) == 1))))


def record_kind(args):
    """The lit record the ray cast of ``args`` would read, by its bake: :data:`.models.RECORD` for one
    rgb slot — one point light (the reference) or directional lights and diffusion's field (a
    constant reference weight) — :data:`.models.RECORD_GREY` for one grey slot (one word per sample),
    :data:`.models.RECORD_PAIR` for a point light's rgb slot beside the other lights' (kept apart:
    summed into one record, the second slot's light would be interpolated times the point light's
    ``d²``, which trilinear interpolation overestimates by ``h²·f(1 − f)`` per axis, percents a few
    samples from the light); None otherwise (two grey slots: their scalar and the slots read three
    values per corner, as many as a record would hold)."""
    lights, grid = args[4], args[5]
    points = int(np.sum(np.asarray(lights.kind) == 0))
    channels = np.shape(grid.inc)[3] if np.ndim(grid.inc) == 4 else 0
    if int(grid.baked) == 1 and channels == 1 and points <= 1:
        return RECORD_GREY
    if int(grid.baked) != 3:
        return None
    if channels == 3 and points <= 1:
        return RECORD
    if channels == 6 and points == 1:
        return RECORD_PAIR
    return None


def record_applies(req, args) -> bool:
    """Whether the ray cast of ``args`` (the model id and its records) reads a lit record for
    request ``req``: on the CPU, a baked single or ambient scattering kernel (diffusion's field
    folded into the bake is single scattering's) of a table transfer function (a LUT-mode medium:
    what the packet driver marches; the scalar fallback reads the same record), its light grid on
    the data samples, a bake :func:`record_kind` reads."""
    model, _view, _march, medium, _lights, grid = args[:6]
    return (enabled() and req.backend == "cpu" and model in (SINGLE_SCATTERING, AMBIENT_SCATTERING)
            and record_kind(args) is not None and min(medium.field.shape) >= 2 and table_medium(medium)
            and _on_samples(grid, medium.field.shape))


def _record(renderer, args, ref, kind):
    """The packed lit record of frame ``args`` (:func:`packed_light_record` or
    :func:`packed_pair_record`), kept while its inputs (the arrays and values it was shaded from)
    are the same: a camera move shades it once."""
    _model, _view, _march, medium, lights, grid = args[:6]
    inputs = (kind, medium.field, medium.table.shape[0], medium.lut_lo, medium.lut_inv, K.arrays(lights),
              lights.d2min, grid.inc, grid.baked)
    cache, key = renderer.stages.cache, ("lit_record",)
    if key in cache and same_inputs(cache[key][0], inputs):
        return cache[key][1]
    if kind in (RECORD, RECORD_GREY):
        packed = packed_light_record(medium, lights, grid, ref)
    else:
        packed = packed_pair_record(medium, grid)
    cache[key] = (held_inputs(inputs), packed)
    return packed


def record_args(renderer, args):
    """The ray cast's arguments of frame ``args`` reading its lit record (:func:`record_applies`
    holds): model :data:`.models.RECORD`, :data:`.models.RECORD_GREY` or :data:`.models.RECORD_PAIR`,
    the scalar codes as the medium, the reference point as the lights (its power the record's
    scale, or the point slot's and the other slot's), the record as the diffusion field."""
    model, view, march, medium, lights, grid, ambient, diffusion = args
    kind = record_kind(args)
    ref = reference(lights, renderer.geometry, lights.d2min)
    words, codes, scale, lut = _record(renderer, args, ref, kind)
    coded = medium._replace(field=codes, lut_lo=lut[0], lut_inv=lut[1])
    power = np.zeros_like(np.asarray(ref.power))
    power[0, :] = (scale[0], scale[1], 0.0) if kind == RECORD_PAIR else scale
    return (kind, view, march, coded, ref._replace(power=power), grid, ambient, diffusion._replace(field=words))
