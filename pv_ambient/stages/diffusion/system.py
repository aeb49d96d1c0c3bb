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

Discrete power balance holds to the solver's residual: ``Σ Q0 V = Σ σa φ V + Σ_box faces A F·n``
(:attr:`DiffusionSolution.power`).

This module imports numpy, the kernels and the input checks only.
"""

from __future__ import annotations

import numpy as np

from ...inputs.validation import check_choice

__all__ = ["FVGrid", "NO_Q1", "assemble", "check_boundary", "node_flux", "power_balance", "reflects"]

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


def _face_mean(D, axis, harmonic):
    n = D.shape[axis]
    d0, d1 = D[_sl(axis, 0, n - 1)], D[_sl(axis, 1, n)]
    if harmonic:
        return 2.0 * d0 * d1 / (d0 + d1)
    return 0.5 * (d0 + d1)


def reflects(grid, axis, side):
    """Whether the box face on ``side`` (−1 low, +1 high) of ``axis`` is a symmetry plane."""
    return grid.faces[axis][0 if side < 0 else 1] == "reflect"


def _boundary(grid, axis, side):
    """Slices of the boundary nodes on one side of an axis and their face areas."""
    idx = 0 if side < 0 else grid.shape[axis] - 1
    return _sl(axis, idx, idx + 1), grid.area[axis]


def assemble(grid, sigma_a, D, Q0, Q1):
    """Couplings, absorption/boundary diagonal and right-hand side of one channel (float64).
    Interior faces: ``_kernels.diffusion_system.assemble_faces``; box faces here."""
    from ..._kernels.diffusion_system import assemble_faces

    shape = grid.shape
    w = [np.empty(shape) for _ in range(3)]
    b = Q0 * grid.volume
    c = sigma_a * grid.volume
    q1 = NO_Q1 if Q1 is None else np.ascontiguousarray(Q1, np.float64)
    hx, hy, hz = (float(v) for v in grid.h)
    assemble_faces(np.ascontiguousarray(D, np.float64), q1, Q1 is not None, *grid.wd, hx, hy, hz, *w, b)
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


def node_flux(grid, phi, D, Q1):
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
    if reflects(grid, a, side):
        return np.zeros_like(phi[s])
    if grid.association == "point":
        return 0.5 * phi[s]
    Dn, h = D[s], grid.h[a]
    out = 2.0 * Dn * phi[s] / (4.0 * Dn + h)
    if q is not None:
        out = out + 3.0 * Dn * h * side * q[s] / (4.0 * Dn + h)
    return out


def power_balance(grid, phi, sigma_a, D, Q0, Q1):
    """(source Σ Q0 V, absorbed Σ σa φ V, escaped Σ_box faces A F·n) of one channel, in W."""
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
