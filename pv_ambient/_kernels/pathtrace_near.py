"""A path near a point light (:mod:`.pathtrace`, steps 5–7 with ``paths.equiangular``): the
scattered direction drawn about the light, the roulette's boost and splitting (docs/path_tracer.rst,
"Point lights inside the medium"). Each acts only within ``R = paths.eq_radius`` of a point light
and keeps the estimator unbiased; without such a light none draws a random number or changes a
weight, so those scenes render bit for bit as without them.

**Directions about the light** (:func:`scatter_direction`). What equiangular sampling
(:mod:`.pathtrace_nee`) leaves is the ``1/D`` of a segment passing the light at distance ``D``.
Rule: at a vertex within ``R``, the scattered direction comes from a mixture — with probability
:data:`CONE_SHARE` about a near light, else from the phase function — and the path weight is
``p(θ)/pdf_mixture``. About the light, the angle θ to it is uniform on [0, π] (solid-angle pdf
``1/(2π² sin θ)``, and ``D = r sin θ``: the ``1/D`` becomes ``1/r``) or, with probability
:func:`log_share`, has density ``∝ 1/max(θ, θ_min)`` on [0, π] (``θ_min`` the angle of the light
clamp's radius seen from the vertex: uniform below it, log-uniform above). That probability is
:data:`LOG_SHARE` scaled by ``σ_l / (σ_l + σ)`` (extinction at the light and at the vertex), so a
light in empty space or outside the box keeps the uniform angle alone. Why the second density:
in media densest about their light (a star in its nebula) the light scattered toward the vertex
grows with the extinction at the segment's closest approach, which the uniform angle finds at a
rate ``∝ θ``, so paths from far away that found the dense core were rare and heavy.
Why it continues below θ_min: a density that stopped there gave the directions passing within
the clamp only the uniform angle's density, and weights far above those just outside it.

**Roulette near the light** (:func:`rr_boost`). Rule: at a vertex ``d`` from the nearest point
light within ``R``, the roulette's ``max(β)/w`` is multiplied by ``(RR_NEAR·R/d)² ≥ 4``. Why: what
a path gathers there grows as it nears the light, and a roulette on the throughput alone gave
the few survivors that reached a dense core much larger weights — most fireflies of a light
inside a dense core. Elsewhere ``q`` is bit for bit as without it.

**Splitting** (:func:`split_count`). What a path gathers at a vertex ``d`` from a point light
grows as ``β/d`` (its equiangular and next-event terms, once the directions about the light have
turned a segment's ``1/D`` into ``1/r``). Rule: at a collision within ``R`` whose largest
throughput ``β`` exceeds ``SPLIT_WINDOW · d/R`` the path continues as
``n = ⌈β R / (SPLIT_WINDOW d)⌉`` copies (at most :data:`SPLIT_MAX`), each with ``β/n`` and ``w/n``
(so the roulette's ``q`` is unchanged) and its own random numbers — a weight window, as in
particle transport's splitting by importance, with importance ``R/d``. Any ``n`` fixed by the
path so far keeps the estimator unbiased.
"""

from __future__ import annotations

import math

from ._jit import scalar
from .geometry import affine_point
from .pathtrace_nee import EQ_D_MIN
from .phase import direction_about, phase_eval, phase_sample
from .tracking import draw, sigma_lookup

#: Share of scattered directions drawn about a point light within the equiangular radius; the rest
#: come from the phase function, which forward-scattering media need. 0.7 had the fewest fireflies
#: of the shares tried on a light inside a dense core (docs/path_tracer.rst, "Point lights inside
#: the medium").
CONE_SHARE = 0.7
#: Of the directions about a light, the largest share whose angle θ to it has density
#: ∝ 1/max(θ, θ_min) rather than uniform on [0, π]; :func:`log_share` scales it by σ_l/(σ_l + σ),
#: so it nears this where the medium is far denser at the light than at the vertex and is 0 where
#: the light is in empty space (docs/path_tracer.rst, "Point lights inside the medium").
LOG_SHARE = 0.7
#: Near a point light (within the equiangular radius R, at distance d) the roulette's survival
#: probability is multiplied by (RR_NEAR · R / d)² (module docstring, "Roulette near the light").
RR_NEAR = 2.0
#: Splitting near a point light: a path continues as ⌈β·R/(SPLIT_WINDOW·d)⌉ copies (module
#: docstring, "Splitting"). Why 1: a smaller window splits more and lowers the error, but is no
#: more efficient per unit of time; on scenes whose variance is not made next to a light splitting
#: only costs time (docs/path_tracer.rst, "Point lights inside the medium").
SPLIT_WINDOW = 1.0
#: Most copies one split makes.
SPLIT_MAX = 8


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
    (module docstring, "Roulette near the light")."""
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
def split_count(lights, wx, wy, wz, radius, beta):
    """How many copies a path of largest throughput ``beta`` at world point w continues as: within
    ``R = radius`` of a point light (``d`` the nearest one's distance), ``⌈beta · R / (SPLIT_WINDOW · d)⌉``
    capped at :data:`SPLIT_MAX` where that exceeds 1, else exactly 1 (module docstring, "Splitting")."""
    d2 = nearest_near_light(lights, wx, wy, wz, radius)
    if not d2 < math.inf:
        return 1
    v = beta * radius / (SPLIT_WINDOW * math.sqrt(d2))
    if not v > 1.0:
        return 1
    return int(min(math.ceil(v), SPLIT_MAX))
