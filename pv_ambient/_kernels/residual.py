"""The ``progressive`` model's Monte Carlo part (docs/progressive.rst): path samples of the *residual*
between the transport equation's radiance and a noise-free ray-cast model, with that model as a
control variate.

A noise-free model's picture is the ray march of ``N = ∫ T(t) σt(t) S(x_t) dt + T·L_b`` with its
source ``S = a·J + (1 − a)·Le`` (``J`` the model's in-scattered light per unit albedo,
:func:`.raycast.lit_source`). The path tracer's first free flight (:mod:`.pathtrace`) samples a
collision with density ``σt T``; evaluating the same source there, ``C = S(x_t)`` (and ``L_b`` when
the ray escapes), is an estimate of ``N`` with no other randomness. One residual sample is the
path sample minus it, computed from the *same* random numbers (the first ``delta_track`` of
:func:`.pathtrace.trace_path` draws dimensions ``0, 1, …`` of the path's key, and so does
:func:`control_sample`):

``R = X − C``, ``E[R] = L − N_c``,

``L`` the transport equation's radiance (``E[X]``) and ``N_c`` the exact (continuous) integral the
march approximates. The model's picture ``N + mean(R)`` is therefore noise-free at zero samples
and converges to ``L + (N − N_c)``: the transport solution up to the march's quadrature error
(a step of ¼–1 data spacing through a trilinear field; measured in docs/progressive.rst). The
variance of ``R`` lacks what the first collision's position contributes to ``X`` wherever the
model is close to the truth — the emission at the first collision cancels exactly.
"""

from __future__ import annotations

from ._jit import driver, prange, scalar
from .geometry import affine_point, affine_vector, camera_ray, ray_box
from .pathtrace import add_sample, trace_path
from .raycast import lit_source, medium_albedo_emission
from .rng import key
from .tracking import delta_track


@scalar
def control_sample(model, view, medium, lights, grid, ambient, diffusion, bg, seed, i, j, width, height, pixel,
                   sample):
    """The control variate of path sample (pixel, sample): the first free flight of
    :func:`.pathtrace.trace_path` (the same random numbers, so the same collision) and the ray-cast
    ``model``'s source there (``lights``, ``grid``, ``ambient``, ``diffusion``: its records), or the
    background ``bg`` when the ray leaves the medium. Returns ``(r, g, b)``."""
    cam, w2i, lo, hi = view.cam, view.w2i, view.lo, view.hi
    k = key(seed, pixel, sample)
    ox, oy, oz, dx, dy, dz = camera_ray(cam, i, j, width, height)
    px, py, pz = affine_point(w2i, ox, oy, oz)
    qx, qy, qz = affine_vector(w2i, dx, dy, dz)
    t0, t1 = ray_box(px, py, pz, qx, qy, qz, lo, hi)
    t0 = max(t0, 0.0)
    if not t0 < t1:
        return bg[0], bg[1], bg[2]
    collided, t, sig, k0, k1, f, _ = delta_track(px, py, pz, qx, qy, qz, t0, t1, medium, k, 0)
    if not collided:
        return bg[0], bg[1], bg[2]
    x = px + t * qx
    y = py + t * qy
    z = pz + t * qz
    ar, ag, ab, er, eg, eb = medium_albedo_emission(medium, k0, k1, f, x, y, z)
    lr, lg, lb = lit_source(model, x, y, z, ox + t * dx, oy + t * dy, oz + t * dz, dx, dy, dz, w2i, lights, grid,
                            ambient, diffusion)
    return (ar * lr + (1.0 - ar) * er, ag * lg + (1.0 - ag) * eg, ab * lb + (1.0 - ab) * eb)


@scalar
def residual_pixel(view, medium, lights, paths, cmodel, clights, cgrid, cambient, cdiffusion, s0, s1, j, i, sum_rad,
                   sum_sq, sum_hit):
    """Add residual samples ``[s0, s1)`` of pixel (i, j) to the sums (as
    :func:`.pathtrace.pathtrace_pixel` adds path samples): path sample minus
    :func:`control_sample` of ray-cast model ``cmodel`` with its Lights, LightGrid, Ambient and
    Diffusion records (flat arguments: a parallel driver takes no nested records)."""
    H, W = sum_hit.shape
    pixel = j * W + i
    for s in range(s0, s1):
        r, gg, b, h = trace_path(view, medium, lights, paths, i, j, W, H, pixel, s)
        cr, cg, cb = control_sample(cmodel, view, medium, clights, cgrid, cambient, cdiffusion, paths.bg, paths.seed,
                                    i, j, W, H, pixel, s)
        add_sample(sum_rad, sum_sq, sum_hit, j, i, r - cr, gg - cg, b - cb, h)


@driver
def residual_image(view, medium, lights, paths, cmodel, clights, cgrid, cambient, cdiffusion, s0, s1, row0, row1,
                   sum_rad, sum_sq, sum_hit):
    """CPU driver: add residual samples ``[s0, s1)`` of every pixel in rows ``[row0, row1)`` to the
    float64 sums (:func:`.pathtrace.pathtrace_image`'s layout)."""
    W = sum_hit.shape[1]
    for j in prange(row0, row1):
        for i in range(W):
            residual_pixel(view, medium, lights, paths, cmodel, clights, cgrid, cambient, cdiffusion, s0, s1, j, i,
                           sum_rad, sum_sq, sum_hit)
