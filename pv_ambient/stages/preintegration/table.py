"""Preintegrated homogeneous-ball tables D and F (DESIGN §4.2): compute, cache, load, look up.

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

Departure from DESIGN §4.2: the unscattered irradiance inside the ball is computed with the exact
chord from the ball's entry point, ``exp(−σ̄(y_z − z_entry(y)))`` with
``z_entry = −sqrt(r² − y_x² − y_y²)``; DESIGN's ``e^{−σ̄(y_z + r)}`` holds only on the z axis.

Table layout
------------
* τ nodes: ``0`` then ``n_tau − 1`` nodes log-spaced over [``TAU_MIN``, ``TAU_MAX``] = [1e-3, 50].
* θ nodes: ``n_theta`` nodes uniform in [0, π]; a single node (θ = 0) when the phase function is
  isotropic (isotropic, or HG/Schlick with g = 0), where D does not depend on θ.
* albedo nodes: the subset of the global :data:`ALBEDO_NODES` (dense near 1) that brackets the
  scene's albedo range ``[a_min, a_max]``.
* ``D``, ``D_err``: float32 ``(n_a, n_tau, n_theta)``; ``F``, ``F_err``, ``F_diff`` (= E_diff,
  the scattered part, which the lookups interpolate before adding the exact e^{−2τ}): float32
  ``(n_a, n_tau)``.

Kernel lookups (``pv_ambient._kernels.preint``), for ``D, F_diff, a_nodes, tau_lo_log, tau_dlog
= table.lookup_args()``::

    d_lookup(D, a_nodes, tau_lo_log, tau_dlog, cos_theta, tau, a) -> float   # 1/sr
    f_lookup(F_diff, a_nodes, tau_lo_log, tau_dlog, tau, a) -> float

linear in θ (from acos), in log τ between log nodes and in τ below the first one, in albedo;
clamped at every end (τ > 50 uses τ = 50 for the scattered parts; e^{−2τ} stays exact).

Cost and accuracy
-----------------
Paths per τ node are the preset's ``n_paths`` × up to :data:`PATH_BOOST` (32) for τ ≲ 1, falling
to ×1 from τ ≈ 22: short walks are cheap, and at albedo 1 a walk from the centre of a τ = 50 ball
takes ~10³–5·10³ vertices. Measured CPU time for one g over all 16 albedo nodes (the machine had
one free core; on 2 cores halve it): ``"preview"`` 0.3–0.7 s, ``"balanced"`` 5–11 s (isotropic
and g > 0 fastest, g = −0.9 slowest), ``"accurate"`` 57–145 s. Standard errors of the shipped
``"balanced"`` slices (albedo 1): isotropic D 0.02 % (τ = 0.1), 0.1 % (τ = 1), 0.3 % (τ = 4.3),
1.6 % (τ = 17.5); g = 0.9, D(θ = 0) 0.6 %, 0.7 %, 1.2 %, 6 % and D(θ = π/2) 0.5 %, 1 %, 4 %,
14 %; F 0.003 %–0.7 % up to τ = 1, 1–2 % at τ = 4.3, 7–9 % at τ = 17.5. Where a quantity is
tiny (large τ with albedo < 1; backward directions for g → 1) its relative error is larger.

Caching and the shipped default
-------------------------------
Slices are cached as ``.npz`` under ``$PV_AMBIENT_CACHE``, else the user cache directory
(``platformdirs`` when importable, else ``~/.cache/pv_ambient``), named by a format version and a
hash of every parameter; files are written atomically (temporary file + ``os.replace``) and a
corrupt or mismatched file is recomputed with a :class:`UserWarning`.
``pv_ambient/data/default_table.npz`` ships the ``"balanced"``, ``seed=0`` slices for the phase
functions in :data:`DEFAULT_PHASES` (isotropic; HG g = 0.3, 0.6, 0.9) over all albedo nodes
(308,614 bytes; about 25 s of CPU to build); :func:`get_table` serves a request from it, sliced to
the requested albedo nodes, whenever every other parameter matches (a slice computed for those
nodes alone would hold other random numbers — Russian roulette depends on the largest albedo — but
estimates the same quantities). Rebuild it reproducibly (same arrays) with::

    python -m pv_ambient.preintegration --build-default

This module imports only numpy, the kernels and (lazily) tqdm/platformdirs: no pyvista or vtk.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
import tempfile
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._kernels import phase as _kp
from .._kernels import preint as _k
from ..inputs.validation import check_choice, check_int, check_real
from ..inputs.phase import HenyeyGreenstein, Isotropic, PhaseFunction, as_phase

__all__ = [
    "ALBEDO_NODES",
    "DEFAULT_PHASES",
    "QUALITY_PRESETS",
    "TAU_MAX",
    "TAU_MIN",
    "BallEstimate",
    "PreintegratedTable",
    "albedo_nodes_for",
    "ball_exitance",
    "cache_dir",
    "compute_table",
    "get_table",
    "simulate_ball",
]

FORMAT_VERSION = 1
"""Bumped whenever the estimator, the layout or the node sets change (invalidates caches)."""

TAU_MIN = 1e-3
TAU_MAX = 50.0

ALBEDO_NODES = np.array(
    [0.0, 0.2, 0.4, 0.6, 0.7, 0.8, 0.85, 0.9, 0.93, 0.95, 0.97, 0.98, 0.99, 0.995, 0.998, 1.0]
)
"""Global albedo nodes, dense near 1 where multiple scattering grows fastest (at large τ the
diffusion length ~1/sqrt(3(1 − a)(1 − ag)) varies most there). Tables hold a bracketing subset."""

QUALITY_PRESETS = {
    "preview": {"n_tau": 17, "n_theta": 9, "n_paths": 512},
    "balanced": {"n_tau": 33, "n_theta": 25, "n_paths": 4096},
    "accurate": {"n_tau": 49, "n_theta": 49, "n_paths": 32768},
}
"""``n_tau`` τ nodes (incl. τ = 0), ``n_theta`` θ nodes (1 for isotropic), ``n_paths``: base
paths per τ node for D and for F (× up to :data:`PATH_BOOST` for small τ)."""

PATH_BOOST = 32.0
PATH_BOOST_TAU2 = 16.0
"""Paths per τ node are ``n_paths · clip(PATH_BOOST / (1 + τ²/PATH_BOOST_TAU2), 1, PATH_BOOST)``
(×32 up to τ ≈ 1, ×3 at τ = 12, ×1 from τ ≈ 22): walks at small τ are short, so more of them
cost little; at large τ the walk length (~τ² vertices at albedo 1) dominates the cost."""

N_CHUNKS = 64
"""Fixed number of path chunks per τ node (prange unit); results do not depend on threads."""

BEAM_MIX = 0.5
"""Backward directions are drawn from ``(1 − c)·p(ω_in·ω) + c·p(ẑ·ω_in)`` with ``c = BEAM_MIX ·
E_dir(x)`` (anisotropic phase only): the next vertex's beam connection is importance sampled."""

MIX_UNIFORM = 0.1
MIX_AXIS = 0.3
"""Defensive mixture for D's first direction (anisotropic phase): 10 % uniform, 30 % the lobe
p(ω'·ẑ) (the shape of singly scattered light), 60 % split evenly over the θ nodes' lobes."""

DEFAULT_PHASES = (Isotropic(), HenyeyGreenstein(0.3), HenyeyGreenstein(0.6), HenyeyGreenstein(0.9))
"""Phase functions whose ``"balanced"`` slices ship in ``data/default_table.npz``."""

DEFAULT_TABLE_PATH = Path(__file__).parent.parent / "data" / "default_table.npz"
_ARRAYS = ("a_nodes", "tau_nodes", "theta_nodes", "n_paths", "D", "D_err", "F", "F_err", "F_diff")


# --- nodes ----------------------------------------------------------------------------------


def tau_nodes(n_tau: int) -> np.ndarray:
    """τ nodes: 0, then ``n_tau − 1`` nodes log-spaced over [TAU_MIN, TAU_MAX] (float64)."""
    out = np.zeros(n_tau)
    out[1:] = np.exp(np.linspace(math.log(TAU_MIN), math.log(TAU_MAX), n_tau - 1))
    return out


def theta_nodes(n_theta: int) -> np.ndarray:
    """θ nodes uniform in [0, π] (a single node 0.0 when ``n_theta == 1``)."""
    return np.linspace(0.0, math.pi, n_theta) if n_theta > 1 else np.zeros(1)


def albedo_nodes_for(a_min: float, a_max: float) -> np.ndarray:
    """The nodes of :data:`ALBEDO_NODES` bracketing ``[a_min, a_max]``: from the largest node
    ``<= a_min`` to the smallest node ``>= a_max``.

    Examples
    --------
    >>> from pv_ambient.stages.preintegration import albedo_nodes_for
    >>> albedo_nodes_for(0.5, 0.65).tolist()
    [0.4, 0.6, 0.7]
    >>> albedo_nodes_for(1.0, 1.0).tolist()
    [1.0]
    """
    lo = int(np.searchsorted(ALBEDO_NODES, a_min, side="right")) - 1
    hi = int(np.searchsorted(ALBEDO_NODES, a_max, side="left"))
    return ALBEDO_NODES[max(lo, 0) : min(hi, len(ALBEDO_NODES) - 1) + 1].copy()


def _path_counts(n_paths: int, taus: np.ndarray) -> np.ndarray:
    boost = np.clip(PATH_BOOST / (1.0 + taus**2 / PATH_BOOST_TAU2), 1.0, PATH_BOOST)
    return np.maximum(np.round(n_paths * boost), 2).astype(np.int64)


def _canonical_phase(phase: PhaseFunction) -> tuple[int, float, bool]:
    """(kind, g, isotropic): HG/Schlick with g = 0 are the isotropic phase function."""
    kind, g = phase.kind, float(phase.g)
    iso = kind == _kp.ISOTROPIC or (kind in (_kp.HENYEY_GREENSTEIN, _kp.SCHLICK) and g == 0.0)
    if iso:
        return _kp.ISOTROPIC, 0.0, True
    return kind, g, False


# --- the raw estimator ----------------------------------------------------------------------


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


def _simulate(kind, g, iso, taus, thetas, a_nodes, n_paths, seed, progress_bar=False, desc="D, F"):
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


def _check_nodes(values, name, lo, hi) -> np.ndarray:
    try:
        arr = np.atleast_1d(np.asarray(values, dtype=np.float64))
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be an array of numbers, got {values!r}") from None
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"{name} must be a non-empty 1-D array, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)) or np.any(arr < lo) or np.any(arr > hi):
        raise ValueError(f"{name} must lie in [{lo}, {hi}], got {arr!r}")
    return arr


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
    ph = as_phase(phase)
    kind, g, iso = _canonical_phase(ph)
    taus = _check_nodes(tau, "tau", 0.0, np.inf)
    thetas = _check_nodes(theta, "theta", 0.0, math.pi)
    a = _check_nodes(albedo, "albedo", 0.0, 1.0)
    if np.any(np.diff(a) < 0):
        raise ValueError(f"albedo must be ascending, got {a!r}")
    n = check_int(n_paths, "n_paths", lo=2)
    s = check_int(seed, "seed", lo=0)
    return _simulate(kind, g, iso, taus, thetas, a, np.full(taus.size, n), s, progress_bar)


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
    ph = as_phase(phase)
    kind, g, iso = _canonical_phase(ph)
    R = check_real(tau, "tau", lo=0.0, lo_open=True)
    a = _check_nodes(albedo, "albedo", 0.0, 1.0)
    if np.any(np.diff(a) < 0):
        raise ValueError(f"albedo must be ascending, got {a!r}")
    n = check_int(n_paths, "n_paths", lo=2)
    s = np.empty((N_CHUNKS, a.size))
    q = np.empty_like(s)
    _k.exitance_paths(R, kind, g, 0.0 if iso else BEAM_MIX, a, check_int(seed, "seed", lo=0), n, s, q)
    mean, se = _mean_se(s, q, n)
    direct = 0.5 * math.pi * -math.expm1(-2.0 * R) - 0.5 * math.pi * math.exp(-2.0 * R) * 2.0 * R
    return mean + direct, se, math.pi * R * R


# --- the table ------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class PreintegratedTable:
    """A table slice of D and F for one phase function (see the module docstring for layout).

    Attributes
    ----------
    kind, g : int, float
        Phase-function kind and anisotropy (``ISOTROPIC, 0.0`` for any isotropic phase).
    quality : str
        Preset name, or ``"custom"``.
    seed : int
    a_nodes, tau_nodes, theta_nodes : numpy.ndarray
        float64 node sets; τ nodes are 0 then log-spaced over [TAU_MIN, TAU_MAX].
    n_paths : numpy.ndarray
        int64 paths per τ node (for D and for F each).
    D, D_err : numpy.ndarray
        float32 ``(n_a, n_tau, n_theta)`` [1/sr] and its standard error.
    F, F_err, F_diff : numpy.ndarray
        float32 ``(n_a, n_tau)``: transfer factor, its standard error, and its scattered part.
    """

    kind: int
    g: float
    quality: str
    seed: int
    a_nodes: np.ndarray
    tau_nodes: np.ndarray
    theta_nodes: np.ndarray
    n_paths: np.ndarray
    D: np.ndarray
    D_err: np.ndarray
    F: np.ndarray
    F_err: np.ndarray
    F_diff: np.ndarray

    @property
    def phase(self) -> PhaseFunction:
        """The phase function as an object (isotropic for every isotropic request)."""
        if self.kind == _kp.ISOTROPIC:
            return Isotropic()
        if self.kind == _kp.RAYLEIGH:
            return as_phase("rayleigh")
        name = "hg" if self.kind == _kp.HENYEY_GREENSTEIN else "schlick"
        return as_phase({"kind": name, "g": self.g})

    @property
    def tau_lo_log(self) -> float:
        """``log(TAU_MIN)``: log of the first non-zero τ node."""
        return math.log(float(self.tau_nodes[1]))

    @property
    def tau_dlog(self) -> float:
        """Spacing of the log τ nodes."""
        n = len(self.tau_nodes)
        return (math.log(float(self.tau_nodes[-1])) - self.tau_lo_log) / (n - 2)

    def lookup_args(self):
        """``(D, F_diff, a_nodes, tau_lo_log, tau_dlog)`` for the kernel lookups::

            d_lookup(D, a_nodes, tau_lo_log, tau_dlog, cos_theta, tau, a)
            f_lookup(F_diff, a_nodes, tau_lo_log, tau_dlog, tau, a)

        Arrays are C-contiguous (D, F_diff float32; a_nodes float64).
        """
        return (
            np.ascontiguousarray(self.D, dtype=np.float32),
            np.ascontiguousarray(self.F_diff, dtype=np.float32),
            np.ascontiguousarray(self.a_nodes, dtype=np.float64),
            self.tau_lo_log,
            self.tau_dlog,
        )

    # Numpy lookups: the same interpolation as the kernels, vectorised, for tests and the API.

    def _tau_coord(self, tau):
        n = len(self.tau_nodes)
        t1 = float(self.tau_nodes[1])
        with np.errstate(divide="ignore"):
            u = (np.log(np.maximum(tau, t1)) - self.tau_lo_log) / self.tau_dlog
        u = np.clip(u, 0.0, n - 2)
        k = np.minimum(np.floor(u).astype(np.int64), n - 3)
        i = np.where(tau < t1, 0, k + 1)
        t = np.where(tau < t1, tau / t1, u - k)
        return i, np.clip(t, 0.0, 1.0)

    def _theta_coord(self, cos_theta):
        n = len(self.theta_nodes)
        if n < 2:
            return np.zeros(np.shape(cos_theta), np.int64), np.zeros(np.shape(cos_theta))
        u = np.arccos(np.clip(cos_theta, -1.0, 1.0)) * (n - 1) / math.pi
        j = np.minimum(np.floor(u).astype(np.int64), n - 2)
        return j, np.clip(u - j, 0.0, 1.0)

    def _albedo_coord(self, a):
        nodes = self.a_nodes
        if len(nodes) < 2:
            return np.zeros(np.shape(a), np.int64), np.zeros(np.shape(a))
        ac = np.clip(a, nodes[0], nodes[-1])
        i = np.clip(np.searchsorted(nodes, ac, side="right") - 1, 0, len(nodes) - 2)
        t = (ac - nodes[i]) / (nodes[i + 1] - nodes[i])
        return i, t

    def d(self, cos_theta, tau, a):
        """D(θ, τ, a) [1/sr] by interpolation (vectorised; the same rule as ``d_lookup``).

        Parameters
        ----------
        cos_theta : array_like
            Cosine of the angle between the light's propagation and the scattered direction.
        tau : array_like
            Optical radius r·σ̄ (>= 0).
        a : array_like
            Albedo in [0, 1] (clamped to the table's nodes).
        """
        c = _check_array(cos_theta, "cos_theta", -1.0 - 1e-6, 1.0 + 1e-6)
        t = _check_array(tau, "tau", 0.0, np.inf)
        al = _check_array(a, "a", 0.0, 1.0)
        c, t, al = np.broadcast_arrays(c, t, al)
        D = self.D.astype(np.float64)
        ia, ta = self._albedo_coord(al)
        it, tt = self._tau_coord(t)
        jt, st = self._theta_coord(c)
        ia1 = np.minimum(ia + 1, len(self.a_nodes) - 1)
        jt1 = np.minimum(jt + 1, len(self.theta_nodes) - 1)
        it1 = it + 1

        def plane(i):
            return (1 - tt) * ((1 - st) * D[i, it, jt] + st * D[i, it, jt1]) + tt * (
                (1 - st) * D[i, it1, jt] + st * D[i, it1, jt1]
            )

        out = (1 - ta) * plane(ia) + ta * plane(ia1)
        return float(out) if out.ndim == 0 else out

    def f(self, tau, a):
        """F(τ, a) = e^{−2τ} + interpolated E_diff (vectorised; the same rule as ``f_lookup``)."""
        t = _check_array(tau, "tau", 0.0, np.inf)
        al = _check_array(a, "a", 0.0, 1.0)
        t, al = np.broadcast_arrays(t, al)
        Fd = self.F_diff.astype(np.float64)
        ia, ta = self._albedo_coord(al)
        it, tt = self._tau_coord(t)
        ia1 = np.minimum(ia + 1, len(self.a_nodes) - 1)
        lo = (1 - tt) * Fd[ia, it] + tt * Fd[ia, it + 1]
        hi = (1 - tt) * Fd[ia1, it] + tt * Fd[ia1, it + 1]
        out = np.exp(-2.0 * t) + (1 - ta) * lo + ta * hi
        return float(out) if out.ndim == 0 else out

    def __repr__(self):
        return (
            f"PreintegratedTable(kind={self.kind}, g={self.g}, quality={self.quality!r}, "
            f"n_a={len(self.a_nodes)}, n_tau={len(self.tau_nodes)}, n_theta={len(self.theta_nodes)})"
        )


def _check_array(values, name, lo, hi):
    """A float64 array with every value in [lo, hi] (NaN rejected; ±inf only if a bound is)."""
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be numbers, got {values!r}") from None
    if np.any(np.isnan(arr)):
        raise ValueError(f"{name} must not contain NaN")
    if arr.size and (np.min(arr) < lo or np.max(arr) > hi):
        raise ValueError(f"{name} must lie in [{lo}, {hi}], got values from {np.min(arr)!r} to {np.max(arr)!r}")
    return arr


def compute_table(
    phase=None,
    albedo_nodes=None,
    *,
    n_tau=33,
    n_theta=None,
    n_paths=4096,
    seed=0,
    progress_bar=False,
    quality="custom",
):
    """Compute a table slice with explicit node counts (no cache). :func:`get_table` calls this.

    Parameters
    ----------
    phase : None, float, PhaseFunction, str or dict
        Phase function (:func:`pv_ambient.inputs.phase.as_phase`).
    albedo_nodes : array_like, optional
        Ascending albedo nodes in [0, 1]; default :data:`ALBEDO_NODES`.
    n_tau : int
        τ nodes including τ = 0 (>= 3).
    n_theta : int, optional
        θ nodes, uniform in [0, π]; default 1 for an isotropic phase, 25 otherwise (an
        anisotropic phase needs >= 2). Forcing ``n_theta > 1`` for an isotropic phase stores the
        same D in every θ column.
    n_paths : int
        Base paths per τ node (see :data:`PATH_BOOST`).
    """
    ph = as_phase(phase)
    kind, g, iso = _canonical_phase(ph)
    a = ALBEDO_NODES.copy() if albedo_nodes is None else _check_nodes(albedo_nodes, "albedo_nodes", 0.0, 1.0)
    if np.any(np.diff(a) <= 0):
        raise ValueError(f"albedo_nodes must be strictly ascending, got {a!r}")
    nt = check_int(n_tau, "n_tau", lo=3)
    nth = (1 if iso else 25) if n_theta is None else check_int(n_theta, "n_theta", lo=1)
    if not iso and nth < 2:
        raise ValueError(f"n_theta must be >= 2 for an anisotropic phase function, got {nth}")
    npath = check_int(n_paths, "n_paths", lo=2)
    s = check_int(seed, "seed", lo=0)
    taus = tau_nodes(nt)
    thetas = theta_nodes(nth)
    counts = _path_counts(npath, taus)
    est = _simulate(kind, g, iso, taus, thetas, a, counts, s, progress_bar, desc=f"preintegrating g={g:g}")
    return PreintegratedTable(
        kind=kind,
        g=g,
        quality=str(quality),
        seed=s,
        a_nodes=a,
        tau_nodes=taus,
        theta_nodes=thetas,
        n_paths=counts,
        D=est.D.astype(np.float32),
        D_err=est.D_err.astype(np.float32),
        F=est.F.astype(np.float32),
        F_err=est.F_err.astype(np.float32),
        F_diff=est.F_diff.astype(np.float32),
    )


# --- cache ----------------------------------------------------------------------------------


def cache_dir() -> Path:
    """The table cache directory: ``$PV_AMBIENT_CACHE``, else the user cache directory."""
    env = os.environ.get("PV_AMBIENT_CACHE")
    if env:
        return Path(env).expanduser()
    try:
        import platformdirs
    except ImportError:
        return Path.home() / ".cache" / "pv_ambient"
    return Path(platformdirs.user_cache_dir("pv_ambient"))


def _key(kind, g, quality, seed, a_nodes, params) -> dict:
    """Every parameter that determines a slice's numbers (a_nodes excluded: see _key_hash)."""
    return {
        "format": FORMAT_VERSION,
        "kind": int(kind),
        "g": float(g).hex(),
        "quality": quality,
        "seed": int(seed),
        "n_tau": int(params["n_tau"]),
        "n_theta": int(params["n_theta"]),
        "n_paths": int(params["n_paths"]),
        "tau_range": [TAU_MIN, TAU_MAX],
        "path_boost": [PATH_BOOST, PATH_BOOST_TAU2],
        "n_chunks": N_CHUNKS,
        "mix": [MIX_UNIFORM, MIX_AXIS, BEAM_MIX],
        "w_rr": _k.W_RR,
        "a_nodes": [float(x) for x in a_nodes],
    }


def _key_hash(key: dict) -> str:
    return hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:20]


def _cache_path(directory: Path, key: dict) -> Path:
    return directory / f"preint-v{FORMAT_VERSION}-k{key['kind']}-{key['quality']}-{_key_hash(key)}.npz"


def _table_to_arrays(table: PreintegratedTable, key: dict, prefix: str = "") -> dict:
    out = {prefix + name: np.asarray(getattr(table, name)) for name in _ARRAYS}
    out[prefix + "meta"] = np.array(json.dumps({"key": key, "kind": table.kind, "g": table.g}))
    return out


def _table_from_arrays(data, key: dict, prefix: str = "") -> PreintegratedTable:
    """Rebuild a table from npz arrays, checking the key and every shape (raises ValueError)."""
    meta = json.loads(str(data[prefix + "meta"][()]))
    if meta.get("key") != key:
        raise ValueError("cache key mismatch")
    arrs = {name: np.array(data[prefix + name]) for name in _ARRAYS}
    n_a, n_tau, n_t = len(arrs["a_nodes"]), len(arrs["tau_nodes"]), len(arrs["theta_nodes"])
    if n_tau != key["n_tau"] or not np.array_equal(arrs["a_nodes"], np.array(key["a_nodes"])):
        raise ValueError("node sets do not match the key")
    for name in ("D", "D_err"):
        if arrs[name].shape != (n_a, n_tau, n_t) or arrs[name].dtype != np.float32:
            raise ValueError(f"{name} has shape {arrs[name].shape}")
    for name in ("F", "F_err", "F_diff"):
        if arrs[name].shape != (n_a, n_tau) or arrs[name].dtype != np.float32:
            raise ValueError(f"{name} has shape {arrs[name].shape}")
    for name in ("D", "F", "F_diff", "D_err", "F_err"):
        if not np.all(np.isfinite(arrs[name])):
            raise ValueError(f"{name} is not finite")
    return PreintegratedTable(
        kind=int(meta["kind"]), g=float(meta["g"]), quality=key["quality"], seed=key["seed"], **arrs
    )


def _save_npz(path: Path, arrays: dict) -> None:
    """Write ``arrays`` to ``path`` atomically: a temporary file in the same directory, then
    ``os.replace`` (readers see the old file or the new one, never a partial one)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez_compressed(fh, **arrays)
        os.chmod(tmp, 0o644)  # mkstemp creates 0600; cache and package data are world-readable
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def _load_cached(path: Path, key: dict):
    """The cached table, or None if absent; a bad file warns and returns None."""
    if not path.exists():
        return None
    try:
        # Open the file here: np.load leaks its own handle when the zip directory is truncated.
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as data:
            return _table_from_arrays(data, key)
    except Exception as exc:  # corrupt, truncated or foreign file: recompute
        warnings.warn(
            f"preintegrated table cache file {str(path)!r} is unreadable ({type(exc).__name__}: {exc}); "
            "recomputing it",
            UserWarning,
            stacklevel=3,
        )
        return None


@functools.lru_cache(maxsize=1)
def _default_slices():
    """The shipped default tables as ``[(key without a_nodes, table)]`` (empty if absent)."""
    if not DEFAULT_TABLE_PATH.exists():
        return ()
    out = []
    with np.load(DEFAULT_TABLE_PATH, allow_pickle=False) as data:
        for i in range(int(data["n_slices"])):
            prefix = f"s{i}_"
            meta = json.loads(str(data[prefix + "meta"][()]))
            table = _table_from_arrays(data, meta["key"], prefix)
            for name in _ARRAYS:  # shared by every table served from it
                getattr(table, name).flags.writeable = False
            out.append((meta["key"], table))
    return tuple(out)


def _from_default(key: dict):
    """A shipped slice matching ``key`` except for holding a superset of its albedo nodes."""
    want = np.array(key["a_nodes"])
    for skey, table in _default_slices():
        if {k: v for k, v in skey.items() if k != "a_nodes"} != {k: v for k, v in key.items() if k != "a_nodes"}:
            continue
        idx = np.searchsorted(table.a_nodes, want)
        idx = np.minimum(idx, len(table.a_nodes) - 1)
        if not np.array_equal(table.a_nodes[idx], want):
            continue
        return PreintegratedTable(
            kind=table.kind,
            g=table.g,
            quality=table.quality,
            seed=table.seed,
            a_nodes=table.a_nodes[idx].copy(),
            tau_nodes=table.tau_nodes,
            theta_nodes=table.theta_nodes,
            n_paths=table.n_paths,
            D=table.D[idx].copy(),
            D_err=table.D_err[idx].copy(),
            F=table.F[idx].copy(),
            F_err=table.F_err[idx].copy(),
            F_diff=table.F_diff[idx].copy(),
        )
    return None


def get_table(phase=None, albedo_range=(0.0, 1.0), *, quality="balanced", cache=True, progress_bar=False, seed=0):
    """The D/F table slice for a phase function and an albedo range: shipped, cached or computed.

    Parameters
    ----------
    phase : None, float, PhaseFunction, str or dict, default: None
        Phase function (:func:`pv_ambient.inputs.phase.as_phase`): ``None`` is isotropic, a float is
        the HG anisotropy g.
    albedo_range : (float, float), default: (0.0, 1.0)
        ``(a_min, a_max)`` of the scene, ``0 <= a_min <= a_max <= 1``; the table holds the
        :data:`ALBEDO_NODES` that bracket it (:func:`albedo_nodes_for`).
    quality : {"preview", "balanced", "accurate"}, default: "balanced"
        Node counts and paths (:data:`QUALITY_PRESETS`).
    cache : bool, default: True
        Read and write the disk cache (:func:`cache_dir`). ``False`` always computes (the
        shipped default is still used).
    progress_bar : bool, default: False
        Show a tqdm bar over τ nodes while computing.
    seed : int, default: 0
        Random seed (part of the cache key).

    Returns
    -------
    PreintegratedTable

    Examples
    --------
    >>> from pv_ambient.stages.preintegration import get_table
    >>> table = get_table(None, (0.8, 0.9))  # isotropic: served from the shipped default
    >>> table.a_nodes.tolist(), table.D.shape
    ([0.8, 0.85, 0.9], (3, 33, 1))
    >>> round(table.f(0.0, 0.85), 6)
    1.0
    """
    ph = as_phase(phase)
    a_min, a_max = _check_albedo_range(albedo_range)
    check_choice(quality, "quality", tuple(QUALITY_PRESETS))
    if not isinstance(cache, (bool, np.bool_)):
        raise TypeError(f"cache must be True or False, got {cache!r}")
    if not isinstance(progress_bar, (bool, np.bool_)):
        raise TypeError(f"progress_bar must be True or False, got {progress_bar!r}")
    seed = check_int(seed, "seed", lo=0)
    kind, g, iso = _canonical_phase(ph)
    params = dict(QUALITY_PRESETS[quality])
    if iso:
        params["n_theta"] = 1
    a_nodes = albedo_nodes_for(a_min, a_max)
    key = _key(kind, g, quality, seed, a_nodes, params)
    table = _from_default(key)
    if table is not None:
        return table
    path = _cache_path(cache_dir(), key) if cache else None
    if path is not None:
        table = _load_cached(path, key)
        if table is not None:
            return table
    table = compute_table(
        ph,
        a_nodes,
        n_tau=params["n_tau"],
        n_theta=params["n_theta"],
        n_paths=params["n_paths"],
        seed=seed,
        progress_bar=bool(progress_bar),
        quality=quality,
    )
    if path is not None:
        try:
            _save_npz(path, _table_to_arrays(table, key))
        except OSError as exc:
            warnings.warn(f"could not write the table cache {str(path)!r}: {exc}", UserWarning, stacklevel=2)
    return table


def _check_albedo_range(albedo_range):
    try:
        a_min, a_max = albedo_range
    except (TypeError, ValueError):
        raise TypeError(f"albedo_range must be (a_min, a_max), got {albedo_range!r}") from None
    a_min = check_real(a_min, "albedo_range[0]", lo=0.0, hi=1.0)
    a_max = check_real(a_max, "albedo_range[1]", lo=0.0, hi=1.0)
    if a_min > a_max:
        raise ValueError(f"albedo_range must have a_min <= a_max, got {albedo_range!r}")
    return a_min, a_max


# --- the shipped default ----------------------------------------------------------------------


def build_default(path=DEFAULT_TABLE_PATH, *, progress_bar=True) -> Path:
    """Compute the :data:`DEFAULT_PHASES` ``"balanced"`` slices (all albedo nodes, seed 0) and
    write them to ``path`` (``pv_ambient/data/default_table.npz``). Deterministic."""
    arrays = {}
    params = QUALITY_PRESETS["balanced"]
    for i, ph in enumerate(DEFAULT_PHASES):
        kind, g, iso = _canonical_phase(ph)
        p = dict(params)
        if iso:
            p["n_theta"] = 1
        key = _key(kind, g, "balanced", 0, ALBEDO_NODES, p)
        t0 = time.perf_counter()
        table = compute_table(
            ph, ALBEDO_NODES, n_tau=p["n_tau"], n_theta=p["n_theta"], n_paths=p["n_paths"], seed=0,
            progress_bar=progress_bar, quality="balanced",
        )
        print(f"{ph!r}: {time.perf_counter() - t0:.1f} s")
        arrays.update(_table_to_arrays(table, key, prefix=f"s{i}_"))
    arrays["n_slices"] = np.array(len(DEFAULT_PHASES))
    path = Path(path)
    _save_npz(path, arrays)
    _default_slices.cache_clear()
    return path
