"""The CPU camera pass in ray packets: :data:`LANES` rays of a 4 × 8 pixel block marched in lockstep,
so that one sample of every ray is computed by SIMD instructions (docs/performance.rst, "CPU camera
pass").

The march is the one of :func:`.raycast.march_pixel` — the same segments, block skipping, early
termination and jitter — split in three passes per step of the packet:

1. :func:`lanes_step` (vectorised): every lane whose next segment is a full step inside its current
   run of non-empty majorant blocks moves to it — the common case;
2. :func:`lanes_fix` (scalar): the other lanes do what :func:`.raycast.march_pixel` does at a block
   boundary, on a partial segment (the jittered first, the last: ``exp`` of the table's σt)
   and at the end of the ray, until each has a full segment to sample or is done — called only on
   a step where pass 1 left a lane (a call with the scene's records and a scalar loop over the
   lanes is what most steps of a packet do not need). Where it looks a block up and finds it
   non-empty, it walks on to the end of the run of non-empty blocks (:func:`.majorant.run_end`):
   the per-pixel march's lookups inside such a run change nothing but its next boundary, so the
   samples are the same and a lane comes back here only at the run's end;
3. :func:`lanes_sample_ea`; a record model's (:mod:`.packet_records`: a draft frame, a lit
   record); or :func:`lanes_lit_light` (+ :func:`lanes_diffusion`) and
   :func:`lanes_lit_composite` (vectorised): every active lane samples its segment with the scalar
   functions the per-pixel march uses (:func:`.medium.step_sample`; :func:`.medium.step_lookup`,
   :func:`.baked.baked_light`'s and :func:`.baked.diffusion_baked`'s terms,
   :func:`.raycast.lit_table_source`) into float32 lane fields, then :func:`.lanes.lanes_composite`
   composites them (float64).

Lane state is a flat structure of arrays per thread (float32 positions for the sample and the
sample's opacity and source, float64 ray state and sums: float64 where sums accumulate), indexed
with unsigned integers. Why these rules: LLVM vectorises a lane loop only when its addresses are
affine in the lane (Numba's negative-index wraparound of a signed index is not), when its body is
branch-free (selects) and when Numba marks the arrays ``noalias`` — which it does for a ``prange``
body with no aliasing assignments, so the vectorised passes are inlined into the driver and create
no array views, tuples or booleans there. LLVM also picks one vector width per loop, from the
widest type the loop loads or stores: a loop that touches a float64 field runs 4 lanes per 256-bit
instruction, a float32-only one 8, so the loops that hold the gathers touch no float64.
``tests/kernels/test_packet.py`` compiles the driver outside the disk cache and checks that vector
FMAs, none of them 128-bit, are in its assembly.

Which models and media (:func:`applies`): emission–absorption, and single scattering, ambient
scattering and diffusion with baked in-scattering, of a LUT-mode (table) transfer function; every other case runs the scalar
driver (:func:`.raycast.raycast_driver`), as does everything when ``PV_AMBIENT_PACKETS=0`` (the
scalar fallback). :func:`raycast_image` is the CPU camera pass's
entry (:mod:`pv_ambient.backend`).
"""

from __future__ import annotations

import os

import numba
import numpy as np

from ._jit import driver, prange, scalar, with_globals
from .geometry import camera_ray, ray_box
from .majorant import block_at, block_span, empty_distance, run_end
from .medium import (FULL_STEP, MODE_LUT, full_segment, step_column, step_lookup, step_opacity,
                     step_sample)
from .models import (AMBIENT_SCATTERING, DIFFUSION, DRAFT, EMISSION_ABSORPTION, RECORD, RECORD_GREY,
                     RECORD_PAIR, SINGLE_SCATTERING)
from .draft import draft_source
from .lanes import (A, ACT, DONE, DX, DY, DZ, FQ, LANES, LX, LY, LZ, N32, N64, OX, OY, OZ, PX, PY, PZ, Q0, QX,
                    QY, QZ, RB, RG, RR, SB, SG, SIDE, SR, T1, TB, TN, TR, TS, WX, WY, WZ, X, Y, Z, lanes_composite)
from .packet_records import lanes_sample_draft, lanes_sample_record, lanes_sample_record_grey, lanes_sample_record_pair
from .baked import baked_grey, baked_rgb, diffusion_grey, diffusion_layout, diffusion_rgb, grid_point, point_weight
from .raycast import STREAM_JITTER, TILE, index_ray, lit_table_source, row_stride, table_source
from .raycast import raycast_image as raycast_image_scalar
from .rng import uniform



@scalar
def packet_begin(view, march, i0, j0, row1, W, H, l32, b32, l64, b64):
    """Set up the lanes of the packet whose top-left pixel is (i0, j0): each ray clipped to the box
    and to its end, its first boundary jittered as :func:`.raycast.march_pixel` does; lanes outside
    the image or the rows [.., row1) are done."""
    cam, w2i, lo, hi = view.cam, view.w2i, view.lo, view.hi
    step, jitter, seed, t_end = march.step, march.jitter, march.seed, march.t_end
    per_pixel = t_end.shape[0] == H and t_end.shape[1] == W
    for k in range(LANES):
        i = i0 + k % SIDE
        j = j0 + k // SIDE
        l32[b32 + ACT * LANES + k] = 0.0
        l64[b64 + DONE * LANES + k] = 1.0
        l64[b64 + TR * LANES + k] = 1.0
        l64[b64 + RR * LANES + k] = 0.0
        l64[b64 + RG * LANES + k] = 0.0
        l64[b64 + RB * LANES + k] = 0.0
        if i >= W or j >= row1:
            continue
        ox, oy, oz, dx, dy, dz = camera_ray(cam, i, j, W, H)
        px, py, pz, qx, qy, qz = index_ray(w2i, ox, oy, oz, dx, dy, dz)
        t0, t1 = ray_box(px, py, pz, qx, qy, qz, lo, hi)
        t0 = max(t0, 0.0)
        t1 = min(t1, t_end[j, i] if per_pixel else t_end[0, 0])
        l64[b64 + PX * LANES + k] = px
        l64[b64 + PY * LANES + k] = py
        l64[b64 + PZ * LANES + k] = pz
        l64[b64 + QX * LANES + k] = qx
        l64[b64 + QY * LANES + k] = qy
        l64[b64 + QZ * LANES + k] = qz
        l64[b64 + OX * LANES + k] = ox
        l64[b64 + OY * LANES + k] = oy
        l64[b64 + OZ * LANES + k] = oz
        l64[b64 + DX * LANES + k] = dx
        l64[b64 + DY * LANES + k] = dy
        l64[b64 + DZ * LANES + k] = dz
        if t0 < t1:
            offset = uniform(seed, STREAM_JITTER, j * W + i, 0) if jitter else 0.0
            l64[b64 + TS * LANES + k] = t0
            l64[b64 + TN * LANES + k] = t0 + (1.0 - offset) * step
            l64[b64 + T1 * LANES + k] = t1
            l64[b64 + TB * LANES + k] = -1.0
            l64[b64 + DONE * LANES + k] = 0.0


@scalar(inline=True)
def lanes_step(l32, b32, l64, b64, step, ert, world):
    """Pass 1 (vectorised): each lane whose next segment ``[t, tnext]`` is a full step that ends
    before the ray does, whose midpoint lies in the current run of non-empty blocks and whose
    transmittance is still above ``ert`` takes it: its sample position is written (the world
    position too where ``world``, a constant of the driver: the lit models' point lights) and ``t``
    moves on. Other lanes are left to :func:`lanes_fix`. Returns how many lanes moved (all of them:
    no lane for :func:`lanes_fix` this step, the common case)."""
    moved = 0
    for k in range(LANES):
        t = l64[np.uint64(b64 + TS * LANES + k)]
        tn = l64[np.uint64(b64 + TN * LANES + k)]
        tm = 0.5 * (t + tn)
        ok = ((l64[np.uint64(b64 + DONE * LANES + k)] == 0.0) & (tm < l64[np.uint64(b64 + TB * LANES + k)])
              & (tn <= l64[np.uint64(b64 + T1 * LANES + k)]) & (tn - t >= FULL_STEP * step)
              & (l64[np.uint64(b64 + TR * LANES + k)] >= ert))
        l32[np.uint64(b32 + X * LANES + k)] = np.float32(l64[np.uint64(b64 + PX * LANES + k)]
                                                         + tm * l64[np.uint64(b64 + QX * LANES + k)])
        l32[np.uint64(b32 + Y * LANES + k)] = np.float32(l64[np.uint64(b64 + PY * LANES + k)]
                                                         + tm * l64[np.uint64(b64 + QY * LANES + k)])
        l32[np.uint64(b32 + Z * LANES + k)] = np.float32(l64[np.uint64(b64 + PZ * LANES + k)]
                                                         + tm * l64[np.uint64(b64 + QZ * LANES + k)])
        if world:
            l32[np.uint64(b32 + WX * LANES + k)] = np.float32(l64[np.uint64(b64 + OX * LANES + k)]
                                                              + tm * l64[np.uint64(b64 + DX * LANES + k)])
            l32[np.uint64(b32 + WY * LANES + k)] = np.float32(l64[np.uint64(b64 + OY * LANES + k)]
                                                              + tm * l64[np.uint64(b64 + DY * LANES + k)])
            l32[np.uint64(b32 + WZ * LANES + k)] = np.float32(l64[np.uint64(b64 + OZ * LANES + k)]
                                                              + tm * l64[np.uint64(b64 + DZ * LANES + k)])
        l32[np.uint64(b32 + ACT * LANES + k)] = np.float32(1.0) if ok else np.float32(0.0)
        l64[np.uint64(b64 + TS * LANES + k)] = tn if ok else t
        l64[np.uint64(b64 + TN * LANES + k)] = tn + step if ok else tn
        moved += 1 if ok else 0
    return moved


@scalar
def lanes_fix(model, march, medium, lights, grid, ambient, diffusion, l32, b32, l64, b64, dist):
    """Pass 2 (scalar): every lane :func:`lanes_step` left marches as :func:`.raycast.march_pixel`
    does — block lookups and skips, partial segments sampled with ``exp`` of the interpolated σt,
    early termination — until it has a full segment to sample (its position written, active) or
    is done. ``model``: emission–absorption, or single scattering or diffusion with baked lights (the
    lit sample of :func:`.raycast.march_pixel`), or a draft frame (:func:`.draft.draft_source`);
    ``dist``: the majorant's :func:`.majorant.empty_distance`.
    Returns the number of active lanes."""
    step, ert = march.step, march.ert
    maj, block = medium.maj, medium.block
    active = 0
    for k in range(LANES):
        if l32[b32 + ACT * LANES + k] != 0.0:
            active += 1
            continue
        if l64[b64 + DONE * LANES + k] != 0.0:
            continue
        T = l64[b64 + TR * LANES + k]
        if T < ert:
            l64[b64 + DONE * LANES + k] = 1.0
            continue
        t = l64[b64 + TS * LANES + k]
        tnext = l64[b64 + TN * LANES + k]
        t1 = l64[b64 + T1 * LANES + k]
        t_block = l64[b64 + TB * LANES + k]
        px = l64[b64 + PX * LANES + k]
        py = l64[b64 + PY * LANES + k]
        pz = l64[b64 + PZ * LANES + k]
        qx = l64[b64 + QX * LANES + k]
        qy = l64[b64 + QY * LANES + k]
        qz = l64[b64 + QZ * LANES + k]
        ox = l64[b64 + OX * LANES + k]
        oy = l64[b64 + OY * LANES + k]
        oz = l64[b64 + OZ * LANES + k]
        dx = l64[b64 + DX * LANES + k]
        dy = l64[b64 + DY * LANES + k]
        dz = l64[b64 + DZ * LANES + k]
        found = 0
        while t < t1:
            te = min(tnext, t1)
            tm = 0.5 * (t + te)
            x = px + tm * qx
            y = py + tm * qy
            z = pz + tm * qz
            if tm >= t_block:
                ba, bb, bc = block_at(x, y, z, maj, block)
                _, _, _, tex = block_span(px, py, pz, qx, qy, qz, ba, bb, bc, maj, block, tm, t1)
                if maj[ba, bb, bc] <= 0.0:
                    if tex > te:
                        t = tex  # skip the empty block; realign the segment grid after it
                        tnext = t + step
                        continue
                    t = te
                    tnext = te + step
                    continue
                # march to the end of this run of non-empty blocks before the next lookup
                t_block = run_end(px, py, pz, qx, qy, qz, ba, bb, bc, tm, t1, maj, dist, block)
            if full_segment(t, te, step) != 0.0:
                l32[b32 + X * LANES + k] = x
                l32[b32 + Y * LANES + k] = y
                l32[b32 + Z * LANES + k] = z
                l32[b32 + WX * LANES + k] = ox + tm * dx
                l32[b32 + WY * LANES + k] = oy + tm * dy
                l32[b32 + WZ * LANES + k] = oz + tm * dz
                l32[b32 + ACT * LANES + k] = 1.0
                t = te
                tnext = te + step
                found = 1
                break
            # a partial segment, as march_pixel: exp of the table's interpolated σt
            q0, fq = step_lookup(medium.field, march.opacity, medium.lut_lo, medium.lut_inv, x, y, z)
            a = step_opacity(march.opacity, q0, fq, 0.0, te - t)
            if a > 0.0:
                if model == DRAFT:
                    cr, cg, cb = draft_source(diffusion.field, lights, x, y, z, ox + tm * dx, oy + tm * dy,
                                              oz + tm * dz)
                else:
                    cr, cg, cb = table_source(model, march.opacity, q0, fq, x, y, z, ox + tm * dx, oy + tm * dy,
                                              oz + tm * dz, lights, grid, ambient, diffusion)
                w = T * a
                l64[b64 + RR * LANES + k] += w * cr
                l64[b64 + RG * LANES + k] += w * cg
                l64[b64 + RB * LANES + k] += w * cb
                T -= w
                if T < ert:
                    t = t1
                    break
            t = te
            tnext = te + step
        l64[b64 + TR * LANES + k] = T
        l64[b64 + TS * LANES + k] = t
        l64[b64 + TN * LANES + k] = tnext
        l64[b64 + TB * LANES + k] = t_block
        if found:
            active += 1
        else:
            l64[b64 + DONE * LANES + k] = 1.0
    return active


@scalar(inline=True)
def lanes_sample_ea(l32, b32, l64, b64, field, stab, lut_lo, lut_inv, lights, grid, dfield):
    """Pass 3 (vectorised): every lane samples its full segment with :func:`.medium.step_sample`
    (float32: its opacity, zero for an inactive lane, and colour) and :func:`lanes_composite`
    composites it (``lights``, ``grid`` and ``dfield`` unused: every pass 3 takes the same
    arguments)."""
    for k in range(LANES):
        a, cr, cg, cb = step_sample(field, stab, lut_lo, lut_inv, l32[np.uint64(b32 + X * LANES + k)],
                                    l32[np.uint64(b32 + Y * LANES + k)], l32[np.uint64(b32 + Z * LANES + k)])
        l32[np.uint64(b32 + A * LANES + k)] = a * l32[np.uint64(b32 + ACT * LANES + k)]
        l32[np.uint64(b32 + SR * LANES + k)] = cr
        l32[np.uint64(b32 + SG * LANES + k)] = cg
        l32[np.uint64(b32 + SB * LANES + k)] = cb
    lanes_composite(l32, b32, l64, b64)


@scalar(inline=True)
def lanes_lit_light(l32, b32, l64, b64, field, stab, lut_lo, lut_inv, lights, grid):
    """Pass 3 of a lit sample with baked lights (vectorised), first part: the opacity and table
    entry of every lane's sample, then the baked light one light slot at a time
    (:func:`.baked.baked_light`'s terms, in its order) into the lanes' light (``SR, SG, SB``)."""
    for k in range(LANES):
        q0, fq = step_lookup(field, stab, lut_lo, lut_inv, l32[np.uint64(b32 + X * LANES + k)],
                             l32[np.uint64(b32 + Y * LANES + k)], l32[np.uint64(b32 + Z * LANES + k)])
        l32[np.uint64(b32 + A * LANES + k)] = step_column(stab, q0, fq, 0) * l32[np.uint64(b32 + ACT * LANES + k)]
        l32[np.uint64(b32 + Q0 * LANES + k)] = np.float32(q0)
        l32[np.uint64(b32 + FQ * LANES + k)] = fq
        lx, ly, lz = grid_point(grid, l32[np.uint64(b32 + X * LANES + k)], l32[np.uint64(b32 + Y * LANES + k)],
                                l32[np.uint64(b32 + Z * LANES + k)])
        l32[np.uint64(b32 + LX * LANES + k)] = lx
        l32[np.uint64(b32 + LY * LANES + k)] = ly
        l32[np.uint64(b32 + LZ * LANES + k)] = lz
        l32[np.uint64(b32 + SR * LANES + k)] = np.float32(0.0)
        l32[np.uint64(b32 + SG * LANES + k)] = np.float32(0.0)
        l32[np.uint64(b32 + SB * LANES + k)] = np.float32(0.0)
    inc = grid.inc
    nch = grid.baked
    lkind = lights.kind
    slot = 0
    for l in range(lkind.shape[0]):
        if lkind[l] == 0:
            lanes_baked_slot(l32, b32, l64, b64, inc, slot * nch, nch, lights, l, 1)
            slot += 1
    if (slot + 1) * nch <= inc.shape[3]:  # the directional lights' slot
        lanes_baked_slot(l32, b32, l64, b64, inc, slot * nch, nch, lights, 0, 0)


@scalar(inline=True)
def lanes_diffusion(l32, b32, l64, b64, dfield):
    """Pass 3 of diffusion with baked lights (vectorised), between the light and the compositing:
    the diffusion field's φ/4π at every lane's sample added to its light (:func:`.baked.diffusion_baked`'s
    terms; one loop per layout, so no branch is left inside them)."""
    per, nch = diffusion_layout(dfield.shape[3])
    if nch == 1:
        for k in range(LANES):
            v = diffusion_grey(dfield, l32[np.uint64(b32 + X * LANES + k)], l32[np.uint64(b32 + Y * LANES + k)],
                               l32[np.uint64(b32 + Z * LANES + k)])
            l32[np.uint64(b32 + SR * LANES + k)] += v
            l32[np.uint64(b32 + SG * LANES + k)] += v
            l32[np.uint64(b32 + SB * LANES + k)] += v
    else:
        for k in range(LANES):
            vr, vg, vb = diffusion_rgb(dfield, per, l32[np.uint64(b32 + X * LANES + k)],
                                       l32[np.uint64(b32 + Y * LANES + k)], l32[np.uint64(b32 + Z * LANES + k)])
            l32[np.uint64(b32 + SR * LANES + k)] += vr
            l32[np.uint64(b32 + SG * LANES + k)] += vg
            l32[np.uint64(b32 + SB * LANES + k)] += vb


@scalar(inline=True)
def lanes_sample_lit(l32, b32, l64, b64, field, stab, lut_lo, lut_inv, lights, grid, dfield):
    """Pass 3 of single scattering with baked lights (vectorised): :func:`lanes_lit_light` then
    :func:`lanes_lit_composite` (``dfield`` unused)."""
    lanes_lit_light(l32, b32, l64, b64, field, stab, lut_lo, lut_inv, lights, grid)
    lanes_lit_composite(l32, b32, l64, b64, stab)


@scalar(inline=True)
def lanes_sample_diffusion(l32, b32, l64, b64, field, stab, lut_lo, lut_inv, lights, grid, dfield):
    """Pass 3 of diffusion with baked lights (vectorised): :func:`lanes_lit_light`,
    :func:`lanes_diffusion`, :func:`lanes_lit_composite`."""
    lanes_lit_light(l32, b32, l64, b64, field, stab, lut_lo, lut_inv, lights, grid)
    lanes_diffusion(l32, b32, l64, b64, dfield)
    lanes_lit_composite(l32, b32, l64, b64, stab)


@scalar(inline=True)
def lanes_lit_composite(l32, b32, l64, b64, stab):
    """Pass 3 of a lit sample, last part (vectorised): the source ``a·L + (1 − a)·Le``
    (:func:`.raycast.lit_table_source`, float32) in place of each lane's light, then
    :func:`lanes_composite`."""
    for k in range(LANES):
        sr, sg, sb = lit_table_source(stab, np.uint64(l32[np.uint64(b32 + Q0 * LANES + k)]),
                                      l32[np.uint64(b32 + FQ * LANES + k)], l32[np.uint64(b32 + SR * LANES + k)],
                                      l32[np.uint64(b32 + SG * LANES + k)], l32[np.uint64(b32 + SB * LANES + k)])
        l32[np.uint64(b32 + SR * LANES + k)] = sr
        l32[np.uint64(b32 + SG * LANES + k)] = sg
        l32[np.uint64(b32 + SB * LANES + k)] = sb
    lanes_composite(l32, b32, l64, b64)


@scalar(inline=True)
def lanes_baked_slot(l32, b32, l64, b64, inc, q, nch, lights, l, point):
    """Add light slot ``q`` of the baked in-scattering (``nch`` channels) to every lane's light,
    weighted by point light ``l``'s ``1/max(d², d2min)`` when ``point`` (vectorised loops, one per
    kind of slot, so no branch is left inside them)."""
    if nch == 1:
        for k in range(LANES):
            v = baked_grey(inc, q, l32[np.uint64(b32 + LX * LANES + k)], l32[np.uint64(b32 + LY * LANES + k)],
                           l32[np.uint64(b32 + LZ * LANES + k)])
            w = point_weight(lights, l, l32[np.uint64(b32 + WX * LANES + k)], l32[np.uint64(b32 + WY * LANES + k)],
                             l32[np.uint64(b32 + WZ * LANES + k)]) if point else np.float32(1.0)
            r = w * v
            l32[np.uint64(b32 + SR * LANES + k)] += r
            l32[np.uint64(b32 + SG * LANES + k)] += r
            l32[np.uint64(b32 + SB * LANES + k)] += r
    else:
        for k in range(LANES):
            vr, vg, vb = baked_rgb(inc, q, l32[np.uint64(b32 + LX * LANES + k)], l32[np.uint64(b32 + LY * LANES + k)],
                                   l32[np.uint64(b32 + LZ * LANES + k)])
            w = point_weight(lights, l, l32[np.uint64(b32 + WX * LANES + k)], l32[np.uint64(b32 + WY * LANES + k)],
                             l32[np.uint64(b32 + WZ * LANES + k)]) if point else np.float32(1.0)
            l32[np.uint64(b32 + SR * LANES + k)] += w * vr
            l32[np.uint64(b32 + SG * LANES + k)] += w * vg
            l32[np.uint64(b32 + SB * LANES + k)] += w * vb


@scalar
def packet_end(march, i0, j0, row1, l64, b64, out_rad, out_alpha):
    """Write the packet's pixels: radiance plus the background seen through, and alpha."""
    W = out_alpha.shape[1]
    bg = march.bg
    for k in range(LANES):
        i = i0 + k % SIDE
        j = j0 + k // SIDE
        if i >= W or j >= row1:
            continue
        T = l64[b64 + TR * LANES + k]
        out_rad[j, i, 0] = l64[b64 + RR * LANES + k] + T * bg[0]
        out_rad[j, i, 1] = l64[b64 + RG * LANES + k] + T * bg[1]
        out_rad[j, i, 2] = l64[b64 + RB * LANES + k] + T * bg[2]
        out_alpha[j, i] = 1.0 - T


def packet_driver(model):
    """The packet driver of ray-cast ``model`` (emission–absorption, single scattering with baked
    lights — which ambient scattering marches as, its ball term in the bake — or diffusion with
    baked lights, its field read beside the bake): rows
    [row0, row1) of an image of a LUT-mode medium, the pixels in :data:`.raycast.TILE`² tiles in
    golden-ratio stride order (as the scalar driver), each tile in 4 × 8 packets; ``l32``/``l64``
    hold :data:`N32`/:data:`N64` lane fields per thread. ``model`` is the closure's constant (one
    compiled driver per model, cached on disk apart); its pass 3, ``sample``, a global bound here
    (:func:`._jit.with_globals`), chosen in Python, so no other model's lane loops are left in the
    compiled body, even dead."""

    def packet_rows(view, march, medium, lights, grid, ambient, diffusion, row0, row1, out_rad, out_alpha, l32, l64,
                    dist):
        H, W = out_alpha.shape
        step, ert = march.step, march.ert
        field, stab, lut_lo, lut_inv = medium.field, march.opacity, medium.lut_lo, medium.lut_inv
        dfield = diffusion.field
        # pass 3 reads world positions (1/d²)
        lit = (model == SINGLE_SCATTERING or model == DIFFUSION or model == DRAFT or model == RECORD
               or model == RECORD_PAIR or model == RECORD_GREY)
        n_rows = (row1 - row0 + TILE - 1) // TILE
        n_cols = (W + TILE - 1) // TILE
        n = n_rows * n_cols
        stride = row_stride(n)
        for q in prange(n):
            tq = (q * stride) % n
            a = tq // n_cols
            b = tq - a * n_cols
            b32 = numba.get_thread_id() * (N32 * LANES)
            b64 = numba.get_thread_id() * (N64 * LANES)
            j_end = min(row0 + (a + 1) * TILE, row1)
            for j0 in range(row0 + a * TILE, j_end, LANES // SIDE):
                for i0 in range(b * TILE, min((b + 1) * TILE, W), SIDE):
                    packet_begin(view, march, i0, j0, j_end, W, H, l32, b32, l64, b64)
                    while True:
                        if lanes_step(l32, b32, l64, b64, step, ert, lit) < LANES and lanes_fix(
                                model, march, medium, lights, grid, ambient, diffusion, l32, b32, l64, b64, dist) == 0:
                            break
                        sample(l32, b32, l64, b64, field, stab, lut_lo, lut_inv, lights, grid, dfield)  # noqa: F821
                    packet_end(march, i0, j0, j_end, l64, b64, out_rad, out_alpha)

    return driver(with_globals(packet_rows, {"sample": PASS3[model]}))


#: Each packet model's pass 3 (:func:`packet_driver`).
PASS3 = {EMISSION_ABSORPTION: lanes_sample_ea, SINGLE_SCATTERING: lanes_sample_lit, DIFFUSION: lanes_sample_diffusion,
         DRAFT: lanes_sample_draft, RECORD: lanes_sample_record, RECORD_PAIR: lanes_sample_record_pair,
         RECORD_GREY: lanes_sample_record_grey}

#: :func:`packet_driver` of each model that runs in packets (compiled on first use).
PACKET_DRIVERS = {model: packet_driver(model) for model in PASS3}


def enabled() -> bool:
    """Whether the packet driver runs where it applies (``PV_AMBIENT_PACKETS=0``: the scalar
    driver everywhere, the fallback)."""
    return os.environ.get("PV_AMBIENT_PACKETS", "1") != "0"


def applies(model, medium, grid) -> bool:
    """Whether ray-cast ``model`` on ``medium`` (a :class:`.records.Medium`) with light grid ``grid``
    runs in packets: emission–absorption, and single scattering, ambient scattering or diffusion whose
    lights' in-scattering is baked (ambient scattering's ball term is in the bake), or a lit record's
    (:mod:`.record`), of a LUT-mode medium."""
    if not enabled() or int(medium.mode) != MODE_LUT:
        return False
    return model in (EMISSION_ABSORPTION, RECORD, RECORD_PAIR, RECORD_GREY) or (
        model in (SINGLE_SCATTERING, AMBIENT_SCATTERING, DIFFUSION) and grid.baked != 0)


def scratch():
    """The lane fields of every thread of Numba's pool: (float32, float64) flat arrays."""
    n = numba.config.NUMBA_NUM_THREADS
    return np.zeros(n * N32 * LANES, np.float32), np.zeros(n * N64 * LANES, np.float64)


#: The last majorant grids' :func:`.majorant.empty_distance` (kept with the grid itself, which a
#: camera move passes again: computed once per transfer function).
_DISTANCES = []


def distances(maj):
    """:func:`.majorant.empty_distance` of majorant grid ``maj`` (int64, its shape), cached for the
    last few grids."""
    for held, dist in _DISTANCES:
        if held is maj:
            return dist
    dist = empty_distance(maj)
    _DISTANCES.insert(0, (maj, dist))
    del _DISTANCES[4:]
    return dist


def raycast_packets(model, view, march, medium, lights, grid, ambient, diffusion, row0, row1, out_rad, out_alpha):
    """Rows [row0, row1) of ray-cast ``model``'s image in packets (:func:`applies` must hold)."""
    l32, l64 = scratch()
    driver_model = SINGLE_SCATTERING if model == AMBIENT_SCATTERING else model  # its ball term is in the bake
    PACKET_DRIVERS[driver_model](view, march, medium, lights, grid, ambient, diffusion, row0, row1, out_rad,
                                 out_alpha, l32, l64, distances(medium.maj))


def raycast_image(model, view, march, medium, lights, grid, ambient, diffusion, row0, row1, out_rad, out_alpha):
    """Rows [row0, row1) of the image with ray-cast ``model`` on the CPU: in packets where they apply
    (:func:`applies`), else one ray at a time (:func:`.raycast.raycast_image`); the scene in the
    records of :mod:`.records`; a draft frame (model :data:`.models.DRAFT`) always in packets."""
    if model == DRAFT or applies(model, medium, grid):
        raycast_packets(model, view, march, medium, lights, grid, ambient, diffusion, row0, row1, out_rad, out_alpha)
    else:
        raycast_image_scalar(model, view, march, medium, lights, grid, ambient, diffusion, row0, row1, out_rad,
                             out_alpha)
