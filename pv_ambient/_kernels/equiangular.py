"""Equiangular distance sampling toward a point light (Kulla & Fajardo 2012, "Importance Sampling
Techniques for Path Tracing in Participating Media"): the path tracer's distance sampling near
point lights inside a medium (:mod:`.pathtrace_nee`; docs/path_tracer.rst, "Point lights inside
the medium").

Along a ray ``x(t) = o + t ω`` (``ω`` a unit vector) over ``t ∈ [a, b]``, a point light at ``c`` is
at squared distance ``D² + (t − Δ)²``, with ``Δ = (c − o)·ω`` the light's projection on the ray and
``D`` its distance from the ray. In-scattered light from it falls off as ``1/(D² + (t − Δ)²)``;
free-flight sampling ignores that factor, so vertices close to the light carry weights that grow
without bound — the infinite variance of next-event estimation near a point light. Sampling ``t``
with density proportional to that factor cancels it. With ``θ(t) = atan((t − Δ)/D)``,

    pdf(t) = D / ((θ_b − θ_a) (D² + (t − Δ)²)),    t(u) = Δ + D tan(θ_a + u (θ_b − θ_a)),

the angle ``θ`` then being uniform on ``[θ_a, θ_b]`` — "equiangular": equal angles seen from the
light. ``D`` is clamped below at ``d_min`` (> 0): a ray through the light itself would otherwise
give ``D = 0`` and an improper density; the renderer passes ``sqrt(d2min)``, the same clamp as its
``1/max(d², d2min)`` light fall-off, so the density still follows the integrand there.

Both angles are kept out of the arithmetic where they would cancel (a segment short or far from the
light has ``θ_a`` and ``θ_b`` close together near ±π/2): with ``τ = (t − Δ)/D``, the span
``θ_b − θ_a = atan2((b − a)/D, 1 + τ_a τ_b)``, and a sample is placed by its offset from ``a``,
``t = a + D tan φ (1 + τ_a²) / (1 − τ_a tan φ)`` with ``φ = u (θ_b − θ_a)`` (the tangent of a sum),
rather than by ``Δ + D tan(θ_a + φ)``, whose pole amplifies rounding by ``τ_a²``.
"""

from __future__ import annotations

import math

from ._jit import scalar


@scalar
def equiangular_setup(ox, oy, oz, dx, dy, dz, cx, cy, cz, a, b, d_min):
    """Parameters of the equiangular density on ``[a, b]`` of the ray ``o + t d`` (``d`` a unit
    vector) toward a light at ``c``: returns ``(delta, D, tau_a, span)`` (see the module docstring;
    ``D ≥ d_min``, ``tau_a = (a − Δ)/D``, ``span = θ_b − θ_a ∈ [0, π)``)."""
    vx = cx - ox
    vy = cy - oy
    vz = cz - oz
    delta = vx * dx + vy * dy + vz * dz
    px = vx - delta * dx
    py = vy - delta * dy
    pz = vz - delta * dz
    D = max(math.sqrt(px * px + py * py + pz * pz), d_min)
    tau_a = (a - delta) / D
    tau_b = (b - delta) / D
    span = math.atan2((b - a) / D, 1.0 + tau_a * tau_b)  # τ_b − τ_a from b − a: no cancellation
    return delta, D, tau_a, span


@scalar
def equiangular_sample(u, a, D, tau_a, span):
    """A distance ``t`` in ``[a, b]`` from the equiangular density set up by
    :func:`equiangular_setup`, for ``u`` uniform in [0, 1), and its pdf."""
    tp = math.tan(u * span)
    off = D * tp * (1.0 + tau_a * tau_a) / (1.0 - tau_a * tp)
    s = D * tau_a + off  # t − Δ
    return a + off, D / (span * (D * D + s * s))


@scalar
def equiangular_pdf(t, delta, D, span):
    """The equiangular density at ``t`` (inside the segment it was set up on)."""
    s = t - delta
    return D / (span * (D * D + s * s))
