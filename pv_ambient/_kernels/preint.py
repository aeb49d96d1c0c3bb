"""Monte Carlo kernels for the preintegrated ball tables D and F (docs/ambient_scattering.rst §2), and their lookups.

The reference problem, in optical units (σ_t = 1, so the ball radius is the optical radius
``R = τ``): a homogeneous ball of albedo ``a`` and phase function ``p`` (integer ``kind``,
anisotropy ``g``), vacuum outside, lit by a collimated front travelling along +z with unit
irradiance on the plane ``z = −R``. Paths that leave the ball are lost.

Unscattered irradiance inside the ball. The front has unit irradiance on the whole plane, but
only the ball holds medium, so the beam reaching ``y`` has travelled the chord from the ball's
entry point ``z_entry(y) = −sqrt(R² − y_x² − y_y²)``:

    E_dir(y) = exp(−(y_z − z_entry(y)))

(docs/ambient_scattering.rst §2); the simpler ``e^{−σ̄(y_z + r)}`` is exact only on the axis
(y_x = y_y = 0) and overestimates the attenuation elsewhere.

Quantities (both per unit front irradiance):

``D(θ, τ, g, a)`` [1/sr]
    ``D = ∫ p(ω'·ω_θ) L_diff(0, ω') dω'`` where ``L_diff(0, ω')`` is the radiance at the centre
    travelling along ω' made of light scattered at least once inside the ball (the direct beam is
    excluded) and ``ω_θ`` makes the angle θ with +z. D carries no σ_s and no albedo of the centre
    vertex: the ray caster adds ``σ_s(x)·E·Φ·D``.
``F(τ, g, a) = e^{−2τ} + E_diff``
    ``E_diff`` is the scattered irradiance crossing the exit plane ``z = +R`` at ``(0, 0, R)``:
    ``E_diff = ∫_{ω_z > 0} L_diff((0, 0, R), ω) ω_z dω``. The tables store ``E_diff`` and the
    lookup adds the exact ``e^{−2τ}``, so the exponential part is never interpolated.

Estimator (backward, :func:`walk`). From the start point, trace against the propagation
direction. Every collision is *forced* inside the ball (distance sampled from the exponential
truncated to the chord ``s_b``, path weight × ``1 − e^{−s_b}``), which keeps the relative error
bounded as τ → 0. At every vertex, next-event estimation to the beam: weight × ``E_dir(x)`` ×
``p(ẑ·ω_out)``, ω_out being the propagation direction leaving the vertex toward the previous one.
The incoming direction at the vertex is drawn from the one-sample mixture
``(1 − c)·p(ω_in·ω_out) + c·p(ẑ·ω_in)``, ``c = beam_mix·E_dir(x)``, weighted by
``p(ω_in·ω_out)/mixture``: the next vertex's beam connection, sharply peaked for |g| → 1, is then
importance sampled where the beam is bright, and deep walks keep plain phase sampling (weight 1).
Paths are traced with albedo 1; a contribution made at the k-th vertex (k scatterings inside the
ball, counting the vertex itself, not counting the centre or the exit point) is multiplied by
``a^k`` for every albedo node at once. Russian roulette on ``weight · a_max^k`` below ``W_RR``
keeps it unbiased; a hard cap of ``MAX_VERTICES`` vertices (never reached in practice: the mean
exit time from the centre of a τ = 50 ball is ~10³–5·10³ vertices and its tail is exponential)
bounds the loop.

D scores all θ nodes with one path: ω' is drawn from a defensive mixture — ``mix_uniform`` uniform
on the sphere, ``mix_axis`` the lobe ``p(ω'·ẑ)`` (the shape of singly scattered light at the
centre), the rest split evenly over the lobes ``p(ω'·ω_θj)`` around the θ nodes
(``ω_θj = (sin θ_j, 0, cos θ_j)``; L_diff is axially symmetric about z, so one azimuth suffices)
— and each node is scored with ``p(ω'·ω_θj)/pdf_mix``. For an isotropic phase the mixture is
uniform and every θ node receives the same score.

F starts at the exit point ``(0, 0, R)`` with a cosine-weighted direction about +z (pdf ω_z/π),
so its estimate is ``π·L_diff``.

Random numbers: ``rng.uniform(seed, stream, path, dim)`` only. A path's numbers depend on its
index, not on the thread or the τ node, so τ nodes share common random numbers (their errors are
correlated, which keeps the tables smooth in τ) and results do not depend on the thread count.
Drivers split the paths into ``n_chunks`` fixed chunks (prange over chunks) and write per-chunk
sums of the per-path estimates and of their squares (float64); the caller reduces them in order.

Lookups (:func:`d_lookup`, :func:`f_lookup`) are scalar kernels for the ray caster: linear in θ
(nodes uniform in θ ∈ [0, π]; one node = no θ dependence), linear in log τ between the log-spaced
nodes and linear in τ between τ = 0 and the first node, linear in albedo between the given nodes,
clamped at every end.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import driver, prange, scalar
from .phase import phase_eval, phase_sample
from .rng import uniform

STREAM_D = 0x7A11
STREAM_F = 0x7A12
STREAM_EXITANCE = 0x7A13

W_RR = 0.1
"""Russian roulette starts when weight · a_max^k falls below this; survivors get exactly W_RR."""

MAX_VERTICES = 1 << 18
"""Hard cap on vertices per path (a safety bound; see the module docstring)."""

PI = math.pi
FOUR_PI = 4.0 * math.pi
INV_4PI = 1.0 / (4.0 * math.pi)


# --- geometry and the beam -----------------------------------------------------------------


@scalar
def chord_to_sphere(R, x, y, z, dx, dy, dz):
    """Distance from a point inside (or on) the sphere |p| = R to the sphere along unit d."""
    b = x * dx + y * dy + z * dz
    # c <= 0 inside; clamp rounding at the surface.
    c = min(x * x + y * y + z * z - R * R, 0.0)
    root = math.sqrt(b * b - c)
    # Stable root of t² + 2bt + c = 0: avoid −b + root cancelling when b > 0.
    if b > 0.0:
        return -c / (b + root) if b + root > 0.0 else 0.0
    return root - b


@scalar
def beam_irradiance(R, x, y, z):
    """Unscattered front irradiance at (x, y, z) inside the ball: exp(−(z − z_entry)) with
    z_entry = −sqrt(R² − x² − y²), the exact chord from the ball's entry point (optical units)."""
    h = R * R - x * x - y * y
    ze = -math.sqrt(h) if h > 0.0 else 0.0
    depth = z - ze
    return math.exp(-depth) if depth > 0.0 else 1.0


# --- the backward walk ---------------------------------------------------------------------


@scalar
def walk(R, kind, g, beam_mix, x, y, z, wx, wy, wz, a_nodes, seed, stream, counter, dim0, apow, acc):
    """Backward random walk estimating the scattered radiance ``L_diff`` at (x, y, z) travelling
    along the unit propagation direction (wx, wy, wz), in a ball of optical radius R.

    Adds the estimate for albedo ``a_nodes[i]`` to ``acc[i]`` (``a_nodes`` ascending, float64;
    ``apow`` is scratch of the same length). Uses uniforms ``dim0, dim0 + 1, …`` of path
    ``counter`` of ``stream``. Returns the number of vertices visited.
    """
    n_a = a_nodes.shape[0]
    for i in range(n_a):
        apow[i] = 1.0
    top = n_a - 1
    w = 1.0
    dim = dim0
    nv = 0
    while nv < MAX_VERTICES:
        # Look back along −w: the chord to the sphere and the forced-collision weight.
        sb = chord_to_sphere(R, x, y, z, -wx, -wy, -wz)
        q = -math.expm1(-sb)
        if not (q > 0.0):
            break
        # Force a collision inside the chord: exponential truncated to [0, s_b].
        u = uniform(seed, stream, counter, dim)
        s = min(-math.log1p(-u * q), sb)
        w *= q
        x -= s * wx
        y -= s * wy
        z -= s * wz
        nv += 1
        for i in range(n_a):
            apow[i] *= a_nodes[i]
        # Next-event estimation to the beam: it scatters from +z into w at this vertex.
        e_dir = beam_irradiance(R, x, y, z)
        c = w * e_dir * phase_eval(kind, g, wz)
        for i in range(n_a):
            acc[i] += c * apow[i]
        # Russian roulette on the largest weight any albedo node still carries.
        wm = w * apow[top]
        if wm < W_RR:
            if not (wm > 0.0):
                break
            if uniform(seed, stream, counter, dim + 1) * W_RR >= wm:
                break
            w = W_RR / apow[top]
        # Sample the incoming propagation direction w_in. The walk needs p(w_in · w) (symmetric in
        # the cosine); the next vertex's NEE weighs p(ẑ · w_in). Draw from the one-sample mixture
        # (1 − c)·p(w_in · w) + c·p(ẑ · w_in) and weight by p(w_in · w) / mixture (≤ 1/(1 − c)).
        # c = beam_mix · E_dir(x): the beam lobe only where the beam is bright, so deep (long)
        # walks keep pure phase sampling and their weights do not drift.
        u1 = uniform(seed, stream, counter, dim + 2)
        u2 = uniform(seed, stream, counter, dim + 3)
        cm = beam_mix * e_dir
        if cm > 1e-3:
            if uniform(seed, stream, counter, dim + 4) < cm:
                nx, ny, nz, _ = phase_sample(kind, g, u1, u2, 0.0, 0.0, 1.0)
            else:
                nx, ny, nz, _ = phase_sample(kind, g, u1, u2, wx, wy, wz)
            pw = phase_eval(kind, g, nx * wx + ny * wy + nz * wz)
            w *= pw / ((1.0 - cm) * pw + cm * phase_eval(kind, g, nz))
            wx, wy, wz = nx, ny, nz
        else:
            wx, wy, wz, _ = phase_sample(kind, g, u1, u2, wx, wy, wz)
        dim += 5
    return nv


# --- drivers -------------------------------------------------------------------------------


@driver
def d_paths(R, kind, g, beam_mix, theta_cos, theta_sin, mix_uniform, mix_axis, a_nodes, seed, n_paths, out_sum, out_sq):
    """Per-chunk sums of the D estimates at the ball centre.

    ``out_sum``, ``out_sq``: ``(n_chunks, n_a, n_theta)`` float64, overwritten. Path ``p`` (0 ≤ p
    < n_paths) belongs to chunk ``p // ceil(n_paths / n_chunks)``.
    """
    n_chunks = out_sum.shape[0]
    n_a = a_nodes.shape[0]
    n_t = theta_cos.shape[0]
    per = (n_paths + n_chunks - 1) // n_chunks
    for ch in prange(n_chunks):
        apow = np.empty(n_a)
        acc = np.empty(n_a)
        for i in range(n_a):
            for j in range(n_t):
                out_sum[ch, i, j] = 0.0
                out_sq[ch, i, j] = 0.0
        p0 = ch * per
        p1 = min(n_paths, p0 + per)
        for p in range(p0, p1):
            # Draw ω' from the defensive mixture: uniform sphere, the lobe p(ω'·ẑ) (the shape of
            # singly scattered light at the centre), or the lobe p(ω'·ω_θj) of one θ node.
            u0 = uniform(seed, STREAM_D, p, 0)
            u1 = uniform(seed, STREAM_D, p, 1)
            u2 = uniform(seed, STREAM_D, p, 2)
            mix_lobes = 1.0 - mix_uniform - mix_axis
            if u0 < mix_uniform:
                wz = 1.0 - 2.0 * u1
                st = math.sqrt(max(0.0, 1.0 - wz * wz))
                wx = st * math.cos(2.0 * PI * u2)
                wy = st * math.sin(2.0 * PI * u2)
            elif u0 < mix_uniform + mix_axis:
                wx, wy, wz, _ = phase_sample(kind, g, u1, u2, 0.0, 0.0, 1.0)
            else:
                j = min(int((u0 - mix_uniform - mix_axis) / mix_lobes * n_t), n_t - 1)
                wx, wy, wz, _ = phase_sample(kind, g, u1, u2, theta_sin[j], 0.0, theta_cos[j])
            pdf = mix_uniform * INV_4PI
            if mix_axis > 0.0:
                pdf += mix_axis * phase_eval(kind, g, wz)
            if mix_lobes > 0.0:
                lobes = 0.0
                for j in range(n_t):
                    lobes += phase_eval(kind, g, wx * theta_sin[j] + wz * theta_cos[j])
                pdf += mix_lobes * lobes / n_t
            # Radiance arriving at the centre along ω'.
            for i in range(n_a):
                acc[i] = 0.0
            walk(R, kind, g, beam_mix, 0.0, 0.0, 0.0, wx, wy, wz, a_nodes, seed, STREAM_D, p, 3, apow, acc)
            # Score every θ node.
            for j in range(n_t):
                ratio = phase_eval(kind, g, wx * theta_sin[j] + wz * theta_cos[j]) / pdf
                for i in range(n_a):
                    v = ratio * acc[i]
                    out_sum[ch, i, j] += v
                    out_sq[ch, i, j] += v * v


@driver
def f_paths(R, kind, g, beam_mix, a_nodes, seed, n_paths, out_sum, out_sq):
    """Per-chunk sums of the E_diff estimates at (0, 0, R) (scattered irradiance through the
    exit plane). ``out_sum``, ``out_sq``: ``(n_chunks, n_a)`` float64, overwritten."""
    n_chunks = out_sum.shape[0]
    n_a = a_nodes.shape[0]
    per = (n_paths + n_chunks - 1) // n_chunks
    for ch in prange(n_chunks):
        apow = np.empty(n_a)
        acc = np.empty(n_a)
        for i in range(n_a):
            out_sum[ch, i] = 0.0
            out_sq[ch, i] = 0.0
        p0 = ch * per
        p1 = min(n_paths, p0 + per)
        for p in range(p0, p1):
            # Cosine-weighted propagation direction about +z (pdf ω_z/π).
            u1 = uniform(seed, STREAM_F, p, 0)
            u2 = uniform(seed, STREAM_F, p, 1)
            st = math.sqrt(u1)
            wz = math.sqrt(1.0 - u1)
            wx = st * math.cos(2.0 * PI * u2)
            wy = st * math.sin(2.0 * PI * u2)
            for i in range(n_a):
                acc[i] = 0.0
            walk(R, kind, g, beam_mix, 0.0, 0.0, R, wx, wy, wz, a_nodes, seed, STREAM_F, p, 2, apow, acc)
            for i in range(n_a):
                v = PI * acc[i]
                out_sum[ch, i] += v
                out_sq[ch, i] += v * v


@driver
def exitance_paths(R, kind, g, beam_mix, a_nodes, seed, n_paths, out_sum, out_sq):
    """Per-chunk sums of estimates of the total *scattered* power leaving the ball (validation:
    at albedo 1 it plus the unscattered power equals the incident power πR²).

    Uniform surface points, cosine-weighted outgoing directions, the same :func:`walk` as D and
    F. ``out_sum``, ``out_sq``: ``(n_chunks, n_a)`` float64, overwritten."""
    n_chunks = out_sum.shape[0]
    n_a = a_nodes.shape[0]
    per = (n_paths + n_chunks - 1) // n_chunks
    scale = PI * FOUR_PI * R * R
    for ch in prange(n_chunks):
        apow = np.empty(n_a)
        acc = np.empty(n_a)
        for i in range(n_a):
            out_sum[ch, i] = 0.0
            out_sq[ch, i] = 0.0
        p0 = ch * per
        p1 = min(n_paths, p0 + per)
        for p in range(p0, p1):
            # Uniform point on the sphere: outward normal n.
            nz = 1.0 - 2.0 * uniform(seed, STREAM_EXITANCE, p, 0)
            sn = math.sqrt(max(0.0, 1.0 - nz * nz))
            phi = 2.0 * PI * uniform(seed, STREAM_EXITANCE, p, 1)
            nx = sn * math.cos(phi)
            ny = sn * math.sin(phi)
            # Cosine-weighted direction about n, in Duff et al.'s frame.
            u3 = uniform(seed, STREAM_EXITANCE, p, 2)
            u4 = uniform(seed, STREAM_EXITANCE, p, 3)
            lx = math.sqrt(u3) * math.cos(2.0 * PI * u4)
            ly = math.sqrt(u3) * math.sin(2.0 * PI * u4)
            lz = math.sqrt(1.0 - u3)
            sign = math.copysign(1.0, nz)
            aa = -1.0 / (sign + nz)
            bb = nx * ny * aa
            wx = lx * (1.0 + sign * nx * nx * aa) + ly * bb + lz * nx
            wy = lx * (sign * bb) + ly * (sign + ny * ny * aa) + lz * ny
            wz = lx * (-sign * nx) + ly * (-ny) + lz * nz
            for i in range(n_a):
                acc[i] = 0.0
            walk(
                R, kind, g, beam_mix, R * nx, R * ny, R * nz, wx, wy, wz, a_nodes, seed, STREAM_EXITANCE, p, 4, apow, acc
            )
            for i in range(n_a):
                v = scale * acc[i]
                out_sum[ch, i] += v
                out_sq[ch, i] += v * v


# --- lookups for the ray caster ------------------------------------------------------------


@scalar
def tau_coord(n_tau, tau_lo_log, tau_dlog, tau):
    """Locate τ among the nodes ``0, exp(tau_lo_log + k·tau_dlog)`` (k = 0 … n_tau − 2).

    Returns ``(i, t)``: τ lies between nodes i and i + 1 at fraction t ∈ [0, 1]; linear in τ
    below the first log node, linear in log τ above, clamped at both ends (τ ≤ 0 or NaN → node 0).
    """
    return tau_coord_in(np.float64, n_tau, tau_lo_log, tau_dlog, tau)


@scalar(inline=True)
def tau_coord_in(F, n_tau, tau_lo_log, tau_dlog, tau):
    """:func:`tau_coord` with its ``exp``, ``log`` and divisions, and the fraction returned, in the
    float type ``F`` (``np.float64`` or ``np.float32``): the one formula. Why: the CUDA ray cast
    locates τ in float32 (:func:`.raycast.direct_ambient_light`), where a float64 ``log``, ``exp`` and
    division are long sequences whose registers every thread of the kernel pays for; the fraction
    weighs float32 table entries."""
    if not (tau > 0.0):
        return 0, F(0.0)
    tau1 = math.exp(F(tau_lo_log))
    if tau < tau1:
        return 0, F(tau) / tau1
    u = (math.log(F(tau)) - F(tau_lo_log)) / F(tau_dlog)
    if not (u < n_tau - 2):
        return n_tau - 2, F(1.0)
    k = int(u)
    return k + 1, u - F(k)


@scalar
def theta_coord(n_theta, cos_theta):
    """Locate θ = acos(cos_theta) among ``n_theta`` nodes uniform in [0, π]: ``(j, t)``."""
    return theta_coord_in(np.float64, n_theta, cos_theta)


@scalar(inline=True)
def theta_coord_in(F, n_theta, cos_theta):
    """:func:`theta_coord` with its ``acos``, division and fraction in the float type ``F``
    (:func:`tau_coord_in`)."""
    if n_theta < 2:
        return 0, F(0.0)
    c = min(max(cos_theta, -1.0), 1.0)
    u = math.acos(F(c)) * F(n_theta - 1) / F(PI)
    j = min(int(u), n_theta - 2)
    return j, min(u - F(j), F(1.0))


@scalar
def albedo_coord(a_nodes, a):
    """Locate albedo ``a`` among ascending ``a_nodes``: ``(i, t)``, clamped at both ends."""
    return albedo_coord_in(np.float64, a_nodes, a)


@scalar(inline=True)
def albedo_coord_in(F, a_nodes, a):
    """:func:`albedo_coord` with its division and fraction in the float type ``F`` (:func:`tau_coord_in`)."""
    n = a_nodes.shape[0]
    if n < 2 or not (a > a_nodes[0]):
        return 0, F(0.0)
    if a >= a_nodes[n - 1]:
        return n - 2, F(1.0)
    i = 0
    while a_nodes[i + 1] <= a:
        i += 1
    return i, F(a - a_nodes[i]) / F(a_nodes[i + 1] - a_nodes[i])


@scalar
def d_lookup(D, a_nodes, tau_lo_log, tau_dlog, cos_theta, tau, a):
    """D(θ, τ, a) [1/sr] from a table slice ``D[n_a, n_tau, n_theta]`` (float32).

    ``cos_theta``: cosine between the light's propagation direction and the scattered direction
    (toward the camera); ``tau = r·σ̄``; ``a`` the albedo. Trilinear in (albedo, τ-coordinate,
    θ), see :func:`tau_coord`, :func:`theta_coord`, :func:`albedo_coord`.
    """
    n_a, n_tau, n_t = D.shape
    ia, ta = albedo_coord(a_nodes, a)
    it, tt = tau_coord(n_tau, tau_lo_log, tau_dlog, tau)
    jt, st = theta_coord(n_t, cos_theta)
    ia1 = min(ia + 1, n_a - 1)
    jt1 = min(jt + 1, n_t - 1)
    it1 = it + 1
    lo = (1.0 - tt) * ((1.0 - st) * D[ia, it, jt] + st * D[ia, it, jt1]) + tt * (
        (1.0 - st) * D[ia, it1, jt] + st * D[ia, it1, jt1]
    )
    hi = (1.0 - tt) * ((1.0 - st) * D[ia1, it, jt] + st * D[ia1, it, jt1]) + tt * (
        (1.0 - st) * D[ia1, it1, jt] + st * D[ia1, it1, jt1]
    )
    return (1.0 - ta) * lo + ta * hi


@scalar(force_inline=True)
def _d_at(F, D, ia, it, tt, jt, st):
    one = F(1.0)
    n_t = D.shape[2]
    jt1 = min(jt + 1, n_t - 1)
    return ((one - tt) * ((one - st) * D[ia, it, jt] + st * D[ia, it, jt1])
            + tt * ((one - st) * D[ia, it + 1, jt] + st * D[ia, it + 1, jt1]))


@scalar(force_inline=True)
def _d_albedo(F, D, a_nodes, it, tt, jt, st, a):
    ia, ta = albedo_coord_in(F, a_nodes, a)
    lo = _d_at(F, D, ia, it, tt, jt, st)
    if ta == 0.0:
        return lo
    return (F(1.0) - ta) * lo + ta * _d_at(F, D, min(ia + 1, D.shape[0] - 1), it, tt, jt, st)


@scalar(force_inline=True)
def d_lookup3(D, a_nodes, it, tt, cos_theta, ar, ag, ab):
    """D at one (θ, τ) for three albedos (rgb): :func:`d_lookup` with the τ and θ coordinates located
    once (``it, tt`` from :func:`tau_coord`)."""
    return d_lookup3_in(np.float64, D, a_nodes, it, tt, cos_theta, ar, ag, ab)


@scalar(force_inline=True)
def d_lookup3_in(F, D, a_nodes, it, tt, cos_theta, ar, ag, ab):
    """:func:`d_lookup3` with the θ and albedo coordinates and the interpolation in the float type
    ``F`` (``tt`` of that type too, :func:`tau_coord_in`): the table is float32, and the
    GPU's ball term interpolates it in float32 (:func:`.raycast.ambient_light_with`)."""
    jt, st = theta_coord_in(F, D.shape[2], cos_theta)
    dr = _d_albedo(F, D, a_nodes, it, tt, jt, st, ar)
    dg = dr if ag == ar else _d_albedo(F, D, a_nodes, it, tt, jt, st, ag)
    if ab == ar:
        db = dr
    elif ab == ag:
        db = dg
    else:
        db = _d_albedo(F, D, a_nodes, it, tt, jt, st, ab)
    return dr, dg, db


@scalar
def f_lookup(F_diff, a_nodes, tau_lo_log, tau_dlog, tau, a):
    """Front transfer factor ``F(τ, a) = e^{−2τ} + E_diff(τ, a)`` from ``F_diff[n_a, n_tau]``
    (float32, the scattered part): the exponential is exact, E_diff bilinear (albedo, τ-coordinate)."""
    n_a, n_tau = F_diff.shape
    ia, ta = albedo_coord(a_nodes, a)
    it, tt = tau_coord(n_tau, tau_lo_log, tau_dlog, tau)
    ia1 = min(ia + 1, n_a - 1)
    it1 = it + 1
    lo = (1.0 - tt) * F_diff[ia, it] + tt * F_diff[ia, it1]
    hi = (1.0 - tt) * F_diff[ia1, it] + tt * F_diff[ia1, it1]
    t = tau if tau > 0.0 else 0.0
    return math.exp(-2.0 * t) + (1.0 - ta) * lo + ta * hi


@driver(parallel=False)
def d_lookup_array(D, a_nodes, tau_lo_log, tau_dlog, cos_theta, tau, a, out):
    """``out[k] = d_lookup(..., cos_theta[k], tau[k], a[k])`` over 1-D float64 arrays (tests)."""
    for k in range(out.shape[0]):
        out[k] = d_lookup(D, a_nodes, tau_lo_log, tau_dlog, cos_theta[k], tau[k], a[k])


@driver(parallel=False)
def f_lookup_array(F_diff, a_nodes, tau_lo_log, tau_dlog, tau, a, out):
    """``out[k] = f_lookup(..., tau[k], a[k])`` over 1-D float64 arrays (tests)."""
    for k in range(out.shape[0]):
        out[k] = f_lookup(F_diff, a_nodes, tau_lo_log, tau_dlog, tau[k], a[k])
