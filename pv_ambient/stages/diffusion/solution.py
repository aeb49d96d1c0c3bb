"""The diffusion stage's result and camera pass (docs/diffusion.rst §4): :class:`DiffusionSolution` (φ and
F on the data grid, trilinear lookup, packing for a kernel) and :func:`camera_source`, the
multiply-scattered radiance source ``σs (φ + 3 g F·ω_o) / (4π)`` at a sample (ω_o toward the
camera, g the phase function's mean cosine).

This module imports numpy and scipy only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["DiffusionSolution", "camera_source"]


@dataclass(eq=False)
class DiffusionSolution:
    """Fluence and flux of the multiply-scattered light on the data grid.

    Attributes
    ----------
    phi : numpy.ndarray
        Fluence φ (W/m² for sources in W/m³), float64 (the solver's iterate: ``residual`` and
        ``power`` hold for it, and it warm-starts the next solve), (nx, ny, nz) or (nx, ny, nz, C);
        float32 when interpolated from a solve on a coarser grid (docs/diffusion.rst, "Solve
        resolution").
    flux : numpy.ndarray or None
        Flux F in world components, float32, (nx, ny, nz, 3) or (nx, ny, nz, C, 3); None from a
        coarser grid's solve without a first-moment source (an isotropic phase function's radiance
        has no flux term, so it is not interpolated).
    iterations : int
        Conjugate-gradient iterations, summed over channels and outer (flux-limiter) passes.
    residual : float
        Largest final relative residual ``‖b − Aφ‖₂/‖b‖₂`` over the solves.
    converged : bool
        Every solve reached ``tol`` (and every flux-limited channel its ``outer_tol``).
    power : dict
        ``"source"`` (Σ Q0 V), ``"absorbed"`` (Σ σa φ V), ``"escaped"`` (Σ over box faces of
        A F·n), in W, float64 arrays of shape (C,) (shape () for one channel), from the float64
        solution.
    solves : int
        Linear solves run (channels with equal albedo and proportional sources share one).
    outer_iterations : int
        Flux-limiter passes (0 for plain diffusion), summed over solved channels.
    time : float
        Wall-clock seconds of the whole call.
    """

    phi: np.ndarray
    flux: np.ndarray
    iterations: int
    residual: float
    converged: bool
    power: dict = field(default_factory=dict)
    solves: int = 0
    outer_iterations: int = 0
    time: float = 0.0

    @property
    def channels(self) -> int | None:
        """Number of channels, or None for a single-channel solution."""
        return self.phi.shape[3] if self.phi.ndim == 4 else None

    def packed(self, dtype=np.float32) -> np.ndarray:
        """φ and F interleaved for a kernel: (nx, ny, nz, 4·C) with ``[..., 4c:4c+4] =
        (φ_c, Fx_c, Fy_c, Fz_c)`` (world components); C = 1 for a single-channel solution."""
        phi = self.phi if self.phi.ndim == 4 else self.phi[..., None]
        F = self.flux if self.flux.ndim == 5 else self.flux[..., None, :]
        out = np.empty(phi.shape + (4,), dtype)  # (nx, ny, nz, C, 4), written in place: no float64 copy
        out[..., 0] = phi
        out[..., 1:] = F
        return out.reshape(out.shape[:3] + (-1,))

    def at(self, points):
        """φ and F trilinear at data-index points ``points`` (N, 3), clamped to the grid.

        Returns ``(phi, F)`` with shapes (N,) and (N, 3), or (N, C) and (N, C, 3).
        """
        from scipy.ndimage import map_coordinates

        p = np.asarray(points, np.float64)
        if p.ndim != 2 or p.shape[1] != 3:
            raise ValueError(f"points must have shape (N, 3), got {p.shape}")
        coords = p.T
        packed = self.packed(np.float64)
        vals = np.stack([map_coordinates(packed[..., m], coords, order=1, mode="nearest")
                         for m in range(packed.shape[-1])], axis=-1).reshape(len(p), -1, 4)
        phi, F = vals[..., 0], vals[..., 1:]
        if self.phi.ndim == 3:
            return phi[:, 0], F[:, 0]
        return phi, F


def camera_source(sigma_s, phi, F, g, omega_o, *, clamp=True):
    """Multiply-scattered radiance source ``σs (φ + 3 g F·ω_o) / (4π)`` (W/m³/sr) at samples.

    Parameters
    ----------
    sigma_s : array (...) or (..., C)
        Scattering coefficient at the samples.
    phi : array (...) or (..., C)
        Fluence at the samples.
    F : array (..., 3) or (..., C, 3)
        Flux at the samples (world components).
    g : float
        Mean cosine of the phase function.
    omega_o : array (..., 3)
        Unit direction from the sample toward the camera (world).
    clamp : bool, default: True
        Clamp ``φ + 3gF·ω_o`` at 0: P1's linear angular term goes negative where
        ``3|g||F| > φ`` (strong flux near a boundary with strongly peaked phase functions).
    """
    phi = np.asarray(phi, np.float64)
    F = np.asarray(F, np.float64)
    om = np.asarray(omega_o, np.float64)
    if F.ndim == om.ndim + 1:
        om = om[..., None, :]
    val = phi + 3.0 * float(g) * np.sum(F * om, axis=-1)
    if clamp:
        val = np.maximum(val, 0.0)
    return np.asarray(sigma_s, np.float64) * val / (4.0 * math.pi)
