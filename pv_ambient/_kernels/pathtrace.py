"""Unbiased volumetric path tracing (the transfer equation of docs/conventions.rst; docs/models.rst ``path_traced``): the per-path scalar
kernel and its CPU driver over image rows.

Estimator (one path per call, RGB throughput ``β``, grey extinction):

1. **Camera ray** through the pixel centre (the quantity every ray-cast model computes, so
   images compare pixel by pixel), clipped to the medium's box.
2. **Free flight** by delta tracking (:mod:`.tracking`): the first real collision has density
   ``σt(x) T(x)``. A primary ray that leaves the medium adds the background ``L_b`` (so its
   expectation is ``T·L_b``); the background is radiance *seen through* the volume, not a
   light (docs/conventions.rst), so a ray that escapes after a scattering event adds nothing.
3. **Emission** at a real collision: ``β·(1 − a)·Le``. Since the collision density is
   ``σt T``, its expectation is ``∫ T σa Le`` with ``σa = (1 − a)σt`` per channel — the
   pbrt/Mitsuba source term (docs/conventions.rst) without a second, stochastic absorb/scatter choice.
4. **Next-event estimation** to every light: ``β·a·E·T_l·p(θ)`` with ``E = I/max(d², d2min)``
   for a point light (the clamp of :func:`.raycast.light_at`) or the directional irradiance,
   ``T_l`` a ratio-tracking estimate along the shadow ray (to the light, or to the box exit for
   a directional light; a point light may lie inside or outside the box) and
   ``cos θ = ω_light · (−ω_ray)`` (propagation directions, docs/conventions.rst).
5. **Scattering**: ``β *= a`` (RGB albedo as a weight, so one path carries all channels),
   a new direction from the phase function by importance sampling (``phase_sample``: the
   weight ``p/pdf`` is exactly 1), and a new free flight from the collision point.
6. **Termination**: after ``rr_depth`` collisions, Russian roulette with survival probability
   ``q = min(max(β), RR_MAX_SURVIVAL)`` (then ``β /= q``); ``max_depth`` collisions at most.
   Without the cap (0.999) a path in a conservative medium (albedo 1: β never drops) would only
   end by leaving the medium, which from inside an optically huge one (σt·L ~ 1e6, camera inside)
   takes ~(σt·L)² collisions: the render never returns. With it, such a path takes ~1000
   collisions after ``rr_depth`` on average, the estimator stays unbiased (β /= q), and nothing
   changes where the albedo is ≤ 0.999 (there max(β) ≤ 0.999 already at every roulette).
   Collision ``n`` adds emission scattered ``n − 1`` times and light scattered ``n`` times, so
   ``max_depth = 1`` is single scattering (NEE at the first collision only) plus the
   emission–absorption term.

Each path also reports whether its primary ray collided (an unbiased estimate of the primary
ray's opacity ``1 − T``). Random numbers: ``rng.uniform(seed, pixel, sample, dim)``, ``dim``
counting the path's draws, so every path is a pure function of (seed, pixel, sample) and the
image does not depend on the thread count.
"""

from __future__ import annotations

import math

from ._jit import driver, prange, scalar
from .geometry import affine_point, affine_vector, camera_ray, ray_box
from .phase import phase_eval, phase_sample
from .raycast import light_at, medium_albedo_emission
from .rng import key
from .tracking import delta_track, draw, ratio_track

#: Ratio tracking along shadow rays switches on Russian roulette below this transmittance.
SHADOW_RR_BELOW = 0.05
#: Largest survival probability of the path's Russian roulette (module docstring, item 6).
RR_MAX_SURVIVAL = 0.999


@scalar
def direct_light_nee(wx, wy, wz, dx, dy, dz, view, medium, lights, k, dim):
    """Σ_l E_l T_l p(θ_l) (rgb) at world point w for a path travelling along d; T_l by ratio tracking.

    Returns ``(r, g, b, dim)``.
    """
    w2i, lo, hi = view.w2i, view.lo, view.hi
    lkind, lvec = lights.kind, lights.vec
    sr = 0.0
    sg = 0.0
    sb = 0.0
    px, py, pz = affine_point(w2i, wx, wy, wz)
    for l in range(lkind.shape[0]):
        er, eg, eb, lx, ly, lz = light_at(l, lights, wx, wy, wz)
        if er <= 0.0 and eg <= 0.0 and eb <= 0.0:
            continue
        # Shadow ray toward the light: to the light itself, or out of the box (directional).
        if lkind[l] == 0:
            vx = lvec[l, 0] - wx
            vy = lvec[l, 1] - wy
            vz = lvec[l, 2] - wz
            dist = math.sqrt(vx * vx + vy * vy + vz * vz)
        else:
            dist = math.inf
        qx, qy, qz = affine_vector(w2i, -lx, -ly, -lz)
        t0, t1 = ray_box(px, py, pz, qx, qy, qz, lo, hi)
        t0 = max(t0, 0.0)
        t1 = min(t1, dist)
        T = 1.0
        if t0 < t1:
            T, dim = ratio_track(px, py, pz, qx, qy, qz, t0, t1, medium, SHADOW_RR_BELOW, k, dim)
        if T > 0.0:
            # Light propagates along (lx, ly, lz) and leaves toward the camera along −d.
            w = T * phase_eval(lights.pkind, lights.g, -(lx * dx + ly * dy + lz * dz))
            sr += er * w
            sg += eg * w
            sb += eb * w
    return sr, sg, sb, dim


@scalar
def trace_path(view, medium, lights, paths, i, j, width, height, pixel, sample):
    """One path sample of pixel (i, j) (see the module docstring); the scene in the records of
    :mod:`.records` (``paths``: background, depths, seed).

    Returns ``(r, g, b, hit)``: the radiance estimate and 1.0 when the primary ray collided.
    """
    cam, w2i, lo, hi = view.cam, view.w2i, view.lo, view.hi
    bg, max_depth, rr_depth, seed = paths.bg, paths.max_depth, paths.rr_depth, paths.seed
    k = key(seed, pixel, sample)
    dim = 0
    ox, oy, oz, dx, dy, dz = camera_ray(cam, i, j, width, height)
    br = 1.0
    bgc = 1.0
    bb = 1.0
    lr = 0.0
    lg = 0.0
    lb = 0.0
    hit = 0.0
    depth = 0
    while True:
        # Free flight through the medium's box.
        px, py, pz = affine_point(w2i, ox, oy, oz)
        qx, qy, qz = affine_vector(w2i, dx, dy, dz)
        t0, t1 = ray_box(px, py, pz, qx, qy, qz, lo, hi)
        t0 = max(t0, 0.0)
        collided = False
        t = t1
        k0 = 0
        k1 = 0
        f = 0.0
        if t0 < t1:
            collided, t, _, k0, k1, f, dim = delta_track(px, py, pz, qx, qy, qz, t0, t1, medium, k, dim)
        if not collided:
            # Escaped: only the primary ray sees the background.
            if depth == 0:
                lr += bg[0]
                lg += bg[1]
                lb += bg[2]
            break
        if depth == 0:
            hit = 1.0
        depth += 1
        x = px + t * qx
        y = py + t * qy
        z = pz + t * qz
        wx = ox + t * dx
        wy = oy + t * dy
        wz = oz + t * dz
        ar, ag, ab, er, eg, eb = medium_albedo_emission(medium, k0, k1, f, x, y, z)
        # Emission: collision density σt·T, so weight σa/σt = 1 − a.
        lr += br * (1.0 - ar) * er
        lg += bgc * (1.0 - ag) * eg
        lb += bb * (1.0 - ab) * eb
        # Scattering weight; nothing more to gather where the medium does not scatter.
        br *= ar
        bgc *= ag
        bb *= ab
        q = max(br, max(bgc, bb))
        if q <= 0.0:
            break
        # Next-event estimation to every light.
        nr, ng, nb, dim = direct_light_nee(wx, wy, wz, dx, dy, dz, view, medium, lights, k, dim)
        lr += br * nr
        lg += bgc * ng
        lb += bb * nb
        if depth >= max_depth:
            break
        # Russian roulette on the throughput after rr_depth collisions.
        q = min(q, RR_MAX_SURVIVAL)
        if depth >= rr_depth and q < 1.0:
            u = draw(k, dim)
            dim += 1
            if u >= q:
                break
            br /= q
            bgc /= q
            bb /= q
        # Sample the scattered direction from the phase function (weight p/pdf = 1).
        u1 = draw(k, dim)
        u2 = draw(k, dim + 1)
        dim += 2
        dx, dy, dz, _ = phase_sample(lights.pkind, lights.g, u1, u2, dx, dy, dz)
        # Renormalise so rounding cannot drift over many bounces.
        inv = 1.0 / math.sqrt(dx * dx + dy * dy + dz * dz)
        dx *= inv
        dy *= inv
        dz *= inv
        ox = wx
        oy = wy
        oz = wz
    return lr, lg, lb, hit


@scalar
def pathtrace_pixel(view, medium, lights, paths, s0, s1, j, i, sum_rad, sum_sq, sum_hit):
    """Add samples ``[s0, s1)`` of pixel (i, j) to the sums, in order (the work of one thread of
    either driver: bitwise the same for any thread count)."""
    H, W = sum_hit.shape
    pixel = j * W + i
    for s in range(s0, s1):
        r, gg, b, h = trace_path(view, medium, lights, paths, i, j, W, H, pixel, s)
        sum_rad[j, i, 0] += r
        sum_rad[j, i, 1] += gg
        sum_rad[j, i, 2] += b
        sum_sq[j, i, 0] += r * r
        sum_sq[j, i, 1] += gg * gg
        sum_sq[j, i, 2] += b * b
        sum_hit[j, i] += h


@driver
def pathtrace_image(view, medium, lights, paths, s0, s1, row0, row1, sum_rad, sum_sq, sum_hit):
    """CPU driver: add samples ``[s0, s1)`` of every pixel in rows ``[row0, row1)`` to the float64
    sums ``sum_rad`` and ``sum_sq`` (H, W, 3: Σx, Σx²) and ``sum_hit`` (H, W); the scene in the
    records of :mod:`.records`."""
    W = sum_hit.shape[1]
    for j in prange(row0, row1):
        for i in range(W):
            pathtrace_pixel(view, medium, lights, paths, s0, s1, j, i, sum_rad, sum_sq, sum_hit)
