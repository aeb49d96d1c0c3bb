"""The baked in-scattering read at a sample (docs/models.rst, "Baked in-scattering"): the
lights' in-scattered light per unit albedo, baked on the light grid for an isotropic phase function
(:func:`.bake.bake_incident`), interpolated at the sample, with each point light's 1/d² applied
there. The per-pixel march (:func:`.raycast.lit_source`) sums it over the light slots in
:func:`baked_light`; the packet driver (:mod:`.packet`) adds the same terms one slot at a time, in
the same order, across 16 rays. The sample's point and the interpolation are float32; the sums
float64.
"""

from __future__ import annotations

import numpy as np

from ._jit import scalar
from .medium import corner32, corners32, trilinear32_c


@scalar(force_inline=True)
def grid_point(grid, x, y, z):
    """The light grid's index coordinates (float32) of index-space point (x, y, z) (float32): as
    the packet driver computes them, so the per-pixel march equals it."""
    llo, linv = grid.lo, grid.inv_step
    return (np.float32((x - llo[0]) * linv[0]), np.float32((y - llo[1]) * linv[1]),
            np.float32((z - llo[2]) * linv[2]))


@scalar(force_inline=True)
def point_weight(lights, l, wx, wy, wz):
    """``1 / max(d², d2min)`` of point light ``l`` at world point w (float32, as the light's position:
    the sample's world position is float32 already), the 1/d² that :func:`baked_light` applies at the
    sample."""
    lvec = lights.vec
    vx = wx - np.float32(lvec[l, 0])
    vy = wy - np.float32(lvec[l, 1])
    vz = wz - np.float32(lvec[l, 2])
    return np.float32(1.0) / max(vx * vx + vy * vy + vz * vz, np.float32(lights.d2min))


@scalar(force_inline=True)
def baked_grey(inc, q, lx, ly, lz):
    """Channel ``q`` of the baked in-scattering at light-grid point (lx, ly, lz) (float32)."""
    return trilinear32_c(inc, lx, ly, lz, q)


@scalar(force_inline=True)
def baked_rgb(inc, q, lx, ly, lz):
    """Channels ``q … q + 2`` of the baked in-scattering at light-grid point (lx, ly, lz) (float32),
    the corners located once."""
    i0, i1, fx, j0, j1, fy, k0, k1, fz = corners32(inc.shape[0], inc.shape[1], inc.shape[2], lx, ly, lz)
    return (corner32(inc, i0, i1, fx, j0, j1, fy, k0, k1, fz, q),
            corner32(inc, i0, i1, fx, j0, j1, fy, k0, k1, fz, q + 1),
            corner32(inc, i0, i1, fx, j0, j1, fy, k0, k1, fz, q + 2))


@scalar(inline=True)
def baked_light(x, y, z, wx, wy, wz, lights, grid):
    """The in-scattered light (rgb, per unit albedo) from the baked ``grid.inc``: per point light its
    smooth factor ``I_j (T_j p + Φ_j D_j)`` interpolated and divided by ``max(d_j², d2min)`` here, at
    the sample (the 1/d² singularity is not interpolated), plus the directional lights' summed slot.
    ``grid.baked`` is the number of channels per slot (1: grey, 3: rgb); see :func:`.bake.bake_incident`.
    Float32 throughout (:func:`grid_point`, :func:`point_weight`; a sum of a few slots, not an
    accumulating one): the packet driver (:mod:`.packet`) computes the same, one light at a time, in
    lane loops that touch no float64 and so run twice the lanes per instruction."""
    inc = grid.inc
    nch = grid.baked
    lkind = lights.kind
    lx, ly, lz = grid_point(grid, np.float32(x), np.float32(y), np.float32(z))
    px, py, pz = np.float32(wx), np.float32(wy), np.float32(wz)
    sr = np.float32(0.0)
    sg = np.float32(0.0)
    sb = np.float32(0.0)
    slot = 0
    for l in range(lkind.shape[0]):
        if lkind[l] == 0:
            w = point_weight(lights, l, px, py, pz)
            q = slot * nch
            if nch == 1:
                r = w * baked_grey(inc, q, lx, ly, lz)
                sr += r
                sg += r
                sb += r
            else:
                vr, vg, vb = baked_rgb(inc, q, lx, ly, lz)
                sr += w * vr
                sg += w * vg
                sb += w * vb
            slot += 1
    if (slot + 1) * nch <= inc.shape[3]:  # the directional lights' slot
        q = slot * nch
        if nch == 1:
            r = baked_grey(inc, q, lx, ly, lz)
            sr += r
            sg += r
            sb += r
        else:
            vr, vg, vb = baked_rgb(inc, q, lx, ly, lz)
            sr += vr
            sg += vg
            sb += vb
    return sr, sg, sb


#: 1/(4π): an isotropic phase function's value, which turns the diffusion field's φ into radiance
#: (float32: the lane loops that read the field touch no float64).
INV_4PI = np.float32(0.07957747154594767)


@scalar(inline=True)
def diffusion_layout(n):
    """``(per, nch)`` of a diffusion field with ``n`` values per sample: ``per`` values per channel
    (4: φ and the flux F; 1: φ alone) and ``nch`` channels (3 coloured, 1 grey) — n = 12, 4, 3 or 1.

    >>> diffusion_layout(12), diffusion_layout(4), diffusion_layout(3), diffusion_layout(1)
    ((4, 3), (4, 1), (1, 3), (1, 1))
    """
    per = 4 if n % 4 == 0 else 1
    return per, n // per


@scalar(force_inline=True)
def diffusion_grey(field, x, y, z):
    """``max(φ, 0)/4π`` of a grey diffusion field (``field``: (nx, ny, nz, n) on the data samples,
    φ in channel 0) at index-space point (x, y, z) (float32): the multiply-scattered light an
    isotropic phase function scatters, read beside the bake where the field was not folded into it
    (:func:`.bake.bake_incident`); the packet driver reads the same, 16 rays at a time."""
    v = trilinear32_c(field, x, y, z, 0)
    return max(v, np.float32(0.0)) * INV_4PI


@scalar(force_inline=True)
def diffusion_rgb(field, per, x, y, z):
    """:func:`diffusion_grey` per channel of a coloured field (φ of channel c at ``per·c``), the
    corners located once."""
    i0, i1, fx, j0, j1, fy, k0, k1, fz = corners32(field.shape[0], field.shape[1], field.shape[2], x, y, z)
    zero = np.float32(0.0)
    return (max(corner32(field, i0, i1, fx, j0, j1, fy, k0, k1, fz, 0), zero) * INV_4PI,
            max(corner32(field, i0, i1, fx, j0, j1, fy, k0, k1, fz, per), zero) * INV_4PI,
            max(corner32(field, i0, i1, fx, j0, j1, fy, k0, k1, fz, 2 * per), zero) * INV_4PI)


@scalar(force_inline=True)
def diffusion_baked(field, x, y, z):
    """The diffusion field's ``max(φ_c, 0)/4π`` (rgb) at index-space point (x, y, z) for baked lights
    (an isotropic phase function: the radiance has no flux term, so only φ is read); the field's
    layout as :func:`diffusion_layout` (φ at every ``per``-th value)."""
    per, nch = diffusion_layout(field.shape[3])
    px, py, pz = np.float32(x), np.float32(y), np.float32(z)
    if nch == 1:  # one channel: grey
        v = diffusion_grey(field, px, py, pz)
        return v, v, v
    return diffusion_rgb(field, per, px, py, pz)
