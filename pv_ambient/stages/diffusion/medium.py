"""Checked inputs of the diffusion stage (docs/diffusion.rst): the medium (σt, albedo) validated once per
scene as :class:`DiffusionMedium`, and the array and mean-cosine checks the other modules share.

This module imports numpy and the input checks only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...inputs.validation import check_array, check_real

__all__ = ["DiffusionMedium", "check_mean_cosine"]


def check_mean_cosine(g, shape):
    """g as a float or an array broadcast to ``shape`` (a phase object gives its mean cosine)."""
    if hasattr(g, "mean_cosine"):
        g = g.mean_cosine
    if np.ndim(g) == 0:
        return check_real(g, "g", lo=-1.0, hi=1.0, lo_open=True, hi_open=True)
    arr = check_array(g, "g", ndim=3)
    if arr.shape != tuple(shape):
        raise ValueError(f"g must be a number or an array of shape {tuple(shape)}, got shape {arr.shape}")
    if np.any(np.abs(arr) >= 1.0):
        raise ValueError(f"g must lie in (-1, 1), got values in [{arr.min()}, {arr.max()}]")
    return arr


@dataclass(frozen=True, eq=False)
class DiffusionMedium:
    """Extinction and albedo of the medium on the data grid, checked once (finite, σt ≥ 0,
    albedo in [0, 1], matching shapes) so that per-light sources and solves need not re-scan them.

    Build it with :meth:`from_arrays`; the fields are taken as valid without further checks.

    Attributes
    ----------
    sigma_t : numpy.ndarray
        float64 (nx, ny, nz), extinction at the data samples (1/world unit).
    albedo : numpy.ndarray
        Floating (nx, ny, nz) or (nx, ny, nz, C), single-scattering albedo (a float32 albedo
        stays float32).
    """

    sigma_t: np.ndarray
    albedo: np.ndarray

    @classmethod
    def from_arrays(cls, sigma_t, albedo):
        """Check ``sigma_t`` (converted to float64) and ``albedo`` and wrap them.

        >>> import numpy as np
        >>> m = DiffusionMedium.from_arrays(np.ones((2, 2, 2), np.float32), np.full((2, 2, 2, 3), 0.5))
        >>> m.sigma_t.dtype, m.shape
        (dtype('float64'), (2, 2, 2))
        """
        sig = check_array(sigma_t, "sigma_t", ndim=3, lo=0.0)
        alb = check_array(albedo, "albedo", ndim=(3, 4), dtype="float", lo=0.0, hi=1.0)
        if alb.shape[:3] != sig.shape:
            raise ValueError(f"albedo must have shape {sig.shape} or {sig.shape + ('C',)}, got {alb.shape}")
        return cls(sig, alb)

    @property
    def shape(self) -> tuple:
        """Grid shape (nx, ny, nz)."""
        return self.sigma_t.shape
