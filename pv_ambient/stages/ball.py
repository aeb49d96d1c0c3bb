"""The ball around each sample (docs/ambient_scattering.rst §1): its mean extinction σ̄ and mean
albedo ā from summed-area tables, and the variant the tube march reads near the grid's faces."""

from __future__ import annotations

import numpy as np

from .sat import mean_extinction


def ball_grid(sigma, albedo, spacing, radius) -> np.ndarray:
    """σ̄ (mean extinction over the ball of world radius ``radius``) and the ball's mean albedo
    ā = mean(σs)/σ̄ per channel, at every data sample: float32 (nx, ny, nz, 4).

    ``sigma`` is σt on the samples (nx, ny, nz), ``albedo`` the albedo (nx, ny, nz, 3). A grey
    albedo takes one box mean for every channel."""
    from .._kernels.sat import ball_albedo

    out = np.zeros(sigma.shape + (4,), np.float32)
    sbar = mean_extinction(sigma, spacing, radius)
    out[..., 0] = sbar
    abar = np.empty(sigma.shape, np.float32)
    for c in range(3):
        if c > 0 and np.array_equal(albedo[..., c], albedo[..., c - 1]):
            out[..., 1 + c] = out[..., c]  # grey albedo: one box mean serves every channel
            continue
        ball_albedo(sbar, mean_extinction(np.multiply(sigma, albedo[..., c]), spacing, radius), abar)
        out[..., 1 + c] = abar
    return out


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
