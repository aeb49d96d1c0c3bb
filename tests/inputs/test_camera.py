"""Tests pv_ambient/inputs/camera.py: our projection against VTK's own transform, ray generation against
projection, PyVista's default camera and camera strings, and the errors."""
import numpy as np
import pytest
import pyvista as pv

import pv_ambient as pa
from pv_ambient import datasets
from pv_ambient.inputs.camera import Camera, as_camera, default_camera


def vtk_pixels(cam: Camera, points, size):
    """Project with VTK's GetCompositeProjectionTransformMatrix → pixel coords (x right, y down)."""
    w, h = size
    vc = cam.to_vtk()
    vc.SetClippingRange(0.01, 1000.0)
    m = np.array([[vc.GetCompositeProjectionTransformMatrix(w / h, -1, 1).GetElement(i, j) for j in range(4)]
                  for i in range(4)])
    hom = np.c_[points, np.ones(len(points))] @ m.T
    ndc = hom[:, :3] / hom[:, 3:4]
    return np.c_[(ndc[:, 0] + 1) / 2 * w, (1 - ndc[:, 1]) / 2 * h]


CAMERAS = [
    Camera((3, -4, 2), (0.1, 0.2, -0.3), (0, 0, 1), view_angle=30),
    Camera((0.5, 0.2, 7), (0, 0, 0), (0.3, 1, 0), view_angle=55),
    Camera((-2, -2, -2), (1, 0.5, 0), (0, 1, 1), parallel_projection=True, parallel_scale=1.7),
]


@pytest.mark.parametrize("cam", CAMERAS)
@pytest.mark.parametrize("size", [(640, 480), (123, 301)])
def test_projection_matches_vtk(cam, size):
    rng = np.random.default_rng(1)
    pts = rng.uniform(-1, 1, (200, 3))
    ours = cam.project(pts, size)
    theirs = vtk_pixels(cam, pts, size)
    assert np.max(np.abs(ours - theirs)) <= 0.01


@pytest.mark.parametrize("cam", CAMERAS)
def test_rays_pass_through_pixel_centres(cam):
    size = (37, 23)
    org, dirs = cam.rays(size)
    pts = org + 2.5 * dirs
    px = cam.project(pts.reshape(-1, 3), size).reshape(23, 37, 2)
    jj, ii = np.mgrid[0:23, 0:37]
    assert np.allclose(px[..., 0], ii + 0.5, atol=1e-9)
    assert np.allclose(px[..., 1], jj + 0.5, atol=1e-9)


def test_from_plotter_uses_window_and_default_camera():
    grid = pv.ImageData(dimensions=(5, 6, 7), spacing=(0.5, 0.5, 0.5))
    pl = pv.Plotter(off_screen=True, window_size=(200, 100))
    pl.add_mesh(grid.outline())
    cam, size = as_camera(pl)
    assert size == (200, 100)
    pl2 = pv.Plotter(off_screen=True, window_size=(200, 100))
    pl2.add_mesh(grid.outline())
    pl2.show(auto_close=False)  # PyVista sets its default camera here
    ref = Camera.from_vtk(pl2.camera)
    assert np.allclose(cam.position, ref.position) and np.allclose(cam.focal_point, ref.focal_point)
    pl.close()
    pl2.close()


def test_default_camera_is_pyvistas():
    grid = pv.ImageData(dimensions=(5, 6, 7), spacing=(0.5, 0.25, 1.0), origin=(1, 2, 3))
    pl = pv.Plotter(off_screen=True)
    pl.add_mesh(grid.outline())
    pl.show(auto_close=False)
    ref = Camera.from_vtk(pl.camera)
    cam = default_camera(grid.bounds)
    assert np.allclose(cam.position, ref.position, atol=1e-9)
    assert np.allclose(cam.focal_point, ref.focal_point, atol=1e-9)
    assert cam.view_angle == ref.view_angle
    pl.close()


@pytest.mark.parametrize("kwargs, match", [
    (dict(position=(0, 0, 0), focal_point=(0, 0, 0)), "coincide"),
    (dict(position=(0, 0, 0), focal_point=(0, 0, 1), view_up=(0, 0, 2)), "parallel"),
    (dict(position=(0, 0, 0), focal_point=(1, 0, 0), view_angle=0), "view_angle"),
    (dict(position=(0, 0, np.nan), focal_point=(1, 0, 0)), "position"),
])
def test_bad_camera(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Camera(**kwargs)


def test_as_camera_errors():
    with pytest.raises(TypeError, match="camera must be"):
        as_camera(42, bounds=(0, 1, 0, 1, 0, 1))
    with pytest.raises(ValueError, match="window_size"):
        as_camera(None, window_size=(0, 10), bounds=(0, 1, 0, 1, 0, 1))


def test_plotter_subplot_size_and_explicit_window_size():
    import pyvista as pv

    import pv_ambient
    from pv_ambient import datasets

    pl = pv.Plotter(off_screen=True, shape=(1, 2), window_size=(200, 80))
    pl.subplot(0, 1)
    _, size = pa_as_camera(pl)
    assert size == (100, 80)  # half the window: the subplot's viewport
    grid = datasets.cloud(n=12)
    _, res = pv_ambient.add_ambient_volume(pl, grid, window_size=(30, 20))
    assert res.window_size == (30, 20)
    pl.close()


def pa_as_camera(pl):
    from pv_ambient.inputs.camera import as_camera

    return as_camera(pl)


def test_view_up_parallel_to_the_view_is_a_clear_error():
    """Already an error on 65d2e28 (with numpy reprs in the message); kept, and the message cleaned."""
    with pytest.raises(ValueError, match=r"view_up \(0.0, 0.0, 1.0\) is parallel to the view direction "
                                         r"\(0.0, 0.0, -1.0\): give a view_up across the view"):
        pa.render(datasets.cloud(n=12), window_size=(8, 8), camera=[(0, 0, 5), (0, 0, 0), (0, 0, 1)])


@pytest.mark.parametrize("view", ["iso", "xy", "xz", "yz", "yx", "zx", "zy"])
def test_camera_strings_are_pyvistas(view):
    """Why: ``camera="iso"`` (PyVista's camera strings) was rejected."""
    import pyvista as pv

    grid = datasets.cloud(n=12)
    res = pa.render(grid, camera=view, window_size=(12, 10))
    pl = pv.Plotter(off_screen=True)
    pl.add_mesh(grid.outline())
    pl.camera_position = view
    pl.reset_camera(bounds=grid.bounds)
    ours, theirs = res.camera, pl.camera
    for a, b in ((ours.position, theirs.position), (ours.focal_point, theirs.focal_point),
                 (ours.view_up, theirs.up)):
        np.testing.assert_allclose(a, b, atol=1e-9)
    pl.close()
    with pytest.raises(ValueError, match=r"camera 'top' is not one of PyVista's camera strings"):
        pa.render(grid, camera="top", window_size=(8, 8))
