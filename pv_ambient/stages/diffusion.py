"""Long-range multiple scattering by diffusion (DESIGN §4b): first-collision source → P1
(optionally flux-limited) diffusion solve on the data grid → fluence φ and flux F per channel.

The model
---------
Light that has scattered at least once is described by its fluence ``φ`` (W/m², the radiance
integrated over the sphere) and flux ``F`` (W/m², the first angular moment). From the light's
direct irradiance ``E_d`` (W/m², transmittance included) and unit propagation direction ``ω``
the first-collision source is ``Q0 = σs E_d`` and ``Q1 = g σs E_d ω`` (W/m³), and P1 reads

    ∇·F + σa φ = Q0,     F = −D ∇φ + 3 D Q1,     D = 1/(3 σt'),   σt' = σa + σs (1 − g).

Discretisation
--------------
Node-centred finite volumes on the data grid: node (i, j, k) owns the control volume
``[i−½, i+½] × …`` (index space) clipped to the medium's box, so for point data a boundary node
owns half a cell (a corner an eighth) and sits on the box face; for cell data every node owns a
full cell and the box face lies half a cell beyond the outermost node. Across the face between
two neighbouring nodes, ``F·n = −D_f (φ_j − φ_i)/h + 3 D_f Q1_f·n`` with ``D_f`` the harmonic
mean of the nodes' D (equivalently D of the mean σt') and ``Q1_f`` their mean: a 7-point
stencil, symmetric positive definite, second-order accurate. The Marshak vacuum condition
``F·n = φ/2`` (no light enters) holds on the box faces: for point data at the boundary node
itself, for cell data at the face, whose φ is eliminated with the one-sided flux
(``F·n = (2Dφ_0 + 3 D h Q1·n)/(4D + h)``). An axis with a single node has no faces: the problem
is uniform along it (a slab or a 2D problem). Spacing may differ per axis. A rotated grid
(``direction``) only rotates vectors: Q1 is given and F returned in world components; the
solver works with their components along the index axes.

Discrete power balance holds to the solver's residual: ``Σ Q0 V = Σ σa φ V + Σ_box faces A F·n``
(:attr:`DiffusionSolution.power`).

Vacuum floor
------------
Where σt' → 0 (empty space) D = 1/(3σt') diverges: the fluence would level out instantly across
every empty region, as if light crossed it at once and spread over all its walls alike. Light
that crosses a void streams in straight lines and lands, on average, one chord length away, so
empty space is given the transport length of the void it fills: σt' is floored at
``sigma_floor``, by default ``1/ℓ̄`` with ``ℓ̄`` the mean chord length of the medium's box
(Cauchy's ``4V/S`` for a box; ``πA/P`` when one axis has a single node, twice the thickness
when two do), the scale of the largest void the box can hold. Equivalently D ≤ ℓ̄/3 (the
diffusion coefficient of a medium whose mean free path is ℓ̄). The floor enters only D, never
σa, and it also raises σt' in media thinner than one optical depth per mean chord — media that
light crosses mostly unscattered, where diffusion's local picture fails just as in a void.

Measured against converged path tracing (``benchmarks/trade.py``'s three scenes at 64³, 80²,
4×4-block relative RMSE of the ``diffusion`` image, image-mean bias): with the earlier floor
``0.01/L`` (L the box diagonal: a near-perfect conductor of fluence) 0.545 / 0.201 / 0.196
(−14 / −7 / −11 %); with ``1/L`` 0.457 / 0.129 / 0.149; with the default ``1/ℓ̄`` (2.6/L for a
cube) 0.353 / 0.164 / 0.107 (−7 / +6 / −3 %); with ``10/L`` 0.131 / 0.550 / 0.170. Too small a
floor carries the light around the supernova's hollow interior and darkens its lit side;
too large a floor holds light back in the cloud's thin fringes. The flux-limited solve barely
depends on it (0.217 / 0.167 / 0.061 with the default, 0.218 / 0.18 / 0.06 before). A larger
floor also conditions the matrix better: fewer iterations. On scenes nothing was chosen on
(``benchmarks/diffusion_floor.py``: smoke plume, Marschner–Lobb lit from its centre, the cloud
under a directional light) the default against the earlier floor: 0.29 vs 0.37, 0.23 vs 0.47,
0.72 vs 1.00; flux-limited 0.17, 0.14, 0.35. Plain diffusion remains −33 % dark on the last:
the camera sees the sunlit side, i.e. light turned back by a forward-scattering medium
(g = 0.6; −15 % at g = 0), where P1 is poor; a floor of 10/L hides it there (−1 %) but
makes the trade's point-lit cloud +28 % bright (block 0.55), so the default stays.

Solver
------
Preconditioned conjugate gradients, matrix-free in Numba (``_kernels/diffusion.py``, which
also assembles the face couplings and evaluates the flux limiter), float64 throughout. The default preconditioner is one symmetric V-cycle of an aggregation multigrid
(2×2×2 aggregates, semi-coarsening on strongly anisotropic spacing; coarse couplings are the
summed fine couplings across an aggregate interface halved along coarsened axes, absorption and
boundary terms summed; red–black Gauss–Seidel, red→black before and black→red after the
coarse correction; a dense solve at 64 nodes or fewer), so iteration counts barely grow with the
grid (a point source at 17³/33³/65³: 8/9/10; the benchmarks' scenes 20–39 at 64³ and 128³).
``preconditioner="jacobi"`` is the diagonal one, for comparison: 680 iterations at 64³ and
1394 at 128³ on the cloud scene, 8× slower than multigrid there (and scipy.sparse CG with the
same preconditioner 4× slower again). Grids and multigrid levels of at most ``SERIAL_NODES``
nodes run on one thread (a parallel launch costs more than the work). The iteration stops when
the relative residual ``‖b − A φ‖₂ / ‖b‖₂ ≤ tol`` (b, A: the finite-volume system, in W per
control volume) and warns (``UserWarning``) if ``maxiter`` is reached first.

Flux-limited diffusion (``flux_limited=True``): ``D = λ(R)/σt'`` with Levermore–Pomraning
``λ(R) = (coth R − 1/R)/R`` and ``R = |∇φ − 3 Q1| / (σt' φ)`` (the gradient that drives F, so
``|F| = λ R φ ≤ φ``), evaluated at the nodes from the previous φ (central differences, lagged
coefficients). The first pass is plain diffusion, then up to ``max_outer`` re-solves, each warm
started; they stop when σs·φ changes by less than ``outer_tol`` (relative 2-norm). The plain
lagged iteration contracts by only ≈ 0.8 per pass where the medium is optically thin, so the
passes are accelerated by Anderson mixing of depth 2. The first pass and the lagged passes are
solved only to ``INNER_REL·outer_tol`` (1e−3): the change they measure is ten times larger, and
the last pass is then finished to ``tol`` (same D), so ``residual`` and ``power`` hold as for
plain diffusion. Measured on the benchmarks' three scenes at 64³: 3 passes per channel,
137 → 86, 135 → 84, 142 → 91 iterations against solving every pass to ``tol``, φ changed by
2e−5 / 5e−6 / 5e−6 (relative 2-norm). A warm start — ``x0`` (a relight) or, for the second
and later channels, the previous channel's solution scaled by the source power — replaces the
plain first pass: the lagged passes start from it (trade scenes at 64³: iterations 86 → 70,
84 → 57, 181 → 108 for the two CT lights; φ within 0.9 / 0.8 / 0.3 %, inside the limiter's own
stopping tolerance). Where σt' = 0 the limiter gives ``D = φ/|∇φ − 3Q1|``
(free streaming, at most the vacuum floor's ℓ̄/3).

Camera pass
-----------
The multiply-scattered radiance source at a sample is ``σs (φ + 3 g F·ω_o) / (4π)`` (ω_o toward
the camera, g the phase function's mean cosine): :func:`camera_source`, with φ and F trilinear
(:meth:`DiffusionSolution.at`, or :meth:`DiffusionSolution.packed` for a kernel).

This module imports numpy, scipy and the kernels only (no pyvista or vtk).
"""

from __future__ import annotations

import math
import time
import warnings
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

from ..inputs.validation import check_choice, check_int, check_real

__all__ = [
    "DiffusionSolution",
    "camera_source",
    "direct_irradiance",
    "first_collision_source",
    "mean_chord",
    "solve_diffusion",
    "solve_for_light",
]

#: Relative residual at which conjugate gradients stop, by default.
DEFAULT_TOL = 1e-6
#: Default iteration caps per preconditioner.
DEFAULT_MAXITER = {"multigrid": 200, "jacobi": 20000}
#: Sub-samples per axis of a control volume when averaging a light's irradiance: within
#: ``SUBSAMPLE_RADIUS`` index units of a point light, and farther out (or for a directional light).
SUBSAMPLES = 4
FAR_SUBSAMPLES = 2
SUBSAMPLE_RADIUS = 8.0
#: Control volumes within this many index units (max-norm) of a point light use the solid-angle form.
NEAR = 1.5
#: Cosine bins of the solid-angle form (twice as many azimuth bins) and chord samples.
NEAR_DIRECTIONS = 64
NEAR_CHORD = 4
#: The multigrid hierarchy ends with a dense solve at or below this many nodes.
COARSE_NODES = 64
#: Default vacuum floor of σt' inside D, in units of 1/(mean chord length of the box).
SIGMA_FLOOR_REL = 1.0
#: Problems and multigrid levels with at most this many nodes run their kernels on one thread.
SERIAL_NODES = 32768
#: History depth of the Anderson mixing that accelerates the flux limiter's lagged passes.
ANDERSON_DEPTH = 2
#: Start the flux limiter's passes from a warm start (relight, previous channel) directly.
WARM_CHANNELS = True
#: The flux limiter's lagged solves stop at this fraction of ``outer_tol`` (the last one at ``tol``).
INNER_REL = 0.1
#: Placeholder passed to the kernels when there is no first-moment source.
_NO_Q1 = np.zeros((1, 1, 1, 3))
#: Smallest diffusion coefficient the flux limiter may produce, in units of the smallest spacing.
D_MIN_REL = 1e-6


# ---------------------------------------------------------------------------------------------
# result
# ---------------------------------------------------------------------------------------------
@dataclass(eq=False)
class DiffusionSolution:
    """Fluence and flux of the multiply-scattered light on the data grid.

    Attributes
    ----------
    phi : numpy.ndarray
        Fluence φ (W/m² for sources in W/m³), float64 (the solver's iterate: ``residual`` and
        ``power`` hold for it, and it warm-starts the next solve), (nx, ny, nz) or (nx, ny, nz, C).
    flux : numpy.ndarray
        Flux F in world components, float32, (nx, ny, nz, 3) or (nx, ny, nz, C, 3).
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
        out = np.concatenate([phi[..., None], F], axis=-1)  # (nx, ny, nz, C, 4)
        return np.ascontiguousarray(out.reshape(out.shape[:3] + (-1,)), dtype=dtype)

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


# ---------------------------------------------------------------------------------------------
# sources
# ---------------------------------------------------------------------------------------------
def _as_grid(value, name, ndim_ok=(3,), keep_float=False):
    """``value`` as a finite float64 array (or any float dtype with ``keep_float``)."""
    try:
        arr = np.asarray(value)
        if not (keep_float and arr.dtype.kind == "f"):
            arr = arr.astype(np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a numeric array, got {type(value).__name__}") from None
    if arr.ndim not in ndim_ok:
        raise ValueError(f"{name} must have {' or '.join(str(n) for n in ndim_ok)} dimensions, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (found {int(np.count_nonzero(~np.isfinite(arr)))} non-finite values)")
    return arr


def _check_g(g, shape):
    """g as a float or an array broadcast to ``shape`` (a phase object gives its mean cosine)."""
    if hasattr(g, "mean_cosine"):
        g = g.mean_cosine
    if np.ndim(g) == 0:
        return check_real(g, "g", lo=-1.0, hi=1.0, lo_open=True, hi_open=True)
    arr = _as_grid(g, "g")
    if arr.shape != tuple(shape):
        raise ValueError(f"g must be a number or an array of shape {tuple(shape)}, got shape {arr.shape}")
    if np.any(np.abs(arr) >= 1.0):
        raise ValueError(f"g must lie in (-1, 1), got values in [{arr.min()}, {arr.max()}]")
    return arr


def _check_sigma_albedo(sigma_t, albedo):
    sig = _as_grid(sigma_t, "sigma_t")
    if np.any(sig < 0):
        raise ValueError(f"sigma_t must be >= 0, got minimum {sig.min()!r}")
    alb = _as_grid(albedo, "albedo", (3, 4), keep_float=True)
    if alb.shape[:3] != sig.shape:
        raise ValueError(f"albedo must have shape {sig.shape} or {sig.shape + ('C',)}, got {alb.shape}")
    if np.any(alb < 0) or np.any(alb > 1):
        raise ValueError(f"albedo must lie in [0, 1], got values in [{alb.min()}, {alb.max()}]")
    return sig, alb


def first_collision_source(sigma_t, albedo, g, E_d, omega):
    """First-collision source of one light (DESIGN §4b.1): ``Q0 = σs E_d``, ``Q1 = g σs E_d ω``.

    Parameters
    ----------
    sigma_t : array (nx, ny, nz)
        Extinction σt at the data samples (1/world unit).
    albedo : array (nx, ny, nz) or (nx, ny, nz, C)
        Single-scattering albedo per channel; σs = albedo·σt.
    g : float, array (nx, ny, nz) or PhaseFunction
        Mean cosine of the phase function (a phase object gives ``mean_cosine``).
    E_d : array (nx, ny, nz) or (nx, ny, nz, C)
        Direct irradiance, transmittance included, averaged over each control volume
        (:func:`direct_irradiance`), W/m².
    omega : array (nx, ny, nz, 3)
        The light's mean unit propagation direction per node (world); its length may fall below
        1 next to a point light, where the control volume sees the light from all sides.

    Returns
    -------
    Q0 : numpy.ndarray
        float32 (nx, ny, nz) or (nx, ny, nz, C), W/m³.
    Q1 : numpy.ndarray
        float32 (nx, ny, nz, 3) or (nx, ny, nz, C, 3), W/m³, world components.

    Examples
    --------
    >>> import numpy as np
    >>> from pv_ambient.stages.diffusion import first_collision_source
    >>> s = np.full((2, 2, 2), 2.0); a = np.full((2, 2, 2, 3), 0.5); E = np.ones((2, 2, 2, 3))
    >>> w = np.zeros((2, 2, 2, 3)); w[..., 2] = 1.0
    >>> Q0, Q1 = first_collision_source(s, a, 0.5, E, w)
    >>> float(Q0[0, 0, 0, 0]), Q1[0, 0, 0, 0].tolist()
    (1.0, [0.0, 0.0, 0.5])
    """
    sig, alb = _check_sigma_albedo(sigma_t, albedo)
    gg = _check_g(g, sig.shape)
    E = _as_grid(E_d, "E_d", (3, 4))
    if E.shape[:3] != sig.shape:
        raise ValueError(f"E_d must have shape {sig.shape} or {sig.shape + ('C',)}, got {E.shape}")
    if np.any(E < 0):
        raise ValueError(f"E_d must be >= 0, got minimum {E.min()!r}")
    om = _as_grid(omega, "omega", (4,))
    if om.shape != sig.shape + (3,):
        raise ValueError(f"omega must have shape {sig.shape + (3,)}, got {om.shape}")
    multi = alb.ndim == 4 or E.ndim == 4
    if alb.ndim == 4 and E.ndim == 4 and alb.shape[3] != E.shape[3]:
        raise ValueError(f"albedo has {alb.shape[3]} channels but E_d has {E.shape[3]}")
    if multi:
        a4 = alb if alb.ndim == 4 else alb[..., None]
        e4 = E if E.ndim == 4 else E[..., None]
        q0 = a4 * sig[..., None] * e4
        gq = gg if np.ndim(gg) == 0 else gg[..., None]
        q1 = (gq * q0)[..., None] * om[..., None, :]
    else:
        q0 = alb * sig * E
        q1 = (gg * q0)[..., None] * om
    return q0.astype(np.float32), q1.astype(np.float32)


def direct_irradiance(light, geometry, tau, light_grid, *, subsamples=SUBSAMPLES, far_subsamples=FAR_SUBSAMPLES,
                      near=NEAR, near_directions=NEAR_DIRECTIONS):
    """Direct irradiance of ``light`` averaged over each node's control volume.

    The control volume of node (i, j, k) is the index box ``[i−½, i+½]³`` clipped to the medium's
    box. Point light: ``I·T/d²`` with the exact ``1/d²`` and T = exp(−τ), τ trilinear on the
    light grid. The mean over a control volume is taken by midpoint sub-samples:
    ``subsamples``³ where the box lies within 8 index units of the light (max-norm),
    ``far_subsamples``³ farther out (the midpoint rule's relative error on ``1/d²`` is about
    δ²/(12 d²) for sub-cells of size δ at distance d, below 0.1% there); and where the box lies
    within ``near`` index units of the light (the singularity) it is
    ``(1/V) ∫_{S²} ∫_{chord} T dt dΩ`` — exact for ``1/d²`` — with ``near_directions`` ×
    2·``near_directions`` directions and 4 samples of T per chord. So ``Σ σ E_d V`` conserves
    the light's power up to the quadrature (see the tests). Directional light: the mean of
    ``E·T`` over ``far_subsamples``³ sub-samples.

    Parameters
    ----------
    light : PointLight or DirectionalLight
    geometry : GridGeometry
        The data grid's placement (``shape``, ``index_to_world``, ``box_lo``, ``box_hi``).
    tau : array (m0, m1, m2)
        Optical depth from the light on ``light_grid`` (``Renderer.optical_depth``).
    light_grid : LightGrid
        Its ``lo`` and ``inv_step`` map a data index to a light-grid index.

    Returns
    -------
    E_d : numpy.ndarray
        float64 (nx, ny, nz, 3), W/m² per RGB channel.
    omega : numpy.ndarray
        float64 (nx, ny, nz, 3): the E-weighted mean propagation direction (world).
    """
    from .._kernels.diffusion import irradiance_point, transmittance_cv
    from ..inputs.lights import DirectionalLight, PointLight

    shape = tuple(int(n) for n in geometry.shape)
    subsamples = check_int(subsamples, "subsamples", lo=1)
    far_subsamples = check_int(far_subsamples, "far_subsamples", lo=1)
    near = check_real(near, "near", lo=0.0)
    near_directions = check_int(near_directions, "near_directions", lo=1)
    tau = np.ascontiguousarray(_as_grid(tau, "tau"))
    M = np.ascontiguousarray(np.asarray(geometry.index_to_world, np.float64)[:3, :])
    lo = np.asarray(geometry.box_lo, np.float64)
    hi = np.asarray(geometry.box_hi, np.float64)
    tlo = np.asarray(light_grid.lo, np.float64)
    tinv = np.asarray(light_grid.inv_step, np.float64)
    e = np.zeros(shape)
    if isinstance(light, PointLight):
        omega = np.zeros(shape + (3,))
        Minv = np.ascontiguousarray(np.linalg.inv(M[:, :3]))
        pl = Minv @ (np.asarray(light.position, np.float64) - M[:, 3])
        cvvol = abs(float(np.linalg.det(M[:, :3])))
        irradiance_point(M, Minv, lo, hi, pl, tau, tlo, tinv, subsamples, far_subsamples, SUBSAMPLE_RADIUS, near,
                         near_directions, NEAR_CHORD, cvvol, e, omega)
        power = np.asarray(light.intensity, np.float64)
    elif isinstance(light, DirectionalLight):
        transmittance_cv(lo, hi, tau, tlo, tinv, far_subsamples, e)
        omega = np.broadcast_to(np.asarray(light.direction, np.float64), shape + (3,)).copy()
        power = np.asarray(light.irradiance, np.float64)
    else:
        raise TypeError(f"light must be a PointLight or DirectionalLight, got {type(light).__name__}")
    return e[..., None] * power, omega


# ---------------------------------------------------------------------------------------------
# the finite-volume system
# ---------------------------------------------------------------------------------------------
def _cv_widths(n, association):
    """Control-volume widths (index units) along an axis with n nodes."""
    w = np.ones(n)
    if association == "point" and n > 1:
        w[0] = w[-1] = 0.5
    return w


class _Grid:
    """Geometry of the finite-volume system: widths, volumes, face areas."""

    def __init__(self, shape, spacing, association, faces=None):
        self.shape = shape
        self.faces = faces or (("marshak", "marshak"),) * 3
        self.h = np.asarray(spacing, np.float64)
        self.association = association
        self.wd = [_cv_widths(n, association) * h for n, h in zip(shape, self.h)]  # world widths
        wx, wy, wz = self.wd
        self.volume = wx[:, None, None] * wy[None, :, None] * wz[None, None, :]
        # face areas perpendicular to each axis, as broadcastable arrays
        self.area = [(wy[:, None] * wz[None, :])[None], (wx[:, None] * wz[None, :])[:, None, :],
                     (wx[:, None] * wy[None, :])[:, :, None]]


def _sl(axis, a, b):
    s = [slice(None)] * 3
    s[axis] = slice(a, b)
    return tuple(s)


def _face_mean(D, axis, harmonic):
    n = D.shape[axis]
    d0, d1 = D[_sl(axis, 0, n - 1)], D[_sl(axis, 1, n)]
    if harmonic:
        return 2.0 * d0 * d1 / (d0 + d1)
    return 0.5 * (d0 + d1)


def _reflects(grid, axis, side):
    return grid.faces[axis][0 if side < 0 else 1] == "reflect"


def _boundary(grid, axis, side):
    """Slices of the boundary nodes on one side of an axis and their face areas."""
    idx = 0 if side < 0 else grid.shape[axis] - 1
    return _sl(axis, idx, idx + 1), grid.area[axis]


def _system(grid, sigma_a, D, Q0, Q1):
    """Couplings, absorption/boundary diagonal and right-hand side of one channel (float64).
    Interior faces: ``_kernels.diffusion.assemble_faces``; box faces here."""
    from .._kernels.diffusion import assemble_faces

    shape = grid.shape
    w = [np.empty(shape) for _ in range(3)]
    b = Q0 * grid.volume
    c = sigma_a * grid.volume
    q1 = _NO_Q1 if Q1 is None else np.ascontiguousarray(Q1, np.float64)
    hx, hy, hz = (float(v) for v in grid.h)
    assemble_faces(np.ascontiguousarray(D, np.float64), q1, Q1 is not None, *grid.wd, hx, hy, hz, *w, b)
    for a in range(3):
        if shape[a] < 2:
            continue
        for side in (-1, 1):
            if _reflects(grid, a, side):
                continue
            s, Ab = _boundary(grid, a, side)
            if grid.association == "point":
                c[s] += 0.5 * Ab
            else:
                Dn = D[s]
                c[s] += Ab * 2.0 * Dn / (4.0 * Dn + grid.h[a])
                if Q1 is not None:
                    b[s] -= Ab * 3.0 * Dn * grid.h[a] * side * Q1[..., a][s] / (4.0 * Dn + grid.h[a])
    return w, c, b


def _node_flux(grid, phi, D, Q1):
    """F at the nodes (index-axis components): the mean of the two adjacent face fluxes; at a
    point-data boundary node its Marshak face flux; 3 D Q1 along an axis with one node."""
    shape = grid.shape
    F = np.zeros(shape + (3,))
    for a in range(3):
        n = shape[a]
        q = None if Q1 is None else Q1[..., a]
        if n < 2:
            if q is not None:
                F[..., a] = 3.0 * D * q
            continue
        Df = _face_mean(D, a, True)
        Ff = -Df * (phi[_sl(a, 1, n)] - phi[_sl(a, 0, n - 1)]) / grid.h[a]
        if q is not None:
            Ff += 3.0 * Df * 0.5 * (q[_sl(a, 0, n - 1)] + q[_sl(a, 1, n)])
        Fa = F[..., a]
        Fa[_sl(a, 1, n - 1)] = 0.5 * (Ff[_sl(a, 0, n - 2)] + Ff[_sl(a, 1, n - 1)])
        for side in (-1, 1):
            s, _ = _boundary(grid, a, side)
            out = _boundary_flux(grid, a, side, phi, D, q)  # outward F·n at the box face
            if grid.association == "point":
                Fa[s] = side * out
            else:
                inner = Ff[_sl(a, 0, 1)] if side < 0 else Ff[_sl(a, n - 2, n - 1)]
                Fa[s] = 0.5 * (side * out + inner)
    return F


def _boundary_flux(grid, a, side, phi, D, q):
    """Outward F·n at the box face on one side of axis a, per unit area."""
    s = _boundary(grid, a, side)[0]
    if _reflects(grid, a, side):
        return np.zeros_like(phi[s])
    if grid.association == "point":
        return 0.5 * phi[s]
    Dn, h = D[s], grid.h[a]
    out = 2.0 * Dn * phi[s] / (4.0 * Dn + h)
    if q is not None:
        out = out + 3.0 * Dn * h * side * q[s] / (4.0 * Dn + h)
    return out


def _power(grid, phi, sigma_a, D, Q0, Q1):
    src = float(np.sum(Q0 * grid.volume))
    absorbed = float(np.sum(sigma_a * phi * grid.volume))
    escaped = 0.0
    for a in range(3):
        if grid.shape[a] < 2:
            continue
        q = None if Q1 is None else Q1[..., a]
        for side in (-1, 1):
            _, Ab = _boundary(grid, a, side)
            escaped += float(np.sum(Ab * _boundary_flux(grid, a, side, phi, D, q)))
    return src, absorbed, escaped


# ---------------------------------------------------------------------------------------------
# multigrid-preconditioned conjugate gradients
# ---------------------------------------------------------------------------------------------
class _Level:
    def __init__(self, w, c):
        from .._kernels.diffusion import make_diag

        self.wx, self.wy, self.wz = (np.ascontiguousarray(x, dtype=np.float64) for x in w)
        self.c = np.ascontiguousarray(c, dtype=np.float64)
        self.shape = self.c.shape
        self.diag = np.empty(self.shape)
        make_diag(self.wx, self.wy, self.wz, self.c, self.diag)
        self.x = np.zeros(self.shape)
        self.b = np.zeros(self.shape)
        self.f = (1, 1, 1)
        self.inv = None
        self.serial = self.c.size <= SERIAL_NODES

    @property
    def ops(self):
        return self.wx, self.wy, self.wz, self.diag


def _dense(lv):
    """Dense matrix of a (small) level."""
    nx, ny, nz = lv.shape
    N = nx * ny * nz
    A = np.diag(lv.diag.ravel())
    idx = np.arange(N).reshape(lv.shape)
    for w, s0, s1 in ((lv.wx[:-1], idx[:-1], idx[1:]), (lv.wy[:, :-1], idx[:, :-1], idx[:, 1:]),
                      (lv.wz[:, :, :-1], idx[:, :, :-1], idx[:, :, 1:])):
        A[s0.ravel(), s1.ravel()] = -w.ravel()
        A[s1.ravel(), s0.ravel()] = -w.ravel()
    return A


def _hierarchy(w, c, spacing, coarse_nodes=COARSE_NODES):
    """Aggregation multigrid levels, finest first; the last carries a dense inverse."""
    from .._kernels.diffusion import coarsen

    levels = [_Level(w, c)]
    h = np.asarray(spacing, np.float64).copy()
    while True:
        lv = levels[-1]
        n = lv.shape
        if int(np.prod(n)) <= coarse_nodes or all(m == 1 for m in n):
            break
        active = [m > 1 for m in n]
        hmin = min(h[a] for a in range(3) if active[a])
        f = tuple(2 if active[a] and h[a] <= 2.0 * hmin * (1 + 1e-9) else 1 for a in range(3))
        nc = tuple(-(-n[a] // f[a]) for a in range(3))
        wc = [np.zeros(nc) for a in range(3)]
        cc = np.zeros(nc)
        coarsen(lv.wx, lv.wy, lv.wz, lv.c, f[0], f[1], f[2], wc[0], wc[1], wc[2], cc)
        lv.f = f
        h = h * np.asarray(f)
        levels.append(_Level(wc, cc))
    A = _dense(levels[-1])
    try:
        inv = np.linalg.inv(A)
    except np.linalg.LinAlgError:  # pragma: no cover - excluded by the checks in solve_diffusion
        inv = np.linalg.pinv(A)
    levels[-1].inv = 0.5 * (inv + inv.T)
    return levels


@contextmanager
def _one_thread_if(flag):
    """Run the enclosed kernels on one thread when ``flag`` (restores the thread count)."""
    if not flag:
        yield
        return
    import numba

    nt = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(nt)


def _vcycle(levels, l):
    """levels[l].x ≈ A_l⁻¹ levels[l].b by one symmetric V-cycle."""
    from .._kernels.diffusion import gs_color, gs_first, prolong_add, residual_restrict

    lv = levels[l]
    if lv.inv is not None:
        lv.x[...] = (lv.inv @ lv.b.ravel()).reshape(lv.shape)
        return
    # small levels run on one thread: a parallel launch costs more than the work
    with _one_thread_if(lv.serial and l > 0 and not levels[l - 1].serial):
        _vcycle_body(levels, l, gs_color, gs_first, prolong_add, residual_restrict)


def _vcycle_body(levels, l, gs_color, gs_first, prolong_add, residual_restrict):
    lv = levels[l]
    ops = lv.ops
    # pre-smooth red → black, coarse-grid correction, post-smooth black → red (symmetric)
    gs_first(*ops, lv.x, lv.b, 0)
    gs_color(*ops, lv.x, lv.b, 1)
    nxt = levels[l + 1]
    residual_restrict(*ops, lv.x, lv.b, *lv.f, nxt.b)
    _vcycle(levels, l + 1)
    prolong_add(nxt.x, *lv.f, lv.x)
    gs_color(*ops, lv.x, lv.b, 1)
    gs_color(*ops, lv.x, lv.b, 0)


def _pcg(levels, b, x0, tol, maxiter, preconditioner, bar=None):
    """Solve A x = b (A = levels[0]); returns x, iterations, relative residual."""
    from .._kernels.diffusion import cg_direction, cg_step, dot_parts, jacobi, matvec_dot, residual

    lv = levels[0]
    ops = lv.ops
    part = np.zeros(lv.shape[0])
    bnorm = math.sqrt(float(np.sum(b * b)))
    x = np.zeros(lv.shape) if x0 is None else np.array(x0, dtype=np.float64)
    if bnorm == 0.0:
        return np.zeros(lv.shape), 0, 0.0
    r = np.empty(lv.shape)
    if x0 is None:
        r[...] = b
    else:
        residual(*ops, x, b, r)
    rnorm = math.sqrt(float(np.sum(r * r)))
    if rnorm <= tol * bnorm:
        return x, 0, rnorm / bnorm
    z = lv.x if preconditioner == "multigrid" else np.empty(lv.shape)

    def precondition():
        if preconditioner == "multigrid":
            lv.b[...] = r
            _vcycle(levels, 0)
            dot_parts(r, z, part)
        else:
            jacobi(lv.diag, r, z, part)
        return float(part.sum())

    rz = precondition()
    p = z.copy()
    q = np.empty(lv.shape)
    it = 0
    while it < maxiter:
        it += 1
        matvec_dot(*ops, p, q, part)
        pq = float(part.sum())
        if not pq > 0.0:  # pragma: no cover - breakdown: A not SPD in floating point
            break
        alpha = rz / pq
        cg_step(x, r, p, q, alpha, part)
        rnorm = math.sqrt(float(part.sum()))
        if bar is not None:
            bar.update(1)
        if rnorm <= tol * bnorm:
            break
        rz_new = precondition()
        cg_direction(p, z, rz_new / rz)
        rz = rz_new
    return x, it, rnorm / bnorm


# ---------------------------------------------------------------------------------------------
# the solver
# ---------------------------------------------------------------------------------------------
def _flux_limited_D(grid, phi, sig_p, Q1, d_max, d_min):
    """Levermore–Pomraning D = λ(R)/σt' at the nodes, R = |∇φ − 3Q1|/(σt' φ), clipped to
    [d_min, d_max] (d_max: the vacuum floor's D); ∇φ as ``numpy.gradient`` (central differences,
    one-sided on the box faces). The kernel: ``_kernels.diffusion.limiter_coefficients``."""
    from .._kernels.diffusion import limiter_coefficients

    out = np.empty(grid.shape)
    q1 = _NO_Q1 if Q1 is None else np.ascontiguousarray(Q1, np.float64)
    hx, hy, hz = (float(v) for v in grid.h)
    limiter_coefficients(np.ascontiguousarray(phi, np.float64), np.ascontiguousarray(sig_p, np.float64), q1,
                             Q1 is not None, hx, hy, hz, float(d_max), float(d_min), out)
    return out


def _solve_channel(grid, sig_p, sigma_a, sigma_s, D0, Q0, Q1, x0, tol, maxiter, preconditioner, flux_limited,
                   max_outer, outer_tol, d_max, d_min, bar):
    """One channel: (phi float64, D used, iterations, largest residual, outer passes, whether the
    flux limiter's passes converged)."""
    w, c, b = _system(grid, sigma_a, D0, Q0, Q1)
    levels = _hierarchy(w, c, grid.h) if preconditioner == "multigrid" else [_Level(w, c)]
    # The flux limiter's passes only need each lagged solve well below the change they measure
    # (outer_tol): they run to INNER_REL·outer_tol, and the last one is finished to tol.
    loose = max(tol, INNER_REL * outer_tol) if flux_limited else tol
    if flux_limited and x0 is not None and WARM_CHANNELS and np.any(x0 > 0):
        # a warm start (a relight, or another channel) is already near the limited solution:
        # the lagged passes start from it instead of from a plain-diffusion solve
        phi, its, res = np.maximum(np.asarray(x0, np.float64), 0.0), 0, math.inf
    else:
        phi, its, res = _pcg(levels, b, x0, loose, maxiter, preconditioner, bar)
    D = D0
    outer = 0
    outer_ok = True
    if flux_limited:
        # Lagged coefficients: φ_{k+1} = S(φ_k), the solve with D(φ_k), accelerated by Anderson
        # mixing of depth ANDERSON_DEPTH (the plain lagged iteration contracts by only ≈ 0.8 per
        # pass in optically thin regions). The change that ends the passes is weighted by σs:
        # what the camera pass sees.
        weight = sigma_s if np.any(sigma_s > 0) else np.ones(grid.shape)
        xs, gs = [], []
        x = phi
        outer_ok = False
        for outer in range(1, max_outer + 1):
            D = _flux_limited_D(grid, x, sig_p, Q1, d_max, d_min)
            w, c, b = _system(grid, sigma_a, D, Q0, Q1)
            levels = _hierarchy(w, c, grid.h) if preconditioner == "multigrid" else [_Level(w, c)]
            phi, k, res = _pcg(levels, b, x, loose, maxiter, preconditioner, bar)
            its += k
            change = float(np.linalg.norm(weight * (phi - x))) / max(float(np.linalg.norm(weight * phi)), 1e-300)
            if change < outer_tol:
                outer_ok = True
                break
            xs.append(x)
            gs.append(phi)
            del xs[:-(ANDERSON_DEPTH + 1)], gs[:-(ANDERSON_DEPTH + 1)]
            x = _anderson(xs, gs) if len(xs) > 1 else phi
    if loose > tol and res > tol:  # finish the last solve (same D) to the stated tolerance
        phi, k, res = _pcg(levels, b, phi, tol, maxiter, preconditioner, bar)
        its += k
    worst = res
    return phi, D, its, worst, outer, outer_ok


def _anderson(xs, gs):
    """Anderson mixing: the combination of the last images S(x_i) = gs[i] whose residuals
    f_i = gs[i] − xs[i] combine to the least 2-norm; clamped at 0 (φ ≥ 0 for the limiter)."""
    f = [g - x for x, g in zip(xs, gs)]
    dF = np.stack([(f[i + 1] - f[i]).ravel() for i in range(len(f) - 1)], axis=1)
    dG = np.stack([(gs[i + 1] - gs[i]).ravel() for i in range(len(gs) - 1)], axis=1)
    A = dF.T @ dF
    A += 1e-12 * np.trace(A) * np.eye(A.shape[0])
    try:
        gamma = np.linalg.solve(A, dF.T @ f[-1].ravel())
    except np.linalg.LinAlgError:  # pragma: no cover - degenerate history: plain lagged step
        return gs[-1]
    return np.maximum((gs[-1].ravel() - dG @ gamma).reshape(gs[-1].shape), 0.0)


def mean_chord(shape, spacing, association="point"):
    """Mean chord length of the medium's box: the average distance a straight line crossing it
    travels inside (isotropic, uniformly placed lines; Cauchy's formula).

    ``4V/S`` for a box; axes with a single node are infinite (a uniform problem along them):
    ``πA/P`` for a rectangle (2D), twice the thickness for a slab (1D); for a single node, its
    largest spacing. The box is ``(n − 1)·h`` per axis for point data and ``n·h`` for cell data.

    >>> round(mean_chord((65, 65, 65), (1 / 32,) * 3), 6)  # a 2-unit cube: 4V/S = 2a/3
    1.333333
    """
    n = np.asarray(shape)
    sp = np.asarray(spacing, np.float64)
    ext = (n - (1 if association == "point" else 0)) * sp
    e = ext[n > 1]
    if e.size == 3:
        a, b, c = e
        return float(2.0 * a * b * c / (a * b + b * c + c * a))
    if e.size == 2:
        return float(math.pi * e[0] * e[1] / (2.0 * (e[0] + e[1])))
    if e.size == 1:
        return float(2.0 * e[0])
    return float(np.max(sp))


def solve_diffusion(sigma_t, albedo, g, spacing, Q0, Q1=None, *, flux_limited=False, tol=DEFAULT_TOL,
                    maxiter=None, x0=None, progress_bar=False, association="point", direction=None,
                    sigma_floor=None, preconditioner="multigrid", max_outer=20, outer_tol=1e-2,
                    boundary="marshak"):
    """Solve P1 diffusion for the multiply-scattered light (DESIGN §4b.2–3).

    ``∇·F + σa φ = Q0``, ``F = −D∇φ + 3DQ1``, ``D = 1/(3σt')``, ``σt' = σa + σs(1 − g)``;
    Marshak vacuum boundary ``F·n = φ/2`` on the box faces. Discretisation and solver: see the
    module docstring. Channels are solved one by one (σa differs per channel); channels whose
    albedo is equal share the operator, and channels whose sources are also proportional share
    the solve (the answer is scaled).

    Parameters
    ----------
    sigma_t : array (nx, ny, nz)
        Extinction at the data samples (1/world unit), ≥ 0.
    albedo : array (nx, ny, nz) or (nx, ny, nz, C)
        Single-scattering albedo in [0, 1] (one grey channel, or one per channel).
    g : float, array (nx, ny, nz) or PhaseFunction
        Mean cosine of the phase function, in (−1, 1).
    spacing : sequence of 3 floats
        World length of one index step per axis.
    Q0 : array (nx, ny, nz) or (nx, ny, nz, C)
        Isotropic source, W/m³, averaged over each control volume.
    Q1 : array (nx, ny, nz, 3) or (nx, ny, nz, C, 3), optional
        First-moment source, W/m³, world components (zero when None).
    flux_limited : bool, default: False
        Levermore–Pomraning flux limiter with lagged coefficients.
    tol : float, default: 1e-6
        Stop when ``‖b − Aφ‖₂/‖b‖₂ ≤ tol`` (the finite-volume system in W per control volume).
    maxiter : int, optional
        Iteration cap per solve (200 with multigrid, 20000 with Jacobi when None).
    x0 : array like the returned ``phi``, optional
        Warm start (e.g. the previous solution of a relit scene).
    progress_bar : bool, default: False
        tqdm bar over the iterations.
    association : {"point", "cell"}, default: "point"
        Point data: boundary nodes lie on the box faces (half control volumes); cell data: the
        faces lie half a spacing beyond them (``GridGeometry.association``).
    direction : array (3, 3), optional
        Orthonormal matrix whose columns are the world directions of the index axes
        (``index_to_world[:3, :3] / spacing``); identity when None.
    sigma_floor : float, optional
        Floor of σt' inside D (vacuum); ``1/ℓ̄`` when None, ℓ̄ the mean chord length of the
        medium's box (:func:`mean_chord`; module docstring, "Vacuum floor").
    preconditioner : {"multigrid", "jacobi"}, default: "multigrid"
    max_outer : int, default: 20
        Flux-limiter passes after the first (plain) solve. Scenes that converge take 2–4 per
        channel; a point light inside the medium can take 12–20 (the extremes' scale scene).
    outer_tol : float, default: 1e-2
        Relative change of σs·φ (2-norm; of φ where σs = 0 everywhere) that ends the
        flux-limiter passes.
    boundary : str or 3 pairs of str, default: "marshak"
        ``"marshak"`` (vacuum outside: ``F·n = φ/2``) or ``"reflect"`` (a symmetry plane:
        ``F·n = 0``), for every face or per face as ``((x_lo, x_hi), (y_lo, y_hi), (z_lo, z_hi))``.

    Returns
    -------
    DiffusionSolution

    Examples
    --------
    >>> import numpy as np
    >>> from pv_ambient.stages.diffusion import solve_diffusion
    >>> sig = np.full((9, 9, 9), 4.0); alb = np.full((9, 9, 9), 0.9)
    >>> Q0 = np.zeros((9, 9, 9)); Q0[4, 4, 4] = 1.0
    >>> sol = solve_diffusion(sig, alb, 0.0, (0.25, 0.25, 0.25), Q0)
    >>> sol.converged, sol.phi.shape
    (True, (9, 9, 9))
    """
    t_start = time.perf_counter()
    sig, alb = _check_sigma_albedo(sigma_t, albedo)
    shape = sig.shape
    gg = _check_g(g, shape)
    sp = np.asarray(spacing, dtype=np.float64) if not np.isscalar(spacing) else np.full(3, float(spacing))
    if sp.shape != (3,) or not np.all(np.isfinite(sp)) or np.any(sp <= 0):
        raise ValueError(f"spacing must be 3 positive finite numbers, got {spacing!r}")
    check_choice(association, "association", ("point", "cell"))
    check_choice(preconditioner, "preconditioner", ("multigrid", "jacobi"))
    tol = check_real(tol, "tol", lo=0.0, hi=1.0, lo_open=True, hi_open=True)
    maxiter = DEFAULT_MAXITER[preconditioner] if maxiter is None else check_int(maxiter, "maxiter", lo=1)
    max_outer = check_int(max_outer, "max_outer", lo=1)
    outer_tol = check_real(outer_tol, "outer_tol", lo=0.0, lo_open=True)
    q0 = _as_grid(Q0, "Q0", (3, 4), keep_float=True)  # float32 sources stay float32 until sliced
    if q0.shape[:3] != shape:
        raise ValueError(f"Q0 must have shape {shape} or {shape + ('C',)}, got {q0.shape}")
    multi = q0.ndim == 4
    C = q0.shape[3] if multi else 1
    if alb.ndim == 4 and (not multi or alb.shape[3] != C):
        if not multi:
            raise ValueError(f"albedo has {alb.shape[3]} channels, so Q0 must have shape {shape + (alb.shape[3],)}, "
                             f"got {q0.shape}")
        raise ValueError(f"albedo has {alb.shape[3]} channels but Q0 has {C}")
    qshape = shape + ((C, 3) if multi else (3,))
    if Q1 is None:
        q1 = None
    else:
        q1 = _as_grid(Q1, "Q1", (4, 5), keep_float=True)
        if q1.shape != qshape:
            raise ValueError(f"Q1 must have shape {qshape} (matching Q0 {q0.shape}), got {q1.shape}")
    if direction is not None:
        R = np.asarray(direction, np.float64)
        if R.shape != (3, 3) or not np.allclose(R.T @ R, np.eye(3), atol=1e-6):
            raise ValueError("direction must be an orthonormal 3×3 matrix (columns: the index axes in world), "
                             f"got {direction!r}")
    else:
        R = None
    if x0 is not None:
        x0 = _as_grid(x0, "x0", (3, 4))
        if x0.shape != q0.shape:
            raise ValueError(f"x0 must have the shape of phi {q0.shape}, got {x0.shape}")
    if sigma_floor is None:
        sigma_floor = SIGMA_FLOOR_REL / mean_chord(shape, sp, association)
    sigma_floor = check_real(sigma_floor, "sigma_floor", lo=0.0, lo_open=True)
    d_max = 1.0 / (3.0 * sigma_floor)
    d_min = D_MIN_REL * float(np.min(sp))

    grid = _Grid(shape, sp, association, _check_boundary(boundary))
    phi_out = np.zeros(shape + ((C,) if multi else ()), np.float64)
    F_out = np.zeros(qshape, np.float32)
    power = {k: np.zeros(C) for k in ("source", "absorbed", "escaped")}
    total_its, worst, conv_all, n_solves, n_outer = 0, 0.0, True, 0, 0
    bar = None
    if progress_bar:
        from tqdm.auto import tqdm

        bar = tqdm(desc="diffusion", unit="it")
    solved = []  # (albedo channel, Q0, Q1, phi) of channels solved so far
    try:
        for ch in range(C):
            a = alb[..., ch] if alb.ndim == 4 else alb
            s0 = np.asarray(q0[..., ch] if multi else q0, np.float64)
            s1 = None if q1 is None else np.asarray(q1[..., ch, :] if multi else q1, np.float64)
            if s1 is not None and R is not None:
                s1 = s1 @ R  # world → index-axis components
            sigma_a = (1.0 - a) * sig
            sig_p = sigma_a + a * sig * (1.0 - gg)
            D0 = 1.0 / (3.0 * np.maximum(sig_p, sigma_floor))
            if not np.any(sigma_a > 0) and not any(
                    shape[ax] > 1 and not _reflects(grid, ax, sd) for ax in range(3) for sd in (-1, 1)):
                raise ValueError("the diffusion problem is singular: no absorption (albedo 1 everywhere) and no "
                                 "face where light can leave (every face reflects or every axis has one node)")
            phi = D = None
            # reuse an earlier channel with equal albedo and proportional sources
            for a_prev, s0_prev, s1_prev, phi_prev, D_prev in solved:
                k = _proportional(a, s0, s1, a_prev, s0_prev, s1_prev)
                if k is not None:
                    phi, D = k * phi_prev, D_prev
                    break
            if phi is None:
                x0c = None if x0 is None else (x0[..., ch] if multi else x0)
                if x0c is None and flux_limited and solved and WARM_CHANNELS:
                    # the previous channel's limited solution, scaled by the source power
                    a_p, s0_p, _, phi_p, _ = solved[-1]
                    p_prev, p_cur = float(np.sum(s0_p)), float(np.sum(s0))
                    if p_prev > 0 and p_cur > 0:
                        x0c = phi_p * (p_cur / p_prev)
                with _one_thread_if(sig.size <= SERIAL_NODES):
                    phi, D, its, res, outer, outer_ok = _solve_channel(
                        grid, sig_p, sigma_a, a * sig, D0, s0, s1, x0c, tol, maxiter, preconditioner, flux_limited,
                        max_outer, outer_tol, d_max, d_min, bar)
                conv = res <= tol and outer_ok
                total_its += its
                worst = max(worst, res)
                conv_all = conv_all and conv
                n_solves += 1
                n_outer += outer
                if not conv:
                    what = (f"relative residual {res:.2e} > tol={tol:.1e} (maxiter={maxiter})" if res > tol else
                            f"the flux limiter's σs·φ still changed by ≥ outer_tol={outer_tol:g} after "
                            f"max_outer={max_outer} passes")
                    warnings.warn(f"diffusion solve of channel {ch} did not converge: {what}, {its} iterations in "
                                  f"all; raise maxiter/max_outer or loosen tol/outer_tol", UserWarning, stacklevel=2)
                solved.append((a, s0, s1, phi, D))
            F = _node_flux(grid, phi, D, s1)
            if R is not None:
                F = F @ R.T  # index-axis → world components
            src, absorbed, escaped = _power(grid, phi, sigma_a, D, s0, s1)
            power["source"][ch], power["absorbed"][ch], power["escaped"][ch] = src, absorbed, escaped
            if multi:
                phi_out[..., ch] = phi
                F_out[..., ch, :] = F
            else:
                phi_out[...] = phi
                F_out[...] = F
    finally:
        if bar is not None:
            bar.close()
    if not multi:
        power = {k: v[0] for k, v in power.items()}
    return DiffusionSolution(phi=phi_out, flux=F_out, iterations=total_its, residual=worst, converged=conv_all,
                             power=power, solves=n_solves, outer_iterations=n_outer,
                             time=time.perf_counter() - t_start)


def _check_boundary(boundary):
    kinds = ("marshak", "reflect")
    if isinstance(boundary, str):
        check_choice(boundary, "boundary", kinds)
        return ((boundary, boundary),) * 3
    try:
        faces = tuple((lo, hi) for lo, hi in boundary)
    except (TypeError, ValueError):
        raise TypeError(f"boundary must be 'marshak', 'reflect' or 3 (low, high) pairs of them, "
                        f"got {boundary!r}") from None
    if len(faces) != 3:
        raise ValueError(f"boundary must give 3 (low, high) pairs, got {len(faces)}: {boundary!r}")
    for pair in faces:
        for f in pair:
            check_choice(f, "boundary face", kinds)
    return faces


def _proportional(a, s0, s1, a_prev, s0_prev, s1_prev):
    """k with (s0, s1) = k·(s0_prev, s1_prev) when the albedo is equal, else None."""
    if not np.array_equal(a, a_prev) or (s1 is None) != (s1_prev is None):
        return None

    def zero(s):
        return s is None or not np.any(s)

    if zero(s0_prev) and zero(s1_prev):
        return 0.0 if zero(s0) and zero(s1) else None
    ref, cur = (s0_prev, s0) if np.any(s0_prev) else (s1_prev, s1)
    i = np.unravel_index(int(np.argmax(np.abs(ref))), ref.shape)
    k = float(cur[i]) / float(ref[i])
    if not np.allclose(s0, k * s0_prev, rtol=1e-6, atol=0.0):
        return None
    if s1 is not None and not np.allclose(s1, k * s1_prev, rtol=1e-6, atol=0.0):
        return None
    return k


# ---------------------------------------------------------------------------------------------
# camera pass and renderer glue
# ---------------------------------------------------------------------------------------------
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


def solve_for_light(renderer, light, g, *, light_resolution=None, **options):
    """Direct irradiance → first-collision source → diffusion for a light (or several) of a
    ``Renderer``.

    Uses ``renderer.optics.sigma_grid()``/``albedo_grid()``, ``renderer.geometry`` and
    ``renderer.optical_depth(light, renderer.light_grid(light_resolution))``. A sequence of
    lights sums their sources into one solve (the problem is linear; per-light solves instead
    let a relight re-solve one light, warm-started with ``x0``). ``options`` go to
    :func:`solve_diffusion`. Returns the 3-channel :class:`DiffusionSolution`.
    """
    geom = renderer.geometry
    grid = renderer.light_grid(light_resolution)
    sig = renderer.optics.sigma_grid()
    alb = renderer.optics.albedo_grid()
    Q0 = Q1 = None
    for lt in (light if isinstance(light, (list, tuple)) else (light,)):
        E, omega = direct_irradiance(lt, geom, renderer.optical_depth(lt, grid), grid)
        q0, q1 = first_collision_source(sig, alb, g, E, omega)
        Q0, Q1 = (q0, q1) if Q0 is None else (Q0 + q0, Q1 + q1)
    if Q0 is None:
        raise ValueError("light must be a light or a non-empty sequence of lights")
    sp = np.asarray(geom.spacing, np.float64)
    R = np.asarray(geom.index_to_world, np.float64)[:3, :3] / sp
    opts = dict(association=getattr(geom, "association", "point"),
                direction=None if np.allclose(R, np.eye(3)) else R)
    opts.update(options)
    return solve_diffusion(sig, alb, g, sp, Q0, Q1, **opts)
