"""The table slice of D and F for one phase function: nodes, presets, :func:`compute_table` and
the lookups.

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

Cost
----
Paths per τ node are the preset's ``n_paths`` × up to :data:`PATH_BOOST` (32) for τ ≲ 1, falling
to ×1 from τ ≈ 22: short walks are cheap, and at albedo 1 a walk from the centre of a τ = 50 ball
takes ~10³–5·10³ vertices. Where a quantity is tiny (large τ with albedo < 1; backward
directions for g → 1) its relative error is larger. Measured times and standard errors per
preset: docs/ambient_scattering.rst §2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...inputs.phase import PhaseFunction, as_phase
from ...inputs.validation import check_array, check_int
from .estimator import simulate_nodes

__all__ = [
    "ALBEDO_NODES",
    "PATH_BOOST",
    "PATH_BOOST_TAU2",
    "QUALITY_PRESETS",
    "TABLE_ARRAYS",
    "TAU_MAX",
    "TAU_MIN",
    "PreintegratedTable",
    "albedo_nodes_for",
    "compute_table",
    "tau_nodes",
    "theta_nodes",
]

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

TABLE_ARRAYS = ("a_nodes", "tau_nodes", "theta_nodes", "n_paths", "D", "D_err", "F", "F_err", "F_diff")
"""The array fields of a :class:`PreintegratedTable`, in the order a file stores them."""


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
        return PhaseFunction.from_kind(self.kind, self.g)

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
        c = check_array(cos_theta, "cos_theta", finite="nan", lo=-1.0 - 1e-6, hi=1.0 + 1e-6)
        t = check_array(tau, "tau", finite="nan", lo=0.0, hi=np.inf)
        al = check_array(a, "a", finite="nan", lo=0.0, hi=1.0)
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
        t = check_array(tau, "tau", finite="nan", lo=0.0, hi=np.inf)
        al = check_array(a, "a", finite="nan", lo=0.0, hi=1.0)
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
    kind, g, iso = as_phase(phase).canonical()
    if albedo_nodes is None:
        a = ALBEDO_NODES.copy()
    else:
        a = check_array(albedo_nodes, "albedo_nodes", ndim=1, nonempty=True, promote_scalar=True, lo=0.0, hi=1.0)
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
    est = simulate_nodes(kind, g, iso, taus, thetas, a, counts, s, progress_bar, desc=f"preintegrating g={g:g}")
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
