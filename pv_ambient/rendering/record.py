"""The lit record a CPU camera pass reads (docs/performance.rst, "Lit record"): where a lit model's
in-scattering is baked on the data samples, the frame reads the scalar and the summed light from one
packed record per data sample (:mod:`pv_ambient._kernels.record`) instead of the scalar field and
the bake's rgb slot — two gathers per corner instead of four, the transfer
function's albedo and emission still classified at the sample. It applies on the CPU where the
packet driver marches the frame (and to its scalar fallback, ``PV_AMBIENT_PACKETS=0``) where the
bake is one rgb slot, so that the record's light is the bake's (:func:`record_applies`).
``PV_AMBIENT_RECORD=0`` marches the bake as it is.
"""

from __future__ import annotations

import os

import numpy as np

from .._kernels import records as K
from .._kernels.models import AMBIENT_SCATTERING, RECORD, SINGLE_SCATTERING
from ..stages.record import packed_light_record, table_medium
from .draft import held_inputs, reference, same_inputs


def enabled() -> bool:
    """Whether a camera pass reads the lit record where it applies (``PV_AMBIENT_RECORD=0``: never)."""
    return os.environ.get("PV_AMBIENT_RECORD", "1") != "0"


def _on_samples(grid, shape) -> bool:
    """Whether light-grid record ``grid``'s nodes are the data samples of a grid of ``shape``."""
    return (tuple(np.shape(grid.inc)[:3]) == tuple(shape) and bool(np.all(np.asarray(grid.lo) == 0.0))
            and bool(np.all((np.asarray(grid.inv_step) == 1.0) | (np.asarray(shape) == 1))))


def record_applies(req, args) -> bool:
    """Whether the ray cast of ``args`` (the model id and its records) reads the lit record for
    request ``req``: on the CPU, a baked single or ambient scattering kernel (diffusion's field
    folded into the bake is single scattering's) of a table transfer function (a LUT-mode medium:
    what the packet driver marches; the scalar fallback reads the same record), its light grid on
    the data samples, and a bake of one rgb slot: one point light (the reference) or only
    directional lights and diffusion's field (a constant reference weight), so the record's light
    is the bake's. A second slot would join the reference's slot times its ``d²``, which trilinear
    interpolation overestimates by ``h²·f(1 − f)`` per axis (percents a few samples from the
    light); a grey slot reads two values per corner already."""
    model, _view, _march, medium, _lights, grid = args[:6]
    return (enabled() and req.backend == "cpu" and model in (SINGLE_SCATTERING, AMBIENT_SCATTERING)
            and int(grid.baked) == 3 and np.shape(grid.inc)[3] == 3
            and min(medium.field.shape) >= 2 and table_medium(medium) and _on_samples(grid, medium.field.shape))


def _record(renderer, args, ref):
    """The packed lit record of frame ``args`` (:func:`packed_light_record`), kept while its inputs
    (the arrays and values it was shaded from) are the same: a camera move shades it once."""
    _model, _view, _march, medium, lights, grid = args[:6]
    inputs = (medium.field, medium.table.shape[0], medium.lut_lo, medium.lut_inv, K.arrays(lights), lights.d2min,
              grid.inc, grid.baked)
    cache, key = renderer.stages.cache, ("lit_record",)
    if key in cache and same_inputs(cache[key][0], inputs):
        return cache[key][1]
    packed = packed_light_record(medium, lights, grid, renderer.geometry.index_to_world, ref)
    cache[key] = (held_inputs(inputs), packed)
    return packed


def record_args(renderer, args):
    """The ray cast's arguments of frame ``args`` reading the lit record (:func:`record_applies`
    holds): model :data:`.models.RECORD`, the scalar codes as the medium, the reference point as
    the lights (its power the record's scale), the record as the diffusion field."""
    model, view, march, medium, lights, grid, ambient, diffusion = args
    ref = reference(lights, renderer.geometry, lights.d2min)
    words, codes, scale, lut = _record(renderer, args, ref)
    coded = medium._replace(field=codes, lut_lo=lut[0], lut_inv=lut[1])
    ref = ref._replace(power=np.full_like(np.asarray(ref.power), scale))
    return (RECORD, view, march, coded, ref, grid, ambient, diffusion._replace(field=words))
