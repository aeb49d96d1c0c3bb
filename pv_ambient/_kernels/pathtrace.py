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

**Point lights inside the medium** (``paths.equiangular``; docs/path_tracer.rst). A collision at
distance ``d`` from a point light gets ``I/d²`` from next-event estimation: vertices next to a
light inside the medium carry unbounded weights (fireflies; infinite variance without the ``d²``
clamp). Two more sampling steps cancel it, both only within ``paths.eq_radius`` of the light:

* **Equiangular distances** (Kulla & Fajardo 2012, :mod:`.equiangular`): on each segment's part
  within the radius, one distance per point light with density ∝ ``1/d²``, its estimate
  ``T(ta, t) σs(t) E T_l p`` (``T`` by ratio tracking) combined with the free-flight collision's
  next-event estimate by the balance heuristic. The free-flight density ``σt T`` in the weights
  is replaced by the deterministic lower bound ``σt exp(−τ̄)``, ``τ̄`` the majorant's optical
  depth (any deterministic weights that sum to one keep the sum unbiased; a lower bound keeps
  the free-flight share ``w·I/d²`` bounded by ``≈ σt π I / D``, ``D`` the segment's distance
  from the light).
* **Directions about the light**: the remaining ``1/D`` of a segment passing the light at
  distance ``D`` is cancelled by sampling, at a vertex within the radius, the scattered direction
  from a mixture: with probability :data:`CONE_SHARE` about a near light, else from the phase
  function; the path weight is ``p(θ)/pdf_mixture``. About the light, the angle θ to it is
  uniform on [0, π] (solid-angle pdf ``1/(2π² sin θ)``, and ``D = r sin θ``: the ``1/D`` becomes
  ``1/r``) or, with probability :data:`LOG_SHARE`, with density ``∝ 1/max(θ, θ_min)`` on [0, π]
  (``θ_min`` the angle of the light clamp's radius seen from the vertex: uniform below it,
  log-uniform above; a density that stopped at θ_min gave the directions passing within the clamp
  only the uniform angle's density, weights ~60× those just outside it, each such direction from
  the shell of the light-in-core scene a firefly). The second density follows media that are
  densest about their light (a star in its nebula): the light scattered toward the vertex by
  the segment's closest part grows with the extinction there, which the uniform angle samples
  at a rate ``∝ θ``, so paths from far away that found the dense core were rare and heavy (the
  light-in-core scene of benchmarks/light_in_core.py, 48², 64 spp, seeds 9–24: median 4×4-block
  error 0.59 → 0.38, median largest pixel / reference 14 → 6.4). The share is scaled by
  ``σ_l / (σ_l + σ)`` (:func:`log_share`: extinction at the light and at the vertex), so a light in
  empty space or outside the box keeps the uniform angle alone (inside a hollow shell a fixed
  share raised a 2048-spp image's block noise from 0.025 to 0.038).

Without point lights within the radius neither draws a random number, so such scenes render
bitwise as without them.
6. **Termination**: after ``rr_depth`` collisions, Russian roulette with survival probability
   ``q = min(max(β)/w, RR_MAX_SURVIVAL)`` (then ``β /= q``); ``max_depth`` collisions at most.
   ``w`` is the product of the path's direction weights ``p(θ)/pdf`` (1 unless directions were
   sampled about a point light, below): a direction aimed at a light on purpose carries a small
   weight, and a roulette on ``β`` alone would kill such paths and give the survivors a weight
   near 1 right beside the light — fireflies (the light-in-core scene of
   benchmarks/light_in_core.py, 48², 8 seeds: median 4×4-block error at 64 spp 1.09 with ``β``
   alone, 0.67 without ``w``). Any ``q`` in (0, 1] keeps the estimator unbiased.
   With ``paths.equiangular``, at a vertex within ``R = paths.eq_radius`` of a point light (``d`` the
   nearest one's distance) ``max(β)/w`` is multiplied by ``(RR_NEAR·R/d)² ≥ 4`` (:func:`rr_boost`):
   what a path gathers there grows as it nears the light, and a roulette on the throughput alone
   (``q`` 0.03–0.6 at the first roulette) gave the survivors that reached the dense core
   weights 2–30× larger — most fireflies of the light-in-core scene (48², 64 spp, seeds 1–40:
   pixels above 5× their reference 81 → 23 with ``(R/d)²``; with ``(2R/d)²``, CONE_SHARE 0.7 and the
   θ_min continuation, 4; ~25 % more time there, 43 % on marschner_lobb with its light at the
   centre). Elsewhere ``q`` is bit for bit as without it.
   Without the cap (0.999) a path in a conservative medium (albedo 1: β never drops) would only
   end by leaving the medium, which from inside an optically huge one (σt·L ~ 1e6, camera inside)
   takes ~(σt·L)² collisions: the render never returns. With it, such a path takes ~1000
   collisions after ``rr_depth`` on average, the estimator stays unbiased (β /= q), and nothing
   changes where the albedo is ≤ 0.999 (there max(β) ≤ 0.999 already at every roulette).
   Collision ``n`` adds emission scattered ``n − 1`` times and light scattered ``n`` times, so
   ``max_depth = 1`` is single scattering (NEE at the first collision only) plus the
   emission–absorption term.
7. **Splitting near a point light** (``paths.equiangular``): what a path gathers at a vertex ``d``
   from a point light grows as ``β/d`` (its equiangular and next-event terms, once the directions
   about the light have turned a segment's ``1/D`` into ``1/r``), so a path that reaches the
   light's neighbourhood with much of its throughput left makes a firefly. At a collision within
   ``R`` of a point light whose largest throughput ``β`` exceeds ``SPLIT_WINDOW · d/R`` the path
   continues as
   ``n = ⌈β R / (SPLIT_WINDOW d)⌉`` copies (at most :data:`SPLIT_MAX`; a weight window,
   as in particle transport's splitting by importance, with importance ``R/d``), each with
   ``β/n`` and ``w/n`` (so the roulette's ``q`` is unchanged) and its own random numbers; a copy may
   split once more, a copy of a copy not. Any ``n`` fixed by the path so far keeps the estimator
   unbiased; without point lights within ``R`` no path splits and the pictures are bit for bit
   as without it. Light-in-core scene (48², 64 spp, seeds 1–80): median 4×4-block error 0.221 →
   0.178 at 1.2× the time (≈ 10 % less error at equal time), median largest pixel / reference 3.35 →
   3.12, seeds with a pixel above 5× its reference 3 → 1 (docs/path_tracer.rst).

Each path also reports whether its primary ray collided (an unbiased estimate of the primary
ray's opacity ``1 − T``). Random numbers: ``rng.uniform(seed, pixel, sample, dim)``, ``dim``
counting the path's draws, so every path is a pure function of (seed, pixel, sample) and the
image does not depend on the thread count.
"""

from __future__ import annotations

import math

from ._jit import driver, prange, scalar
from .equiangular import equiangular_pdf, equiangular_sample, equiangular_setup
from .geometry import affine_point, affine_vector, camera_ray, ray_box
from .majorant import walk_optical_depth
from .phase import direction_about, phase_eval, phase_sample
from .raycast import light_at, medium_albedo_emission, row_stride
from .rng import key
from .tracking import delta_track, draw, ratio_track, sigma_lookup

#: Ratio tracking along shadow rays switches on Russian roulette below this transmittance.
SHADOW_RR_BELOW = 0.05
#: Largest survival probability of the path's Russian roulette (module docstring, item 6).
RR_MAX_SURVIVAL = 0.999
#: Floor of the equiangular density's distance from the ray, relative to the equiangular radius
#: (when the light clamp is smaller; scale-free, as the supported spacings span 1e-100 to 1e100).
EQ_D_MIN = 1e-12
#: Share of scattered directions sampled about a point light within the equiangular radius (the
#: light-in-core scene's median block error at 64 spp: 0.67 at 0.3, 0.58 at 0.5, 0.52 at 0.7; with
#: the roulette of :func:`rr_boost`, seeds 1–40: pixels above 5× their reference 23 at 0.5, 9–10 at
#: 0.7, 17 at 0.8; the rest is taken from the phase function, which forward-scattering media need).
CONE_SHARE = 0.7
#: Of the directions about a light, the share whose angle θ to it has density ∝ 1/max(θ, θ_min) on
#: [0, π] (θ_min the light clamp's angle; log-uniform above it) rather than uniform on [0, π], where
#: the medium is densest at the light (scaled by :func:`log_share`). Light-in-core scene, 48², 64 spp,
#: seeds 1–8, fixed share: median block error 0.58 at 0, 0.336 at 0.5, 0.335 at 0.7 but its worst seed
#: 0.49 against 0.38; with :func:`rr_boost`, CONE_SHARE 0.7, seeds 1–80: seeds whose largest pixel
#: exceeds 5× its reference 7 at 0.5, 4 at 0.7 (pixels above 3× 131 → 99).
LOG_SHARE = 0.7
#: Near a point light (within the equiangular radius R, at distance d) the roulette's survival
#: probability is multiplied by (RR_NEAR · R / d)² (module docstring, item 6).
RR_NEAR = 2.0
#: Splitting near a point light: a path continues as ⌈β·R/(SPLIT_WINDOW·d)⌉ copies (module docstring, item 7).
#: Light-in-core scene, 48², 64 spp, seeds 1–80 (benchmarks/light_in_core.py): median 4×4-block error 0.221
#: without splitting, 0.178 / 0.162 / 0.148 at windows 1 / 0.7 / 0.5 for 1.2 / 1.4 / 1.7× the time; at 1,
#: variance × time rises ~12 % on the trade's supernova and on Marschner–Lobb (light at its centre), whose
#: variance is not made next to the light.
SPLIT_WINDOW = 1.0
#: Most copies one split makes.
SPLIT_MAX = 8


@scalar
def light_nee(l, wx, wy, wz, px, py, pz, dx, dy, dz, view, medium, lights, k, dim):
    """Light ``l``'s ``E_l T_l p(θ_l)`` (rgb) at world point w (index point p) for a path travelling
    along d; ``T_l`` by ratio tracking. Returns ``(r, g, b, dim)``."""
    w2i, lo, hi = view.w2i, view.lo, view.hi
    lkind, lvec = lights.kind, lights.vec
    er, eg, eb, lx, ly, lz = light_at(l, lights, wx, wy, wz)
    if er <= 0.0 and eg <= 0.0 and eb <= 0.0:
        return 0.0, 0.0, 0.0, dim
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
    if T <= 0.0:
        return 0.0, 0.0, 0.0, dim
    # Light propagates along (lx, ly, lz) and leaves toward the camera along −d.
    w = T * phase_eval(lights.pkind, lights.g, -(lx * dx + ly * dy + lz * dz))
    return er * w, eg * w, eb * w, dim


@scalar
def free_flight_proxy(sigma, px, py, pz, qx, qy, qz, ta, t, paths, medium):
    """The deterministic stand-in for the free-flight density at distance ``t`` of the segment
    ``p + s q``, ``s ≥ ta`` (extinction ``sigma`` there) in the MIS weights: ``σt exp(−τ̄)``, ``τ̄``
    the majorant's optical depth (:func:`.majorant.walk_optical_depth`). The true density ``σt T``
    is unknown in a heterogeneous medium; any deterministic weights that sum to one keep the
    combination unbiased, and a lower bound of it (``T ≥ exp(−τ̄)``) keeps the free-flight share
    of next-event estimation near a light bounded (module docstring)."""
    tau = walk_optical_depth(px, py, pz, qx, qy, qz, ta, t, paths.eq_grid, medium.block)
    return sigma * math.exp(-tau)


@scalar
def equiangular_span(l, lights, ox, oy, oz, dx, dy, dz, ta, tb, radius):
    """Where the segment ``o + t d``, ``t ∈ [ta, tb]``, is sampled toward point light ``l``: its part
    within ``radius`` of the light, ``[a, b]``, and the equiangular density's ``(delta, D, tau_a,
    span)`` there (:func:`.equiangular.equiangular_setup`); ``span`` 0 where there is no such part."""
    lvec = lights.vec
    d_min = max(math.sqrt(lights.d2min), EQ_D_MIN * radius)
    delta, D, tau_a, span = equiangular_setup(ox, oy, oz, dx, dy, dz, lvec[l, 0], lvec[l, 1], lvec[l, 2],
                                              ta, tb, d_min)
    if D >= radius:
        return ta, tb, delta, D, tau_a, 0.0
    h = math.sqrt(radius * radius - D * D)
    a = max(ta, delta - h)
    b = min(tb, delta + h)
    if not a < b:
        return ta, tb, delta, D, tau_a, 0.0
    if a > ta or b < tb:
        delta, D, tau_a, span = equiangular_setup(ox, oy, oz, dx, dy, dz, lvec[l, 0], lvec[l, 1], lvec[l, 2],
                                                  a, b, d_min)
    return a, b, delta, D, tau_a, span


@scalar
def direct_light_nee(wx, wy, wz, dx, dy, dz, view, medium, lights, k, dim, eq, ox, oy, oz, ta, tb, t, paths,
                     qx, qy, qz, sigma):
    """Σ_l E_l T_l p(θ_l) (rgb) at world point w for a path travelling along d; T_l by ratio tracking.

    With ``eq`` the point lights' terms carry the free-flight strategy's MIS weight
    ``p_ff/(p_ff + p_eq)`` (balance heuristic, module docstring): w is the collision at distance
    ``t`` (extinction ``sigma``) on the segment ``o + s d``, ``s ∈ [ta, tb]`` (``q`` = ``d`` in index space).

    Returns ``(r, g, b, dim)``.
    """
    sr = 0.0
    sg = 0.0
    sb = 0.0
    px, py, pz = affine_point(view.w2i, wx, wy, wz)
    lkind = lights.kind
    pf = -1.0
    for l in range(lkind.shape[0]):
        r, g, b, dim = light_nee(l, wx, wy, wz, px, py, pz, dx, dy, dz, view, medium, lights, k, dim)
        if eq and lkind[l] == 0:
            a, bb, delta, D, _, span = equiangular_span(l, lights, ox, oy, oz, dx, dy, dz, ta, tb, paths.eq_radius)
            if span > 0.0 and a <= t <= bb:
                if pf < 0.0:
                    # the segment's start in index space: w is at distance t along q
                    pf = free_flight_proxy(sigma, px - t * qx, py - t * qy, pz - t * qz, qx, qy, qz, ta, t, paths,
                                           medium)
                w = pf / (pf + equiangular_pdf(t, delta, D, span))
                r *= w
                g *= w
                b *= w
        sr += r
        sg += g
        sb += b
    return sr, sg, sb, dim


@scalar
def equiangular_nee(ox, oy, oz, dx, dy, dz, px, py, pz, qx, qy, qz, ta, tb, view, medium, lights, paths, k, dim):
    """The equiangular strategy on the segment ``o + t d``, ``t ∈ [ta, tb]`` (index-space ray
    ``p + t q``): for each point light one distance ``t`` from :func:`.equiangular.equiangular_sample`
    on the part within ``paths.eq_radius`` of the light (:func:`equiangular_span`) and
    ``T(ta, t) σs(t) E_l T_l p(θ_l) / (p_ff + p_eq)`` (rgb) — its estimate of the light's
    single-scattered radiance there times its balance-heuristic weight ``p_eq/(p_ff + p_eq)``;
    ``T(ta, t)`` by ratio tracking. Returns ``(r, g, b, dim)``."""
    lkind = lights.kind
    sr = 0.0
    sg = 0.0
    sb = 0.0
    for l in range(lkind.shape[0]):
        if lkind[l] != 0:
            continue
        a, b, delta, D, tau_a, span = equiangular_span(l, lights, ox, oy, oz, dx, dy, dz, ta, tb, paths.eq_radius)
        if not span > 0.0:
            continue
        u = draw(k, dim)
        dim += 1
        t, pe = equiangular_sample(u, a, D, tau_a, span)
        t = min(max(t, a), b)
        x = px + t * qx
        y = py + t * qy
        z = pz + t * qz
        s, k0, k1, f = sigma_lookup(medium, x, y, z)
        if not s > 0.0:
            continue
        ar, ag, ab, _, _, _ = medium_albedo_emission(medium, k0, k1, f, x, y, z)
        if ar <= 0.0 and ag <= 0.0 and ab <= 0.0:
            continue
        T, dim = ratio_track(px, py, pz, qx, qy, qz, ta, t, medium, SHADOW_RR_BELOW, k, dim)
        if T <= 0.0:
            continue
        r, g, bl, dim = light_nee(l, ox + t * dx, oy + t * dy, oz + t * dz, x, y, z, dx, dy, dz, view, medium,
                                  lights, k, dim)
        c = T * s / (free_flight_proxy(s, px, py, pz, qx, qy, qz, ta, t, paths, medium) + pe)
        sr += ar * r * c
        sg += ag * g * c
        sb += ab * bl * c
    return sr, sg, sb, dim


@scalar
def near_light(l, lights, wx, wy, wz, radius):
    """Whether light ``l`` is a point light within ``radius`` of world point w (and not on it), and
    the vector from w to it with its squared length: ``(near, vx, vy, vz, d2)``."""
    if lights.kind[l] != 0:
        return False, 0.0, 0.0, 0.0, 0.0
    lvec = lights.vec
    vx = lvec[l, 0] - wx
    vy = lvec[l, 1] - wy
    vz = lvec[l, 2] - wz
    d2 = vx * vx + vy * vy + vz * vz
    return 0.0 < d2 < radius * radius, vx, vy, vz, d2


@scalar
def log_share(l, lights, view, medium, sig):
    """The share of light ``l``'s directions whose angle is log-uniform (:data:`LOG_SHARE` scaled by
    ``σ_l / (σ_l + σ)``, ``σ_l`` the extinction at the light, ``σ`` at the vertex): about half where
    the medium is densest at the light, none where the light is in empty space or outside the box
    (module docstring)."""
    lvec, lo, hi = lights.vec, view.lo, view.hi
    x, y, z = affine_point(view.w2i, lvec[l, 0], lvec[l, 1], lvec[l, 2])
    if not (lo[0] <= x <= hi[0] and lo[1] <= y <= hi[1] and lo[2] <= z <= hi[2]):
        return 0.0
    s = sigma_lookup(medium, x, y, z)[0]
    if not s > 0.0:
        return 0.0
    return LOG_SHARE * s / (s + max(sig, 0.0))


@scalar
def nearest_near_light(lights, wx, wy, wz, radius):
    """The squared distance from world point w to the nearest point light within ``radius`` of it
    (:func:`near_light`), ``inf`` where there is none."""
    d2 = math.inf
    for l in range(lights.kind.shape[0]):
        ok, _, _, _, e2 = near_light(l, lights, wx, wy, wz, radius)
        if ok:
            d2 = min(d2, e2)
    return d2


@scalar
def rr_boost(lights, wx, wy, wz, radius):
    """The factor of the roulette's survival probability at world point w: ``(RR_NEAR · R / d)²``
    for the nearest point light within ``R = radius`` (``d`` its distance; ≥ 4), else exactly 1
    (module docstring, item 6)."""
    d2 = nearest_near_light(lights, wx, wy, wz, radius)
    if not d2 < math.inf:
        return 1.0
    return RR_NEAR * RR_NEAR * radius * radius / d2


@scalar(inline=True)
def log_angle_range(d_min, r):
    """``(θ_min, ln(π/θ_min))`` of the log-uniform angle about a light at distance ``r``, ``θ_min``
    the angle of the radius ``d_min`` seen from there."""
    th_min = math.atan2(d_min, r)
    return th_min, math.log(math.pi / th_min)


@scalar
def scatter_direction(wx, wy, wz, dx, dy, dz, sig, view, medium, lights, paths, k, dim):
    """The direction after scattering at world point w of a path travelling along d, and its weight
    ``p(θ)/pdf``: from the phase function (weight 1) or, with ``paths.equiangular`` and point lights
    within ``paths.eq_radius`` of w, from a mixture: with probability :data:`CONE_SHARE` a direction
    about a near light chosen uniformly, its angle θ_l to the light uniform on [0, π]
    (solid-angle pdf ``1/(2π² sin θ_l)``) or, with probability :data:`LOG_SHARE`, with density
    ``∝ 1/max(θ_l, θ_min)`` on ``[0, π]``, ``θ_min = atan(d_min / r)`` (``d_min`` the light clamp's
    radius, ``r`` the light's distance), else the phase function (module docstring).
    Returns ``(dx, dy, dz, weight, dim)``."""
    nlights, radius = lights.kind.shape[0], paths.eq_radius
    near = 0
    if paths.equiangular:
        for l in range(nlights):
            if near_light(l, lights, wx, wy, wz, radius)[0]:
                near += 1
    if near == 0:
        u1 = draw(k, dim)
        u2 = draw(k, dim + 1)
        nx, ny, nz, _ = phase_sample(lights.pkind, lights.g, u1, u2, dx, dy, dz)
        return nx, ny, nz, 1.0, dim + 2
    u0 = draw(k, dim)
    u1 = draw(k, dim + 1)
    u2 = draw(k, dim + 2)
    dim += 3
    d_min = max(math.sqrt(lights.d2min), EQ_D_MIN * radius)
    if u0 < CONE_SHARE:
        v = u0 / CONE_SHARE * near
        pick = min(int(v), near - 1)
        frac = v - pick  # uniform in [0, 1): which of the two angle densities
        for l in range(nlights):
            ok, vx, vy, vz, d2 = near_light(l, lights, wx, wy, wz, radius)
            if ok:
                if pick == 0:
                    r = math.sqrt(d2)
                    if frac < log_share(l, lights, view, medium, sig):
                        th_min, span = log_angle_range(d_min, r)
                        v = u1 * (1.0 + span)
                        if v < 1.0:
                            theta = th_min * v
                        else:
                            theta = th_min * math.exp(v - 1.0)
                    else:
                        theta = math.pi * u1
                    inv = 1.0 / r
                    nx, ny, nz = direction_about(math.cos(theta), u2, vx * inv, vy * inv, vz * inv)
                    break
                pick -= 1
    else:
        nx, ny, nz, _ = phase_sample(lights.pkind, lights.g, u1, u2, dx, dy, dz)
    # the mixture's pdf at the chosen direction
    cone = 0.0
    for l in range(nlights):
        ok, vx, vy, vz, d2 = near_light(l, lights, wx, wy, wz, radius)
        if ok:
            c = (nx * vx + ny * vy + nz * vz) / math.sqrt(d2)
            sin_t = math.sqrt(max(0.0, (1.0 - c) * (1.0 + c)))
            if not sin_t > 0.0:
                return nx, ny, nz, 0.0, dim
            share = log_share(l, lights, view, medium, sig)
            if share > 0.0:
                r = math.sqrt(d2)
                theta = math.atan2(sin_t, c)
                th_min, span = log_angle_range(d_min, r)
                pdf_theta = (1.0 - share) / math.pi + share / ((1.0 + span) * max(theta, th_min))
                cone += pdf_theta / (2.0 * math.pi * sin_t)
            else:
                cone += 1.0 / (2.0 * math.pi * math.pi * sin_t)
    p = phase_eval(lights.pkind, lights.g, nx * dx + ny * dy + nz * dz)
    return nx, ny, nz, p / ((1.0 - CONE_SHARE) * p + CONE_SHARE * cone / near), dim


@scalar
def trace_path(view, medium, lights, paths, i, j, width, height, pixel, sample):
    """One path sample of pixel (i, j) (see the module docstring); the scene in the records of
    :mod:`.records` (``paths``: background, depths, seed).

    Returns ``(r, g, b, hit)``: the radiance estimate and 1.0 when the primary ray collided.
    """
    r, g, b, hit, _, _, _, _ = trace_path_first(view, medium, lights, paths, i, j, width, height, pixel, sample)
    return r, g, b, hit


@scalar
def split_count(lights, wx, wy, wz, radius, beta):
    """How many copies a path of largest throughput ``beta`` at world point w continues as: within
    ``R = radius`` of a point light (``d`` the nearest one's distance), ``⌈beta · R / (SPLIT_WINDOW · d)⌉``
    capped at :data:`SPLIT_MAX` where that exceeds 1, else exactly 1 (module docstring, item 7)."""
    d2 = nearest_near_light(lights, wx, wy, wz, radius)
    if not d2 < math.inf:
        return 1
    v = beta * radius / (SPLIT_WINDOW * math.sqrt(d2))
    if not v > 1.0:
        return 1
    return int(min(math.ceil(v), SPLIT_MAX))


@scalar
def walk(view, medium, lights, paths, k, dim, ox, oy, oz, dx, dy, dz, br, bgc, bb, wdir, depth, sig, scatter_first,
         can_split):
    """The transport loop of :func:`trace_path_first` from ray ``o + t d`` with throughput ``β`` (rgb),
    direction weight ``wdir`` and ``depth`` collisions so far, random numbers ``draw(k, dim…)``; with
    ``scatter_first`` it starts by scattering at ``o`` (a collision of extinction ``sig`` reached
    along ``d``). With ``can_split`` it stops at the first collision whose :func:`split_count` ``n``
    exceeds 1 and returns that collision's state with ``β`` and ``wdir`` divided by ``n``.

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
            # Sample the scattered direction (from the phase function: weight p/pdf = 1).
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
    (:mod:`.residual`). A path that splits (:func:`split_count`) continues as its copies, each
    with its own random numbers (``key(k, copy + 1, depth)``, ``k`` the path's key); copies may
    split once more, their copies not (module docstring, item 7)."""
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
