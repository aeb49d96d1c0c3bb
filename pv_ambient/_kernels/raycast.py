"""Front-to-back ray marching for every ray-cast model: per-sample source functions and the
march loop (scalar), and their CPU driver.

A camera ray is clipped to the medium's box in sample index space and cut into segments of
world length ``step`` (the last one shorter); each segment is classified at its midpoint and
integrated exactly for a piecewise-constant medium: a segment of extinction σ and length ℓ adds
``T·(1 − e^{−σℓ})·S`` where ``S`` is the model's source per unit extinction, then ``T *= e^{−σℓ}``:

* emission–absorption: ``S = C`` (TF colour; Max's model, σt·C per unit length);
* ambient occlusion (docs/ambient_scattering.rst §5): ``S = C + a·L_amb·e^{−r σ̄}``;
* single scattering: ``S = a·Σ_j E_j T_j p(θ_j) + (1 − a)·Le``;
* ambient scattering (docs/ambient_scattering.rst §4): single scattering plus ``a·Σ_j E_j Φ_j D(θ_j, rσ̄, g, ā)``,

per RGB channel (a: albedo, Le: emission, E_j: I_j/d² or the directional irradiance, T_j and
Φ_j the light's transmittance volumes); ``model`` is one of the ids of :mod:`.models`. Segments
whose block majorant is zero are skipped to the block's exit; marching stops when T falls below
``ert``; with ``jitter`` the segment grid is shifted by a counter-based uniform per pixel.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import ON_GPU, driver, prange, scalar
from .geometry import affine_point, affine_vector, camera_ray, ray_box
from .interp import corner_lerp, locate, trilinear4, trilinear_c
from .majorant import block_at, block_span
from .baked import baked_light, diffusion_baked, diffusion_layout
from .medium import (MODE_GRID, MODE_LUT, corner32, corners32, full_segment, lut_coords, lut_value,
                     step_albedo_emission, step_column, step_lookup, step_opacity, trilinear32, trilinear32_c)
from .models import (AMBIENT_OCCLUSION, AMBIENT_SCATTERING, DIFFUSION, EMISSION_ABSORPTION, RAYCAST_MODELS, RECORD,
                     RECORD_GREY, RECORD_PAIR, SINGLE_SCATTERING)
from .phase import phase_eval, phase_in
from .record import grey_light, pair_light, record_light
from .preint import d_lookup3, d_lookup3_in, tau_coord, tau_coord_in
from .rng import uniform

STREAM_JITTER = 1
INV_4PI_RC = 1.0 / (4.0 * math.pi)


@scalar(inline=True)
def index_ray(w2i, ox, oy, oz, dx, dy, dz):
    """The world ray in sample index space: t stays the world distance along the ray."""
    px, py, pz = affine_point(w2i, ox, oy, oz)
    qx, qy, qz = affine_vector(w2i, dx, dy, dz)
    return px, py, pz, qx, qy, qz


@scalar(inline=True)
def medium_albedo_emission(mode, medium, k0, k1, f, x, y, z):
    """(albedo rgb, emission rgb) at index-space point (x, y, z) of ``medium`` (a :class:`.records.Medium`)
    classified in ``mode`` (``medium.mode``, or the constant of a ray-cast specialisation); (k0, k1, f)
    locate the table entries (:func:`.tracking.sigma_lookup`; unused in GRID mode)."""
    table, aux = medium.table, medium.aux
    if mode == MODE_GRID:
        return (trilinear_c(aux, x, y, z, 0), trilinear_c(aux, x, y, z, 1), trilinear_c(aux, x, y, z, 2),
                trilinear_c(aux, x, y, z, 3), trilinear_c(aux, x, y, z, 4), trilinear_c(aux, x, y, z, 5))
    return (lut_value(table, k0, k1, f, 1), lut_value(table, k0, k1, f, 2), lut_value(table, k0, k1, f, 3),
            lut_value(table, k0, k1, f, 4), lut_value(table, k0, k1, f, 5), lut_value(table, k0, k1, f, 6))


@scalar(inline=True)
def medium_sigma(mode, medium, x, y, z):
    """(σt, s) at index-space point (x, y, z) of ``medium`` classified in ``mode`` (as
    :func:`medium_albedo_emission`): the extinction and the interpolated scalar (σt itself in GRID mode),
    from which :func:`medium_optics` classifies the rest. Why not the located table entries (k0, k1, f):
    the march holds one value, not three, across a lit model's loop over the lights, and a GPU thread's
    registers are what that loop is short of. The field is read in float32 (:func:`.medium.trilinear32`)."""
    s = np.float64(trilinear32(medium.field, x, y, z))
    if mode == MODE_GRID:
        return s, s
    k0, k1, f = lut_coords(s, medium.lut_lo, medium.lut_inv, medium.table.shape[0])
    return lut_value(medium.table, k0, k1, f, 0), s


@scalar(inline=True)
def medium_optics(mode, medium, s, x, y, z):
    """(colour rgb, albedo rgb, emission rgb) at the point where :func:`medium_sigma` gave the scalar
    ``s``: the table entries located again from ``s`` (LUT mode) or ``aux`` interpolated at (x, y, z)
    (GRID mode, where the colour is the emission) — the values of :func:`medium_albedo_emission`, and
    the colour (table columns 7–9); ``aux`` in float32. What a caller leaves unused is not computed (inlined)."""
    if mode == MODE_GRID:
        aux = medium.aux
        i0, i1, fx, j0, j1, fy, k0, k1, fz = corners32(aux.shape[0], aux.shape[1], aux.shape[2], x, y, z)
        er = corner32(aux, i0, i1, fx, j0, j1, fy, k0, k1, fz, 3)
        eg = corner32(aux, i0, i1, fx, j0, j1, fy, k0, k1, fz, 4)
        eb = corner32(aux, i0, i1, fx, j0, j1, fy, k0, k1, fz, 5)
        return (er, eg, eb, corner32(aux, i0, i1, fx, j0, j1, fy, k0, k1, fz, 0),
                corner32(aux, i0, i1, fx, j0, j1, fy, k0, k1, fz, 1), corner32(aux, i0, i1, fx, j0, j1, fy, k0, k1, fz, 2),
                er, eg, eb)
    table = medium.table
    k0, k1, f = lut_coords(s, medium.lut_lo, medium.lut_inv, table.shape[0])
    return (lut_value(table, k0, k1, f, 7), lut_value(table, k0, k1, f, 8), lut_value(table, k0, k1, f, 9),
            lut_value(table, k0, k1, f, 1), lut_value(table, k0, k1, f, 2), lut_value(table, k0, k1, f, 3),
            lut_value(table, k0, k1, f, 4), lut_value(table, k0, k1, f, 5), lut_value(table, k0, k1, f, 6))


@scalar(force_inline=True)
def light_at(l, lights, wx, wy, wz):
    """Unoccluded irradiance (rgb) of light ``l`` of ``lights`` (a :class:`.records.Lights`) at
    world point w and its propagation direction."""
    lkind, lvec, lpow, d2min = lights.kind, lights.vec, lights.power, lights.d2min
    if lkind[l] == 0:  # point light: I/d², direction from the light to w
        vx = wx - lvec[l, 0]
        vy = wy - lvec[l, 1]
        vz = wz - lvec[l, 2]
        d2 = vx * vx + vy * vy + vz * vz
        if d2 > 0.0:
            inv = 1.0 / math.sqrt(d2)
        else:
            vx, vy, vz, inv = 0.0, 0.0, 1.0, 1.0
        # Clamp d² at d2min: no sample resolves the 1/d² singularity at the light
        # (docs/conventions.rst, "Lights"). One reciprocal: a float64 division inlines a slow path.
        w = 1.0 / max(d2, d2min)
        return lpow[l, 0] * w, lpow[l, 1] * w, lpow[l, 2] * w, vx * inv, vy * inv, vz * inv
    return lpow[l, 0], lpow[l, 1], lpow[l, 2], lvec[l, 0], lvec[l, 1], lvec[l, 2]


@scalar(force_inline=True)
def direct_light(x, y, z, wx, wy, wz, dx, dy, dz, lights, grid):
    """Σ_j E_j T_j p(θ_j) (rgb): in-scattered direct light toward the camera (−d); T_j from the
    optical depth on the light grid (a :class:`.records.LightGrid`)."""
    sr = 0.0
    sg = 0.0
    sb = 0.0
    for l in range(lights.kind.shape[0]):
        er, eg, eb = direct_light_one(l, x, y, z, wx, wy, wz, dx, dy, dz, lights, grid)
        sr += er
        sg += eg
        sb += eb
    return sr, sg, sb


@scalar(force_inline=True)
def direct_light_one(l, x, y, z, wx, wy, wz, dx, dy, dz, lights, grid):
    """Light ``l``'s term of :func:`direct_light`: ``E_l T_l p(θ_l)`` (rgb). On the GPU the
    transmittance and the phase function's square root and division are float32
    (:data:`._jit.ON_GPU`, :func:`.phase.phase_in`): in float64 the square root and the division call
    slow paths, and the ``exp`` holds its polynomial's constants, in registers that every thread of
    an unbaked lit kernel pays for."""
    er, eg, eb, ox, oy, oz = light_at(l, lights, wx, wy, wz)
    return direct_light_with(l, er, eg, eb, ox, oy, oz, x, y, z, dx, dy, dz, lights, grid)


@scalar(force_inline=True)
def direct_light_with(l, er, eg, eb, ox, oy, oz, x, y, z, dx, dy, dz, lights, grid):
    """:func:`direct_light_one` with light ``l``'s irradiance (er, eg, eb) and direction (ox, oy, oz)
    at the point given (:func:`light_at`)."""
    llo, linv, tau = grid.lo, grid.inv_step, grid.tau
    lx, ly, lz = (x - llo[0]) * linv[0], (y - llo[1]) * linv[1], (z - llo[2]) * linv[2]
    c = -(ox * dx + oy * dy + oz * dz)
    if ON_GPU:
        T = np.float64(math.exp(-trilinear32_c(tau, lx, ly, lz, l)))
        p = np.float64(phase_in(np.float32, lights.pkind, lights.g, c))
    else:
        T = math.exp(-trilinear_c(tau, lx, ly, lz, l))
        p = phase_eval(lights.pkind, lights.g, c)
    w = T * p
    return er * w, eg * w, eb * w


@scalar(force_inline=True)
def direct_ambient_light(x, y, z, wx, wy, wz, dx, dy, dz, w2i, lights, grid, ambient):
    """Unbaked ambient scattering's in-scattered light (rgb): :func:`direct_light` plus
    Σ_j E_j Φ_j D(θ_j, r σ̄, ā), light scattered at least once inside the ball (docs/ambient_scattering.rst
    §4).

    Φ_j is read at the ball's entry point ``x − s·ω_j`` (s = r, or the distance to a point light
    when that is shorter) from the front optical depth ``grid.phi``: one component per light
    (grey, Beer–Lambert mode: the optical depth itself) or three per light (per channel, tube mode).

    One loop over the lights for both terms: each light's irradiance and direction (:func:`light_at`)
    are computed once, and a GPU thread holds one loop's state, not two loops' in turn. The CPU sums
    the two terms apart and adds them at the end (the order of its additions, so its images, as when
    they were two loops); the GPU adds both into one sum (:data:`._jit.ON_GPU`): three register
    pairs fewer across the loop. There the τ coordinate and the ball term are float32
    (:func:`ambient_light_with`)."""
    bs, abr, abg, abb = trilinear4(ambient.ball, x, y, z)
    if ON_GPU:
        it, tt = tau_coord_in(np.float32, ambient.D.shape[1], ambient.tau_lo_log, ambient.tau_dlog, ambient.radius * bs)
    else:
        it, tt = tau_coord(ambient.D.shape[1], ambient.tau_lo_log, ambient.tau_dlog, ambient.radius * bs)
    sr = 0.0
    sg = 0.0
    sb = 0.0
    mr = 0.0
    mg = 0.0
    mb = 0.0
    for l in range(lights.kind.shape[0]):
        er, eg, eb, ox, oy, oz = light_at(l, lights, wx, wy, wz)
        qr, qg, qb = direct_light_with(l, er, eg, eb, ox, oy, oz, x, y, z, dx, dy, dz, lights, grid)
        pr, pg, pb = ambient_light_with(l, er, eg, eb, ox, oy, oz, ball_entry(l, lights, ambient.radius, wx, wy, wz),
                                        x, y, z, dx, dy, dz, w2i, lights, grid, ambient, it, tt, abr, abg, abb)
        if ON_GPU:
            sr += qr + pr
            sg += qg + pg
            sb += qb + pb
        else:
            sr += qr
            sg += qg
            sb += qb
            mr += pr
            mg += pg
            mb += pb
    return sr + mr, sg + mg, sb + mb


@scalar(force_inline=True)
def ball_entry(l, lights, radius, wx, wy, wz):
    """How far back toward light ``l`` the ball around world point w is entered: its radius, or the
    distance to a point light when that is shorter (a float32 square root on the GPU: a float64 one
    calls a slow path there, and the entry point is read in float32)."""
    if lights.kind[l] == 0:
        lvec = lights.vec
        vx = wx - lvec[l, 0]
        vy = wy - lvec[l, 1]
        vz = wz - lvec[l, 2]
        if ON_GPU:
            return min(radius, np.float64(math.sqrt(np.float32(vx * vx + vy * vy + vz * vz))))
        return min(radius, math.sqrt(vx * vx + vy * vy + vz * vz))
    return radius


@scalar(force_inline=True)
def ambient_light_with(l, er, eg, eb, ox, oy, oz, s, x, y, z, dx, dy, dz, w2i, lights, grid, ambient, it, tt, abr,
                       abg, abb):
    """Light ``l``'s term ``E_l Φ_l D(θ_l, ·)`` (rgb) of :func:`direct_ambient_light`, D's τ coordinate
    located as ``(it, tt)``, with the light's irradiance (er, eg, eb) and direction (ox, oy, oz) at
    the point (:func:`light_at`) and the ball's entry distance ``s`` (:func:`ball_entry`) given: a
    caller that has them (the bake, the ray cast's loop over the lights) computes them once.

    On the GPU (:data:`._jit.ON_GPU`) the front optical depth is interpolated, and its ``exp`` and the
    D lookup (:func:`.preint.d_lookup3_in`) computed, in float32, as :func:`direct_light_one`'s
    transmittance: ``phi`` and D are float32 tables, and the float64 ``exp``, ``acos`` and divisions
    are long sequences whose registers every thread of the unbaked kernel holds."""
    llo, linv, phi = grid.lo, grid.inv_step, grid.phi
    D, a_nodes = ambient.D, ambient.a_nodes
    nch = phi.shape[3] // lights.kind.shape[0]
    qx, qy, qz = affine_vector(w2i, ox, oy, oz)
    lx = (x - s * qx - llo[0]) * linv[0]
    ly = (y - s * qy - llo[1]) * linv[1]
    lz = (z - s * qz - llo[2]) * linv[2]
    c = -(ox * dx + oy * dy + oz * dz)
    if ON_GPU:
        i0, i1, fx, j0, j1, fy, k0, k1, fz = corners32(phi.shape[0], phi.shape[1], phi.shape[2], lx, ly, lz)
        fr = np.float64(math.exp(-corner32(phi, i0, i1, fx, j0, j1, fy, k0, k1, fz, nch * l)))
        fg = fr
        fb = fr
        if nch != 1:
            fg = np.float64(math.exp(-corner32(phi, i0, i1, fx, j0, j1, fy, k0, k1, fz, 3 * l + 1)))
            fb = np.float64(math.exp(-corner32(phi, i0, i1, fx, j0, j1, fy, k0, k1, fz, 3 * l + 2)))
        dr, dg, db = d_lookup3_in(np.float32, D, a_nodes, it, tt, c, abr, abg, abb)
    else:
        i0, i1, fx, j0, j1, fy, k0, k1, fz = locate(phi, lx, ly, lz)  # once for every channel
        fr = math.exp(-corner_lerp(phi, i0, i1, fx, j0, j1, fy, k0, k1, fz, nch * l))
        fg = fr
        fb = fr
        if nch != 1:
            fg = math.exp(-corner_lerp(phi, i0, i1, fx, j0, j1, fy, k0, k1, fz, 3 * l + 1))
            fb = math.exp(-corner_lerp(phi, i0, i1, fx, j0, j1, fy, k0, k1, fz, 3 * l + 2))
        dr, dg, db = d_lookup3(D, a_nodes, it, tt, c, abr, abg, abb)
    return er * fr * dr, eg * fg * dg, eb * fb * db


@scalar(force_inline=True)
def diffusion_light(diff, x, y, z, dx, dy, dz, g):
    """(φ_c + 3g F_c·ω_o)⁺/(4π) per channel (rgb): in-scattered radiance of the multiply-scattered
    light from the diffusion solve (docs/diffusion.rst), ω_o = −d toward the camera. ``diff`` is
    (nx, ny, nz, 12): (φ, Fx, Fy, Fz) per channel at the data samples, F in world components; or
    (nx, ny, nz, 4) when the three channels are equal (grey albedo and white lights); or, for an
    isotropic phase function (g = 0: the flux term vanishes), φ alone: (nx, ny, nz, 3) or (…, 1).
    Read in float32, as :func:`.baked.diffusion_baked` (:func:`.medium.corners32`)."""
    i0, i1, fx, j0, j1, fy, k0, k1, fz = corners32(diff.shape[0], diff.shape[1], diff.shape[2], x, y, z)
    out0 = 0.0
    out1 = 0.0
    out2 = 0.0
    per, nch = diffusion_layout(diff.shape[3])
    for c in range(nch):
        q = per * c
        v = corner32(diff, i0, i1, fx, j0, j1, fy, k0, k1, fz, q)
        if g != 0.0 and per == 4:  # the flux term (none in an isotropic phase function's radiance)
            v -= 3.0 * g * (corner32(diff, i0, i1, fx, j0, j1, fy, k0, k1, fz, q + 1) * dx
                            + corner32(diff, i0, i1, fx, j0, j1, fy, k0, k1, fz, q + 2) * dy
                            + corner32(diff, i0, i1, fx, j0, j1, fy, k0, k1, fz, q + 3) * dz)
        v = max(v, 0.0) * INV_4PI_RC
        if c == 0:
            out0 = v
            out1 = v
            out2 = v
        elif c == 1:
            out1 = v
        else:
            out2 = v
    return out0, out1, out2


@scalar(inline=True)
def lit_source(model, baked, x, y, z, wx, wy, wz, dx, dy, dz, w2i, lights, grid, ambient, diffusion):
    """The in-scattered light per unit albedo (rgb) of lit ray-cast ``model`` at index-space point
    (x, y, z) = world point w, seen along d: the baked (``baked`` true: ``grid.inc`` holds it) or
    per-light direct light, plus ambient scattering's ball term or diffusion's multiply-scattered
    light (module docstring). The march's source there is ``a·this + (1 − a)·Le``; :mod:`.residual`
    evaluates the same function at a path's first collision."""
    if baked:  # isotropic phase: the lights' in-scattering, baked
        lr, lg, lb = baked_light(x, y, z, wx, wy, wz, lights, grid)
    elif model == AMBIENT_SCATTERING:
        return direct_ambient_light(x, y, z, wx, wy, wz, dx, dy, dz, w2i, lights, grid, ambient)
    else:
        lr, lg, lb = direct_light(x, y, z, wx, wy, wz, dx, dy, dz, lights, grid)
    if model == DIFFUSION:
        mr, mg, mb = diffusion_light(diffusion.field, x, y, z, dx, dy, dz, diffusion.g)
        lr += mr
        lg += mg
        lb += mb
    return lr, lg, lb


@scalar(force_inline=True)
def table_source(model, stab, q0, fq, x, y, z, wx, wy, wz, lights, grid, ambient, diffusion):
    """The source per unit extinction (rgb) of a table TF's sample at ``(q0, fq)`` of the step-corrected
    table ``stab``: the colour for emission–absorption, :func:`occlusion_table_source` for ambient
    occlusion, else baked single scattering's ``a·L + (1 − a)·Le`` (the light first: the albedo and
    emission are not held across its loop over the slots), with diffusion's field beside the bake
    for diffusion, or the light of a lit record (:data:`.models.RECORD`, :data:`.models.RECORD_PAIR`,
    :data:`.models.RECORD_GREY`).
    The per-pixel march, the CUDA kernels and the packet driver's scalar pass share it."""
    if model == EMISSION_ABSORPTION:
        return step_column(stab, q0, fq, 1), step_column(stab, q0, fq, 2), step_column(stab, q0, fq, 3)
    if model == AMBIENT_OCCLUSION:
        return occlusion_table_source(stab, q0, fq, x, y, z, ambient)
    if model == RECORD:  # the light from the lit record, diffusion.field (light 0 of lights: its reference)
        lr, lg, lb = record_light(diffusion.field, lights, x, y, z, wx, wy, wz)
        return lit_table_source(stab, q0, fq, lr, lg, lb)
    if model == RECORD_PAIR:
        lr, lg, lb = pair_light(diffusion.field, lights, x, y, z, wx, wy, wz)
        return lit_table_source(stab, q0, fq, lr, lg, lb)
    if model == RECORD_GREY:
        lr, lg, lb = grey_light(diffusion.field, lights, x, y, z, wx, wy, wz)
        return lit_table_source(stab, q0, fq, lr, lg, lb)
    lr, lg, lb = baked_light(x, y, z, wx, wy, wz, lights, grid)
    if model == DIFFUSION:
        mr, mg, mb = diffusion_baked(diffusion.field, x, y, z)
        lr += mr
        lg += mg
        lb += mb
    return lit_table_source(stab, q0, fq, lr, lg, lb)


@scalar(force_inline=True)
def lit_table_source(stab, q0, fq, lr, lg, lb):
    """A lit sample's source ``a·L + (1 − a)·Le`` at the step-corrected table's ``(q0, fq)`` with
    in-scattered light L (rgb, per unit albedo), float32 (:func:`table_source`; the packet driver's
    lane loop that computes it touches no float64)."""
    one = np.float32(1.0)
    ar, ag, ab, er, eg, eb = step_albedo_emission(stab, q0, fq)
    return (ar * np.float32(lr) + (one - ar) * er, ag * np.float32(lg) + (one - ag) * eg,
            ab * np.float32(lb) + (one - ab) * eb)


@scalar(force_inline=True)
def occlusion_table_source(stab, q0, fq, x, y, z, ambient):
    """:func:`table_source` of ambient occlusion: the colour plus the albedo times the ambient
    radiance seen through the ball's mean optical depth, ``amb·e^{−r σ̄}`` (docs/models.rst)."""
    occ = ambient.amb * math.exp(-ambient.radius * trilinear_c(ambient.ball, x, y, z, 0))
    ar, ag, ab, _er, _eg, _eb = step_albedo_emission(stab, q0, fq)
    return (step_column(stab, q0, fq, 1) + ar * occ, step_column(stab, q0, fq, 2) + ag * occ,
            step_column(stab, q0, fq, 3) + ab * occ)


@scalar
def march_pixel(model, baked, mode, view, march, medium, lights, grid, ambient, diffusion, i, j, W, H, t_end):
    """(r, g, b, T): radiance gathered along pixel (i, j)'s ray with ray-cast ``model`` (module
    docstring) and the ray's remaining transmittance. ``baked``: whether the lights' in-scattering
    is read from ``grid.inc``; ``mode``: the medium's classification mode (``medium.mode``). The ray
    stops at world distance ``t_end`` (opaque geometry; ``inf`` for none). The background is not
    added. The scene comes in the records of :mod:`.records`.

    A CUDA kernel passes ``model``, ``baked`` and ``mode`` as constants (:data:`SPECIALISATIONS`), a
    CPU driver ``model`` (:func:`raycast_driver`): Numba compiles this function once per set of
    constants (literal argument types) and drops the other models' and modes' branches from the
    sample loop."""
    cam, w2i, lo, hi = view.cam, view.w2i, view.lo, view.hi
    step, jitter, seed, ert = march.step, march.jitter, march.seed, march.ert
    maj, block = medium.maj, medium.block
    radius, ball, amb = ambient.radius, ambient.ball, ambient.amb
    ox, oy, oz, dx, dy, dz = camera_ray(cam, i, j, W, H)
    px, py, pz, qx, qy, qz = index_ray(w2i, ox, oy, oz, dx, dy, dz)
    t0, t1 = ray_box(px, py, pz, qx, qy, qz, lo, hi)
    t0 = max(t0, 0.0)
    t1 = min(t1, t_end)
    r = 0.0
    gg = 0.0
    b = 0.0
    T = 1.0
    if t0 < t1:
        offset = uniform(seed, STREAM_JITTER, j * W + i, 0) if jitter else 0.0
        t = t0
        tnext = t0 + (1.0 - offset) * step
        t_block = -1.0  # exit of the current non-empty block: no block lookups before it
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
                t_block = tex
            if mode == MODE_LUT and (model == EMISSION_ABSORPTION or model == AMBIENT_OCCLUSION or model == RECORD
                                     or model == RECORD_PAIR or model == RECORD_GREY or (baked and (model == SINGLE_SCATTERING or model
                                                                            == AMBIENT_SCATTERING or model == DIFFUSION))):
                # a table TF's emission–absorption, ambient occlusion or baked lit sample (ambient
                # scattering folds into the bake, diffusion's field is read beside it): the
                # step-corrected table, as the packet driver. On a GPU this path keeps a warp's rays
                # together; the general one below ran 1.2 of 32 threads per warp (docs/performance.rst, "GPU")
                q0, fq = step_lookup(medium.field, march.opacity, medium.lut_lo, medium.lut_inv, x, y, z)
                a = step_opacity(march.opacity, q0, fq, full_segment(t, te, step), te - t)
                if a > 0.0:
                    sr, sg, sb = table_source(model, march.opacity, q0, fq, x, y, z, ox + tm * dx, oy + tm * dy,
                                              oz + tm * dz, lights, grid, ambient, diffusion)
                    w = T * a
                    r += w * sr
                    gg += w * sg
                    b += w * sb
                    T -= w
                    if T < ert:
                        break
                t = te
                tnext = te + step
                continue
            # σt and the scalar first; the rest of the classification where the source needs it
            # (:func:`medium_sigma`): nothing classified is held across the ball's or the lights' lookups
            sig, s = medium_sigma(mode, medium, x, y, z)
            if sig > 0.0:
                if model == EMISSION_ABSORPTION:
                    sr, sg, sb, _, _, _, _, _, _ = medium_optics(mode, medium, s, x, y, z)
                elif model == AMBIENT_OCCLUSION:
                    occ = amb * math.exp(-radius * trilinear32_c(ball, x, y, z, 0))
                    cr, cg, cb, ar, ag, ab, _, _, _ = medium_optics(mode, medium, s, x, y, z)
                    sr = cr + ar * occ
                    sg = cg + ag * occ
                    sb = cb + ab * occ
                else:
                    # the light first: the albedo and emission are not held across its loop over lights
                    lr, lg, lb = lit_source(model, baked, x, y, z, ox + tm * dx, oy + tm * dy, oz + tm * dz, dx, dy, dz,
                                            w2i, lights, grid, ambient, diffusion)
                    _, _, _, ar, ag, ab, er, eg, eb = medium_optics(mode, medium, s, x, y, z)
                    sr = ar * lr + (1.0 - ar) * er
                    sg = ag * lg + (1.0 - ag) * eg
                    sb = ab * lb + (1.0 - ab) * eb
                e = math.exp(-sig * (te - t))
                w = T * (1.0 - e)
                r += w * sr
                gg += w * sg
                b += w * sb
                T *= e
                if T < ert:
                    break
            t = te
            tnext = te + step
    return r, gg, b, T


@scalar
def raycast_pixel(model, baked, mode, view, march, medium, lights, grid, ambient, diffusion, j, i, out_rad, out_alpha):
    """Render pixel (i, j) into ``out_rad``/``out_alpha`` (the work of one thread of either
    driver: :func:`raycast_driver`'s loop, :func:`pv_ambient._kernels.cuda.raycast_kernel`'s
    thread); ``march.t_end`` is (H, W) (each pixel's ray end) or (1, 1) (one for all)."""
    H, W = out_alpha.shape
    t_end, bg = march.t_end, march.bg
    per_pixel = t_end.shape[0] == H and t_end.shape[1] == W
    te = t_end[j, i] if per_pixel else t_end[0, 0]
    r, gg, b, T = march_pixel(model, baked, mode, view, march, medium, lights, grid, ambient, diffusion, i, j, W, H, te)
    out_rad[j, i, 0] = r + T * bg[0]
    out_rad[j, i, 1] = gg + T * bg[1]
    out_rad[j, i, 2] = b + T * bg[2]
    out_alpha[j, i] = 1.0 - T


@scalar
def row_stride(n):
    """A stride coprime with ``n`` near ``0.618·n``: indices ``(q·stride) mod n`` for q = 0 … n−1 visit
    every index once, and any run of consecutive q spreads over the whole range."""
    s = max(1, int(0.6180339887498949 * n))
    while True:
        a = s
        b = n
        while b:
            a, b = b, a % b
        if a == 1:
            return s
        s += 1


#: The CPU driver's pixel tiles: ``TILE`` × ``TILE`` pixels marched one after the other by one thread.
#: Why: neighbouring rays in both image directions read the same cache lines of the volume, so a
#: tile reads each line from memory about once where a row of pixels reads it again for every row.
#: Which pixel a thread renders does not change its value.
TILE = 16


#: The ray cast's specialisations, ``(model id, baked, medium mode)``: each compiles to a CUDA kernel
#: (:mod:`.cuda`) of its own, the model, whether the lights' in-scattering is baked and how
#: the medium is classified (:data:`.medium.MODE_LUT` or :data:`.medium.MODE_GRID`) fixed when it is
#: compiled — no branch over models or modes is left in the sample loop, and a kernel keeps in
#: registers only what its model reads (docs/architecture.rst, "One kernel per model"). Ambient
#: scattering with baked lights marches as baked single scattering (its ball term is in the bake). The
#: CPU drivers fix the model only (:func:`raycast_driver`).
SPECIALISATIONS = tuple((model, baked, mode) for model, baked in (
    (EMISSION_ABSORPTION, 0), (AMBIENT_OCCLUSION, 0), (SINGLE_SCATTERING, 0), (SINGLE_SCATTERING, 1),
    (AMBIENT_SCATTERING, 0), (DIFFUSION, 0), (DIFFUSION, 1)) for mode in (MODE_LUT, MODE_GRID))


def specialisation(model, baked, mode):
    """The :data:`SPECIALISATIONS` entry that renders ray-cast ``model`` with ``baked`` (the light
    grid's ``baked`` field: non-zero when the lights' in-scattering is baked) on a medium of
    classification ``mode``.

    >>> specialisation(AMBIENT_SCATTERING, 3, MODE_LUT), specialisation(EMISSION_ABSORPTION, 1, MODE_GRID)
    ((2, 1, 0), (0, 0, 1))
    """
    baked = int(bool(baked) and model in (SINGLE_SCATTERING, AMBIENT_SCATTERING, DIFFUSION))
    if baked and model == AMBIENT_SCATTERING:
        model = SINGLE_SCATTERING
    return model, baked, int(mode)


def raycast_driver(model):
    """The CPU driver of ray-cast ``model``: rows [row0, row1) of the image, one
    :func:`raycast_pixel` per pixel, the scene in the records of :mod:`.records`. The pixels are
    visited in :data:`TILE`² tiles (cache locality), the tiles in a golden-ratio stride order
    (:func:`row_stride`): ``prange`` hands each thread one contiguous run of iterations, which would
    otherwise be one band of the image (all of the volume, or none of it).

    ``model`` is the closure's constant: Numba compiles (and caches on disk, keyed by it) one driver
    per model. Whether the lights are baked and the medium's mode stay run-time values on the CPU:
    each constant more would double the drivers a user waits to compile, and a CPU thread has no
    register file that every thread of a launch pays for (docs/architecture.rst, "One kernel per
    model"). The CUDA kernels fix all three (:data:`SPECIALISATIONS`)."""

    def raycast_rows(view, march, medium, lights, grid, ambient, diffusion, row0, row1, out_rad, out_alpha):
        baked = 1 if grid.baked != 0 else 0
        mode = medium.mode
        W = out_alpha.shape[1]
        n_rows = (row1 - row0 + TILE - 1) // TILE
        n_cols = (W + TILE - 1) // TILE
        n = n_rows * n_cols
        stride = row_stride(n)
        for q in prange(n):
            t = (q * stride) % n
            a = t // n_cols
            b = t - a * n_cols
            for j in range(row0 + a * TILE, min(row0 + (a + 1) * TILE, row1)):
                for i in range(b * TILE, min((b + 1) * TILE, W)):
                    raycast_pixel(model, baked, mode, view, march, medium, lights, grid, ambient, diffusion, j, i,
                                  out_rad, out_alpha)

    return driver(raycast_rows)


#: :func:`raycast_driver` of every ray-cast model (compiled on first use).
RAYCAST_DRIVERS = {model: raycast_driver(model) for model in RAYCAST_MODELS + (RECORD, RECORD_PAIR, RECORD_GREY)}


def raycast_image(model, view, march, medium, lights, grid, ambient, diffusion, row0, row1, out_rad, out_alpha):
    """Rows [row0, row1) of the image with ray-cast ``model`` on the CPU, one ray at a time: the driver
    of its model, the scene in the records of :mod:`.records`. :func:`.packet.raycast_image` runs the
    packet driver instead where it applies."""
    RAYCAST_DRIVERS[model](view, march, medium, lights, grid, ambient, diffusion, row0, row1, out_rad, out_alpha)
