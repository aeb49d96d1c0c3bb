"""The one converter between ``pyvista.ImageData`` and numpy (docs/conventions.rst "Grid").

Point data value ``v[i, j, k]`` sits at ``index_to_physical · (i + i0, j + j0, k + k0, 1)`` where
``(i0, j0, k0)`` is the extent offset; VTK stores x fastest, so a flat point array reshapes with
``order="F"`` to ``(nx, ny, nz)`` — done here as a view (a C-order reshape to ``(nz, ny, nx)``
followed by a transpose), never a copy. Cell data is the same rule on cell centres
(``i + i0 + ½``). Between samples: trilinear; the medium exists only inside the grid's bounds.

The array core works in *sample index space*: continuous coordinates in which sample ``[i, j, k]``
of the array sits at ``(i, j, k)``. :class:`GridGeometry` holds the affine map from that space to
world space and the box, in index space, where the medium exists. This module imports pyvista
only inside the functions that read ``ImageData``; :class:`Volume` and :class:`GridGeometry` are
array-core objects.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from .validation import check_vector

_RESAMPLE_HINT = (
    "pv_ambient renders pyvista.ImageData (uniform grids). Resample your data onto one first, "
    "e.g. `image = pv.ImageData(dimensions=(n, n, n), spacing=..., origin=...).sample(mesh)` "
    "for a mesh, or `pv.wrap(array)` / `pv.ImageData(dimensions=array.shape)` with "
    "`image.point_data['values'] = array.ravel(order='F')` for a numpy array."
)


@dataclass(frozen=True, eq=False)
class GridGeometry:
    """Placement of a sample array in world space.

    Attributes
    ----------
    shape : tuple of int
        Sample array shape ``(nx, ny, nz)``.
    index_to_world : numpy.ndarray
        4×4 affine map from sample index space to world space.
    box_lo, box_hi : numpy.ndarray
        Index-space box where the medium exists (``[0, n−1]`` for point data,
        ``[−½, n−½]`` for cell data; an axis with one grid point has zero thickness).
    association : str
        ``"point"`` or ``"cell"``.
    """

    shape: tuple
    index_to_world: np.ndarray
    box_lo: np.ndarray
    box_hi: np.ndarray
    association: str = "point"
    world_to_index: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        m = np.asarray(self.index_to_world, dtype=np.float64)
        object.__setattr__(self, "index_to_world", m)
        object.__setattr__(self, "box_lo", np.asarray(self.box_lo, dtype=np.float64))
        object.__setattr__(self, "box_hi", np.asarray(self.box_hi, dtype=np.float64))
        object.__setattr__(self, "world_to_index", np.linalg.inv(m))

    @functools.cached_property
    def spacing(self) -> np.ndarray:
        """World length of one index step along each axis (read-only: computed once, as every
        frame's request reads it; docs/performance.rst, "Host work of a frame")."""
        out = _column_norms(self.index_to_world[:3, :3])
        out.setflags(write=False)
        return out

    @property
    def corners(self) -> np.ndarray:
        """The 8 world-space corners of the medium's box, shape (8, 3)."""
        lo, hi = self.box_lo, self.box_hi
        idx = np.array([[x, y, z] for z in (lo[2], hi[2]) for y in (lo[1], hi[1]) for x in (lo[0], hi[0])])
        return self.to_world(idx)

    @functools.cached_property
    def bounds(self) -> tuple:
        """Axis-aligned world bounds ``(xmin, xmax, ymin, ymax, zmin, zmax)`` of the box (computed
        once)."""
        c = self.corners
        lo, hi = c.min(axis=0), c.max(axis=0)
        return (lo[0], hi[0], lo[1], hi[1], lo[2], hi[2])

    @property
    def is_empty(self) -> bool:
        """True when the box has zero volume (an axis with a single grid point)."""
        return bool(np.any(self.box_hi <= self.box_lo))

    @property
    def diagonal(self) -> float:
        """World length of the box's longest diagonal (the largest distance between two corners)."""
        c = self.corners
        return float(np.max(np.linalg.norm(c[:, None, :] - c[None, :, :], axis=2)))

    def distance_to(self, xyz) -> np.ndarray:
        """World distance from each point of ``xyz`` (shape (..., 3)) to the medium's box (0 inside).

        Exact when the index axes are orthogonal in world space (a spacing times a rotation, as
        every VTK image's direction matrix is); for a sheared map a lower bound (the distance to
        the box's circumscribed sphere).

        >>> g = geometry_from_spacing((3, 3, 3), spacing=(0.5, 0.5, 0.5))    # the box [0, 1]³
        >>> g.distance_to([[2.0, 0.5, 0.5], [0.5, 0.5, 0.5], [2.0, 2.0, 0.5]]).round(4).tolist()
        [1.0, 0.0, 1.4142]
        """
        xyz = np.asarray(xyz, dtype=np.float64)
        m = self.index_to_world[:3, :3]
        gram = m.T @ m
        off = gram - np.diag(np.diag(gram))
        if np.all(np.abs(off) <= 1e-12 * np.max(np.abs(gram))):  # orthogonal axes: clamp per axis
            ijk = self.to_index(xyz)
            near = self.to_world(np.clip(ijk, self.box_lo, self.box_hi))
            return np.linalg.norm(xyz - near, axis=-1)
        centre = self.corners.mean(axis=0)  # a parallelepiped's main diagonals meet there
        return np.maximum(np.linalg.norm(xyz - centre, axis=-1) - 0.5 * self.diagonal, 0.0)

    def to_world(self, ijk) -> np.ndarray:
        ijk = np.asarray(ijk, dtype=np.float64)
        return ijk @ self.index_to_world[:3, :3].T + self.index_to_world[:3, 3]

    def to_index(self, xyz) -> np.ndarray:
        xyz = np.asarray(xyz, dtype=np.float64)
        return xyz @ self.world_to_index[:3, :3].T + self.world_to_index[:3, 3]

    def key(self) -> tuple:
        """Hashable identity for caches."""
        return (self.shape, self.association, self.index_to_world.tobytes(),
                self.box_lo.tobytes(), self.box_hi.tobytes())


#: Supported grid spacings (world units). Rendering is scale invariant (tests/acceptance/test_extremes.py),
#: but squared world lengths (I/d², the point-light clamp (step/4)², lights 1e6 box sizes away)
#: must stay normal float64 numbers: spacings beyond this range underflow or overflow them.
SPACING_RANGE = (1e-100, 1e100)


def _column_norms(a) -> np.ndarray:
    """Euclidean norms of the columns of ``a``, without under/overflow of the squares."""
    scale = np.max(np.abs(a), axis=0)
    safe = np.where(scale > 0, scale, 1.0)
    return scale * np.sqrt(np.sum((a / safe[None, :]) ** 2, axis=0))


def _check_index_to_physical(index_to_physical, flat) -> np.ndarray:
    """The 4×4 index→world matrix as float64, or a ValueError naming the grid's spacing.

    Every axis that holds more than one grid point needs a finite, non-zero spacing (the map
    must be invertible: kernels work in index space). A flat axis (one grid point) has no
    thickness whatever its spacing, so a zero spacing there is replaced by 1 along the axis's
    direction (VTK writes 0 for the third axis of some 2D images).
    """
    m = np.array(index_to_physical, dtype=np.float64)
    if m.shape != (4, 4) or not np.all(np.isfinite(m)):
        raise ValueError(f"the grid's index-to-world matrix must be a finite 4x4 matrix (spacing, origin and "
                         f"direction finite), got {m.tolist()!r}")
    a = m[:3, :3]
    spacing = _column_norms(a)
    for ax in range(3):
        if spacing[ax] == 0.0 and flat[ax]:
            # a zero column has lost its direction: take the right-handed normal of the others
            n = np.cross(a[:, (ax + 1) % 3], a[:, (ax + 2) % 3])
            nn = np.linalg.norm(n)
            a[:, ax] = n / nn if nn > 0 else np.eye(3)[:, ax]
            spacing[ax] = 1.0
    if np.any(spacing == 0.0):
        raise ValueError(f"grid spacing must be positive along every axis with more than one point, got "
                         f"{tuple(float(x) for x in spacing)} (axes with one point: {tuple(bool(f) for f in flat)})")
    if np.any(spacing < SPACING_RANGE[0]) or np.any(spacing > SPACING_RANGE[1]):
        raise ValueError(f"grid spacing must lie in [{SPACING_RANGE[0]:g}, {SPACING_RANGE[1]:g}] world units (squared "
                         f"lengths must stay normal doubles), got {tuple(float(x) for x in spacing)}")
    if abs(np.linalg.det(a / spacing[None, :])) < 1e-12:
        raise ValueError(f"the grid's direction matrix must be invertible, got {(a / spacing[None, :]).tolist()!r}")
    return m


def make_geometry(point_dims, index_to_physical, offset=(0, 0, 0), association="point") -> GridGeometry:
    """Geometry of the point or cell samples of an image with ``point_dims`` grid points.

    ``index_to_physical`` maps *structured* indices (extent-based, as VTK's
    ``GetIndexToPhysicalMatrix``) to world; ``offset`` is the extent's first index.
    """
    dims = np.asarray(point_dims, dtype=np.int64)
    flat = dims <= 1
    m = _check_index_to_physical(index_to_physical, flat)
    shift = np.asarray(offset, dtype=np.float64).copy()
    if association == "point":
        shape = tuple(int(d) for d in dims)
        lo = np.zeros(3)
        hi = (dims - 1).astype(np.float64)
    elif association == "cell":
        ncell = np.where(flat, 1, dims - 1)
        shape = tuple(int(d) for d in ncell)
        shift = shift + np.where(flat, 0.0, 0.5)
        lo = np.where(flat, 0.0, -0.5)
        hi = np.where(flat, 0.0, ncell - 0.5)
    else:  # pragma: no cover - internal
        raise ValueError(f"association must be 'point' or 'cell', got {association!r}")
    translate = np.eye(4)
    translate[:3, 3] = shift
    m = m @ translate
    return GridGeometry(shape=shape, index_to_world=m, box_lo=lo, box_hi=hi, association=association)


def geometry_from_spacing(shape, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0), direction=None,
                          association="point") -> GridGeometry:
    """Geometry from plain values (the array core's way in, no pyvista needed)."""
    spacing = check_vector(spacing, "spacing")
    if np.any(spacing <= 0):
        raise ValueError(f"spacing must be positive, got {tuple(spacing)}")
    origin = check_vector(origin, "origin")
    d = np.eye(3) if direction is None else np.asarray(direction, dtype=np.float64)
    if d.shape != (3, 3) or not np.all(np.isfinite(d)) or abs(np.linalg.det(d)) < 1e-12:
        raise ValueError(f"direction must be an invertible 3x3 matrix, got {direction!r}")
    m = np.eye(4)
    m[:3, :3] = d * spacing[None, :]
    m[:3, 3] = origin
    shape = tuple(int(s) for s in shape)
    dims = shape if association == "point" else tuple(s + 1 for s in shape)
    return make_geometry(dims, m, association=association)


class Volume:
    """Arrays on a regular grid plus their placement: the array core's input.

    Parameters
    ----------
    arrays : numpy.ndarray or dict of str to numpy.ndarray
        Sample arrays shaped ``(nx, ny, nz)`` or ``(nx, ny, nz, ncomp)``, indexed ``[i, j, k]``
        with ``i`` along x. A single array is stored under the name ``"values"``.
    spacing, origin : sequence of float, default: (1, 1, 1), (0, 0, 0)
        World spacing and position of sample ``[0, 0, 0]`` (for point data).
    direction : array_like, optional
        3×3 direction matrix (columns: world direction of the i, j, k axes).
    association : {"point", "cell"}, default: "point"
        Whether the samples sit on grid points or cell centres.
    active : str, optional
        Name of the active scalars; defaults to the first array.

    Examples
    --------
    >>> import numpy as np
    >>> from pv_ambient.inputs.grid import Volume
    >>> vol = Volume(np.zeros((4, 5, 6), np.float32), spacing=(0.5, 0.5, 0.5))
    >>> vol.geometry.shape, vol.active
    ((4, 5, 6), 'values')
    """

    def __init__(self, arrays, *, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0), direction=None,
                 association="point", active=None, geometry=None):
        if not isinstance(arrays, dict):
            arrays = {"values": arrays}
        if not arrays:
            raise ValueError("arrays must hold at least one array, got an empty dict")
        shape = None
        clean = {}
        for name, a in arrays.items():
            a = np.asarray(a)
            if a.ndim not in (3, 4):
                raise ValueError(f"array {name!r} must be 3D (nx, ny, nz) or 4D with components, "
                                 f"got shape {a.shape}")
            if shape is None:
                shape = a.shape[:3]
            elif a.shape[:3] != shape:
                raise ValueError(f"array {name!r} has shape {a.shape[:3]}, expected {shape} like the others")
            clean[name] = a
        if min(shape) == 0:
            raise ValueError(f"arrays must not be empty, got shape {shape}")
        self.arrays = clean
        self.association = association
        self.active = active if active is not None else next(iter(clean))
        if geometry is None:
            geometry = geometry_from_spacing(shape, spacing, origin, direction, association)
        self.geometry = geometry

    def __repr__(self):
        names = ", ".join(f"{k}{tuple(v.shape)}" for k, v in self.arrays.items())
        return f"Volume({names}, association={self.association!r})"


# ---------------------------------------------------------------------------------------------
# pyvista side
# ---------------------------------------------------------------------------------------------

def as_image_data(grid, name: str = "grid"):
    """Return ``grid`` as a ``pyvista.ImageData`` (wrapping a raw ``vtkImageData``), or raise."""
    import pyvista as pv

    if isinstance(grid, pv.ImageData):
        return grid
    try:
        from vtkmodules.vtkCommonDataModel import vtkImageData
    except ImportError:  # pragma: no cover
        vtkImageData = ()
    if isinstance(grid, vtkImageData):
        return pv.wrap(grid)
    raise TypeError(f"{name} must be a pyvista.ImageData or vtkImageData, got "
                    f"{type(grid).__module__}.{type(grid).__name__}. {_RESAMPLE_HINT}")


def _reshape_vtk_array(flat, dims):
    """View a flat VTK-ordered array (x fastest) as ``(nx, ny, nz[, ncomp])``."""
    nx, ny, nz = dims
    a = np.asarray(flat)
    if a.ndim == 1:
        return a.reshape((nz, ny, nx)).transpose(2, 1, 0)
    return a.reshape((nz, ny, nx, a.shape[1])).transpose(2, 1, 0, 3)


def image_geometry(image, association="point") -> GridGeometry:
    """:class:`GridGeometry` of an ImageData's point or cell samples."""
    ext = image.extent
    return make_geometry(image.dimensions, image.index_to_physical_matrix,
                         offset=(ext[0], ext[2], ext[4]), association=association)


def volume_from_image(grid, *, preference="point", name="grid") -> Volume:
    """Read every numeric point (or cell) array of an ImageData into a :class:`Volume` of views."""
    image = as_image_data(grid, name)
    if image.n_points == 0:
        raise ValueError(f"{name} is empty (0 points); nothing to render")
    point = {k: image.point_data[k] for k in image.point_data.keys()}
    cell = {k: image.cell_data[k] for k in image.cell_data.keys()}
    active_name, active_assoc = None, None
    info = image.active_scalars_info
    if info is not None and info.name is not None:
        active_name = info.name
        active_assoc = "point" if "POINT" in str(info.association).upper() else "cell"
    # cell data when asked for (preference="cell"), when there is nothing else, or when the active
    # scalars are cell data (PyVista's default choice)
    use_cell = bool(cell) and (preference == "cell" or not point or active_assoc == "cell")
    assoc = "cell" if use_cell else "point"
    source = cell if use_cell else point
    if not source:
        raise ValueError(f"{name} has no point or cell arrays; add one, e.g. "
                         f"grid.point_data['density'] = values.ravel(order='F')")
    geom = image_geometry(image, assoc)
    arrays = {k: _reshape_vtk_array(v, geom.shape) for k, v in source.items()}
    active = active_name if active_name in arrays else next(iter(arrays))
    vol = Volume(arrays, association=assoc, active=active, geometry=geom)
    vol.other_arrays = {"point": point, "cell": cell}
    return vol


def select_scalars(volume: Volume, scalars=None, *, component=None, name="scalars") -> np.ndarray:
    """The scalar field to classify, shape ``(nx, ny, nz)``, any numeric dtype (not copied).

    ``scalars=None`` takes the active scalars. A multi-component array is reduced by its
    magnitude, or to one component when ``component`` (an index) is given.
    """
    if scalars is None:
        key = volume.active
    elif isinstance(scalars, str):
        key = scalars
    else:
        raise TypeError(f"{name} must be an array name (str) or None, got {type(scalars).__name__}")
    if key not in volume.arrays:
        avail = sorted(volume.arrays)
        extra = ""
        other = getattr(volume, "other_arrays", None)
        if other:
            alt = "cell" if volume.association == "point" else "point"
            if key in other[alt]:
                extra = f" ({key!r} is a {alt} array: pass preference={alt!r})"
        raise ValueError(f"{name}={key!r} is not an array of the grid's {volume.association} data; "
                         f"available: {avail}{extra}")
    a = volume.arrays[key]
    if not np.issubdtype(a.dtype, np.number) or np.issubdtype(a.dtype, np.complexfloating):
        raise TypeError(f"{name}={key!r} must be a real numeric array, got dtype {a.dtype}")
    if a.ndim == 4:
        if component is None:
            a = np.sqrt(np.sum(np.square(a, dtype=np.float64), axis=3))
        else:
            nc = a.shape[3]
            if not isinstance(component, (int, np.integer)) or not -nc <= component < nc:
                raise ValueError(f"component must be an integer index into the {nc} components "
                                 f"of {key!r}, got {component!r}")
            a = a[..., component]
    elif component not in (None, 0):
        raise ValueError(f"component={component!r} given but {name}={key!r} has one component")
    return a


def as_float32_c(a) -> np.ndarray:
    """``a`` as a C-ordered float32 array: ``a`` itself when it is one, else a copy made in parallel
    (:func:`pv_ambient._kernels.medium.copy_float32`; NumPy's copy of a grid's x-fastest view runs
    on one thread at a stride)."""
    a = np.asarray(a)
    if a.dtype == np.float32 and a.flags.c_contiguous:
        return a
    if a.ndim != 3 or a.size < 1 << 16:
        return np.ascontiguousarray(a, dtype=np.float32)
    from .._kernels.medium import copy_float32

    out = np.empty(a.shape, np.float32)
    copy_float32(a, out)
    return out
