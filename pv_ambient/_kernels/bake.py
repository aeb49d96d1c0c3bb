"""The bake of the lights' in-scattered light on the light grid (docs/models.rst, "Baked
in-scattering"): for an isotropic phase function the light a sample scatters toward the camera does
not depend on the view, so it is computed once per light change at the light-grid nodes from the
same per-light terms the ray cast evaluates per sample (:mod:`.raycast`), and read there by
:func:`.baked.baked_light`. The stage that calls it: :mod:`pv_ambient.stages.bake`.
"""

from __future__ import annotations

import math

from ._jit import driver, prange, scalar
from .baked import diffusion_layout
from .interp import trilinear4
from .models import AMBIENT_SCATTERING
from .phase import phase_eval
from .preint import tau_coord
from .raycast import INV_4PI_RC, ambient_light_with, ball_entry, light_at


@scalar(inline=True)
def bake_node(model, lights, grid, ambient, w2i, i2w, lo, step, nch, q, on_samples, i, j, k, out):
    """Node (i, j, k) of the baked in-scattered light (:func:`bake_incident`): adds the lights' sum
    to slot ``q`` (its first channel). A light's optical depth is read at the node itself (the
    node's value, nothing to interpolate), and so is the ball grid when the nodes are the data
    samples (``on_samples``)."""
    x = lo[0] + i * step[0]
    y = lo[1] + j * step[1]
    z = lo[2] + k * step[2]
    wx = i2w[0, 0] * x + i2w[0, 1] * y + i2w[0, 2] * z + i2w[0, 3]
    wy = i2w[1, 0] * x + i2w[1, 1] * y + i2w[1, 2] * z + i2w[1, 3]
    wz = i2w[2, 0] * x + i2w[2, 1] * y + i2w[2, 2] * z + i2w[2, 3]
    lkind, lvec, d2min = lights.kind, lights.vec, lights.d2min
    ball_tau = 0.0
    b1 = 0.0
    b2 = 0.0
    b3 = 0.0
    if model == AMBIENT_SCATTERING:
        ball = ambient.ball
        if on_samples:
            bs, b1, b2, b3 = ball[i, j, k, 0], ball[i, j, k, 1], ball[i, j, k, 2], ball[i, j, k, 3]
        else:
            bs, b1, b2, b3 = trilinear4(ball, x, y, z)
        ball_tau = ambient.radius * bs
    it, tt = tau_coord(ambient.D.shape[1], ambient.tau_lo_log, ambient.tau_dlog, ball_tau)
    for l in range(lkind.shape[0]):
        # isotropic phase and D: any view direction gives the same value (d = +z); the direct
        # term of :func:`direct_light_one` with T at the node
        er, eg, eb, ox, oy, oz = light_at(l, lights, wx, wy, wz)
        w = math.exp(-grid.tau[i, j, k, l]) * phase_eval(lights.pkind, lights.g, -oz)
        sr = er * w
        sg = eg * w
        sb = eb * w
        if model == AMBIENT_SCATTERING:  # the light's irradiance and direction at the node reused
            s = ball_entry(l, lights, ambient.radius, wx, wy, wz)
            mr, mg, mb = ambient_light_with(l, er, eg, eb, ox, oy, oz, s, x, y, z, 0.0, 0.0, 1.0, w2i, lights, grid,
                                            ambient, it, tt, b1, b2, b3)
            sr += mr
            sg += mg
            sb += mb
        if lkind[l] == 0:  # undo the 1/d² the lookup applies at the sample
            vx = wx - lvec[l, 0]
            vy = wy - lvec[l, 1]
            vz = wz - lvec[l, 2]
            d2 = max(vx * vx + vy * vy + vz * vz, d2min)
            sr *= d2
            sg *= d2
            sb *= d2
        out[i, j, k, q] += sr
        if nch == 3:
            out[i, j, k, q + 1] += sg
            out[i, j, k, q + 2] += sb


@driver
def bake_incident(model, lights, grid, ambient, w2i, i2w, lo, step, nch, q, out):
    """Adds to slot ``q`` of ``out`` the in-scattered light per unit albedo of ``lights`` at every
    light-grid node for an isotropic phase function (view-independent): per light ``E_j T_j p``
    (single scattering and diffusion's direct part) plus, for ambient scattering, ``E_j Φ_j D(r σ̄,
    ā)`` (D has no angle then), a point light's times ``max(d_j², d2min)`` (smooth:
    :func:`baked_light` divides by d² at the sample). Node (i, j, k) sits at data index
    ``lo + (i, j, k)·step``; ``w2i``/``i2w`` map world ↔ index. ``nch`` channels per slot: 1 when
    every channel is equal (the red one is kept), else 3; ``out`` is (m0, m1, m2, slots·nch), a slot
    per point light and the last for the directional lights
    (:func:`pv_ambient.stages.bake.bake_incident` bakes the lights one slot at a time, each from
    its own volumes)."""
    m0, m1, m2 = out.shape[0], out.shape[1], out.shape[2]
    ball = ambient.ball
    on_samples = (lo[0] == 0.0 and lo[1] == 0.0 and lo[2] == 0.0 and step[0] == 1.0 and step[1] == 1.0
                  and step[2] == 1.0 and ball.shape[0] == m0 and ball.shape[1] == m1 and ball.shape[2] == m2)
    for i in prange(m0):  # the last index innermost: ``out`` and the light grid are C-ordered
        for j in range(m1):
            for k in range(m2):
                bake_node(model, lights, grid, ambient, w2i, i2w, lo, step, nch, q, on_samples, i, j, k, out)


@scalar(inline=True)
def fold_node(diff, q, nch, i, j, k, out):
    """Node (i, j, k) of :func:`bake_diffusion`: adds diffusion's ``max(φ_c, 0)/4π`` to the ``nch``
    channels of slot ``q`` (its first channel)."""
    per, nd = diffusion_layout(diff.shape[3])
    for c in range(nch):
        out[i, j, k, q + c] += max(diff[i, j, k, per * min(c, nd - 1)], 0.0) * INV_4PI_RC


@scalar(inline=True)
def clear_node(q, n, i, j, k, out):
    """Node (i, j, k): channels ``q … q + n − 1`` of ``out`` set to 0 — a slot about to be baked
    again, since :func:`bake_node` adds into it (the GPU's bake clears its slots on the device, where
    the CPU's clears them in the host array)."""
    for c in range(n):
        out[i, j, k, q + c] = 0.0


@driver
def bake_diffusion(diff, q, nch, out):
    """Adds diffusion's ``max(φ_c, 0)/4π`` to slot ``q`` of the bake ``out`` (whose nodes are the
    data samples: trilinear interpolation is linear, so reading the slot equals reading φ beside
    it); ``diff`` (nx, ny, nz, n) in :func:`diffusion_layout`'s layout."""
    m0, m1, m2 = out.shape[0], out.shape[1], out.shape[2]
    for i in prange(m0):
        for j in range(m1):
            for k in range(m2):
                fold_node(diff, q, nch, i, j, k, out)
