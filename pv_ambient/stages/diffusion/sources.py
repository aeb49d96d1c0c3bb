"""Sources of the diffusion stage (docs/diffusion.rst §1): a light's direct irradiance averaged over each
node's control volume, and the first-collision source ``Q0 = σs E_d``, ``Q1 = g σs E_d ω`` it
gives (W/m³).

This module imports numpy, the kernels and the input records only.
"""

from __future__ import annotations

import numpy as np

from ...inputs.validation import check_array, check_int, check_real
from .medium import DiffusionMedium, check_mean_cosine

__all__ = ["direct_irradiance", "first_collision_source", "hat_medium", "hat_source", "optics_arrays",
           "source_in_medium", "unit_irradiance"]

#: Sub-samples per axis of a control volume when averaging a light's irradiance: within
#: ``SUBSAMPLE_RADIUS`` index units of a point light, and farther out (or for a directional light).
SUBSAMPLES = 4
FAR_SUBSAMPLES = 2
#: Placeholder for the first-moment output the kernel does not write.
NO_Q1_5D = np.zeros((1, 1, 1, 1, 3), np.float32)
#: Placeholder for the direction output the irradiance kernel does not write.
NO_OMEGA = np.zeros((1, 1, 1, 3))
SUBSAMPLE_RADIUS = 8.0
#: With the medium's σt given, a control volume at least ``ONE_SAMPLE_RADIUS`` index units from a
#: point light (or any, for a directional light) whose σt·h is at most ``THIN_CV`` takes one
#: sample: the midpoint rule's error there, ``δ²/(12 d²)`` on ``1/d²`` and ``(σt h)²/8`` on T,
#: stays below 0.5 % (docs/diffusion.rst §1).
ONE_SAMPLE_RADIUS = 16.0
THIN_CV = 0.2
#: Control volumes within this many index units (max-norm) of a point light use the solid-angle form.
NEAR = 1.5
#: Cosine bins of the solid-angle form (twice as many azimuth bins) and chord samples.
NEAR_DIRECTIONS = 64
NEAR_CHORD = 4


def first_collision_source(sigma_t, albedo, g, E_d, omega):
    """First-collision source of one light (docs/diffusion.rst §1): ``Q0 = σs E_d``, ``Q1 = g σs E_d ω``.

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
    return source_in_medium(DiffusionMedium.from_arrays(sigma_t, albedo), g, E_d, omega)


def source_in_medium(medium, g, E_d, omega, *, first_moment=True):
    """:func:`first_collision_source` in an already checked :class:`DiffusionMedium` (σt and
    albedo are not scanned again: once per scene, not once per light); one parallel pass, float32
    out (``_kernels.diffusion_sources.first_collision``). ``first_moment=False``: ``Q1`` is None
    where it vanishes (g = 0 everywhere), so the solve neither stores nor reads it."""
    from ..._kernels.diffusion_sources import first_collision

    sig, alb = medium.sigma_t, medium.albedo
    gg = check_mean_cosine(g, sig.shape)
    E = check_array(E_d, "E_d", ndim=(3, 4))
    if E.shape[:3] != sig.shape:
        raise ValueError(f"E_d must have shape {sig.shape} or {sig.shape + ('C',)}, got {E.shape}")
    if np.any(E < 0):
        raise ValueError(f"E_d must be >= 0, got minimum {E.min()!r}")
    om = check_array(omega, "omega", ndim=(4,))
    if om.shape != sig.shape + (3,):
        raise ValueError(f"omega must have shape {sig.shape + (3,)}, got {om.shape}")
    multi = alb.ndim == 4 or E.ndim == 4
    if alb.ndim == 4 and E.ndim == 4 and alb.shape[3] != E.shape[3]:
        raise ValueError(f"albedo has {alb.shape[3]} channels but E_d has {E.shape[3]}")
    a4 = alb if alb.ndim == 4 else alb[..., None]
    e4 = E if E.ndim == 4 else E[..., None]
    C = max(a4.shape[3], e4.shape[3])
    g_node = np.ndim(gg) == 3
    with_q1 = g_node or float(gg) != 0.0
    q0 = np.empty(sig.shape + (C,), np.float32)
    q1 = np.zeros(sig.shape + (C, 3), np.float32) if first_moment or with_q1 else None
    first_collision(sig, a4, e4, np.asarray(gg, np.float64) if g_node else np.zeros((1, 1, 1)), g_node,
                    0.0 if g_node else float(gg), om, with_q1, q0, NO_Q1_5D if q1 is None else q1)
    if not multi:
        q0, q1 = q0[..., 0], None if q1 is None else q1[..., 0, :]
    return q0, q1


def direct_irradiance(light, geometry, tau, light_grid, *, subsamples=SUBSAMPLES, far_subsamples=FAR_SUBSAMPLES,
                      near=NEAR, near_directions=NEAR_DIRECTIONS, sigma_t=None):
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
    ``E·T`` over ``far_subsamples``³ sub-samples. Given the medium's ``sigma_t``, control volumes
    that are optically thin (σt·h at most ``THIN_CV`` at the node and its six neighbours) and,
    for a point light, at least ``ONE_SAMPLE_RADIUS`` index units away take one sample, their
    midpoint: most of a large grid, at an eighth of the lookups.

    Parameters
    ----------
    light : PointLight or DirectionalLight
    geometry : GridGeometry
        The data grid's placement (``shape``, ``index_to_world``, ``box_lo``, ``box_hi``).
    tau : array (m0, m1, m2)
        Optical depth from the light on ``light_grid`` (``Renderer.optical_depth``).
    light_grid : LightGrid
        Its ``lo`` and ``inv_step`` map a data index to a light-grid index.
    sigma_t : array (nx, ny, nz), optional
        σt at the data samples (1/world unit): enables the one-sample rule for thin volumes.

    Returns
    -------
    E_d : numpy.ndarray
        float64 (nx, ny, nz, 3), W/m² per RGB channel.
    omega : numpy.ndarray
        float64 (nx, ny, nz, 3): the E-weighted mean propagation direction (world).
    """
    e, omega, power = unit_irradiance(light, geometry, tau, light_grid, subsamples=subsamples,
                                      far_subsamples=far_subsamples, near=near, near_directions=near_directions,
                                      sigma_t=sigma_t)
    return e[..., None] * power, omega


def unit_irradiance(light, geometry, tau, light_grid, *, subsamples=SUBSAMPLES, far_subsamples=FAR_SUBSAMPLES,
                    near=NEAR, near_directions=NEAR_DIRECTIONS, sigma_t=None, direction=True):
    """:func:`direct_irradiance` per unit power: ``(e, omega, power)`` with ``E_d = e[..., None] ·
    power`` — e float64 (nx, ny, nz), ``power`` the light's intensity or irradiance per channel (3,),
    ``omega`` as there, or None with ``direction=False`` (not computed: an isotropic phase function's
    source has no first moment). Same parameters as :func:`direct_irradiance`."""
    from ..._kernels.diffusion_sources import irradiance_point, transmittance_cv
    from ...inputs.lights import DirectionalLight, PointLight

    shape = tuple(int(n) for n in geometry.shape)
    subsamples = check_int(subsamples, "subsamples", lo=1)
    far_subsamples = check_int(far_subsamples, "far_subsamples", lo=1)
    near = check_real(near, "near", lo=0.0)
    near_directions = check_int(near_directions, "near_directions", lo=1)
    tau = np.ascontiguousarray(check_array(tau, "tau", ndim=3))
    M = np.ascontiguousarray(np.asarray(geometry.index_to_world, np.float64)[:3, :])
    lo = np.asarray(geometry.box_lo, np.float64)
    hi = np.asarray(geometry.box_hi, np.float64)
    tlo = np.asarray(light_grid.lo, np.float64)
    tinv = np.asarray(light_grid.inv_step, np.float64)
    e = np.empty(shape)  # every node written by the kernels
    use_sig = sigma_t is not None
    sig = np.ascontiguousarray(sigma_t if use_sig else np.zeros((1, 1, 1)), np.float64)  # checked by the caller
    if use_sig and sig.shape != shape:
        raise ValueError(f"sigma_t must have the grid's shape {shape}, got {sig.shape}")
    hmax = float(np.max(geometry.spacing))
    if isinstance(light, PointLight):
        omega = np.empty(shape + (3,)) if direction else NO_OMEGA
        Minv = np.ascontiguousarray(np.linalg.inv(M[:, :3]))
        pl = Minv @ (np.asarray(light.position, np.float64) - M[:, 3])
        cvvol = abs(float(np.linalg.det(M[:, :3])))
        irradiance_point(M, Minv, lo, hi, pl, tau, tlo, tinv, subsamples, far_subsamples, SUBSAMPLE_RADIUS, near,
                         near_directions, NEAR_CHORD, cvvol, sig, use_sig, hmax, THIN_CV, ONE_SAMPLE_RADIUS, bool(direction),
                         e, omega)
        power = np.asarray(light.intensity, np.float64)
    elif isinstance(light, DirectionalLight):
        transmittance_cv(lo, hi, tau, tlo, tinv, far_subsamples, sig, use_sig, hmax, THIN_CV, e)
        omega = np.broadcast_to(np.asarray(light.direction, np.float64), shape + (3,)).copy() if direction else None
        power = np.asarray(light.irradiance, np.float64)
    else:
        raise TypeError(f"light must be a PointLight or DirectionalLight, got {type(light).__name__}")
    return e, (omega if direction else None), power


def hat_source(light, geometry, tau, light_grid, optics, medium, *, near=NEAR):
    """The first-collision source ``σs E_d`` projected on each node's hat function (the trilinear
    basis function of the node: 1 at it, 0 at its neighbours), for the transport sweeps (§5):
    ``Q0_n = ∫ hat_n σs E dV / ∫ hat_n dV``, σs classified at 3³ half-index sub-samples (as the
    camera pass and the path tracer see it), E there from the light grid's τ. The
    control-volume form ``σs_n · mean(E)`` of :func:`source_in_medium` takes σs at the node
    alone — too much where classification is convex in the data or a dense layer is one voxel
    thin, which makes the swept orders too bright (docs/diffusion.rst §5, "Sub-voxel medium"). Within
    ``near + 1`` index units of a point light (1/d² singular) the control-volume form
    ``σs_n · mean(E)`` is kept (:func:`direct_irradiance`, σs from ``medium``).

    Parameters
    ----------
    light, geometry, tau, light_grid
        As for :func:`direct_irradiance`.
    optics : Optics or DiffusionMedium
        The medium to classify at the sub-samples: the transfer function's
        :class:`~pv_ambient.inputs.transfer.Optics`, or a :class:`DiffusionMedium` (σt and
        albedo interpolated trilinearly between the nodes).
    medium : DiffusionMedium
        The nodes' σt and albedo for the control-volume form next to a point light
        (:func:`hat_medium`'s for the sweeps).

    Returns
    -------
    Q0 : numpy.ndarray
        float64 (nx, ny, nz, 3), W/m³ per RGB channel.
    omega : numpy.ndarray
        float64 (nx, ny, nz, 3), the light's mean propagation direction weighted by σt E.
    """
    from ..._kernels.diffusion_sources import hat_source as kernel
    from ...inputs.lights import DirectionalLight, PointLight

    rec = optics_arrays(optics)
    shape = tuple(int(n) for n in geometry.shape)
    tau = np.ascontiguousarray(check_array(tau, "tau", ndim=3))
    M = np.ascontiguousarray(np.asarray(geometry.index_to_world, np.float64)[:3, :])
    lo = np.asarray(geometry.box_lo, np.float64)
    hi = np.asarray(geometry.box_hi, np.float64)
    if isinstance(light, PointLight):
        lw = np.asarray(light.position, np.float64)
        pl = np.linalg.inv(M[:, :3]) @ (lw - M[:, 3])
        is_point, power = True, np.asarray(light.intensity, np.float64)
    elif isinstance(light, DirectionalLight):
        lw = np.asarray(light.direction, np.float64)
        pl = np.zeros(3)
        is_point, power = False, np.asarray(light.irradiance, np.float64)
    else:
        raise TypeError(f"light must be a PointLight or DirectionalLight, got {type(light).__name__}")
    q = np.zeros(shape + (3,))
    w = np.zeros(shape + (3,))
    done = np.zeros(shape, np.bool_)
    kernel(*rec, M, lo, hi, is_point, pl, lw, tau, np.asarray(light_grid.lo, np.float64),
           np.asarray(light_grid.inv_step, np.float64), float(near), q, w, done)
    q *= power
    if not np.all(done):  # next to a point light: the control-volume form, on the nodes' bounding box alone
        near_nodes = np.argwhere(~done)
        box = tuple(slice(int(a), int(b) + 1) for a, b in zip(near_nodes.min(axis=0), near_nodes.max(axis=0)))
        sub_geometry, sub_grid = _sub_box(geometry, light_grid, box)
        E_d, omega = direct_irradiance(light, sub_geometry, tau, sub_grid)
        keep = ~done[box]
        alb = medium.albedo if medium.albedo.ndim == 4 else medium.albedo[..., None]
        cv = alb[box] * medium.sigma_t[box][..., None] * E_d
        q[box][keep] = cv[keep]
        w[box][keep] = omega[keep]
    return q, w


def _sub_box(geometry, light_grid, box):
    """The nodes ``box`` (three slices) of ``geometry`` as a grid of their own for
    :func:`unit_irradiance`, and ``light_grid`` seen from it: index 0 at the box's first node,
    the medium's box and the light grid's origin shifted by the same offset, so each node's
    control volume is clipped, and its τ read, exactly where the whole grid's are."""
    from types import SimpleNamespace

    off = np.array([sl.start for sl in box], np.float64)
    M = np.array(geometry.index_to_world, np.float64)
    M[:3, 3] += M[:3, :3] @ off
    sub = SimpleNamespace(shape=tuple(sl.stop - sl.start for sl in box), index_to_world=M,
                          box_lo=np.asarray(geometry.box_lo, np.float64) - off,
                          box_hi=np.asarray(geometry.box_hi, np.float64) - off, spacing=geometry.spacing)
    return sub, SimpleNamespace(lo=np.asarray(light_grid.lo, np.float64) - off, inv_step=light_grid.inv_step)


def optics_arrays(optics):
    """(mode, field, table, lut_lo, lut_inv, aux) for the classification kernels: an Optics' own,
    or a :class:`DiffusionMedium` as a physical (grid-mode) medium, σt and albedo trilinear."""
    from ...inputs.transfer import MODE_GRID

    if isinstance(optics, DiffusionMedium):
        alb = optics.albedo if optics.albedo.ndim == 4 else np.repeat(optics.albedo[..., None], 3, axis=3)
        if alb.shape[3] != 3:
            raise ValueError(f"the sweeps need an RGB albedo (the lights are RGB), got {alb.shape[3]} channels")
        aux = np.zeros(optics.sigma_t.shape + (6,), np.float32)
        aux[..., :3] = alb
        return (MODE_GRID, np.ascontiguousarray(optics.sigma_t, np.float32), np.zeros((2, 10), np.float32), 0.0,
                1.0, aux)
    return optics.mode, optics.field, optics.table, float(optics.lut_lo), float(optics.lut_inv), optics.aux


def hat_medium(optics, geometry):
    """The medium the transport sweeps use (§5): each node's hat-weighted mean of σt and of σs,
    classified at 3³ half-index sub-samples, as a :class:`DiffusionMedium` (albedo = mean σs /
    mean σt). Node samples of a classified field miss its integral where the transfer function
    is not linear in the data (sharp edges, windows); these means keep it to the quadrature
    (exactly for a physical medium, whose σt and albedo are trilinear; for binary data through
    a convex transfer function +20 % where the node samples are +116 %, tests/stages/test_diffusion_ordinates.py)."""
    from ..._kernels.medium import hat_medium as kernel
    from ..._kernels.medium import scattering_to_albedo

    shape = tuple(int(n) for n in geometry.shape)
    sig = np.empty(shape)  # every node written by the kernel
    alb = np.empty(shape + (3,))
    kernel(*optics_arrays(optics), np.asarray(geometry.box_lo, np.float64), np.asarray(geometry.box_hi, np.float64),
           sig, alb)
    scattering_to_albedo(sig, alb)
    # valid by construction (DiffusionMedium's checks need not scan them): means of a classified
    # field, finite and ≥ 0, and an albedo clipped to [0, 1]
    return DiffusionMedium(sig, alb)
