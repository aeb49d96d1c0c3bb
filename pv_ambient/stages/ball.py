"""The ball around each sample (docs/ambient_scattering.rst §1): its mean extinction σ̄ and mean
albedo ā from summed-area tables, and the variant the tube march reads near the grid's faces."""

from __future__ import annotations

import numpy as np

from .sat import mean_extinction


def ball_grid(sigma, albedo, spacing, radius, same_as_previous=None, scattering=None) -> np.ndarray:
    """σ̄ (mean extinction over the ball of world radius ``radius``) and the ball's mean albedo
    ā = mean(σs)/σ̄ per channel, at every data sample: float32 (nx, ny, nz, 4).

    ``sigma`` is σt on the samples (nx, ny, nz); ``albedo`` the albedo (nx, ny, nz, 3), or a
    function ``c ↦`` channel ``c`` on the samples (:meth:`pv_ambient.inputs.transfer.Optics.albedo_channel`),
    called once per channel so that one channel at a time is held. ``same_as_previous[c]`` says
    that channel ``c`` equals channel ``c − 1`` (a grey albedo), which then takes the same box
    mean; compared here when not given. ``scattering``: a function ``c ↦ σ·a_c`` (a new float32
    array, :meth:`pv_ambient.inputs.transfer.Optics.scattering_channel`) that replaces forming the
    product from ``albedo``.

    The box means are separable (:func:`pv_ambient.stages.sat.box_mean_separable`, done in place),
    so besides the result the stage holds σ̄ and one channel's σ·a: 2× the float32 volume."""
    from .._kernels.sat import ball_albedo_into

    if callable(albedo):
        channel = albedo
    else:
        albedo = np.asarray(albedo)

        def channel(c):
            return albedo[..., c]

        if same_as_previous is None:
            same_as_previous = (False,) + tuple(bool(np.array_equal(albedo[..., c], albedo[..., c - 1]))
                                                for c in (1, 2))
    same = tuple(same_as_previous) if same_as_previous is not None else (False, False, False)
    sigma = np.asarray(sigma)
    out = np.empty(sigma.shape + (4,), np.float32)
    sbar = mean_extinction(sigma, spacing, radius)
    for c in range(3):
        if c > 0 and same[c]:
            out[..., 1 + c] = out[..., c]  # grey albedo: one box mean serves every channel
            continue
        ms = scattering(c) if scattering is not None else np.multiply(sigma, channel(c), dtype=np.float32)
        ms = mean_extinction(ms, spacing, radius) if ms.size == 0 else _mean_in_place(ms, spacing, radius)
        ball_albedo_into(sbar, ms, out, 1 + c)
        del ms
    out[..., 0] = sbar
    return out


def ball_on_device(optics, sigma, spacing, radius, device_cache):
    """:func:`ball_grid` of ``optics`` (σt on the samples ``sigma``, :func:`pv_ambient.stages.medium.sigma_samples`)
    on the GPU (:func:`pv_ambient.device_stages.ball_grid`: σs per sample, the separable box means
    and the ball's albedo from the CPU's scalar functions; the device copy kept in ``device_cache``
    for the ray cast and the bake that read it). None without a device cache, for an empty grid or
    when it does not fit in the GPU's free memory: the caller then computes it on the CPU."""
    if device_cache is None or np.size(sigma) == 0:
        return None
    from ..backend import DeviceMemoryError
    from ..device_stages import ball_grid as on_device
    from ..inputs.transfer import COL_ALBEDO
    from .._kernels.medium import MODE_LUT
    from .sat import axis_weights, box_half_edges

    sigma = np.ascontiguousarray(sigma, np.float32)
    half = box_half_edges(spacing, radius)
    passes = [(ax, *axis_weights(sigma.shape[ax], float(a)), 1.0 / (2.0 * float(a)))
              for ax, a in enumerate(half) if a > 0.5]  # a half-edge ≤ ½ keeps each sample's cell
    lut = optics.mode == MODE_LUT
    cols = tuple(COL_ALBEDO + c if lut else c for c in range(3))
    medium = (int(optics.mode), np.ascontiguousarray(optics.field), optics.table, float(optics.lut_lo),
              float(optics.lut_inv), optics.aux)
    out = np.empty(sigma.shape + (4,), np.float32)
    try:
        on_device(device_cache, medium, sigma, passes, cols, optics.albedo_same_as_previous(), out)
    except DeviceMemoryError:
        return None
    return out


def _mean_in_place(field, spacing, radius):
    """:func:`pv_ambient.stages.sat.mean_extinction` of a float32 C-contiguous array of this module's
    own, overwritten (no copy)."""
    from .sat import box_half_edges, box_mean_separable

    if radius > 0.0:
        box_mean_separable(field, box_half_edges(spacing, radius), field)
    return field


def albedo_range(ball) -> tuple:
    """(min, max) of the ball-mean albedo ā over the medium (where σ̄ > 0), all channels; (0, 0)
    without a medium."""
    from .._kernels.sat import positive_range

    if ball.size == 0:
        return (0.0, 0.0)
    lo, hi = positive_range(np.ascontiguousarray(ball))
    return (float(lo), float(hi)) if lo <= hi else (0.0, 0.0)


def ball_inside(ball, spacing, radius) -> np.ndarray:
    """A copy of ``ball`` with σ̄ averaged over the part of each ball inside the grid.

    The tube march (docs/ambient_scattering.rst §3) starts where the light enters the medium, so
    its balls never straddle the entry face; averaging over the inside part gives the continuous
    march the same property (homogeneous medium, albedo 0: Φ equals Beer–Lambert exactly)."""
    ball = ball.copy()
    if radius > 0:
        half = 0.5 * radius * (4.0 * np.pi / 3.0) ** (1.0 / 3.0) / np.asarray(spacing)
        frac = np.ones(ball.shape[:3])
        for ax, n in enumerate(ball.shape[:3]):
            i = np.arange(n, dtype=np.float64)
            inside = np.clip(np.minimum(i + half[ax], n - 0.5) - np.maximum(i - half[ax], -0.5), 0.0, None)
            shape = [1, 1, 1]
            shape[ax] = n
            frac = frac * (inside / (2.0 * half[ax])).reshape(shape)
        ball[..., 0] = (ball[..., 0] / np.maximum(frac, 1e-12)).astype(np.float32)
    return ball
