"""Shared pytest set-up: headless VTK, deterministic seeds; the MNI152 template that two folders
read (tests/pyvista/test_nifti.py, tests/acceptance/test_mni152.py)."""
import os

import numpy as np
import pytest

import pv_ambient  # noqa: F401  (first: it sets Numba's CPU features before Numba is imported, as for a user)

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
os.environ.setdefault("MPLBACKEND", "Agg")
# Preintegrated table slices computed by the tests are cached inside the checkout (ignored by
# git), never in the user's cache directory.
os.environ.setdefault("PV_AMBIENT_CACHE", os.path.join(os.path.dirname(os.path.dirname(__file__)), ".cache", "tables"))
# OpenMP worker threads that spin while waiting slow the light-volume sweeps (one parallel region
# per layer) badly when the 2 CI cores are shared; passive waiting costs nothing measurable here.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")


@pytest.fixture(scope="session")
def mni152():
    """MNI152 in 2 mm voxels (2×2×2 block means), world units mm: built here from the NIfTI affine,
    independently of pv_ambient.pyvista.nifti_to_image_data (checked against it in
    tests/pyvista/test_nifti.py)."""
    import pyvista as pv

    nilearn_datasets = pytest.importorskip("nilearn.datasets")
    img = nilearn_datasets.load_mni152_template()
    data = img.get_fdata(dtype=np.float32)
    n = [s // 2 for s in data.shape]
    data = data[:2 * n[0], :2 * n[1], :2 * n[2]].reshape(n[0], 2, n[1], 2, n[2], 2).mean(axis=(1, 3, 5))
    linear = img.affine[:3, :3] * 2.0
    spacing = np.linalg.norm(linear, axis=0)
    origin = img.affine[:3, 3] + img.affine[:3, :3] @ np.full(3, 0.5)  # centre of the first 2×2×2 block
    grid = pv.ImageData(dimensions=data.shape, spacing=spacing, origin=origin, direction_matrix=linear / spacing)
    grid.point_data["T1"] = data.astype(np.float32).ravel(order="F")
    return grid, img
