"""The Monte Carlo estimator of the homogeneous ball's D and F, at arbitrary nodes.

Backward walks in a ball of optical radius τ, albedo ``a`` and the scene's phase function, lit
by a collimated front of unit irradiance along +z (the kernels in ``_kernels/preint.py``, whose
docstring gives the estimator). Every albedo node is traced by one path, every θ node scored by
it; τ nodes share common random numbers. Paths run in :data:`N_CHUNKS` fixed chunks reduced in
chunk order, so the numbers do not depend on the thread count.

This module imports only numpy, the kernels and (lazily) tqdm: no pyvista or vtk.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..._kernels import preint as _k
from ...inputs.phase import as_phase
from ...inputs.validation import check_array, check_int, check_real

__all__ = [
    "BEAM_MIX",
    "MIX_AXIS",
    "MIX_UNIFORM",
    "N_CHUNKS",
    "BallEstimate",
    "ball_exitance",
    "simulate_ball",
    "simulate_nodes",
]

N_CHUNKS = 64
"""Fixed number of path chunks per τ node (prange unit); results do not depend on threads."""

BEAM_MIX = 0.5
"""Backward directions are drawn from ``(1 − c)·p(ω_in·ω) + c·p(ẑ·ω_in)`` with ``c = BEAM_MIX ·
E_dir(x)`` (anisotropic phase only): the next vertex's beam connection is importance sampled."""

MIX_UNIFORM = 0.1
MIX_AXIS = 0.3
"""Defensive mixture for D's first direction (anisotropic phase): 10 % uniform, 30 % the lobe
p(ω'·ẑ) (the shape of singly scattered light), 60 % split evenly over the θ nodes' lobes."""


@dataclass(frozen=True)
class BallEstimate:
    """Raw Monte Carlo estimates for arbitrary nodes (float64), see :func:`simulate_ball`.

    ``D``, ``D_err``: ``(n_a, n_tau, n_theta)``; ``F``, ``F_err``, ``F_diff``: ``(n_a, n_tau)``.
    """

    D: np.ndarray
    D_err: np.ndarray
    F: np.ndarray
    F_err: np.ndarray
    F_diff: np.ndarray


def _mean_se(s: np.ndarray, q: np.ndarray, n: int):
    """Mean and standard error of the mean from per-chunk sums (reduced in chunk order)."""
    total = np.zeros(s.shape[1:])
    total_sq = np.zeros(s.shape[1:])
    for ch in range(s.shape[0]):  # fixed order: deterministic
        total += s[ch]
        total_sq += q[ch]
    mean = total / n
    var = np.maximum(total_sq / n - mean * mean, 0.0) * (n / max(n - 1, 1))
    return mean, np.sqrt(var / n)


def simulate_nodes(kind, g, iso, taus, thetas, a_nodes, n_paths, seed, progress_bar=False, desc="D, F"):
    """D and F at checked nodes (no argument checks): the loop behind :func:`simulate_ball` and
    :func:`~pv_ambient.stages.preintegration.table.compute_table`.

    Parameters
    ----------
    kind, g, iso : int, float, bool
        The phase function in the form :meth:`pv_ambient.inputs.phase.PhaseFunction.canonical`
        gives.
    taus, thetas, a_nodes : numpy.ndarray
        float64 node sets (albedo ascending).
    n_paths : numpy.ndarray
        int paths per τ node.
    seed : int
    progress_bar : bool, default: False
        A tqdm bar over τ nodes, labelled ``desc``.

    Returns
    -------
    BallEstimate
    """
    n_a, n_tau, n_t = len(a_nodes), len(taus), len(thetas)
    D = np.zeros((n_a, n_tau, n_t))
    D_err = np.zeros_like(D)
    Fd = np.zeros((n_a, n_tau))
    F_err = np.zeros_like(Fd)
    a = np.ascontiguousarray(a_nodes, dtype=np.float64)
    tc = np.ascontiguousarray(np.cos(thetas))
    ts = np.ascontiguousarray(np.sin(thetas))
    mix_u, mix_ax, beam_mix = (1.0, 0.0, 0.0) if iso else (MIX_UNIFORM, MIX_AXIS, BEAM_MIX)
    ds = np.empty((N_CHUNKS, n_a, n_t))
    dq = np.empty_like(ds)
    fs = np.empty((N_CHUNKS, n_a))
    fq = np.empty_like(fs)
    order = range(n_tau)
    bar = None
    if progress_bar:
        from tqdm.auto import tqdm

        bar = tqdm(total=n_tau, desc=desc, unit="τ")
    try:
        for it in order:
            tau = float(taus[it])
            n = int(n_paths[it])
            if tau > 0.0:
                _k.d_paths(tau, kind, g, beam_mix, tc, ts, mix_u, mix_ax, a, seed, n, ds, dq)
                D[:, it, :], D_err[:, it, :] = _mean_se(ds, dq, n)
                _k.f_paths(tau, kind, g, beam_mix, a, seed, n, fs, fq)
                Fd[:, it], F_err[:, it] = _mean_se(fs, fq, n)
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    F = np.exp(-2.0 * np.asarray(taus))[None, :] + Fd
    return BallEstimate(D=D, D_err=D_err, F=F, F_err=F_err, F_diff=Fd)


def simulate_ball(phase=None, tau=1.0, theta=0.0, albedo=1.0, *, n_paths=4096, seed=0, progress_bar=False):
    """Estimate D and F at arbitrary nodes (the raw estimator behind the tables).

    Parameters
    ----------
    phase : None, float, PhaseFunction, str or dict, default: None
        Phase function (see :func:`pv_ambient.inputs.phase.as_phase`); ``None`` is isotropic.
    tau : float or array_like
        Optical radii (>= 0); τ nodes share common random numbers.
    theta : float or array_like
        Scattering-direction angles θ to +z, in [0, π]. Any set: all are scored by one path.
    albedo : float or array_like
        Albedo values in [0, 1], ascending (all traced by one path).
    n_paths : int, default: 4096
        Paths per τ node, for D and for F.
    seed : int, default: 0

    Returns
    -------
    BallEstimate
        float64 arrays ``D, D_err (n_a, n_tau, n_theta)`` and ``F, F_err, F_diff (n_a, n_tau)``.
    """
    kind, g, iso = as_phase(phase).canonical()
    taus = check_array(tau, "tau", ndim=1, nonempty=True, promote_scalar=True, lo=0.0, hi=np.inf)
    thetas = check_array(theta, "theta", ndim=1, nonempty=True, promote_scalar=True, lo=0.0, hi=math.pi)
    a = check_array(albedo, "albedo", ndim=1, nonempty=True, promote_scalar=True, lo=0.0, hi=1.0)
    if np.any(np.diff(a) < 0):
        raise ValueError(f"albedo must be ascending, got {a!r}")
    n = check_int(n_paths, "n_paths", lo=2)
    s = check_int(seed, "seed", lo=0)
    return simulate_nodes(kind, g, iso, taus, thetas, a, np.full(taus.size, n), s, progress_bar)


def ball_exitance(phase=None, tau=1.0, albedo=1.0, *, n_paths=65536, seed=0):
    """Total power leaving the ball, for validation (energy conservation at albedo 1).

    The scattered part is estimated by backward walks (the same walk as D and F) from uniform
    surface points in cosine-weighted directions; the unscattered part is exact,
    ``(π/2)(1 − e^{−2τ}(1 + 2τ))``. The incident power is ``πτ²`` (optical units).

    Returns
    -------
    total, total_err, incident : numpy.ndarray, numpy.ndarray, float
        Per albedo node: total exitant power and its standard error; the incident power.
    """
    kind, g, iso = as_phase(phase).canonical()
    R = check_real(tau, "tau", lo=0.0, lo_open=True)
    a = check_array(albedo, "albedo", ndim=1, nonempty=True, promote_scalar=True, lo=0.0, hi=1.0)
    if np.any(np.diff(a) < 0):
        raise ValueError(f"albedo must be ascending, got {a!r}")
    n = check_int(n_paths, "n_paths", lo=2)
    s = np.empty((N_CHUNKS, a.size))
    q = np.empty_like(s)
    _k.exitance_paths(R, kind, g, 0.0 if iso else BEAM_MIX, a, check_int(seed, "seed", lo=0), n, s, q)
    mean, se = _mean_se(s, q, n)
    direct = 0.5 * math.pi * -math.expm1(-2.0 * R) - 0.5 * math.pi * math.exp(-2.0 * R) * 2.0 * R
    return mean + direct, se, math.pi * R * R


