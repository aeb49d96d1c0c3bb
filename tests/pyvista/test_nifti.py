"""Tests pv_ambient/pyvista/nifti.py: a NIfTI image as an ImageData placed by its affine."""
import numpy as np


def test_nifti_to_image_data_matches_an_independent_conversion(mni152):
    from pv_ambient.pyvista import nifti_to_image_data

    grid, img = mni152
    ours = nifti_to_image_data(img, factor=2, name="T1")
    assert ours.dimensions == grid.dimensions and np.allclose(ours.spacing, (2.0, 2.0, 2.0))
    np.testing.assert_allclose(ours.origin, grid.origin)
    np.testing.assert_allclose(ours.points[[0, -1]], grid.points[[0, -1]])
    np.testing.assert_array_equal(ours["T1"], grid["T1"])
