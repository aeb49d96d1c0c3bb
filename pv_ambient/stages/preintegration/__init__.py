"""Preintegrated homogeneous-ball tables D and F (docs/ambient_scattering.rst §2): estimate, tabulate, store, look up.

The ambient-scattering model replaces the medium around every sample by a homogeneous ball of
radius r and optical radius ``τ = r·σ̄``, albedo ``a`` and the scene's phase function, lit by a
collimated front of unit irradiance travelling along +z (vacuum outside; paths that leave are
lost). Two quantities are preintegrated by Monte Carlo (kernels in ``_kernels/preint.py``, whose
docstring gives the estimator), each with its standard error:

``D(θ, τ, a)`` [1/sr]
    radiance scattered at the ball's centre into the direction at angle θ to +z by light that has
    scattered at least once inside the ball, per unit σ_s at the centre and unit front irradiance:
    ``D = ∫ p(ω'·ω_θ) L_diff(0, ω') dω'``. The direct beam is excluded, so D → 0 as τ → 0 or
    a → 0: for small τ, D ≈ a·τ·∫p(ω'·ω_θ) p(ẑ·ω') dω' = a·τ·p_HG(g²)(cos θ) for HG (two HG lobes
    convolve to the HG lobe of g²), a·τ/(4π) when isotropic. The ray caster adds ``σ_s(x)·E·Φ·D``.
``F(τ, a) = e^{−2τ} + E_diff``
    transfer factor of a front through one ball: ``E_diff`` is the scattered irradiance crossing
    the exit plane z = +r at (0, 0, r). F(0) = 1, 0 < F ≤ 1, F = e^{−2τ} at a = 0; for small τ,
    E_diff ≈ 4π·a·τ·∫₀¹ p(μ) μ² dμ (a·τ/3 when isotropic).

The unscattered irradiance inside the ball uses the exact chord from the ball's entry point,
``exp(−σ̄(y_z − z_entry(y)))`` with ``z_entry = −sqrt(r² − y_x² − y_y²)`` (docs/ambient_scattering.rst
§2); the simpler ``e^{−σ̄(y_z + r)}`` holds only on the z axis.

Modules
-------
:mod:`~pv_ambient.stages.preintegration.estimator`
    the Monte Carlo estimator at arbitrary nodes (:func:`simulate_ball`, :func:`ball_exitance`);
:mod:`~pv_ambient.stages.preintegration.table`
    the table slice of one phase function: node sets, quality presets, :func:`compute_table`,
    :class:`PreintegratedTable` and its lookups;
:mod:`~pv_ambient.stages.preintegration.store`
    the disk cache and the shipped default: :func:`get_table`, :func:`build_default`.

Measured costs and standard errors: docs/ambient_scattering.rst §2.
This package imports only numpy, the kernels and (lazily) tqdm/platformdirs: no pyvista or vtk.
"""

from __future__ import annotations

from .estimator import BallEstimate, ball_exitance, simulate_ball
from .store import DEFAULT_PHASES, DEFAULT_TABLE_PATH, build_default, cache_dir, get_table
from .table import (
    ALBEDO_NODES,
    QUALITY_PRESETS,
    TAU_MAX,
    TAU_MIN,
    PreintegratedTable,
    albedo_nodes_for,
    compute_table,
    tau_nodes,
    theta_nodes,
)

__all__ = [
    "ALBEDO_NODES",
    "DEFAULT_PHASES",
    "DEFAULT_TABLE_PATH",
    "QUALITY_PRESETS",
    "TAU_MAX",
    "TAU_MIN",
    "BallEstimate",
    "PreintegratedTable",
    "albedo_nodes_for",
    "ball_exitance",
    "build_default",
    "cache_dir",
    "compute_table",
    "get_table",
    "simulate_ball",
    "tau_nodes",
    "theta_nodes",
]
