"""Rays: camera ray generation, world→index transform, ray/box clipping (scalar kernels)."""

from __future__ import annotations

import math

from ._jit import scalar

INF = math.inf


@scalar
def camera_ray(cam, i, j, width, height):
    """World origin and unit direction of the ray through the centre of pixel (i, j).

    ``cam`` is :meth:`pv_ambient.inputs.camera.Camera.params`; row j counts from the top.
    """
    su = 2.0 * (i + 0.5) / width - 1.0
    sv = 1.0 - 2.0 * (j + 0.5) / height
    aspect = cam[13]
    if cam[14] > 0.5:  # parallel projection
        s = cam[15]
        ox = cam[0] + su * s * aspect * cam[6] + sv * s * cam[9]
        oy = cam[1] + su * s * aspect * cam[7] + sv * s * cam[10]
        oz = cam[2] + su * s * aspect * cam[8] + sv * s * cam[11]
        return ox, oy, oz, cam[3], cam[4], cam[5]
    t = cam[12]
    dx = cam[3] + su * t * aspect * cam[6] + sv * t * cam[9]
    dy = cam[4] + su * t * aspect * cam[7] + sv * t * cam[10]
    dz = cam[5] + su * t * aspect * cam[8] + sv * t * cam[11]
    inv = 1.0 / math.sqrt(dx * dx + dy * dy + dz * dz)
    return cam[0], cam[1], cam[2], dx * inv, dy * inv, dz * inv


@scalar
def affine_point(m, x, y, z):
    """``m[:3, :3] @ (x, y, z) + m[:3, 3]`` for a 4×4 (or 3×4) matrix."""
    return (m[0, 0] * x + m[0, 1] * y + m[0, 2] * z + m[0, 3],
            m[1, 0] * x + m[1, 1] * y + m[1, 2] * z + m[1, 3],
            m[2, 0] * x + m[2, 1] * y + m[2, 2] * z + m[2, 3])


@scalar
def affine_vector(m, x, y, z):
    """``m[:3, :3] @ (x, y, z)``."""
    return (m[0, 0] * x + m[0, 1] * y + m[0, 2] * z,
            m[1, 0] * x + m[1, 1] * y + m[1, 2] * z,
            m[2, 0] * x + m[2, 1] * y + m[2, 2] * z)


@scalar
def _slab(o, d, lo, hi, t0, t1):
    """Intersect [t0, t1] with the parameter interval where o + t·d lies in [lo, hi]."""
    if d == 0.0:  # parallel to the slab: inside for all t or for none
        if o < lo or o > hi:
            return 1.0, 0.0
        return t0, t1
    a = (lo - o) / d
    b = (hi - o) / d
    if a > b:
        a, b = b, a
    return max(t0, a), min(t1, b)


@scalar
def ray_box(ox, oy, oz, dx, dy, dz, lo, hi):
    """Parameter interval ``(t0, t1)`` of the ray inside the box [lo, hi]; empty when t0 >= t1.

    The box is closed; a degenerate (zero-thickness) box gives an empty interval.
    """
    t0, t1 = -INF, INF
    t0, t1 = _slab(ox, dx, lo[0], hi[0], t0, t1)
    t0, t1 = _slab(oy, dy, lo[1], hi[1], t0, t1)
    t0, t1 = _slab(oz, dz, lo[2], hi[2], t0, t1)
    return t0, t1
