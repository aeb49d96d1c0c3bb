"""The ``progressive`` model's Monte Carlo part (docs/progressive.rst): path samples of the *residual*
between the transport equation's radiance and a noise-free ray-cast model, with that model as a
control variate.

A noise-free model's picture is the ray march of ``N = ∫ T(t) σt(t) S(x_t) dt + T·L_b`` with its
source ``S = a·J + (1 − a)·Le`` (``J`` the model's in-scattered light per unit albedo,
:func:`.raycast.lit_source`). The path tracer's first free flight (:mod:`.pathtrace`) samples a
collision with density ``σt T``; evaluating the same source there, ``C = S(x_t)`` (and ``L_b`` when
the ray escapes), is an estimate of ``N`` with no other randomness. One residual sample is the
path sample minus it at the *same* collision (:func:`.pathtrace.trace_path_first` returns where
the path's primary ray first collided, and :func:`control_at` evaluates the source there — the
free flight is tracked once):

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
from .geometry import affine_point, affine_vector, camera_ray
from .pathtrace import add_sample, trace_path_first
from .raycast import lit_source, medium_albedo_emission, row_stride


@scalar
def control_at(model, view, medium, lights, grid, ambient, diffusion, bg, i, j, width, height, hit, t, k0, k1, f):
    """The control variate of a path sample whose primary ray first collided at distance ``t``
    (``hit`` 1.0; ``(k0, k1, f)`` the medium's table entries there: what
    :func:`.pathtrace.trace_path_first` returns): the ray-cast ``model``'s source there
    (``lights``, ``grid``, ``ambient``, ``diffusion``: its records), or the background ``bg`` where
    the primary ray left the medium (``hit`` 0). Returns ``(r, g, b)``."""
    if not hit > 0.0:
        return bg[0], bg[1], bg[2]
    cam, w2i = view.cam, view.w2i
    ox, oy, oz, dx, dy, dz = camera_ray(cam, i, j, width, height)
    px, py, pz = affine_point(w2i, ox, oy, oz)
    qx, qy, qz = affine_vector(w2i, dx, dy, dz)
    x = px + t * qx
    y = py + t * qy
    z = pz + t * qz
    ar, ag, ab, er, eg, eb = medium_albedo_emission(medium.mode, medium, k0, k1, f, x, y, z)
    lr, lg, lb = lit_source(model, grid.baked != 0, x, y, z, ox + t * dx, oy + t * dy, oz + t * dz, dx, dy, dz, w2i,
                            lights, grid, ambient, diffusion)
    return (ar * lr + (1.0 - ar) * er, ag * lg + (1.0 - ag) * eg, ab * lb + (1.0 - ab) * eb)


@scalar
def residual_pixel(view, medium, lights, paths, cmodel, clights, cgrid, cambient, cdiffusion, s0, s1, j, i, sum_rad,
                   sum_sq, sum_hit):
    """Add residual samples ``[s0, s1)`` of pixel (i, j) to the sums (as
    :func:`.pathtrace.pathtrace_pixel` adds path samples): path sample minus
    :func:`control_at` its first collision, of ray-cast model ``cmodel`` with its Lights, LightGrid, Ambient and
    Diffusion records (flat arguments: a parallel driver takes no nested records)."""
    H, W = sum_hit.shape
    pixel = j * W + i
    for s in range(s0, s1):
        r, gg, b, h, t, k0, k1, f = trace_path_first(view, medium, lights, paths, i, j, W, H, pixel, s)
        cr, cg, cb = control_at(cmodel, view, medium, clights, cgrid, cambient, cdiffusion, paths.bg, i, j, W, H,
                                h, t, k0, k1, f)
        add_sample(sum_rad, sum_sq, sum_hit, j, i, r - cr, gg - cg, b - cb, h)


@driver
def residual_image(view, medium, lights, paths, cmodel, clights, cgrid, cambient, cdiffusion, s0, s1, row0, row1,
                   sum_rad, sum_sq, sum_hit):
    """CPU driver: add residual samples ``[s0, s1)`` of every pixel in rows ``[row0, row1)`` to the
    float64 sums (:func:`.pathtrace.pathtrace_image`'s layout and row order)."""
    W = sum_hit.shape[1]
    n = row1 - row0
    stride = row_stride(n)
    for q in prange(n):
        j = row0 + (q * stride) % n
        for i in range(W):
            residual_pixel(view, medium, lights, paths, cmodel, clights, cgrid, cambient, cdiffusion, s0, s1, j, i,
                           sum_rad, sum_sq, sum_hit)
