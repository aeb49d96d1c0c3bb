"""The diffusion solve (docs/diffusion.rst §2–3): P1 or flux-limited diffusion per channel, and the
stage's per-light entry point.

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
Too small a floor carries light around a hollow interior and darkens its lit side; too large a
floor holds light back in thin fringes. A larger floor also conditions the matrix better.

Flux-limited diffusion
----------------------
``flux_limited=True``: ``D = λ(R)/σt'`` with Levermore–Pomraning
``λ(R) = (coth R − 1/R)/R`` and ``R = |∇φ − 3 Q1| / (σt' φ)`` (the gradient that drives F, so
``|F| = λ R φ ≤ φ``), evaluated at the nodes from the previous φ (central differences, lagged
coefficients). The first pass is plain diffusion, then up to ``max_outer`` re-solves, each warm
started; they stop when σs·φ changes by less than ``outer_tol`` (relative 2-norm). The plain
lagged iteration contracts by only ≈ 0.8 per pass where the medium is optically thin, so the
passes are accelerated by Anderson mixing of depth 2. The first pass and the lagged passes are
solved only to ``INNER_REL·outer_tol`` (1e−3): the change they measure is ten times larger, and
the last pass is then finished to ``tol`` (same D), so ``residual`` and ``power`` hold as for
plain diffusion. A warm start — ``x0`` (a relight) or, for the second and later channels, the
previous channel's solution scaled by the source power — replaces the plain first pass: the
lagged passes start from it. Where σt' = 0 the limiter gives ``D = φ/|∇φ − 3Q1|`` (free
streaming, at most the vacuum floor's ℓ̄/3).

Warm starts
-----------
Every linear solve starts from its warm start scaled by the energy-optimal factor
(:func:`.multigrid.pcg`): it never starts further from the solution, in the energy norm, than a
zero start, and costs one matrix product. The second and later channels of plain diffusion start from the previous channel's
solution, ``x0`` (the stage passes the previous solution on a relight or a transfer-function
change, docs/diffusion.rst, "Warm starts") from the first channel on.

Transport sweeps
----------------
:func:`solve_for_light` with ``sweep_orders = K`` carries the first K scattering orders by
discrete-ordinates sweeps (:mod:`.ordinates`, docs/diffusion.rst §5) and solves diffusion (plain
or flux-limited, as above) only for the light scattered more than K times, from order K's
fluence and flux; φ and F are the sums.

A solve that reaches ``maxiter`` (or ``max_outer``) first warns (``UserWarning``).

Measured errors against path tracing for several floors, iteration counts and the limiter's
passes: docs/diffusion.rst ("The vacuum floor", "Accuracy").

This module imports numpy, the input checks and the other modules of this package only (no
Renderer, no pyvista or vtk): the caller computes the light's optical depth.
"""

from __future__ import annotations

import math
import time
import warnings

import numpy as np

from ...inputs.validation import check_array, check_choice, check_int, check_real
from .medium import DiffusionMedium, check_mean_cosine
from .ordinates import DEFAULT_DIRECTIONS, scattering_orders
from .multigrid import SERIAL_NODES, Level, hierarchy, one_thread_if, pcg
from .sources import direct_irradiance, hat_source, source_in_medium, unit_irradiance
from .solution import DiffusionSolution
from .limiter import anderson, flux_limited_D, weighted_change
from .system import FVGrid, assemble, check_boundary, flux_and_power, reflects

__all__ = ["flux_limited_D", "mean_chord", "solve_diffusion", "solve_for_light", "solve_in_medium"]

#: Relative residual at which conjugate gradients stop, by default.
DEFAULT_TOL = 1e-6
#: Default iteration caps per preconditioner.
DEFAULT_MAXITER = {"multigrid": 200, "jacobi": 20000}
#: Default vacuum floor of σt' inside D, in units of 1/(mean chord length of the box).
SIGMA_FLOOR_REL = 1.0
#: History depth of the Anderson mixing that accelerates the flux limiter's lagged passes.
ANDERSON_DEPTH = 2
#: Start the flux limiter's passes from a warm start (relight, previous channel) directly.
WARM_CHANNELS = True
#: The flux limiter's lagged solves stop at this fraction of ``outer_tol`` (the last one at ``tol``).
INNER_REL = 0.1
#: Smallest diffusion coefficient the flux limiter may produce, in units of the smallest spacing.
D_MIN_REL = 1e-6


def _solve_channel(grid, sig, a, D0, Q0, Q1, x0, tol, maxiter, preconditioner, flux_limited, max_outer,
                   outer_tol, d_max, d_min, bar, gg):
    """One channel (σt ``sig``, albedo ``a``, D ``D0``): (phi float64, D used, iterations, largest
    residual, outer passes, whether the flux limiter's passes converged)."""
    w, c, b = assemble(grid, sig, a, D0, Q0, Q1)
    levels = hierarchy(w, c, grid.h) if preconditioner == "multigrid" else [Level(w, c)]
    # The flux limiter's passes only need each lagged solve well below the change they measure
    # (outer_tol): they run to INNER_REL·outer_tol, and the last one is finished to tol.
    loose = max(tol, INNER_REL * outer_tol) if flux_limited else tol
    if flux_limited and x0 is not None and WARM_CHANNELS and np.any(x0 > 0):
        # a warm start (a relight, or another channel) is already near the limited solution:
        # the lagged passes start from it instead of from a plain-diffusion solve
        phi, its, res = np.maximum(np.asarray(x0, np.float64), 0.0), 0, math.inf
    else:
        phi, its, res = pcg(levels, b, x0, loose, maxiter, preconditioner, bar)
    D = D0
    outer = 0
    outer_ok = True
    if flux_limited:
        # Lagged coefficients: φ_{k+1} = S(φ_k), the solve with D(φ_k), accelerated by Anderson
        # mixing of depth ANDERSON_DEPTH (the plain lagged iteration contracts by only ≈ 0.8 per
        # pass in optically thin regions). The change that ends the passes is weighted by σs:
        # what the camera pass sees.
        sigma_s = a * sig
        sig_p = (1.0 - a) * sig + sigma_s * (1.0 - gg)
        weight = sigma_s if np.any(sigma_s > 0) else np.ones(grid.shape)
        xs, gs = [], []
        x = phi
        outer_ok = False
        for outer in range(1, max_outer + 1):
            D = flux_limited_D(grid, x, sig_p, Q1, d_max, d_min)
            w, c, b = assemble(grid, sig, a, D, Q0, Q1)
            levels = hierarchy(w, c, grid.h) if preconditioner == "multigrid" else [Level(w, c)]
            phi, k, res = pcg(levels, b, x, loose, maxiter, preconditioner, bar)
            its += k
            change = weighted_change(weight, phi, x)
            if change < outer_tol:
                outer_ok = True
                break
            xs.append(x)
            gs.append(phi)
            del xs[:-(ANDERSON_DEPTH + 1)], gs[:-(ANDERSON_DEPTH + 1)]
            x = anderson(xs, gs) if len(xs) > 1 else phi
    if loose > tol and res > tol:  # finish the last solve (same D) to the stated tolerance
        phi, k, res = pcg(levels, b, phi, tol, maxiter, preconditioner, bar)
        its += k
    worst = res
    return phi, D, its, worst, outer, outer_ok


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


def solve_diffusion(sigma_t, albedo, g, spacing, Q0, Q1=None, **options):
    """Solve P1 diffusion for the multiply-scattered light (docs/diffusion.rst §2–3).

    ``∇·F + σa φ = Q0``, ``F = −D∇φ + 3DQ1``, ``D = 1/(3σt')``, ``σt' = σa + σs(1 − g)``;
    Marshak vacuum boundary ``F·n = φ/2`` on the box faces. Discretisation: :mod:`.system`;
    solver: :mod:`.multigrid` and this module's docstring. Channels are solved one by one (σa
    differs per channel); channels whose albedo is equal share the operator, and channels whose
    sources are also proportional share the solve (the answer is scaled).

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

    Other Parameters
    ----------------
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
        medium's box (:func:`mean_chord`; this module's docstring, "Vacuum floor").
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
    return solve_in_medium(DiffusionMedium.from_arrays(sigma_t, albedo), g, spacing, Q0, Q1, **options)


def solve_in_medium(medium, g, spacing, Q0, Q1=None, *, flux_limited=False, tol=DEFAULT_TOL, maxiter=None, x0=None,
                    progress_bar=False, association="point", direction=None, sigma_floor=None,
                    preconditioner="multigrid", max_outer=20, outer_tol=1e-2, boundary="marshak"):
    """:func:`solve_diffusion` in an already checked :class:`DiffusionMedium` (σt and albedo are
    not scanned or converted again: once per scene, not once per light); same parameters."""
    from ..._kernels.diffusion_system import medium_coefficients

    t_start = time.perf_counter()
    sig, alb = medium.sigma_t, medium.albedo
    shape = sig.shape
    gg = check_mean_cosine(g, shape)
    sp = np.asarray(spacing, dtype=np.float64) if not np.isscalar(spacing) else np.full(3, float(spacing))
    if sp.shape != (3,) or not np.all(np.isfinite(sp)) or np.any(sp <= 0):
        raise ValueError(f"spacing must be 3 positive finite numbers, got {spacing!r}")
    check_choice(association, "association", ("point", "cell"))
    check_choice(preconditioner, "preconditioner", ("multigrid", "jacobi"))
    tol = check_real(tol, "tol", lo=0.0, hi=1.0, lo_open=True, hi_open=True)
    maxiter = DEFAULT_MAXITER[preconditioner] if maxiter is None else check_int(maxiter, "maxiter", lo=1)
    max_outer = check_int(max_outer, "max_outer", lo=1)
    outer_tol = check_real(outer_tol, "outer_tol", lo=0.0, lo_open=True)
    q0, q1, x0, R, multi, C, qshape = _checked_sources(shape, alb, Q0, Q1, x0, direction)
    if sigma_floor is None:
        sigma_floor = SIGMA_FLOOR_REL / mean_chord(shape, sp, association)
    sigma_floor = check_real(sigma_floor, "sigma_floor", lo=0.0, lo_open=True)
    d_max = 1.0 / (3.0 * sigma_floor)
    d_min = D_MIN_REL * float(np.min(sp))

    grid = FVGrid(shape, sp, association, check_boundary(boundary))
    phi_out = np.zeros(shape + ((C,) if multi else ()), np.float64)
    F_out = np.zeros(qshape, np.float32)
    power = {k: np.zeros(C) for k in ("source", "absorbed", "escaped")}
    total_its, worst, conv_all, n_solves, n_outer = 0, 0.0, True, 0, 0
    bar = None
    if progress_bar:
        from tqdm.auto import tqdm

        bar = tqdm(desc="diffusion", unit="it")
    solved = []  # (albedo channel, Q0, Q1, phi, D) of channels solved so far
    g_node = np.ndim(gg) == 3
    g_arr = np.ascontiguousarray(gg, np.float64) if g_node else np.zeros((1, 1, 1))
    part = np.zeros(shape[0])
    try:
        for ch in range(C):
            # channel views, never copies (docs/diffusion.rst, "Precision and memory traffic")
            a = alb[..., ch] if alb.ndim == 4 else alb
            s0 = q0[..., ch] if multi else q0
            s1 = None if q1 is None else (q1[..., ch, :] if multi else q1)
            if s1 is not None and R is not None:
                s1 = s1 @ R  # world → index-axis components
            D0 = np.empty(shape)
            medium_coefficients(sig, a, g_arr, g_node, 0.0 if g_node else float(gg), float(sigma_floor), D0, part)
            if not part.max() > 0.0 and not any(
                    shape[ax] > 1 and not reflects(grid, ax, sd) for ax in range(3) for sd in (-1, 1)):
                raise ValueError("the diffusion problem is singular: no absorption (albedo 1 everywhere) and no "
                                 "face where light can leave (every face reflects or every axis has one node)")
            phi = D = None
            fresh = False
            # reuse an earlier channel with equal albedo and proportional sources
            for a_prev, s0_prev, s1_prev, phi_prev, D_prev in solved:
                k = _proportional(a, s0, s1, a_prev, s0_prev, s1_prev)
                if k is not None:
                    phi, D = k * phi_prev, D_prev
                    break
            if phi is None:
                x0c = None if x0 is None else (x0[..., ch] if multi else x0)
                if x0c is None and solved and WARM_CHANNELS:
                    # the previous channel's solution: pcg scales a start by its energy-optimal
                    # factor; the flux limiter's passes start from it as is, so scaled by the
                    # source power there
                    a_p, s0_p, _, phi_p, _ = solved[-1]
                    x0c = phi_p
                    if flux_limited:
                        p_prev, p_cur = float(np.sum(s0_p, dtype=np.float64)), float(np.sum(s0, dtype=np.float64))
                        x0c = phi_p * (p_cur / p_prev) if p_prev > 0 and p_cur > 0 else None
                with one_thread_if(sig.size <= SERIAL_NODES):
                    phi, D, its, res, outer, outer_ok = _solve_channel(
                        grid, sig, a, D0, s0, s1, x0c, tol, maxiter, preconditioner, flux_limited, max_outer,
                        outer_tol, d_max, d_min, bar, gg)
                fresh = True
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
            phi_c = phi_out[..., ch] if multi else phi_out
            phi_c[...] = phi
            del phi
            if fresh:
                solved.append((a, s0, s1, phi_c, D))
            F_c = F_out[..., ch, :] if multi else F_out
            src, absorbed, escaped = flux_and_power(grid, phi_c, sig, a, D, s0, s1, R, F_c)
            power["source"][ch], power["absorbed"][ch], power["escaped"][ch] = src, absorbed, escaped
    finally:
        if bar is not None:
            bar.close()
    if not multi:
        power = {k: v[0] for k, v in power.items()}
    return DiffusionSolution(phi=phi_out, flux=F_out, iterations=total_its, residual=worst, converged=conv_all,
                             power=power, solves=n_solves, outer_iterations=n_outer,
                             time=time.perf_counter() - t_start)


def _checked_sources(shape, alb, Q0, Q1, x0, direction):
    """The sources, start and direction of :func:`solve_in_medium` checked against the grid's
    ``shape`` and the albedo ``alb``: ``(q0, q1, x0, R, multi, C, qshape)`` — ``multi`` when the
    sources have a channel axis of ``C`` channels, ``qshape`` the flux's shape, ``R`` the index
    axes in world (None: the identity)."""
    q0 = check_array(Q0, "Q0", ndim=(3, 4), dtype="float")  # float32 sources stay float32 until sliced
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
        q1 = check_array(Q1, "Q1", ndim=(4, 5), dtype="float")
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
        x0 = check_array(x0, "x0", ndim=(3, 4), dtype="float")  # float32 stays: pcg converts per channel
        if x0.shape != q0.shape:
            raise ValueError(f"x0 must have the shape of phi {q0.shape}, got {x0.shape}")
    return q0, q1, x0, R, multi, C, qshape


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


def solve_for_light(light, g, *, medium, geometry, tau, light_grid, sweep_orders=0,
                    sweep_directions=DEFAULT_DIRECTIONS, optics=None, coarse=None, coarse_remainder=None, with_flux=True,
                    **options):
    """Direct irradiance → first-collision source → diffusion for a light (or several).

    A sequence of lights sums their sources into one solve (the problem is linear; per-light
    solves instead let a relight re-solve one light, warm-started with ``x0``).

    With ``sweep_orders = K > 0`` the first K scattering orders are carried by transport sweeps
    (:mod:`.ordinates`, docs/diffusion.rst §5) and only the light scattered more than K times by
    diffusion, whose source is then order K's ``Q0 = σs φ_K``, ``Q1 = g σs F_K``; the returned
    φ and F are the sums of both parts (``power`` is the diffusion part's balance).

    Parameters
    ----------
    light : PointLight, DirectionalLight or a sequence of them
    g : float or PhaseFunction
        Mean cosine of the phase function; the transport sweep needs the phase function itself
        (a float stands for Henyey–Greenstein with that ``g``).
    medium : DiffusionMedium
        σt and albedo on the data grid, checked once per scene
        (``DiffusionMedium.from_arrays(optics.sigma_grid(), optics.albedo_grid())``).
    geometry : GridGeometry
        The data grid's placement (spacing, ``index_to_world``, box, ``association``).
    tau : array (m0, m1, m2), or a sequence of them (one per light)
        The light's optical depth on ``light_grid`` (``Renderer.optical_depth``), computed by
        the caller.
    light_grid : LightGrid
        The grid ``tau`` lives on.
    sweep_orders : int, default: 0
        Scattering orders carried by transport sweeps (0: diffusion from the first-collision
        source, §1–3).
    sweep_directions : int or (int, int), default: (64, 32)
        Directions of the sweeps: the first order's and the later orders'.
    optics : Optics, optional
        The transfer function's optics, classified at sub-samples for the sweeps' first-order
        source (:func:`.sources.hat_source`); ``medium`` (trilinear) when None. For the sweeps
        ``medium`` should be :func:`.sources.hat_medium`'s.
    coarse : (Coarsening, DiffusionMedium), optional
        Solve on a coarser grid (:mod:`.coarse`; plain diffusion only, not with ``sweep_orders``
        or ``flux_limited``): the first-collision source is computed on the data grid and
        restricted, the coarse medium (``Coarsening.medium``) takes the solve, φ and F come back
        interpolated at the data samples, and a box around each point light is solved again at
        the data resolution. ``x0`` stays on the data grid.
    coarse_remainder : (Coarsening, DiffusionMedium), optional
        With ``sweep_orders``: the light scattered more than K times diffused on this coarser grid
        (``DiffusionMedium``: ``medium`` restricted, :meth:`.coarse.Coarsening.medium`), its source
        restricted and φ and F interpolated back at the data samples; the swept orders stay on
        the data grid. No box around the lights is needed: order K's fluence, scattered K times
        already, is smooth there (docs/diffusion.rst, "Solve resolution"). An isotropic phase
        function only (no first-moment source).
    with_flux : bool, default: True
        With ``sweep_orders``: False forms no flux sum and returns ``flux`` None — for a phase
        function of mean cosine 0, whose radiance has no flux term (docs/diffusion.rst §4), so the
        camera pass reads φ alone; an isotropic one's sweeps then store a third as much
        (:func:`.ordinates.sweep_once`).
    **options
        Passed to :func:`solve_in_medium` (see :func:`solve_diffusion`); ``association`` and
        ``direction`` default to the geometry's.

    Returns
    -------
    DiffusionSolution
        3 channels.
    """
    lights = light if isinstance(light, (list, tuple)) else (light,)
    taus = tau if isinstance(tau, (list, tuple)) else (tau,)
    if len(taus) != len(lights):
        raise ValueError(f"tau must give one optical depth per light: {len(lights)} lights, {len(taus)} tau")
    if not lights:
        raise ValueError("light must be a light or a non-empty sequence of lights")
    sweep_orders = check_int(sweep_orders, "sweep_orders", lo=0)
    sp = np.asarray(geometry.spacing, np.float64)
    R = np.asarray(geometry.index_to_world, np.float64)[:3, :3] / sp
    opts = dict(association=getattr(geometry, "association", "point"),
                direction=None if np.allclose(R, np.eye(3)) else R)
    opts.update(options)
    t_start = time.perf_counter()
    if sweep_orders:
        kind, pg = _phase_kind(g)  # before any work: one phase function for the whole medium
    if not sweep_orders and coarse is not None:
        return _solve_coarse(lights, taus, g, medium, geometry, light_grid, coarse, opts, t_start)
    Q0 = Q1 = None
    first = []  # the sweeps' first order per light: (Q0, ω)
    for lt, tau_l in zip(lights, taus):
        if sweep_orders:
            first.append(hat_source(lt, geometry, tau_l, light_grid, medium if optics is None else optics, medium))
        else:
            E, omega = direct_irradiance(lt, geometry, tau_l, light_grid, sigma_t=medium.sigma_t)
            q0, q1 = source_in_medium(medium, g, E, omega, first_moment=False)  # Q1 None where g = 0
            del E, omega
            if Q0 is None:
                Q0, Q1 = q0, q1
            else:
                Q0 += q0
                if q1 is not None:
                    Q1 += q1
    if not sweep_orders:
        return solve_in_medium(medium, g, sp, Q0, Q1, **opts)
    phi, F, phi_k, F_k = scattering_orders(medium.sigma_t, medium.albedo, first, kind, pg, sp, sweep_orders,
                                           association=opts["association"], direction=opts["direction"],
                                           directions=sweep_directions, progress_bar=opts.get("progress_bar", False),
                                           flux=bool(with_flux))
    # the light scattered more than K times: diffusion from order K's moments (no first-moment
    # source where the phase function is isotropic: the same solve, without a zero array)
    alb = medium.albedo if medium.albedo.ndim == 4 else medium.albedo[..., None]
    sig_s = alb * medium.sigma_t[..., None]
    gm = float(check_mean_cosine(g, ()))
    q0 = sig_s * phi_k
    del phi_k
    if coarse_remainder is not None:
        if gm != 0.0:
            raise ValueError("coarse_remainder needs an isotropic phase function (g = 0)")
        sol = _remainder_coarse(coarse_remainder, g, q0, medium, sp, opts)
    else:
        sol = solve_in_medium(medium, g, sp, q0, None if gm == 0.0 else gm * sig_s[..., None] * F_k, **opts)
    sol.phi = sol.phi + phi
    sol.flux = None if F is None else (sol.flux + F).astype(np.float32)
    sol.time = time.perf_counter() - t_start
    return sol


def _remainder_coarse(coarse, g, q0, medium, spacing, opts):
    """The sweeps' remainder on the coarse grid (:func:`.coarse.solve_remainder`) by
    :func:`solve_in_medium` with ``opts``, the data grid's vacuum floor."""
    from .coarse import solve_remainder

    o = dict(opts)
    floor = o.pop("sigma_floor", None) or SIGMA_FLOOR_REL / mean_chord(medium.sigma_t.shape, spacing,
                                                                        o["association"])
    x0 = o.pop("x0", None)

    def solve(med, sp, source, start):
        return solve_in_medium(med, g, sp, source, None, x0=start, sigma_floor=floor, **o)

    return solve_remainder(solve, coarse, q0, tuple(medium.sigma_t.shape), x0)


def _phase_kind(g):
    """(kernel kind, parameter) of a phase function, or of Henyey–Greenstein for a mean cosine;
    isotropic where the function is (Henyey–Greenstein or Schlick at g = 0: the same value, and
    the sweeps then skip the direction field, :mod:`.ordinates`)."""
    from ..._kernels.phase import HENYEY_GREENSTEIN, ISOTROPIC, SCHLICK

    if hasattr(g, "kind") and hasattr(g, "g"):
        kind, pg = int(g.kind), float(g.g)
    elif np.ndim(g) != 0:
        raise ValueError("sweep_orders needs one phase function for the whole medium (a number or a "
                         "PhaseFunction), not a mean cosine per node")
    else:
        kind, pg = HENYEY_GREENSTEIN, float(check_mean_cosine(g, ()))
    if kind in (HENYEY_GREENSTEIN, SCHLICK) and pg == 0.0:
        return ISOTROPIC, 0.0
    return kind, pg


def _solve_coarse(lights, taus, g, medium, geometry, light_grid, coarse, opts, t_start):
    """:func:`solve_for_light` on the coarser grid of ``coarse`` (:func:`.coarse.solve_coarse`): each
    light's irradiance per unit power on the data grid, restricted with σs as the coarse source; the
    first-moment source on the data grid only where g ≠ 0."""
    from ...inputs.lights import PointLight
    from .coarse import solve_coarse

    if opts.get("flux_limited"):
        raise ValueError("coarse solves plain diffusion only (flux_limited=False)")
    g = float(check_mean_cosine(g, ()))
    sp = np.asarray(geometry.spacing, np.float64)
    M = np.asarray(geometry.index_to_world, np.float64)[:3]
    points = [np.linalg.solve(M[:, :3], np.asarray(lt.position, np.float64) - M[:, 3])
              for lt in lights if isinstance(lt, PointLight)]
    sources, Q1 = [], None
    for lt, tau_l in zip(lights, taus):
        e, omega, power = unit_irradiance(lt, geometry, tau_l, light_grid, sigma_t=medium.sigma_t, direction=g != 0.0)
        sources.append((e, power))
        if g != 0.0:
            _, q1 = source_in_medium(medium, g, e[..., None] * power, omega)
            Q1 = q1 if Q1 is None else Q1 + q1
    co, medium_c = coarse
    opts = dict(opts)
    x0 = opts.pop("x0", None)
    floor = opts.get("sigma_floor") or SIGMA_FLOOR_REL / mean_chord(medium.sigma_t.shape, sp, opts["association"])

    def solve(med, spacing, q0, q1, start):  # the coarse grid's floor is the data grid's
        return solve_in_medium(med, g, spacing, q0, q1, x0=start, **dict(opts, sigma_floor=floor))

    sol = solve_coarse(solve, medium, medium_c, co, g, sp, sources, Q1, points, floor=floor,
                       tol=opts.get("tol", DEFAULT_TOL), x0=x0, association=opts["association"],
                       direction=opts["direction"])
    sol.time = time.perf_counter() - t_start
    return sol
