"""Unbiased volumetric path tracing (docs/path_tracer.rst): the per-path scalar kernel and its CPU
driver over image rows. Its expectation is the exact solution of the transfer equation of
docs/conventions.rst; every other model is measured against it.

Estimator (one path per call, RGB throughput ``β``, grey extinction):

1. **Camera ray** through the pixel centre (the ray every ray-cast model integrates, so images
   compare pixel by pixel), clipped to the medium's box.
2. **Free flight** by delta tracking (:mod:`.tracking`): the first real collision has density
   ``σt(x) T(x)``. A primary ray that leaves the medium adds the background ``L_b`` (so its
   expectation is ``T·L_b``); the background is radiance *seen through* the volume, not a
   light (docs/conventions.rst), so a ray that escapes after a scattering event adds nothing.
3. **Emission** at a real collision: ``β·(1 − a)·Le``. Since the collision density is
   ``σt T``, its expectation is ``∫ T σa Le`` with ``σa = (1 − a)σt`` per channel — the
   pbrt/Mitsuba source term (docs/conventions.rst) without a second, stochastic absorb/scatter choice.
4. **Next-event estimation** to every light (:mod:`.pathtrace_nee`): ``β·a·E·T_l·p(θ)``, ``T_l``
   by ratio tracking along the shadow ray; with ``paths.equiangular`` a point light's term is also
   sampled by equiangular distances on the segment, the two combined by the balance heuristic.
5. **Scattering**: ``β *= a`` (RGB albedo as a weight, so one path carries all channels),
   a new direction (:func:`.pathtrace_near.scatter_direction`: from the phase function by
   importance sampling, weight ``p/pdf`` exactly 1, or near a point light from a mixture aimed at
   it), and a new free flight from the collision point.
6. **Termination**: after ``rr_depth`` collisions, Russian roulette with survival probability
   ``q = min(max(β)/w, RR_MAX_SURVIVAL)`` (then ``β /= q``); ``max_depth`` collisions at most.
   ``w`` is the product of the path's direction weights ``p(θ)/pdf`` (1 unless directions were
   drawn about a point light). Why ``/w``: a direction aimed at a light on purpose carries a small
   weight, and a roulette on ``β`` alone would end such paths and give the survivors a weight near
   1 right beside the light — fireflies. Near a point light ``max(β)/w`` is boosted
   (:func:`.pathtrace_near.rr_boost`). Any ``q`` in (0, 1] keeps the estimator unbiased.
   Collision ``n`` adds emission scattered ``n − 1`` times and light scattered ``n`` times, so
   ``max_depth = 1`` is single scattering (NEE at the first collision only) plus the
   emission–absorption term.
7. **Splitting near a point light** (:func:`.pathtrace_near.split_count`): a path that reaches a
   light's neighbourhood with much of its throughput left continues as several copies, each with
   its own random numbers (``key(k, copy + 1, depth)``); a copy may split once more, a copy of a
   copy not.

Steps 4–7 sample point lights inside the medium only within ``paths.eq_radius`` of one; elsewhere
they draw no random number, so scenes without such a light render bitwise as without them
(docs/path_tracer.rst, "Point lights inside the medium").

Each path also reports whether its primary ray collided (an unbiased estimate of the primary
ray's opacity ``1 − T``). Random numbers: ``rng.uniform(seed, pixel, sample, dim)``, ``dim``
counting the path's draws, so every path is a pure function of (seed, pixel, sample) and the
image does not depend on the thread count (docs/path_tracer.rst, "Random numbers and
reproducibility").
"""

from __future__ import annotations

import math

from ._jit import driver, prange, scalar
from .geometry import affine_point, affine_vector, camera_ray, ray_box
from .pathtrace_near import rr_boost, scatter_direction, split_count
from .pathtrace_nee import direct_light_nee, equiangular_nee
from .raycast import medium_albedo_emission, row_stride
from .rng import key
from .tracking import delta_track, draw

#: Largest survival probability of the path's Russian roulette (step 6). Why: in a conservative
#: medium (albedo 1, β never drops) a path would otherwise end only by leaving the medium, which
#: from inside an optically huge one (σt·L ~ 1e6) takes ~(σt·L)² collisions and the render never
#: returns; with the cap it ends ~1000 collisions after ``rr_depth`` on average, still unbiased
#: (β /= q), and nothing changes where the albedo is ≤ 0.999 (docs/path_tracer.rst, "One path").
RR_MAX_SURVIVAL = 0.999


@scalar
def trace_path(view, medium, lights, paths, i, j, width, height, pixel, sample):
    """One path sample of pixel (i, j) (see the module docstring); the scene in the records of
    :mod:`.records` (``paths``: background, depths, seed).

    Returns ``(r, g, b, hit)``: the radiance estimate and 1.0 when the primary ray collided.
    """
    r, g, b, hit, _, _, _, _ = trace_path_first(view, medium, lights, paths, i, j, width, height, pixel, sample)
    return r, g, b, hit


@scalar
def walk(view, medium, lights, paths, k, dim, ox, oy, oz, dx, dy, dz, br, bgc, bb, wdir, depth, sig, scatter_first,
         can_split):
    """The transport loop of :func:`trace_path_first` from ray ``o + t d`` with throughput ``β`` (rgb),
    direction weight ``wdir`` and ``depth`` collisions so far, random numbers ``draw(k, dim…)``; with
    ``scatter_first`` it starts by scattering at ``o`` (a collision of extinction ``sig`` reached
    along ``d``). With ``can_split`` it stops at the first collision whose
    :func:`.pathtrace_near.split_count` ``n`` exceeds 1 and returns that collision's state with
    ``β`` and ``wdir`` divided by ``n``.

    Returns ``(r, g, b, hit, t, k0, k1, f, n, ox, oy, oz, dx, dy, dz, br, bg, bb, wdir, depth, sig)``:
    the radiance gathered, the primary-ray first collision of :func:`trace_path_first` (depth 0
    only), and ``n`` (0 when the path ended) with the state its copies continue from."""
    w2i, lo, hi = view.w2i, view.lo, view.hi
    bg, max_depth, rr_depth, eq = paths.bg, paths.max_depth, paths.rr_depth, paths.equiangular
    lr = 0.0
    lg = 0.0
    lb = 0.0
    hit = 0.0
    t_hit = 0.0
    k0_hit = 0
    k1_hit = 0
    f_hit = 0.0
    scatter = scatter_first
    while True:
        if scatter:
            # Sample the scattered direction and its weight p/pdf (step 5: 1 from the phase function).
            dx, dy, dz, wd, dim = scatter_direction(ox, oy, oz, dx, dy, dz, sig, view, medium, lights, paths, k, dim)
            if wd != 1.0:
                wdir *= wd
                br *= wd
                bgc *= wd
                bb *= wd
                if not max(br, max(bgc, bb)) > 0.0:
                    break
            # Renormalise so rounding cannot drift over many bounces.
            inv = 1.0 / math.sqrt(dx * dx + dy * dy + dz * dz)
            dx *= inv
            dy *= inv
            dz *= inv
        scatter = True
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
        sig = 0.0
        if t0 < t1:
            collided, t, sig, k0, k1, f, dim = delta_track(px, py, pz, qx, qy, qz, t0, t1, medium, k, dim)
            if eq:
                # The equiangular strategy's share of the point lights' light scattered at the
                # segment (the collision's NEE below carries the free-flight share).
                nr, ng, nb, dim = equiangular_nee(ox, oy, oz, dx, dy, dz, px, py, pz, qx, qy, qz, t0, t1, view,
                                                  medium, lights, paths, k, dim)
                lr += br * nr
                lg += bgc * ng
                lb += bb * nb
        if not collided:
            # Escaped: only the primary ray sees the background.
            if depth == 0:
                lr += bg[0]
                lg += bg[1]
                lb += bg[2]
            break
        if depth == 0:
            hit = 1.0
            t_hit = t
            k0_hit = k0
            k1_hit = k1
            f_hit = f
        depth += 1
        x = px + t * qx
        y = py + t * qy
        z = pz + t * qz
        wx = ox + t * dx
        wy = oy + t * dy
        wz = oz + t * dz
        ar, ag, ab, er, eg, eb = medium_albedo_emission(medium.mode, medium, k0, k1, f, x, y, z)
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
        nr, ng, nb, dim = direct_light_nee(wx, wy, wz, dx, dy, dz, view, medium, lights, k, dim, eq, ox, oy, oz,
                                           t0, t1, t, paths, qx, qy, qz, sig)
        lr += br * nr
        lg += bgc * ng
        lb += bb * nb
        if depth >= max_depth:
            break
        if eq and can_split:
            n = split_count(lights, wx, wy, wz, paths.eq_radius, q)
            if n > 1:
                inv = 1.0 / n
                return (lr, lg, lb, hit, t_hit, k0_hit, k1_hit, f_hit, n, wx, wy, wz, dx, dy, dz, br * inv,
                        bgc * inv, bb * inv, wdir * inv, depth, sig)
        # Russian roulette on the throughput after rr_depth collisions.
        if eq and depth >= rr_depth:
            g = rr_boost(lights, wx, wy, wz, paths.eq_radius)
            if g > 1.0:
                q *= g
        q = min(q / wdir, RR_MAX_SURVIVAL)
        if depth >= rr_depth and q < 1.0:
            u = draw(k, dim)
            dim += 1
            if u >= q:
                break
            br /= q
            bgc /= q
            bb /= q
        ox = wx
        oy = wy
        oz = wz
    return (lr, lg, lb, hit, t_hit, k0_hit, k1_hit, f_hit, 0, ox, oy, oz, dx, dy, dz, br, bgc, bb, wdir, depth, sig)


@scalar
def trace_path_first(view, medium, lights, paths, i, j, width, height, pixel, sample):
    """:func:`trace_path`, and where its primary ray first collided: returns ``(r, g, b, hit, t,
    k0, k1, f)`` with ``t`` the collision's distance along the camera ray and ``(k0, k1, f)`` the
    medium's table entries there (:func:`.tracking.delta_track`'s; all 0 where ``hit`` is 0) — the
    ``progressive`` model's control variate evaluates its source at that point
    (:mod:`.residual`). A path that splits (:func:`.pathtrace_near.split_count`) continues as its
    copies, each with its own random numbers (``key(k, copy + 1, depth)``, ``k`` the path's key);
    copies may split once more, their copies not (module docstring, item 7)."""
    k = key(paths.seed, pixel, sample)
    ox, oy, oz, dx, dy, dz = camera_ray(view.cam, i, j, width, height)
    (lr, lg, lb, hit, t_hit, k0_hit, k1_hit, f_hit, n, ox, oy, oz, dx, dy, dz, br, bgc, bb, wdir, depth,
     sig) = walk(view, medium, lights, paths, k, 0, ox, oy, oz, dx, dy, dz, 1.0, 1.0, 1.0, 1.0, 0, 0.0, False, True)
    for c in range(n):
        kc = key(k, c + 1, depth)
        (r, g, b, _, _, _, _, _, n2, ox2, oy2, oz2, dx2, dy2, dz2, br2, bg2, bb2, wdir2, depth2,
         sig2) = walk(view, medium, lights, paths, kc, 0, ox, oy, oz, dx, dy, dz, br, bgc, bb, wdir, depth, sig, True,
                      True)
        lr += r
        lg += g
        lb += b
        for c2 in range(n2):
            kc2 = key(kc, c2 + 1, depth2)
            r, g, b, _, _, _, _, _, _, _, _, _, _, _, _, _, _, _, _, _, _ = walk(
                view, medium, lights, paths, kc2, 0, ox2, oy2, oz2, dx2, dy2, dz2, br2, bg2, bb2, wdir2, depth2, sig2,
                True, False)
            lr += r
            lg += g
            lb += b
    return lr, lg, lb, hit, t_hit, k0_hit, k1_hit, f_hit


@scalar(inline=True)
def add_sample(sum_rad, sum_sq, sum_hit, j, i, r, g, b, h):
    """Add one sample (rgb radiance, hit indicator) of pixel (i, j) to the float64 sums Σx, Σx², Σhit."""
    sum_rad[j, i, 0] += r
    sum_rad[j, i, 1] += g
    sum_rad[j, i, 2] += b
    sum_sq[j, i, 0] += r * r
    sum_sq[j, i, 1] += g * g
    sum_sq[j, i, 2] += b * b
    sum_hit[j, i] += h


@scalar
def pathtrace_pixel(view, medium, lights, paths, s0, s1, j, i, sum_rad, sum_sq, sum_hit):
    """Add samples ``[s0, s1)`` of pixel (i, j) to the sums, in order (the work of one thread of
    either driver: bitwise the same for any thread count)."""
    H, W = sum_hit.shape
    pixel = j * W + i
    for s in range(s0, s1):
        r, gg, b, h = trace_path(view, medium, lights, paths, i, j, W, H, pixel, s)
        add_sample(sum_rad, sum_sq, sum_hit, j, i, r, gg, b, h)


@driver
def pathtrace_image(view, medium, lights, paths, s0, s1, row0, row1, sum_rad, sum_sq, sum_hit):
    """CPU driver: add samples ``[s0, s1)`` of every pixel in rows ``[row0, row1)`` to the float64
    sums ``sum_rad`` and ``sum_sq`` (H, W, 3: Σx, Σx²) and ``sum_hit`` (H, W); the scene in the
    records of :mod:`.records`. The rows are visited in a golden-ratio stride order
    (:func:`.raycast.row_stride`): ``prange`` hands each thread one contiguous run of iterations,
    which would otherwise be one band of the image (all of the medium, or none of it)."""
    W = sum_hit.shape[1]
    n = row1 - row0
    stride = row_stride(n)
    for q in prange(n):
        j = row0 + (q * stride) % n
        for i in range(W):
            pathtrace_pixel(view, medium, lights, paths, s0, s1, j, i, sum_rad, sum_sq, sum_hit)
