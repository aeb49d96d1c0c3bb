"""The finite-volume system of the diffusion stage (docs/diffusion.rst §2): control volumes, couplings,
box-face terms, the flux at the nodes and the power balance.

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

The couplings are stored in float32, the diagonal terms and every sum in float64
(:mod:`.multigrid`, "Precision").

Discrete power balance holds to the solver's residual: ``Σ Q0 V = Σ σa φ V + Σ_box faces A F·n``
(:attr:`DiffusionSolution.power`).

This module imports numpy, the kernels and the input checks only.
"""

from __future__ import annotations

import numpy as np

from ...inputs.validation import check_choice

__all__ = ["FVGrid", "NO_Q1", "assemble", "check_boundary", "flux_and_power", "reflects"]

#: Placeholder passed to the kernels when there is no first-moment source.
NO_Q1 = np.zeros((1, 1, 1, 3))


def _cv_widths(n, association):
    """Control-volume widths (index units) along an axis with n nodes."""
    w = np.ones(n)
    if association == "point" and n > 1:
        w[0] = w[-1] = 0.5
    return w


class FVGrid:
    """Geometry of the finite-volume system: widths, volumes, face areas.

    ``shape`` and ``spacing`` of the data grid, ``association`` "point" or "cell", ``faces`` the
    boundary kinds as returned by :func:`check_boundary` (Marshak everywhere when None)."""

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


def reflects(grid, axis, side):
    """Whether the box face on ``side`` (−1 low, +1 high) of ``axis`` is a symmetry plane."""
    return grid.faces[axis][0 if side < 0 else 1] == "reflect"


def _boundary(grid, axis, side):
    """Slices of the boundary nodes on one side of an axis and their face areas."""
    idx = 0 if side < 0 else grid.shape[axis] - 1
    return _sl(axis, idx, idx + 1), grid.area[axis]


def assemble(grid, sigma_t, albedo, D, Q0, Q1):
    """Couplings ``w`` (3 arrays, float32), diagonal terms ``c`` (absorption σa V plus the box
    faces' terms) and the right-hand side ``b`` (float64) of one channel: σa = (1 − a)σt
    from ``sigma_t`` and the channel's ``albedo``. Any float dtype and layout (channel views)
    is read as is. Interior faces, c and b in one pass
    (``_kernels.diffusion_system.assemble_faces``); box faces here."""
    from ..._kernels.diffusion_system import assemble_faces

    shape = grid.shape
    w = [np.empty(shape, np.float32) for _ in range(3)]
    c = np.empty(shape)
    b = np.empty(shape)
    q1 = NO_Q1 if Q1 is None else Q1
    hx, hy, hz = (float(v) for v in grid.h)
    assemble_faces(D, sigma_t, albedo, Q0, q1, Q1 is not None, *grid.wd, hx, hy, hz, *w, c, b)
    for a in range(3):
        if shape[a] < 2:
            continue
        for side in (-1, 1):
            if reflects(grid, a, side):
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


def _boundary_flux(grid, a, side, phi, D, q):
    """Outward F·n at the box face on one side of axis a, per unit area."""
    s = _boundary(grid, a, side)[0]
    if reflects(grid, a, side):
        return np.zeros_like(phi[s])
    if grid.association == "point":
        return 0.5 * phi[s]
    Dn, h = D[s], grid.h[a]
    out = 2.0 * Dn * phi[s] / (4.0 * Dn + h)
    if q is not None:
        out = out + 3.0 * Dn * h * side * q[s] / (4.0 * Dn + h)
    return out


def flux_and_power(grid, phi, sigma_t, albedo, D, Q0, Q1, R, F):
    """F at the nodes written into ``F`` (nx, ny, nz, 3), any float dtype (e.g. a float32 channel
    view), in world components (``R``: the index axes in world; None: the identity), and the
    power balance ``(source Σ Q0 V, absorbed Σ σa φ V, escaped Σ_box faces A F·n)`` in W (float64
    sums). F: the mean of the two adjacent face fluxes; at a point-data boundary node its
    Marshak face flux, at a cell-data one the mean of the face's and the inner face's; 3 D Q1
    along an axis with one node (``_kernels.diffusion_system.node_flux_power``). ``Q1``:
    index-axis components."""
    from ..._kernels.diffusion_system import node_flux_power

    shape = grid.shape
    outs = np.array([[0.0 if reflects(grid, a, sd) else 1.0 for sd in (-1, 1)] for a in range(3)])
    part = np.zeros((shape[0], 2))
    rot = R is not None
    hx, hy, hz = (float(v) for v in grid.h)
    node_flux_power(phi, D, NO_Q1 if Q1 is None else Q1, Q1 is not None, sigma_t, albedo, Q0, *grid.wd, hx, hy, hz,
                    grid.association == "cell", outs, np.asarray(R if rot else np.eye(3), np.float64), rot, F, part)
    escaped = 0.0
    for a in range(3):
        if shape[a] < 2:
            continue
        q = None if Q1 is None else Q1[..., a]
        for side in (-1, 1):
            _, Ab = _boundary(grid, a, side)
            escaped += float(np.sum(Ab * _boundary_flux(grid, a, side, phi, D, q)))
    return float(part[:, 0].sum()), float(part[:, 1].sum()), escaped


def check_boundary(boundary):
    """The boundary option as 3 (low, high) pairs of "marshak" / "reflect"."""
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
