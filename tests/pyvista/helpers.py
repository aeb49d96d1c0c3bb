"""What the plotter and geometry tests share: the camera and an off-screen plotter set to it."""
import pyvista as pv

import pv_ambient as pa

CAMERA = pa.Camera((2.5, -3.5, 1.5), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), view_angle=30.0)


def plotter(size, camera=CAMERA):
    """An off-screen plotter of ``size`` looking through ``camera``, on black: the picture is then the
    volume alone (no plotter background behind it)."""
    pl = pv.Plotter(off_screen=True, window_size=size)
    pl.set_background("black")
    camera.to_vtk(pl.camera)
    pl.camera_set = True
    return pl
