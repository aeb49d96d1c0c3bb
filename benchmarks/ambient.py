"""Ambient scattering: cost of each kind of frame, as ratios to VTK's emission–absorption render.

For each volume size (supernova, one point light at the centre, 512² by default) one run measures:

* VTK ``fixed_point`` EA frame of the same TF and camera (the peer; median of repeats);
* a camera-move AS frame (every cache warm: only the ray cast runs);
* a relight (the light moves: its transmittance volume — and its front volume in tube mode — is
  recomputed, then the ray cast);
* a TF change (new classification, mean extinction, light volumes, ray cast; the table slice of the
  new albedo range is reused when cached);
* a table slice (``get_table`` for a new g, cache disabled), in seconds and as a ratio.

Each figure is the median of ``--repeats`` after a warm-up (Numba compilation excluded), printed
as a ratio to the VTK frame measured in the same run.

Usage: ``python benchmarks/ambient.py [--sizes 128 256] [--window 512] [--repeats 3]``
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np  # noqa: E402
import pyvista as pv  # noqa: E402

import pv_ambient as pa  # noqa: E402
from pv_ambient import datasets  # noqa: E402
from pv_ambient.inputs.camera import default_camera  # noqa: E402
from pv_ambient.pyvista.vtk_bridge import add_vtk_volume  # noqa: E402
from _timing import median_time  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[128, 256])
    ap.add_argument("--window", type=int, default=512)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--propagation", default="beer_lambert", choices=("beer_lambert", "tube"))
    args = ap.parse_args(argv)
    size = (args.window, args.window)
    style = datasets.suggested_style("supernova")
    print(f"ambient scattering, supernova, {size[0]}x{size[1]}, point light at the centre, "
          f"propagation={args.propagation}; median of {args.repeats} after warm-up; ratios to VTK fixed_point EA")
    print(f"{'n':>5} {'VTK EA s':>9} {'camera':>8} {'relight':>8} {'TF chg':>8} {'table s':>8} {'table':>8}")
    for n in args.sizes:
        grid = datasets.supernova(n=n)
        tf = pa.TransferFunction(**style, albedo=0.9)
        light = pa.PointLight((0.0, 0.0, 0.0), intensity=4.0)
        r = pa.Renderer(grid, transfer_function=tf, lights=[light])
        cam = default_camera(grid.bounds)
        step = r.default_step()

        pl = pv.Plotter(off_screen=True, window_size=size)
        add_vtk_volume(pl, grid, r, step=step, mapper="fixed_point")
        cam.to_vtk(pl.camera)

        def vtk_frame(k):
            pl.camera.Azimuth(1.0)
            pl.renderer.ResetCameraClippingRange()
            pl.ren_win.Render()

        t_vtk = median_time(vtk_frame, args.repeats)
        pl.close()
        opts = dict(window_size=size, model="ambient_scattering", step=step, propagation=args.propagation)

        def camera_frame(k):
            c = cam.to_vtk()
            c.Azimuth(float(k))
            r.render(camera=pa.Camera.from_vtk(c), **opts)

        t_cam = median_time(camera_frame, args.repeats)

        def relight(k):
            r.set_lights([pa.PointLight((0.02 * (k + 1), 0.0, 0.0), intensity=4.0)])
            r.render(camera=cam, **opts)

        t_relight = median_time(relight, args.repeats)

        def tf_change(k):
            tf2 = pa.TransferFunction(**{**style, "density_scale": style["density_scale"] * (1.0 + 0.05 * (k + 1))},
                                      albedo=0.9)
            r2 = pa.Renderer(grid, transfer_function=tf2, lights=[light])
            r2.cache.share(r.cache)  # the preintegrated table slices: the disk cache's role
            r2.render(camera=cam, **opts)

        t_tf = median_time(tf_change, args.repeats)
        from pv_ambient.stages.preintegration import get_table

        t0 = time.perf_counter()
        get_table(0.5, albedo_range=(0.0, 0.9), cache=False)
        t_table = time.perf_counter() - t0
        print(f"{n:>5} {t_vtk:>9.3f} {t_cam / t_vtk:>8.2f} {t_relight / t_vtk:>8.2f} {t_tf / t_vtk:>8.2f}"
              f" {t_table:>8.2f} {t_table / t_vtk:>8.1f}")


if __name__ == "__main__":
    main()
