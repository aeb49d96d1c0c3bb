"""Next-event estimation of the path tracer (:mod:`.pathtrace`, step 4): the direct light a
path gathers at a collision, and, with ``paths.equiangular``, the equiangular strategy that
samples it along each segment near a point light (docs/path_tracer.rst, "One path" and "Point
lights inside the medium").

At a collision ``w``, light ``l`` adds ``E_l T_l p(θ_l)``: ``E = I/max(d², d2min)`` for a point
light (the clamp of :func:`.raycast.light_at`) or the directional irradiance, ``T_l`` a
ratio-tracking estimate along the shadow ray (to the light, or to the box exit for a directional
light; a point light may lie inside or outside the box) and ``cos θ = ω_light · (−ω_ray)``
(propagation directions, docs/conventions.rst).

**Equiangular distances** (Kulla & Fajardo 2012, :mod:`.equiangular`). A collision at distance
``d`` from a point light gets ``I/d²``: next to a light inside the medium next-event estimation
alone has unbounded weights (fireflies). So on each segment's part within ``paths.eq_radius`` of
a point light, one distance per light is drawn with density ∝ ``1/d²``; its estimate
``T(ta, t) σs(t) E T_l p`` (``T`` by ratio tracking) is combined with the free-flight collision's
next-event estimate by the balance heuristic. Rule: the free-flight density ``σt T`` in the
weights is replaced by the deterministic lower bound ``σt exp(−τ̄)`` (:func:`free_flight_proxy`,
``τ̄`` the majorant's optical depth). Why: the true density is unknown in a heterogeneous medium;
any deterministic weights that sum to one keep the sum unbiased, and a lower bound keeps the
free-flight share ``w·I/d²`` bounded by ``≈ σt π I / D`` (``D`` the segment's distance from the
light).

Without point lights within the radius no equiangular distance is drawn, so such scenes render
bit for bit as without it.
"""

from __future__ import annotations

import math

from ._jit import scalar
from .equiangular import equiangular_pdf, equiangular_sample, equiangular_setup
from .geometry import affine_point, affine_vector, ray_box
from .majorant import walk_optical_depth
from .phase import phase_eval
from .raycast import light_at, medium_albedo_emission
from .tracking import draw, ratio_track, sigma_lookup

#: Ratio tracking along shadow rays switches on Russian roulette below this transmittance
#: (bounded cost in dense media, still unbiased: docs/path_tracer.rst, "Null-collision tracking").
SHADOW_RR_BELOW = 0.05
#: Floor of the equiangular density's distance from the ray, relative to the equiangular radius
#: (when the light clamp is smaller). Why relative: the supported grid spacings span 1e-100 to
#: 1e100, so no absolute floor fits every scene.
EQ_D_MIN = 1e-12


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
        ar, ag, ab, _, _, _ = medium_albedo_emission(medium.mode, medium, k0, k1, f, x, y, z)
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
