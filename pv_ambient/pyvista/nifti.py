"""A NIfTI image (nibabel, nilearn) as a ``pyvista.ImageData`` placed by its affine:
:func:`nifti_to_image_data`.

The NIfTI affine maps voxel indices ``(i, j, k, 1)`` to world coordinates (millimetres for MRI),
exactly what VTK calls the index-to-physical matrix: its column norms are the spacing, the
normalised columns the direction matrix and its last column the origin.
"""

from __future__ import annotations

import numpy as np
import pyvista as pv


def block_mean(data, affine, factor):
    """``data`` averaged over factor³ blocks, and the affine of the coarser grid (new voxel
    ``I`` is the centre of old voxels ``f·I … f·I + f − 1``).

    Examples
    --------
    >>> import numpy as np
    >>> from pv_ambient.pyvista.nifti import block_mean
    >>> data, affine = block_mean(np.arange(64.0).reshape(4, 4, 4), np.eye(4), 2)
    >>> data.shape, float(data[0, 0, 0]), affine[:3, 3].tolist()
    ((2, 2, 2), 10.5, [0.5, 0.5, 0.5])
    """
    f = int(factor)
    if f < 1:
        raise ValueError(f"factor must be an integer >= 1, got {factor!r}")
    data = np.asarray(data)
    if f == 1:
        return data, np.asarray(affine, dtype=np.float64)
    n = [s // f for s in data.shape[:3]]
    blocks = data[:n[0] * f, :n[1] * f, :n[2] * f].reshape(n[0], f, n[1], f, n[2], f)
    coarse = np.eye(4)
    coarse[:3, :3] *= f
    coarse[:3, 3] = (f - 1) / 2
    return blocks.mean(axis=(1, 3, 5)), np.asarray(affine, dtype=np.float64) @ coarse


def nifti_to_image_data(image, *, factor=1, name="values"):
    """A ``pyvista.ImageData`` of a NIfTI image, in the image's world units (mm for MRI).

    Parameters
    ----------
    image : nibabel image or (data, affine)
        Anything with ``get_fdata()`` and ``affine`` (``nibabel.Nifti1Image``, what
        ``nilearn.datasets.load_mni152_template()`` returns), or a ``(data, affine)`` pair with
        ``data`` indexed ``[i, j, k]``.
    factor : int, default: 1
        Average factor³ voxel blocks into one (:func:`block_mean`): 2 turns the 1 mm MNI152
        template into 2 mm voxels, 8× fewer.
    name : str, default: "values"
        Name of the point array.

    Examples
    --------
    >>> import numpy as np
    >>> from pv_ambient.pyvista.nifti import nifti_to_image_data
    >>> affine = np.diag([2.0, 2.0, 2.0, 1.0]); affine[:3, 3] = (-10, -20, -30)
    >>> grid = nifti_to_image_data((np.ones((4, 5, 6)), affine), name="T1")
    >>> grid.dimensions, grid.spacing, grid.origin
    ((4, 5, 6), (2.0, 2.0, 2.0), (-10.0, -20.0, -30.0))
    """
    if hasattr(image, "get_fdata") and hasattr(image, "affine"):
        data, affine = image.get_fdata(dtype=np.float32), image.affine
    else:
        data, affine = image
    data, affine = block_mean(np.asarray(data), affine, factor)
    if data.ndim != 3:
        raise ValueError(f"image must hold a 3-D volume, got data of shape {data.shape}")
    linear = affine[:3, :3]
    spacing = np.linalg.norm(linear, axis=0)
    grid = pv.ImageData(dimensions=data.shape, spacing=spacing, origin=affine[:3, 3],
                        direction_matrix=linear / spacing)
    grid.point_data[name] = np.asarray(data, dtype=np.float32).ravel(order="F")  # VTK: i fastest
    return grid
