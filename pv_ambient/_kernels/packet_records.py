"""The packet driver's pass 3 (:mod:`.packet`) of the models that read a packed record instead of
the scene's arrays: a draft frame (:mod:`.draft`) and the lit records (:mod:`.record`). Each lane
loop interpolates the record, looks the scalar's code up in the step-corrected table, and ends
in :func:`.lanes.lanes_composite`."""

from __future__ import annotations

import numpy as np

from ._jit import scalar
from .baked import point_weight
from .draft import draft_sample
from .lanes import A, ACT, LANES, SB, SG, SR, WX, WY, WZ, X, Y, Z, lanes_composite
from .medium import step_column, table_coords
from .raycast import lit_table_source
from .record import grey_values, pair_values, record_values

@scalar(inline=True)
def lanes_sample_draft(l32, b32, l64, b64, field, stab, lut_lo, lut_inv, lights, grid, dfield):
    """Pass 3 of a draft frame (vectorised): every lane samples its full segment of the draft record
    ``dfield`` with :func:`.draft.draft_sample` (its opacity, zero for an inactive lane, and source
    over the weight of the reference point, light 0 of ``lights``), then :func:`lanes_composite`
    (``field`` and ``grid`` unused)."""
    for k in range(LANES):
        a, cr, cg, cb = draft_sample(dfield, stab, lut_lo, lut_inv, l32[np.uint64(b32 + X * LANES + k)],
                                     l32[np.uint64(b32 + Y * LANES + k)], l32[np.uint64(b32 + Z * LANES + k)])
        w = point_weight(lights, 0, l32[np.uint64(b32 + WX * LANES + k)], l32[np.uint64(b32 + WY * LANES + k)],
                         l32[np.uint64(b32 + WZ * LANES + k)])
        l32[np.uint64(b32 + A * LANES + k)] = a * l32[np.uint64(b32 + ACT * LANES + k)]
        l32[np.uint64(b32 + SR * LANES + k)] = cr * w
        l32[np.uint64(b32 + SG * LANES + k)] = cg * w
        l32[np.uint64(b32 + SB * LANES + k)] = cb * w
    lanes_composite(l32, b32, l64, b64)


@scalar(inline=True)
def lanes_sample_record(l32, b32, l64, b64, field, stab, lut_lo, lut_inv, lights, grid, dfield):
    """Pass 3 of a lit record (vectorised): every lane interpolates the record ``dfield``
    (:func:`.record.record_values`: the scalar's code and the light), looks the code up in the
    step-corrected table (its opacity, zero for an inactive lane), scales the light by the
    record's scale over its ``max(d², d2min)`` to the reference point (light 0 of ``lights``;
    :func:`.record.record_light`) and takes ``a·L + (1 − a)·Le`` (:func:`.raycast.lit_table_source`),
    then :func:`lanes_composite` (``field`` and ``grid`` unused)."""
    power = np.float32(lights.power[0, 0])
    for k in range(LANES):
        s, r, g, b = record_values(dfield, l32[np.uint64(b32 + X * LANES + k)], l32[np.uint64(b32 + Y * LANES + k)],
                                   l32[np.uint64(b32 + Z * LANES + k)])
        q0, fq = table_coords(s, stab, lut_lo, lut_inv)
        w = point_weight(lights, 0, l32[np.uint64(b32 + WX * LANES + k)], l32[np.uint64(b32 + WY * LANES + k)],
                         l32[np.uint64(b32 + WZ * LANES + k)]) * power
        sr, sg, sb = lit_table_source(stab, q0, fq, r * w, g * w, b * w)
        l32[np.uint64(b32 + A * LANES + k)] = step_column(stab, q0, fq, 0) * l32[np.uint64(b32 + ACT * LANES + k)]
        l32[np.uint64(b32 + SR * LANES + k)] = sr
        l32[np.uint64(b32 + SG * LANES + k)] = sg
        l32[np.uint64(b32 + SB * LANES + k)] = sb
    lanes_composite(l32, b32, l64, b64)


@scalar(inline=True)
def lanes_sample_record_pair(l32, b32, l64, b64, field, stab, lut_lo, lut_inv, lights, grid, dfield):
    """Pass 3 of a pair record (vectorised): :func:`lanes_sample_record` with the light of
    :func:`.record.pair_light` — the point slot over its ``max(d², d2min)``, the other slot as it is."""
    sp = np.float32(lights.power[0, 0])
    sd = np.float32(lights.power[0, 1])
    for k in range(LANES):
        s, pr, pg, pb, dr, dg, db = pair_values(dfield, l32[np.uint64(b32 + X * LANES + k)],
                                                l32[np.uint64(b32 + Y * LANES + k)], l32[np.uint64(b32 + Z * LANES + k)])
        q0, fq = table_coords(s, stab, lut_lo, lut_inv)
        w = point_weight(lights, 0, l32[np.uint64(b32 + WX * LANES + k)], l32[np.uint64(b32 + WY * LANES + k)],
                         l32[np.uint64(b32 + WZ * LANES + k)]) * sp
        sr, sg, sb = lit_table_source(stab, q0, fq, pr * w + dr * sd, pg * w + dg * sd, pb * w + db * sd)
        l32[np.uint64(b32 + A * LANES + k)] = step_column(stab, q0, fq, 0) * l32[np.uint64(b32 + ACT * LANES + k)]
        l32[np.uint64(b32 + SR * LANES + k)] = sr
        l32[np.uint64(b32 + SG * LANES + k)] = sg
        l32[np.uint64(b32 + SB * LANES + k)] = sb
    lanes_composite(l32, b32, l64, b64)


@scalar(inline=True)
def lanes_sample_record_grey(l32, b32, l64, b64, field, stab, lut_lo, lut_inv, lights, grid, dfield):
    """Pass 3 of a grey record (vectorised): :func:`lanes_sample_record` with one value of light,
    :func:`.record.grey_values` — one gather per corner."""
    power = np.float32(lights.power[0, 0])
    for k in range(LANES):
        s, v = grey_values(dfield, l32[np.uint64(b32 + X * LANES + k)], l32[np.uint64(b32 + Y * LANES + k)],
                           l32[np.uint64(b32 + Z * LANES + k)])
        q0, fq = table_coords(s, stab, lut_lo, lut_inv)
        w = point_weight(lights, 0, l32[np.uint64(b32 + WX * LANES + k)], l32[np.uint64(b32 + WY * LANES + k)],
                         l32[np.uint64(b32 + WZ * LANES + k)]) * power * v
        sr, sg, sb = lit_table_source(stab, q0, fq, w, w, w)
        l32[np.uint64(b32 + A * LANES + k)] = step_column(stab, q0, fq, 0) * l32[np.uint64(b32 + ACT * LANES + k)]
        l32[np.uint64(b32 + SR * LANES + k)] = sr
        l32[np.uint64(b32 + SG * LANES + k)] = sg
        l32[np.uint64(b32 + SB * LANES + k)] = sb
    lanes_composite(l32, b32, l64, b64)
