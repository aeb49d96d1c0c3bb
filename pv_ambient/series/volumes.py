"""The volumes of a series: what :func:`~pv_ambient.render_series` accepts, how an in-memory grid
travels to a worker, and how a worker reads a file (docs/series.rst, "What a frame is").

Frame ``i`` renders volume ``i``; the list comes from :func:`resolve_volumes` (grids, files, a
glob sorted by name, a ``.pvd`` collection in time order). Files travel to the workers as paths
and are read there (:func:`read_volume`): a cluster's workers read from a shared file system and
the client never holds every time step. A grid in memory travels as a :class:`PackedImage` (plain
numpy arrays), which keeps every digit of its spacing and origin where PyVista's pickling through
VTK's legacy format would keep 6, so that a worker renders the very grid the client holds.
"""

from __future__ import annotations

import glob as globmod
import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np


def is_grid(obj) -> bool:
    """Whether ``obj`` is a volume in memory (a VTK ``vtkImageData`` / ``pyvista.ImageData`` or an
    array-core :class:`~pv_ambient.inputs.grid.Volume`), not a path or a list."""
    return hasattr(obj, "GetDimensions") or type(obj).__name__ == "Volume"


def pvd_files(path) -> list:
    """The data files of a ``.pvd`` collection in time order (paths relative to the ``.pvd``).

    Only part 0 of a multi-part collection is used (one volume per time step).
    """
    import xml.etree.ElementTree as ET

    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"volumes collection {str(path)!r} does not exist")
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise ValueError(f"volumes collection {str(path)!r} is not valid XML: {exc}") from None
    steps = []
    for i, ds in enumerate(root.iter("DataSet")):
        if ds.get("file") is None:
            raise ValueError(f"volumes collection {str(path)!r}: DataSet {i} has no 'file' attribute")
        if int(ds.get("part", "0") or 0) != 0:
            continue
        t = ds.get("timestep")
        steps.append((float(t) if t not in (None, "") else float(i), i, str(path.parent / ds.get("file"))))
    if not steps:
        raise ValueError(f"volumes collection {str(path)!r} lists no DataSet")
    return [p for _, _, p in sorted(steps)]


def resolve_volumes(volumes) -> list:
    """The volume list of :func:`render_series`: each item a file path (str) or an in-memory grid.

    ``volumes`` is one grid, a list of grids and/or paths, a glob pattern, a ``.pvd`` collection
    or one file path. A glob is sorted by name; a ``.pvd`` is in time order.
    """
    if is_grid(volumes):
        return [volumes]
    if isinstance(volumes, (str, os.PathLike)):
        text = os.fspath(volumes)
        if text.lower().endswith(".pvd"):
            return pvd_files(text)
        if any(ch in text for ch in "*?["):
            found = sorted(globmod.glob(text))
            if not found:
                raise FileNotFoundError(f"volumes glob {text!r} matched no file")
            return found
        return [text]
    try:
        items = list(volumes)
    except TypeError:
        raise TypeError("volumes must be an ImageData, a list of ImageData or file paths, a glob or a .pvd path; "
                        f"got {type(volumes).__name__}") from None
    if not items:
        raise ValueError("volumes is empty: give at least one volume")
    out = []
    for i, v in enumerate(items):
        if isinstance(v, (str, os.PathLike)):
            out.append(os.fspath(v))
        elif is_grid(v):
            out.append(v)
        else:
            raise TypeError(f"volumes[{i}] must be an ImageData or a file path, got {type(v).__name__}")
    return out


@dataclass
class PackedImage:
    """An in-memory ImageData in plain numpy arrays, for the trip to a worker.

    PyVista pickles an ImageData through VTK's legacy format, which keeps 6 digits of its spacing
    and origin; this keeps every number, so a worker renders the very grid the client holds.
    """

    dimensions: tuple
    origin: tuple
    spacing: tuple
    direction: np.ndarray
    point: dict
    cell: dict
    active: tuple  # (name, "point" | "cell") or None

    @classmethod
    def of(cls, grid) -> "PackedImage":
        import pyvista as pv

        image = pv.wrap(grid)
        info = image.active_scalars_info
        active = None
        if info is not None and info.name is not None:
            active = (info.name, "point" if "POINT" in str(info.association).upper() else "cell")
        return cls(tuple(image.dimensions), tuple(image.origin), tuple(image.spacing),
                   np.array(image.direction_matrix, dtype=np.float64),
                   {k: np.array(image.point_data[k]) for k in image.point_data.keys()},
                   {k: np.array(image.cell_data[k]) for k in image.cell_data.keys()}, active)

    def unpack(self):
        import pyvista as pv

        image = pv.ImageData(dimensions=self.dimensions, spacing=self.spacing, origin=self.origin)
        image.direction_matrix = self.direction
        for k, v in self.point.items():
            image.point_data[k] = v
        for k, v in self.cell.items():
            image.cell_data[k] = v
        if self.active is not None:
            image.set_active_scalars(self.active[0], preference=self.active[1])
        return image


def read_volume(path):
    """Read one volume file as a ``pyvista.ImageData``, or raise an error that names the file."""
    import pyvista as pv
    from vtkmodules.vtkCommonCore import vtkObject

    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"volume file {str(path)!r} does not exist")
    shown = vtkObject.GetGlobalWarningDisplay()
    vtkObject.GlobalWarningDisplayOff()  # a corrupt file is reported once, by the error below
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            data = pv.read(path)
    except Exception as exc:  # noqa: BLE001 - any reader failure is this file's error
        raise ValueError(f"volume file {str(path)!r} could not be read: {exc}") from None
    finally:
        vtkObject.SetGlobalWarningDisplay(shown)
    if not isinstance(data, pv.ImageData):
        raise TypeError(f"volume {str(path)!r} holds a {type(data).__name__}, not an ImageData")
    if data.n_points == 0:
        why = f": {caught[0].message}" if caught else ""
        raise ValueError(f"volume file {str(path)!r} could not be read (no points){why}")
    return data


def for_worker(volume):
    """``volume`` as it travels to a worker: a path or an array-core ``Volume`` as it is, a
    ``pyvista.ImageData`` as a :class:`PackedImage` (every digit of its geometry kept)."""
    if isinstance(volume, str) or type(volume).__name__ == "Volume":
        return volume
    return PackedImage.of(volume)


def load_volume(volume):
    """The grid a worker renders for ``volume``: a path read (:func:`read_volume`), a
    :class:`PackedImage` unpacked, a grid as it is."""
    if isinstance(volume, str):
        return read_volume(volume)
    if isinstance(volume, PackedImage):
        return volume.unpack()
    return volume
