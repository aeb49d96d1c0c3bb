"""The transport sweeps of the diffusion stage (docs/diffusion.rst §5): the first scattering orders
carried by discrete ordinates, the rest by diffusion.

The first-collision source of §1 emits, at each node, ``σs E_d p(ω·u)`` per steradian into
direction ω (u the light's propagation direction there). That light — scattered once, not yet
again — is marched along ``M`` directions through the data grid by short characteristics
(:mod:`pv_ambient._kernels.ordinates`): its radiance is exact up to the grid's interpolation and
the direction set, in thin fringes and near boundaries alike, where diffusion is poorest. Its
fluence ``φ₁ = Σ w L`` and flux ``F₁ = Σ w L ω`` are the moments the camera pass (§4) needs.

The light of order ``k + 1`` is scattered from that of order ``k``: its source is
``σs ∫ p(ω·ω') L_k(ω') dω'``. Only ``φ_k`` and ``F_k`` are kept, so ``L_k`` is replaced by the
mixture of a beam along ``F_k`` and isotropic light with the same two moments — weight
``m = |F_k|/φ_k`` (≤ 1) for the beam — and the phase function is applied to it exactly: the
source is ``σs φ_k (m p(ω·û) + (1 − m)/4π)``, û = F_k/|F_k|, of the same form as the first
one (one kernel serves every order). It is positive, unlike the P1 source
``σs (φ_k + 3g F_k·ω)/4π``, and its zeroth and first moments are exact.

After ``K`` orders the rest — the light scattered more than K times — is left to diffusion, with
source ``Q0 = σs φ_K``, ``Q1 = g σs F_K`` (:func:`pv_ambient.stages.diffusion.solve_for_light`);
the swept orders and the diffusion solution are added into one φ and F.

Directions: a spherical Fibonacci set (equal weights ``4π/M``, no preferred axis): 64 for the
first order (the phase function's lobe about the light's direction), 32 for the later ones, whose
sources are broader: more directions change the image little (docs/diffusion.rst §5,
"Directions"). Boundaries: nothing enters the box (the direct light is the camera pass's own).

This module imports numpy, the kernels and the input checks only.
"""

from __future__ import annotations

import math

import numpy as np

from ..._kernels.phase import ISOTROPIC
from ...inputs.validation import check_int

__all__ = ["DEFAULT_DIRECTIONS", "fibonacci_directions", "scattering_orders", "sweep_once"]

#: Directions of the sweeps by default: the first order's, the later orders'.
DEFAULT_DIRECTIONS = (64, 32)


def fibonacci_directions(m):
    """``m`` unit vectors on a spherical Fibonacci lattice (equal areas, equal weights ``4π/m``):
    (m, 3) float64.

    >>> d = fibonacci_directions(64)
    >>> d.shape, bool(np.allclose(np.linalg.norm(d, axis=1), 1.0)), bool(np.allclose(d.mean(axis=0), 0, atol=0.01))
    ((64, 3), True, True)
    """
    m = check_int(m, "directions", lo=2)
    i = np.arange(m) + 0.5
    z = 1.0 - 2.0 * i / m
    az = math.pi * (1.0 + math.sqrt(5.0)) * i
    r = np.sqrt(np.maximum(1.0 - z * z, 0.0))
    return np.stack([r * np.cos(az), r * np.sin(az), z], axis=1)


def sweep_once(sigma_t, q0, omega, phase_kind, phase_g, spacing, *, association="point", direction=None,
               directions=DEFAULT_DIRECTIONS[0], out=None, flux=True, work=None):
    """Fluence and flux of the light scattered once by the source ``q0 (m p(ω·û) + (1 − m)/4π)``
    (W/m³/sr) before it interacts again, ``m û = omega`` (this module's docstring).

    Parameters
    ----------
    sigma_t : array (nx, ny, nz)
        Extinction at the data samples (float64).
    q0 : array (nx, ny, nz) or (nx, ny, nz, C)
        Scattered power density per channel (W/m³): §1's ``Q0 = σs E_d`` for the first order.
    omega : array (nx, ny, nz, 3) or None
        Mean propagation direction of the light that scatters, per node (world; length ≤ 1):
        §1's ``ω`` for the first order (below 1 next to a point light), ``F_k/φ_k`` after. An
        isotropic phase function scatters the same into every direction whatever ω, so it may
        be None then.
    phase_kind, phase_g : int, float
        The phase function (``PhaseFunction.kind`` and ``.g``, as the kernels take them).
    spacing : 3 floats
    association : {"point", "cell"}
        Point data: the box faces pass through the outer nodes; cell data: half a spacing beyond.
    direction : array (3, 3), optional
        Columns: the world directions of the index axes (identity when None).
    directions : int
        Number of discrete directions.
    out : (phi, F), optional
        Arrays of the returned shapes and dtypes to fill in place (zeroed here) rather than new
        ones: :func:`scattering_orders` sweeps every order into the same two, as the first writes
        to fresh memory cost a page fault per 4 KiB, a sizeable part of an order at 256³
        (docs/performance.rst, "Transport sweeps"). Not used where the channels share one sweep.
    flux : bool, default: True
        Whether to form ``F`` at all: with an isotropic phase function nothing downstream may
        need it (the next order's source takes no direction field, and the radiance of a mean
        cosine of 0 has no flux term), and without it each sweep stores a third as much.
    work : dict, optional
        Kept by a caller that sweeps the same ``sigma_t`` again (:func:`scattering_orders`, once per
        order): the copies with the last axis first (σt itself, and buffers for the source and the
        sums) are made once and reused, not allocated again at every call.

    Returns
    -------
    phi : numpy.ndarray
        float64, the shape of ``q0``.
    F : numpy.ndarray or None
        float32, ``q0.shape + (3,)``, world components; None where ``flux`` is False.
    """
    from ..._kernels.ordinates import sweep_buffers, sweep_group

    sig = np.ascontiguousarray(sigma_t, np.float64)
    shape = sig.shape
    q = np.asarray(q0, np.float64)
    single = q.ndim == 3
    q4 = q[..., None] if single else q
    C = q4.shape[3]
    # channels with proportional sources (grey albedo, white light) share one sweep (it is linear
    # in the source, and σt and the phase function are the same for all)
    grey = C > 1 and all(np.array_equal(q4[..., 0], q4[..., c]) for c in range(1, C))
    qs = np.ascontiguousarray(q4[..., :1] if grey else q4)
    if int(phase_kind) == ISOTROPIC:
        # the kernel reads no direction field for an isotropic phase function: placeholders
        wu, wm = np.zeros((1, 1, 1, 3)), np.zeros((1, 1, 1))
    elif omega is None:
        raise ValueError("omega is needed for an anisotropic phase function (phase_kind != ISOTROPIC)")
    else:
        om = np.asarray(omega, np.float64)
        wm = np.linalg.norm(om, axis=-1)
        wu = np.ascontiguousarray(om / np.where(wm > 0, wm, 1.0)[..., None])
        wm = np.ascontiguousarray(np.minimum(wm, 1.0))
    dirs = fibonacci_directions(directions)
    wgt = np.full(len(dirs), 4.0 * math.pi / len(dirs))
    R = np.eye(3) if direction is None else np.asarray(direction, np.float64)
    h = np.asarray(spacing, np.float64)
    u = (dirs @ R) / h  # index-axis components per world length
    active = np.asarray(shape) > 1
    score = np.abs(u) * active
    dom = np.argmax(score, axis=1)
    half = 0.0 if association == "point" else 0.5
    Cs = qs.shape[3]
    phi = _zeroed(out, 0, shape + (Cs,), np.float64, single)
    F = _zeroed(out, 1, shape + (Cs, 3), np.float32, single) if flux else np.zeros((1, 1, 1, 1, 3), np.float32)
    for a in range(3):
        arrays, axis, ua = (sig, qs, wu, wm, phi, F), a, u
        if a == 2 and np.any((dom == 2) & (score[:, 2] > 0)):
            # a plane across the last axis is strided in memory (a node's column is contiguous):
            # those groups sweep a copy with that axis first, where their planes are rows, the
            # sums so far copied with it and back after (docs/performance.rst, "Transport sweeps")
            arrays, axis, ua = _last_first_all(arrays, sigma_t, work), 0, u[:, [2, 0, 1]]
        for sign in (1, -1):
            sel = (dom == a) & (score[:, a] > 0) & (np.sign(u[:, a]) == sign)
            if not np.any(sel):
                continue
            lat = [shape[x] for x in range(3) if x != a]
            bufs, P = sweep_buffers(int(sel.sum()), Cs, lat[0], lat[1], int(phase_kind))
            sweep_group(*arrays[:4], int(phase_kind), float(phase_g), axis, sign, np.ascontiguousarray(dirs[sel]),
                        np.ascontiguousarray(ua[sel]), np.ascontiguousarray(wgt[sel]), half, *arrays[4:], bool(flux),
                        *bufs, P)
        if axis != a:
            _first_last(arrays[4], phi)
            if flux:
                _first_last(arrays[5], F)
    if not flux:
        F = None
    if grey:
        phi = np.repeat(phi, C, axis=3)
        F = None if F is None else np.repeat(F, C, axis=3)
    if single:
        phi, F = phi[..., 0], (None if F is None else F[..., 0, :])
    return phi, F


def _last_first_all(arrays, sigma_t, work):
    """:func:`_last_first` of :func:`sweep_once`'s arrays (σt, q, u, m, φ, F), into the buffers of
    ``work`` where it holds them (a dict, or None): σt's copy is kept there while the same
    ``sigma_t`` is swept again, the others' memory reused (a fresh array of the grid's size costs a
    page fault per 4 KiB at its first write)."""
    if work is None:
        return tuple(_last_first(x) for x in arrays)
    if work.get("sigma_t") is not sigma_t:
        work.clear()
        work["sigma_t"], work["sig"] = sigma_t, _last_first(arrays[0])
    out = [work["sig"]]
    for i, x in enumerate(arrays[1:], 1):
        buf = work.get(i)
        t = _last_first(x, buf if buf is not None and buf.shape[1:] == x.shape[:2] + x.shape[3:]
                        and buf.shape[0] == x.shape[2] and buf.dtype == x.dtype else None)
        work[i] = t
        out.append(t)
    return tuple(out)


def _last_first(a, out=None):
    """``a`` (n0, n1, n2, …) as a C-contiguous array (n2, n0, n1, …), written into ``out`` where
    given (in parallel: :func:`pv_ambient._kernels.ordinates.last_axis_first`)."""
    from ..._kernels.ordinates import last_axis_first

    n0, n1, n2 = a.shape[:3]
    if out is None:
        out = np.empty((n2, n0, n1) + a.shape[3:], a.dtype)
    last_axis_first(np.ascontiguousarray(a).reshape(n0, n1, n2, -1), out.reshape(n2, n0, n1, -1))
    return out


def _first_last(a, dst):
    """Write :func:`_last_first`'s ``a`` back into ``dst`` (n0, n1, n2, …), C-contiguous."""
    from ..._kernels.ordinates import first_axis_last

    n2, n0, n1 = a.shape[:3]
    view = dst.reshape(n0, n1, n2, -1)
    if not np.shares_memory(view, dst):  # a copy would take the sums and drop them
        raise ValueError("dst must be C-contiguous")
    first_axis_last(a.reshape(n2, n0, n1, -1), view)


def _zeroed(out, i, shape, dtype, single):
    """``out[i]`` zero-filled where it is an array of ``shape`` and ``dtype`` (as :func:`sweep_once`
    returns it: without the channel axis where ``single``), else a new zero array."""
    a = None if out is None else out[i]
    if single and a is not None:
        a = a[..., None, :] if i == 1 else a[..., None]
    if a is None or a.shape != shape or a.dtype != dtype or not a.flags.c_contiguous:
        return np.zeros(shape, dtype)
    a.fill(0)
    return a


def scattering_orders(sigma_t, albedo, sources, phase_kind, phase_g, spacing, orders, *,
                      directions=DEFAULT_DIRECTIONS, progress_bar=False, flux=True, **kw):
    """The first ``orders`` scattering orders by :func:`sweep_once` (this module's docstring):
    ``(φ, F, φ_K, F_K)``, the sums over the orders and the last order alone.

    ``sources``: the first order's ``(q0, omega)`` per light (§1; one sweep each, their
    directions differ); orders two and up are scattered from the lights' summed φ and F, with
    σs = ``albedo``·σt ((nx, ny, nz) or per channel). Their direction field ``F_k/φ_k`` is taken
    from the channels' sums (the channels share σt and the phase function; it is exact when they
    are proportional). ``directions``: an int, or (first order, later orders). ``progress_bar``:
    a tqdm bar over the orders (each order sweeps the whole grid along every direction: at 256³
    an order takes seconds). ``flux``: whether the caller needs ``F`` (None in its place
    otherwise; an anisotropic phase function forms each order's anyway, for the next order's
    direction field). ``kw``: :func:`sweep_once`'s other keywords.
    """
    orders = check_int(orders, "orders", lo=1)
    m1, m2 = (directions, directions) if np.ndim(directions) == 0 else tuple(directions)
    sig = np.asarray(sigma_t, np.float64)
    if progress_bar:
        from tqdm.auto import tqdm

        with tqdm(total=orders, desc="transport sweeps", unit="order") as bar:
            return _orders(sig, albedo, sources, phase_kind, phase_g, spacing, orders, m1, m2, bar.update, flux, kw)
    return _orders(sig, albedo, sources, phase_kind, phase_g, spacing, orders, m1, m2, None, flux, kw)


def _orders(sig, albedo, sources, phase_kind, phase_g, spacing, orders, m1, m2, done, flux, kw):
    """:func:`scattering_orders`' work; ``done()`` (or None) is called after each order."""
    from ..._kernels.ordinates import add_order, order_source

    iso = int(phase_kind) == ISOTROPIC
    need = bool(flux) or not iso  # an anisotropic order's flux gives the next one its direction field
    kw = dict(kw, work={})  # every order sweeps the same σt: its transposed copy and buffers are kept
    phi_k = F_k = None
    for q0, omega in sources:
        p, f = sweep_once(sig, q0, omega, phase_kind, phase_g, spacing, directions=m1, flux=need, **kw)
        phi_k, F_k = (p, f) if phi_k is None else (phi_k + p, None if f is None else F_k + f)
    if phi_k is None:
        raise ValueError("sources must hold at least one (q0, omega) pair")
    if done is not None:
        done()
    alb = np.asarray(albedo)
    if phi_k.ndim == 4 and alb.ndim == 3:
        alb = alb[..., None]
    sig_s = alb * (sig[..., None] if alb.ndim == 4 else sig)
    phi, F = phi_k.copy(), (F_k.astype(np.float64) if flux else None)
    # every order's source and result go into the same arrays: the last order's, once its source
    # is formed (sweep_once's ``out``)
    q = np.empty(np.broadcast_shapes(sig_s.shape, phi_k.shape)) if orders > 1 else None
    # the elementwise steps on every core where the arrays line up (order_source, add_order)
    flat = (q is not None and sig_s.shape == phi_k.shape == q.shape and sig_s.dtype == np.float64
            and sig_s.flags.c_contiguous and phi_k.flags.c_contiguous)
    for _ in range(1, orders):
        om = None  # an isotropic phase function needs no direction field (sweep_once)
        if not iso:
            tot = phi_k.sum(axis=3) if phi_k.ndim == 4 else phi_k
            ftot = F_k.sum(axis=3) if F_k.ndim == 5 else F_k
            # the beam's weight |F|/φ (≤ 1 for any radiance; clipped against rounding), none where φ
            # is (sub)normal-small
            ok = tot > 1e-280
            om = np.where(ok[..., None], ftot / np.where(ok, tot, 1.0)[..., None], 0.0)
        if flat:
            order_source(sig_s.reshape(-1), phi_k.reshape(-1), q.reshape(-1))
        else:
            np.multiply(sig_s, phi_k, out=q)
        phi_k, F_k = sweep_once(sig, q, om, phase_kind, phase_g, spacing, directions=m2, out=(phi_k, F_k), flux=need,
                                **kw)
        if F is None:  # no flux sum: the fluence alone
            if flat and phi_k.shape == phi.shape:
                add_order(phi.reshape(-1), np.empty(0), phi_k.reshape(-1), np.empty(0, np.float32))
            else:
                phi += phi_k
        elif flat and phi_k.shape == phi.shape and F_k.shape == F.shape:
            add_order(phi.reshape(-1), F.reshape(-1), phi_k.reshape(-1), F_k.reshape(-1))
        else:
            phi += phi_k
            F += F_k
        if done is not None:
            done()
    return phi, (None if F is None else F.astype(np.float32)), phi_k, F_k
