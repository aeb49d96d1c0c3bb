"""Per-light volumes (docs/ambient_scattering.rst §3): Beer–Lambert optical depth and the ambient front Φ.

For every light j the renderer needs, at any point x of the medium,

* the direct transmittance ``T_j(x) = exp(−∫σt)`` from the light to x (single scattering and the
  direct term of ambient scattering), stored as optical depth τ_j on a *light grid*;
* the front transmittance ``Φ_j`` read at the ball's entry point ``x − r·ω_j``, in one of two
  modes: ``"beer_lambert"`` (``Φ = T_j(x − r·ω_j)``, a second lookup in the same τ grid) or
  ``"tube"`` (the paper's tube march through touching balls, :func:`tube_extinction`).

A point light's fall-off ``I/|x − x_l|²`` is evaluated by the ray caster at the sample itself;
a directional light has none and starts where its ray enters the grid. Optical depth is
computed by an upwind sweep (short characteristics, :mod:`pv_ambient._kernels.lightvol`), linear
in the number of light-grid nodes.

The light grid covers the medium's box. Its resolution is a quality knob ``light_resolution``:
a factor on the data resolution, by default 2 where ``max σt·h > 0.3`` (h: the largest grid
spacing; trilinear interpolation of a coarse transmittance is biased, docs/ambient_scattering.rst §3) and 1
elsewhere, capped so a grid has at most ``MAX_NODES`` nodes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..inputs.lights import DirectionalLight, PointLight

MAX_NODES = 2 ** 25  # 32 M nodes = 128 MB of float32 per light


@dataclass(frozen=True, eq=False)
class LightGrid:
    """A regular grid over the medium's box in data index space.

    Node ``k`` sits at data index ``lo + k·step``; ``B`` maps a light-index vector to world.
    """

    shape: tuple
    lo: np.ndarray
    step: np.ndarray
    inv_step: np.ndarray
    B: np.ndarray
    factor: float

    def key(self):
        return (self.shape, self.lo.tobytes(), self.step.tobytes())

    def on_samples(self, shape) -> bool:
        """Whether the nodes are exactly the data samples of a grid of ``shape`` (node k = sample k)."""
        one = np.asarray(self.shape) == 1
        return (tuple(self.shape) == tuple(shape) and bool(np.all(self.lo == 0.0))
                and bool(np.all((self.step == 1.0) | one)))

    def to_light(self, data_index):
        return (np.asarray(data_index, np.float64) - self.lo) * self.inv_step


def default_factor(optics, geometry) -> float:
    """2 where ``max σt·h > 0.3`` (h: largest spacing), else 1."""
    h = float(np.max(geometry.spacing))
    return 2.0 if optics.sigma_max * h > 0.3 else 1.0


def make_light_grid(geometry, factor) -> LightGrid:
    """Light grid with ``factor`` nodes per data spacing (capped at ``MAX_NODES`` nodes)."""
    factor = float(factor)
    if not np.isfinite(factor) or factor <= 0:
        raise ValueError(f"light_resolution must be a positive number, got {factor!r}")
    extent = geometry.box_hi - geometry.box_lo
    while True:
        shape = tuple(int(max(1, np.ceil(e * factor - 1e-9) + 1)) if e > 0 else 1 for e in extent)
        if np.prod(shape, dtype=np.int64) <= MAX_NODES or factor <= 0.05:
            break
        factor *= 0.8
    shape_a = np.array(shape)
    step = np.where(shape_a > 1, extent / np.maximum(shape_a - 1, 1), 0.0)
    inv = np.where(step > 0, 1.0 / np.where(step > 0, step, 1.0), 0.0)
    B = geometry.index_to_world[:3, :3] * step[None, :]
    return LightGrid(shape=shape, lo=geometry.box_lo.copy(), step=step, inv_step=inv, B=B, factor=factor)


def sigma_on_grid(optics, grid: LightGrid, device_cache=None) -> np.ndarray:
    """σt at every light-grid node (float32); on the GPU with a ``device_cache``
    (:func:`pv_ambient.stages.medium.on_device`, which keeps the device copy the sweeps read)."""
    from .._kernels.lightvol import sample_sigma_grid
    from .medium import on_device

    out = np.zeros(grid.shape, np.float32)
    args = (optics.mode, optics.field, optics.table, optics.lut_lo, optics.lut_inv, grid.lo, grid.step)
    if not on_device(device_cache, "sigma_nodes", args, out):
        sample_sigma_grid(*args, out)
    return out


JUMP = 4
#: A point light closer than this (light-grid cells) to a node layer is moved onto it (see
#: :func:`optical_depth`); far below any discretisation error (~1e-3 of τ).
LIGHT_SNAP = 1e-9
#: Relative tolerance under which two components of a directional light count as equal when its
#: sweep axis is chosen.
DIRECTION_TIE = 1e-9


def optical_depth(sig_l, grid: LightGrid, geometry, light, jump=JUMP, device_cache=None, driver="rows",
                  out=None) -> np.ndarray:
    """Optical depth from ``light`` to every node of ``grid`` (float32, same shape).

    ``sig_l`` is :func:`sigma_on_grid`. A point light inside the box has τ = 0 at its position;
    nodes see the light through the medium only (vacuum outside the box). With a
    :class:`pv_ambient.backend.DeviceCache` the sweeps run on the GPU (the per-node kernel,
    :func:`pv_ambient._kernels.lightvol.sweep_node`) and the result also stays there. On the CPU
    ``driver="rows"`` (the default) runs the row driver (:mod:`pv_ambient._kernels.lightsweep`:
    the same rule, 2–4× faster on a 256³ grid, docs/performance.rst "Relight: the light sweep"),
    ``"nodes"`` the per-node driver :func:`pv_ambient._kernels.lightvol.sweep_tau` (the reference
    the tests compare it with). ``out``: a float32 C-order array of the grid's shape to write τ
    into (zeroed first) instead of a new one.
    """
    from .._kernels.lightvol import sweep_tau

    shape = grid.shape
    if out is None:
        out = np.zeros(shape, np.float32)
    else:
        if out.shape != tuple(shape) or out.dtype != np.float32 or not out.flags.c_contiguous:
            raise ValueError(f"out must be a C-order float32 array of shape {tuple(shape)}, got {out.dtype} "
                             f"{out.shape}")
        out.fill(0.0)
    if isinstance(light, PointLight):
        lp = grid.to_light(geometry.to_index(np.asarray(light.position)[None])[0])
        # A light on a node layer (a light "on a grid point") arrives here within rounding of an
        # integer, on either side; the sweeps start at the first layer beyond the light
        # (floor/ceil), so snap it: otherwise which layers are marched directly and which are
        # interpolated depends on the last bit of the world→index map (scale invariance broke by
        # 1e-6 of the image between spacings whose rounding fell on different sides).
        near = np.rint(lp)
        lp = np.where(np.abs(lp - near) <= LIGHT_SNAP, near, lp)
        sweeps = [(a, s) for a in range(3) for s in (1, -1) if shape[a] > 1]
        is_point = True
        lx, ly, lz = lp
    elif isinstance(light, DirectionalLight):
        # direction toward the light in light-index units, scaled to ±1 along its dominant axis
        binv = np.linalg.pinv(grid.B)
        v = binv @ (-np.asarray(light.direction))
        av = np.abs(v) * (np.asarray(shape) > 1)
        if av.max() == 0:
            return out
        # the first axis within rounding of the largest component: a diagonal direction must not
        # pick its sweep axis by the last bit of the world→index map (scale invariance)
        a = int(np.argmax(av >= av.max() * (1.0 - DIRECTION_TIE)))
        v = v / abs(v[a])
        sweeps = [(a, 1 if v[a] < 0 else -1)]
        is_point = False
        lx, ly, lz = v
    else:  # pragma: no cover - lights are validated upstream
        raise TypeError(f"unknown light {light!r}")
    if device_cache is not None:
        from ..backend import sweep

        sweep(device_cache, sig_l, grid.B, is_point, float(lx), float(ly), float(lz), sweeps, int(jump), out)
        return out
    if driver not in ("rows", "nodes"):
        raise ValueError(f"driver must be 'rows' or 'nodes', got {driver!r}")
    if driver == "rows" and min(shape) >= 2:
        _sweep_rows(sig_l, grid, is_point, (float(lx), float(ly), float(lz)), sweeps, int(jump), out)
        return out
    for a, s in sweeps:
        lat = [shape[i] for i in range(3) if i != a]
        hist = np.zeros([jump + 1] + lat, np.float64)
        reach = sweep_reach(shape, (lx, ly, lz), a, s, int(jump)) if is_point else np.full((shape[a], 2), np.inf)
        sweep_tau(sig_l, grid.B, is_point, float(lx), float(ly), float(lz), a, s, int(jump), out, hist, reach)
    return out


def _sweep_rows(sig_l, grid, is_point, light, sweeps, jump, out):
    """:func:`optical_depth`'s sweeps by the CPU row driver: per sweep axis, σt in a copy with that
    axis first (:mod:`pv_ambient._kernels.lightsweep`: a layer's rows then run along memory); each
    sweep writes its nodes into ``out`` in the grid's own order (a point light's sweeps write
    disjoint nodes). A point light's sweeps run side by side
    (:func:`~pv_ambient._kernels.lightsweep.sweep_rows_each`), a directional light's one sweep in
    parallel over the rows of ``jump`` layers at a time (:func:`~pv_ambient._kernels.lightsweep.sweep_rows`)."""
    from .._kernels.lightsweep import chunks, permute, sweep_rows, sweep_rows_each

    shape = grid.shape
    inside = bool(is_point and all(0.0 <= light[i] <= shape[i] - 1.0 for i in range(3)))
    axes = sorted({a for a, _ in sweeps})
    order = {a: [a] + [i for i in range(3) if i != a] for a in axes}
    sig_p = {}
    for a in axes:
        if a == 0:
            sig_p[a] = np.ascontiguousarray(sig_l)  # one array type for the kernels' tuples
        else:
            sig_p[a] = np.empty(tuple(shape[i] for i in order[a]), sig_l.dtype)
            permute(np.ascontiguousarray(sig_l), a, sig_p[a])
    B_p = {a: np.ascontiguousarray(grid.B[:, order[a]]) for a in axes}
    l_p = {a: np.array([light[i] for i in order[a]]) for a in axes}

    def scratch(a, s, slots):
        lat = sig_p[a].shape[1:]
        hist = np.zeros((slots,) + lat)
        reach = sweep_reach(shape, light, a, s, jump) if is_point else np.full((shape[a], 2), np.inf)
        return hist, reach, np.empty((4 * jump + 4, lat[1] + 1))

    if is_point and axes == [0, 1, 2]:
        hists, reaches, rows = zip(*[scratch(a, s, jump + 1) for a, s in sweeps])
        sweep_rows_each(tuple(sig_p[a] for a in axes), tuple(B_p[a] for a in axes), np.stack([l_p[a] for a in axes]),
                        tuple(out for a in axes), np.array([a for a, _ in sweeps]),
                        np.array([s for _, s in sweeps]), jump, hists, reaches, rows, inside)
    else:
        for a, s in sweeps:
            hist, reach, _ = scratch(a, s, max(2 * jump, jump + 1))
            lp = l_p[a]
            rows = np.empty((chunks(), 4 * jump + 4, sig_p[a].shape[2] + 1))
            sweep_rows(sig_p[a], B_p[a], is_point, lp[0], lp[1], lp[2], a, s, jump, out, hist, reach, inside, rows)


def sweep_reach(shape, light, axis, sign, jump) -> np.ndarray:
    """Lateral reach (light-grid cells around the light) of each layer of a point light's sweep
    along ``axis`` of a grid of ``shape`` (light at light-index ``light``) that the sweep must
    compute: (na, 2), per layer the reach on the two lateral axes (the others, in order); −1 on
    layers the sweep does not visit.

    The sweep writes only nodes whose dominant axis is the sweep's: on the layer ``D`` from the
    light, those within ``D`` of it laterally. A node at lateral coordinate ``c`` interpolates the
    layer ``J`` back bilinearly at ``l + (c − l)(1 − J/D)`` (its characteristic toward the light),
    reading the two nodes around that point on each lateral axis. So, from the far end back, each
    layer's range of nodes per axis is widened to the nodes the layers ahead read — exactly those,
    by integer ranges (a margin that compounded by 1.5 cells per ``J`` layers made a sweep compute
    1.3× the grid's nodes, these ranges 1.04×). Nodes outside never feed a written one: the result
    equals a sweep over whole layers (tests/stages/test_propagation.py); ``inf`` reads all."""
    from .._kernels.lightvol import TIE, sweep_start

    na = shape[axis]
    la = light[axis]
    lateral = [(shape[i], light[i]) for i in range(3) if i != axis]
    reach = np.full((na, 2), -1.0)
    layers = []
    k = sweep_start(na, True, la, sign)
    while 0 <= k < na:
        layers.append(k)
        k += sign
    if not layers:
        return reach
    dist = [abs(k - la) for k in layers]
    eps = 1e-9  # a landing point within rounding of a node reads the node on either side
    for q, (n, l) in enumerate(lateral):
        if n < 2:
            reach[layers, q] = np.inf
            continue
        lo = [max(0, math.floor(l - d - TIE)) for d in dist]  # the written pyramid
        hi = [min(n - 1, math.ceil(l + d + TIE)) for d in dist]
        for s in range(len(layers) - 1, 0, -1):
            J = min(jump, s)
            d = dist[s]
            if d > J + TIE:  # interpolates J layers back (else integrates straight to the light)
                f = 1.0 - J / d
                p0 = min(max(l + (lo[s] - l) * f - eps * (1.0 + abs(l)), 0.0), n - 1.0)
                p1 = min(max(l + (hi[s] - l) * f + eps * (1.0 + abs(l)), 0.0), n - 1.0)
                lo[s - J] = min(lo[s - J], min(int(p0), n - 2))
                hi[s - J] = max(hi[s - J], min(int(p1), n - 2) + 1)
        for s, k in enumerate(layers):
            reach[k, q] = max(l - lo[s], hi[s] - l, 0.0)
    return reach


def tube_extinction(ball, grid: LightGrid, radius, table) -> np.ndarray:
    """Tube-march extinction ``ρ_c = −ln F(r σ̄, ā_c)/(2r)`` per channel at the light-grid nodes.

    The paper's tube march multiplies the front by ``F(r·σ̄(c_k))`` for every ball of radius r it
    crosses (step 2r, docs/ambient_scattering.rst §3). Writing each factor as ``exp(−2r·ρ)`` turns the march into an
    optical depth of ρ along the light's ray, which the same sweep as σt integrates
    (:func:`optical_depth`). At ball boundaries in a homogeneous medium this is the discrete march
    exactly (``Φ = F^k``); between them it interpolates exponentially rather than linearly, and
    in a heterogeneous medium σ̄ is integrated along the ray rather than sampled once per 2r (no
    dependence on where the first ball starts). In vacuum ``F(0) = 1`` gives ρ = 0 (Φ = 1), and
    with albedo 0 ``F = e^{−2τ}`` gives ρ = σ̄: Beer–Lambert through the ball-averaged medium.
    Returns float32 (m0, m1, m2, 3).
    """
    from .._kernels.lightvol import tube_density

    out = np.zeros(tuple(grid.shape) + (3,), np.float32)
    if radius <= 0.0:
        return out
    D, F_diff, a_nodes, lo_log, dlog = table.lookup_args()
    tube_density(ball, grid.lo, grid.step, float(radius), F_diff, a_nodes, lo_log, dlog, out)
    return out


def front_depth(ball_inside, grid: LightGrid, geometry, light, radius, table) -> np.ndarray:
    """Tube-mode front optical depth from ``light`` per channel at the nodes of ``grid``, float32
    (m0, m1, m2, 3): :func:`tube_extinction` of the ball grid averaged over the inside part of each
    ball (:func:`pv_ambient.stages.ball.ball_inside`), integrated along the light's rays by
    :func:`optical_depth`."""
    rho = tube_extinction(ball_inside, grid, radius, table)
    out = np.empty_like(rho)
    for c in range(3):
        out[..., c] = optical_depth(np.ascontiguousarray(rho[..., c]), grid, geometry, light)
    return out
