"""Phase-function kernels: evaluate, sample cos θ, sample a direction (docs/conventions.rst, docs/architecture.rst).

Convention (docs/conventions.rst): ``p(cos θ)`` is normalised to 1 over the sphere (it includes the 1/4π),
and θ is the angle between the light's propagation direction *before* and *after* scattering,
so ``cos θ = w_in · w_out`` with both vectors pointing along the propagation. ``g > 0`` (and
Schlick's ``k > 0``) is forward scattering: the peak sits at ``cos θ = 1``.

Kinds are integers (module constants) so that a caller dispatches on a number, never on a
function object (functions passed as arguments defeat Numba's caching). Every function is a
scalar kernel (docs/architecture.rst): scalars in, scalars out, no allocation, uniforms passed in. Kernels
never validate; :mod:`pv_ambient.inputs.phase` rejects ``|g| >= 1`` at construction. The two
``*_array`` drivers at the end are thin serial loops for the Python API and the tests.

Sampling is exact (inverse CDF in closed form for every kind), so the pdf of a sampled
direction is ``phase_eval`` at its cosine.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import driver, scalar

ISOTROPIC = 0
HENYEY_GREENSTEIN = 1
SCHLICK = 2
RAYLEIGH = 3

INV_4PI = 1.0 / (4.0 * math.pi)
RAYLEIGH_NORM = 3.0 / (16.0 * math.pi)
TWO_PI = 2.0 * math.pi

G_MAX = 0.999
"""|g| is clamped to this inside kernels: p(1) ~ 1/(1 − |g|)² stays finite (≈ 1.6e5 at 0.999)."""

K_MAX = 0.999
"""|k| (Schlick) is clamped to this inside kernels; see :func:`schlick_k`."""


@scalar
def schlick_k(g):
    """Schlick's parameter ``k = 1.55 g − 0.55 g³`` (Blasi, Le Saëc, Schlick 1993), clamped.

    The cubic fit is not monotone: it reaches ``k = 1`` at ``|g| ≈ 0.938`` and peaks at
    ``k ≈ 1.0016`` near ``|g| ≈ 0.969``, where ``1 − k²`` would turn negative. Clamp
    ``|k| <= K_MAX`` so every ``|g| < 1`` gives a valid, normalised, strongly forward lobe.
    """
    k = 1.55 * g - 0.55 * g * g * g
    return min(max(k, -K_MAX), K_MAX)


@scalar
def phase_eval(kind, g, cos_theta):
    """Phase function value ``p(cos θ)`` [1/sr] of ``kind`` with anisotropy ``g``."""
    return phase_in(np.float64, kind, g, cos_theta)


@scalar(inline=True)
def phase_in(F, kind, g, cos_theta):
    """:func:`phase_eval` with its square root and division in the float type ``F`` (``np.float64``
    or ``np.float32``) and the rest in the arguments' precision: the one formula of each kind.
    Why: the CUDA ray cast evaluates each light's phase function with float32 for those two
    (:func:`.raycast.direct_light_one`; in float64 a GPU calls slow paths for them) but from float64
    arguments, as ``1 − gμ`` cancels near a forward-scattering peak, where float32 would lose about
    ``1/(1 − |g|)`` ulps."""
    # Clamp the cosine: dot products of unit vectors may overshoot ±1 by a few ulps.
    mu = min(max(cos_theta, -1.0), 1.0)
    if kind == HENYEY_GREENSTEIN:
        # Clamp |g| (construction rejects |g| >= 1; this only keeps 1 − g² > 0 for kernels).
        gc = min(max(g, -G_MAX), G_MAX)
        # Write 1 + g² − 2gμ as (1 − gμ)² + g²(1 − μ²): two non-negative terms, no
        # cancellation near gμ → 1, and never below (1 − |g|)² > 0.
        a = 1.0 - gc * mu
        d = F(a * a + gc * gc * (1.0 - mu) * (1.0 + mu))
        return F(INV_4PI * (1.0 - gc) * (1.0 + gc)) / (d * math.sqrt(d))
    if kind == SCHLICK:
        # (1 − kμ)² is smallest at μ = 1 for k > 0: forward scattering, as for HG.
        k = schlick_k(g)
        a = F(1.0 - k * mu)
        return F(INV_4PI * (1.0 - k) * (1.0 + k)) / (a * a)
    if kind == RAYLEIGH:
        return F(RAYLEIGH_NORM * (1.0 + mu * mu))
    return F(INV_4PI)


@scalar
def phase_sample_cos(kind, g, u):
    """Sample ``cos θ`` of ``kind`` by inverting its CDF at the uniform ``u`` in [0, 1].

    The map is increasing in ``u``: ``u = 0`` gives ``cos θ = −1``, ``u = 1`` gives ``+1``.
    """
    if kind == HENYEY_GREENSTEIN:
        # Clamp |g| as in phase_eval.
        gc = min(max(g, -G_MAX), G_MAX)
        # Sample with |g| and mirror (p_g(μ) = p_{-g}(−μ)): for g >= 0 the denominator
        # d = 1 − g + 2gv >= 1 − g never cancels; with g < 0 it would near u = 1.
        ga = abs(gc)
        v = u if gc >= 0.0 else 1.0 - u
        # Invert the HG CDF. The classical form μ = (1 + g² − s²)/(2g), s = (1 − g²)/d
        # (pbrt-v4 SampleHenyeyGreenstein) divides by g, so pbrt switches to the isotropic
        # map for |g| < 1e-3 — whose samples then do not follow the HG pdf returned (relative
        # error ~3|g|). Factor (1 + g)² − s² instead: 1 + μ = (1 + g) v (1 + g + s) / d.
        # Exact for every g (2v − 1 at g = 0): no division by g, so no small-g branch, and
        # every factor is positive (no cancellation before the final − 1).
        d = 1.0 - ga + 2.0 * ga * v
        s = (1.0 - ga) * (1.0 + ga) / d
        mu = (1.0 + ga) * v * (1.0 + ga + s) / d - 1.0
        if gc < 0.0:
            mu = -mu
    elif kind == SCHLICK:
        # Invert F(μ) = (1 − k²)/(2k) · (1/(1 − kμ) − 1/(1 + k)); multiplied out, no 1/k.
        k = schlick_k(g)
        mu = (2.0 * u - 1.0 + k) / (1.0 - k + 2.0 * k * u)
    elif kind == RAYLEIGH:
        # Solve the CDF (μ³ + 3μ + 4)/8 = u, a depressed cubic with one real root
        # μ = A − 1/A, A = cbrt(z + sqrt(z² + 1)), z = 4u − 2 (Cardano). Take |z| and restore
        # the sign (the root is odd in z) so z + sqrt(z² + 1) never cancels.
        z = 4.0 * u - 2.0
        big = abs(z) + math.sqrt(z * z + 1.0)
        cube_root = big ** (1.0 / 3.0)
        mu = math.copysign(cube_root - 1.0 / cube_root, z)
    else:
        mu = 2.0 * u - 1.0
    # Clamp: rounding may push the cosine a few ulps past ±1.
    return min(max(mu, -1.0), 1.0)


@scalar
def phase_sample(kind, g, u1, u2, wx, wy, wz):
    """Sample a scattered direction for the unit propagation direction ``w``.

    ``u1`` picks ``cos θ`` (inverse CDF), ``u2`` the azimuth ``φ = 2π u2`` around ``w``.
    Returns ``(dx, dy, dz, pdf)``: a unit direction (along the propagation after scattering)
    and its solid-angle pdf, equal to ``phase_eval(kind, g, dot(d, w))``.
    """
    mu = phase_sample_cos(kind, g, u1)
    dx, dy, dz = direction_about(mu, u2, wx, wy, wz)
    return dx, dy, dz, phase_eval(kind, g, mu)


@scalar
def direction_about(mu, u2, wx, wy, wz):
    """The unit direction at polar cosine ``mu`` from the unit vector ``w`` and azimuth ``φ = 2π u2``."""
    sin_theta = math.sqrt(max(0.0, (1.0 - mu) * (1.0 + mu)))
    phi = TWO_PI * u2
    sx = sin_theta * math.cos(phi)
    sy = sin_theta * math.sin(phi)
    # Build an orthonormal frame (t1, t2, w) without branches on the direction
    # (Duff et al. 2017, "Building an Orthonormal Basis, Revisited"); stable at w = ±z.
    sign = math.copysign(1.0, wz)
    a = -1.0 / (sign + wz)
    b = wx * wy * a
    t1x = 1.0 + sign * wx * wx * a
    t1y = sign * b
    t1z = -sign * wx
    t2x = b
    t2y = sign + wy * wy * a
    t2z = -wy
    # Map the local direction into the world frame.
    dx = sx * t1x + sy * t2x + mu * wx
    dy = sx * t1y + sy * t2y + mu * wy
    dz = sx * t1z + sy * t2z + mu * wz
    return dx, dy, dz


# --- thin serial drivers for the Python API (pv_ambient.inputs.phase) and tests -------------------


@driver(parallel=False)
def phase_eval_array(kind, g, cos_theta, out):
    """``out[i] = phase_eval(kind, g, cos_theta[i])`` for 1-D float64 arrays."""
    for i in range(cos_theta.shape[0]):
        out[i] = phase_eval(kind, g, cos_theta[i])


@driver(parallel=False)
def phase_sample_cos_array(kind, g, u, out):
    """``out[i] = phase_sample_cos(kind, g, u[i])`` for 1-D float64 arrays."""
    for i in range(u.shape[0]):
        out[i] = phase_sample_cos(kind, g, u[i])


@driver(parallel=False)
def phase_sample_array(kind, g, u1, u2, w, out_dir, out_pdf):
    """Run :func:`phase_sample` over rows: ``w`` and ``out_dir`` are ``(n, 3)`` float64."""
    for i in range(u1.shape[0]):
        dx, dy, dz, pdf = phase_sample(kind, g, u1[i], u2[i], w[i, 0], w[i, 1], w[i, 2])
        out_dir[i, 0] = dx
        out_dir[i, 1] = dy
        out_dir[i, 2] = dz
        out_pdf[i] = pdf
