"""Baked in-scattering (docs/models.rst, "Baked in-scattering"): for an isotropic phase function
the light a sample scatters toward the camera does not depend on the view, so the lights' share
per unit albedo is computed once per light change on the light grid and read by every camera
move instead of evaluating every light at every sample."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .._kernels import records as K

class BallD(NamedTuple):
    """Ambient scattering's D(r σ̄, ā) per data sample (:func:`ball_d`) in 16 bits: ``values``
    (nx, ny, nz, nch) uint16, D = ``values × scale``. ``scale`` is the preintegrated table's largest
    D over 65535 — D at a sample interpolates the table, so it never exceeds that — and the error
    is at most half a step, 7.7e-6 of the table's largest D (docs/performance.rst, "Memory")."""

    values: np.ndarray
    scale: float

    @property
    def shape(self):
        return self.values.shape


#: The D grid a bake without ambient scattering passes (not read).
NO_D = BallD(np.zeros((1, 1, 1, 1), np.uint16), 0.0)


def grey_ball(ball) -> bool:
    """Whether the ball grid's mean albedo is the same in every channel (or there is no ball)."""
    return ball.shape[3] < 4 or bool(np.array_equal(ball[..., 1], ball[..., 2])
                                     and np.array_equal(ball[..., 1], ball[..., 3]))


def ball_d(ball, table, radius) -> BallD:
    """D(r σ̄, ā) of an isotropic phase function per data sample and channel, a :class:`BallD`
    (nx, ny, nz, 3), or (…, 1) where the ball's albedo is grey (:func:`grey_ball`): what ambient
    scattering's bake reads instead of the ball grid
    (:func:`pv_ambient._kernels.bake_rows.ball_d_rows`; it depends on the transfer function and r,
    not on the lights). ``table`` is the preintegrated slice (``lookup_args()``: D without an angle
    axis). Why 16 bits: D is kept from one relight to the next, beside the bake, and at 256³ its
    three channels in float32 were 192 MB — the largest volume after the bake at the first frame's
    peak of memory."""
    from .._kernels.bake_rows import ball_d_rows, scratch

    D, _, a_nodes, lo_log, dlog = table.lookup_args()
    d_max = float(np.max(D)) if D.size else 0.0
    scale = d_max / 65535.0 if d_max > 0.0 else 1.0
    out = np.empty(tuple(ball.shape[:3]) + (1 if grey_ball(ball) else 3,), np.uint16)
    ball_d_rows(ball, D, a_nodes, float(radius), float(lo_log), float(dlog), 1.0 / scale, out, scratch())
    return BallD(out, scale)


def incident_channels(power, ball, diffusion=None, grey_albedo=None) -> int:
    """1 when every channel of the baked light is equal (grey lights, a grey ball albedo —
    ``grey_albedo``, or :func:`grey_ball` of ``ball`` when None — and a grey or absent diffusion
    field), else 3."""
    from .._kernels.raycast import diffusion_layout

    grey = bool(np.all(power[:, 0:1] == power)) and (grey_ball(ball) if grey_albedo is None else bool(grey_albedo))
    if diffusion is not None and diffusion_layout(diffusion.shape[3])[1] == 3:
        grey = False  # coloured diffusion solution
    return 1 if grey else 3


def incident_slots(kinds) -> list:
    """The slot of each light in the bake: a slot per point light in order, one after them for every
    directional light (and diffusion's term)."""
    points = int(np.sum(np.asarray(kinds) == 0))
    out, p = [], 0
    for kind in kinds:
        out.append(p if kind == 0 else points)
        p += kind == 0
    return out


def rows_apply(model_id, records, grid, phis, dgrid=None) -> bool:
    """Whether :func:`pv_ambient._kernels.bake_rows.bake_rows` bakes these lights (its module
    docstring): the light grid on the data samples, the Beer–Lambert front, an isotropic phase
    function (every light then sees 1/4π) and, for ambient scattering, D per sample (``dgrid``,
    :func:`ball_d`)."""
    from .._kernels.models import AMBIENT_SCATTERING
    from .._kernels.phase import INV_4PI, phase_eval

    lrec = records[0]
    shape = tuple(grid.shape)
    ball = model_id != AMBIENT_SCATTERING or (dgrid is not None and tuple(dgrid.shape[:3]) == shape)
    return bool(phis is None and ball and min(shape) >= 2 and np.all(np.asarray(grid.lo) == 0.0)
                and np.all(np.asarray(grid.step) == 1.0)
                and all(phase_eval(lrec.pkind, lrec.g, c) == INV_4PI for c in (-1.0, 0.0, 1.0)))


def table_applies(table) -> bool:
    """Whether :func:`ball_d` reads this table slice: D without an angle axis, ≥ 3 τ nodes, ≥ 2 albedos."""
    D, _, a_nodes = table.lookup_args()[:3]
    return D.ndim == 3 and D.shape[2] == 1 and D.shape[1] >= 3 and a_nodes.shape[0] >= 2


def bake_incident(model_id, records, geometry, grid, taus, phis=None, diffusion=None, reuse=None,
                  driver="rows", into=None, dgrid=None, device_cache=None) -> tuple:
    """The in-scattered light of the lights per unit albedo at the nodes of ``grid``, ``(array,
    nch)``: float32 (m0, m1, m2, slots·nch), a slot per point light (times d²) and one for the
    directional lights (:func:`incident_slots`), ``nch`` from :func:`incident_channels`
    (:func:`pv_ambient._kernels.bake.bake_incident`): single scattering's direct light, plus
    ambient scattering's ball term.

    ``records`` are the kernel's Lights, LightGrid and Ambient records (the light grid's ``tau`` and
    ``phi`` unused); ``taus`` the optical depth of each light on ``grid`` and ``phis`` its tube front
    (None: Beer–Lambert, the optical depth again): the lights are baked one at a time, each from its
    own volumes, so no stacked copy of every light's volumes is made. ``reuse`` maps a light's index
    to a slot array already baked for it with everything else equal (a relight: the lights that did
    not move), copied instead of baked. ``diffusion`` is a diffusion field on the data samples,
    which must be the light-grid nodes, added as ``max(φ, 0)/4π`` to the last slot. ``into``: the
    bake this one replaces, rebaked in place — its slots of the lights in ``reuse`` kept as they
    are, the others (and the directional lights' slot) baked again — where it has this bake's
    shape (the same kinds of light in the same order and channels); else a new array. ``driver``:
    ``"rows"`` bakes in vectorised chunks of a row where :func:`rows_apply` holds
    (:mod:`pv_ambient._kernels.bake_rows`; ambient scattering reads D per sample, ``dgrid`` =
    :func:`ball_d`), ``"nodes"`` node by node everywhere (the rule it follows; ambient scattering
    reads the ball grid, ``records``' Ambient ``ball``).

    ``device_cache``: a :class:`pv_ambient.backend.DeviceCache` — the bake then runs on the GPU
    (:func:`pv_ambient.backend.bake`: the node rule, one thread per node), from the optical depths
    the cache holds, and the cache keeps the result's device copy for the ray cast; the array
    returned is its download. Except where the CPU's choice is the row driver reading ambient
    scattering's D per sample (``dgrid``): D in 16 bits moves the bake by up to 1e-5 of its largest
    value from the node rule's exact lookup, beyond the GPU's tolerance of 1e-6 against the CPU
    (docs/performance.rst, "GPU"), so that case, and a bake that does not fit in the GPU's free
    memory, bakes on the CPU (the device copy of an array rebaked in place is then dropped)."""
    from .._kernels.bake import bake_diffusion
    from .._kernels.bake import bake_incident as bake
    from .._kernels.models import AMBIENT_SCATTERING
    from .medium import stack_volumes

    lrec, grec, arec = records
    nch = incident_channels(lrec.power, arec.ball, diffusion, grey_albedo=None if dgrid is None else dgrid.shape[3] == 1)
    slots = incident_slots(lrec.kind)
    nslots = int(np.sum(lrec.kind == 0)) + int(np.any(lrec.kind != 0) or diffusion is not None)
    shape = tuple(grid.shape) + (nslots * nch,)
    reuse = {j: v for j, v in (reuse or {}).items() if v.shape[-1] == nch}
    if driver not in ("rows", "nodes"):
        raise ValueError(f"driver must be 'rows' or 'nodes', got {driver!r}")
    rows = driver == "rows" and rows_apply(model_id, records, grid, phis, dgrid)
    in_place = into is not None and into.shape == shape and into.dtype == np.float32 and into.flags.c_contiguous
    out = into if in_place else np.zeros(shape, np.float32)
    if in_place:  # a kept slot must be this array's own (a light that kept its index)
        reuse = {j: v for j, v in reuse.items() if np.shares_memory(v, out)}
    if device_cache is not None and not (rows and model_id == AMBIENT_SCATTERING):
        from ..backend import DeviceMemoryError

        try:
            bake_on_device(device_cache, model_id, records, geometry, grid, taus, phis, diffusion, reuse, in_place,
                           nch, out)
            return out, nch
        except DeviceMemoryError:
            pass  # baked on the CPU below; the ray cast raises, or falls back under backend="auto"
    if in_place:
        # a slot baked again starts from 0, except a point light's slot that the row driver writes whole
        for q in sorted({slots[j] for j in range(len(lrec.kind)) if j not in reuse
                         and not (rows and lrec.kind[j] == 0)} | ({nslots - 1} if diffusion is not None else set())):
            out[..., q * nch:(q + 1) * nch] = 0.0
    if rows:
        from .._kernels.bake_rows import bake_rows, scratch

        chunks = scratch()
    for j in range(len(lrec.kind)):
        q = slots[j] * nch
        if j in reuse:
            if not in_place:
                out[..., q:q + nch] = reuse[j]
            continue
        one = lrec._replace(kind=lrec.kind[j:j + 1].copy(), vec=lrec.vec[j:j + 1].copy(),
                            power=lrec.power[j:j + 1].copy())
        tau = stack_volumes([taus[j]])
        if rows:
            # a point light's slot is its own: written, not added (nothing to clear first)
            dg = dgrid if dgrid is not None else NO_D
            bake_rows(model_id, one, tau, dg.values, float(dg.scale), float(arec.radius),
                      geometry.world_to_index, geometry.index_to_world, nch, q, not (in_place and lrec.kind[j] == 0),
                      out, chunks)
            continue
        if arec.ball.shape[3] < 4 and model_id == AMBIENT_SCATTERING:
            raise ValueError("the node-by-node bake of ambient scattering needs the ball grid (records' Ambient.ball)")
        phi = tau if phis is None else stack_volumes([phis[j]])
        bake(model_id, one, grec._replace(tau=tau, phi=phi), arec, geometry.world_to_index, geometry.index_to_world,
             grid.lo, grid.step, nch, q, out)
    if diffusion is not None:
        bake_diffusion(diffusion, (nslots - 1) * nch, nch, out)
    if device_cache is not None:
        device_cache.forget(out)  # a device copy of the array rebaked here is stale
    return out, nch


def bake_on_device(device_cache, model_id, records, geometry, grid, taus, phis, diffusion, reuse, in_place, nch,
                   out):
    """:func:`bake_incident` on the GPU into host array ``out`` (m0, m1, m2, slots·nch), its
    arguments as there (``reuse`` already this array's own slots where ``in_place``): the slots of
    the lights not in ``reuse`` (and diffusion's) cleared and baked on the device by the node rule,
    the others kept — in the device copy of ``out`` the cache holds, or copied into ``out`` and
    uploaded with it — then ``out`` downloaded (:func:`pv_ambient.backend.bake`). Raises
    :class:`pv_ambient.backend.DeviceMemoryError` before any work when it does not fit."""
    from .. import backend
    from .._kernels.models import AMBIENT_SCATTERING

    lrec, grec, arec = records
    slots = incident_slots(lrec.kind)
    nslots = out.shape[3] // nch
    if arec.ball.shape[3] < 4 and model_id == AMBIENT_SCATTERING:
        raise ValueError("the node-by-node bake of ambient scattering needs the ball grid (records' Ambient.ball)")
    if not in_place:
        for j, v in reuse.items():
            out[..., slots[j] * nch:(slots[j] + 1) * nch] = v
    baked = sorted({slots[j] for j in range(len(lrec.kind)) if j not in reuse}
                   | ({nslots - 1} if diffusion is not None else set()))
    parts = [(slots[j] * nch,
              lrec._replace(kind=lrec.kind[j:j + 1].copy(), vec=lrec.vec[j:j + 1].copy(),
                            power=lrec.power[j:j + 1].copy()),
              taus[j], None if phis is None else phis[j]) for j in range(len(lrec.kind)) if j not in reuse]
    fold = None if diffusion is None else (diffusion, (nslots - 1) * nch)
    backend.bake(device_cache, model_id, parts, [(q * nch, nch) for q in baked], fold, (grec, arec),
                 geometry.world_to_index, geometry.index_to_world, grid.lo, grid.step, nch, out,
                 fresh=not in_place and not reuse)
