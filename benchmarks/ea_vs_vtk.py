"""Emission–absorption: pv_ambient's Numba ray marcher against VTK's volume mappers.

For each volume size, one run renders the same dataset, transfer function, camera and sample
distance with VTK's ``fixed_point`` and ``gpu`` mappers (linear interpolation, explicit sample
distance, off-screen, image read back) and with ``pv_ambient`` (a camera-move frame: caches warm).
Each timing is the median of ``--repeats`` frames after one warm-up frame, each frame with the
camera rotated by one degree. Printed as ratios (ours / VTK) measured in this run; absolute
times are printed for context only. Also prints the image agreement (uint8, mean and p99 of
the absolute difference).

Usage: ``python benchmarks/ea_vs_vtk.py [--sizes 128 256] [--window 512] [--repeats 5]``
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


def vtk_frames(grid, renderer, cam, size, step, mapper, repeats):
    pl = pv.Plotter(off_screen=True, window_size=size)
    pl.set_background("black")
    add_vtk_volume(pl, grid, renderer, step=step, mapper=mapper)
    times, img = [], None
    for k in range(repeats + 1):
        c = cam.to_vtk(pl.camera)
        c.Azimuth(float(k))
        pl.renderer.ResetCameraClippingRange()
        t = time.perf_counter()
        pl.render()
        img = pl.screenshot()
        if k:
            times.append(time.perf_counter() - t)
    first = pa.Camera.from_vtk(pl.camera)
    pl.close()
    return float(np.median(times)), img[..., :3], first


def our_frames(renderer, cam, size, step, repeats):
    times, res = [], None
    for k in range(repeats + 1):
        c = cam.to_vtk()
        c.Azimuth(float(k))
        t = time.perf_counter()
        res = renderer.render(camera=pa.Camera.from_vtk(c), window_size=size, step=step)
        if k:
            times.append(time.perf_counter() - t)
    return float(np.median(times)), res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[128, 256])
    ap.add_argument("--window", type=int, default=512)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--dataset", default="supernova")
    args = ap.parse_args(argv)
    size = (args.window, args.window)
    print(f"EA frame at {size[0]}x{size[1]}, dataset {args.dataset}, median of {args.repeats} after warm-up")
    print(f"{'n':>5} {'ours/fixed_point':>17} {'ours/gpu':>9} {'ours s':>8} {'fixed s':>8} {'gpu s':>8}"
          f" {'|d| mean fp':>11} {'p99 fp':>7} {'|d| mean gpu':>12} {'p99 gpu':>8}")
    for n in args.sizes:
        grid = getattr(datasets, args.dataset)(n=n)
        style = datasets.suggested_style(args.dataset)
        tf = pa.TransferFunction(cmap=style["cmap"], clim=style["clim"], opacity=style["opacity"],
                                 density_scale=style["density_scale"])
        r = pa.Renderer(grid, transfer_function=tf)
        cam = default_camera(grid.bounds)
        step = r.default_step()
        t_ours, res = our_frames(r, cam, size, step, args.repeats)
        row = [t_ours]
        diffs = []
        for mapper in ("fixed_point", "gpu"):
            t_vtk, img, last_cam = vtk_frames(grid, r, cam, size, step, mapper, args.repeats)
            ours = r.render(camera=last_cam, window_size=size, step=step).to_uint8().astype(int)
            d = np.abs(ours - img.astype(int))
            diffs += [d.mean(), np.percentile(d, 99)]
            row.append(t_vtk)
        print(f"{n:>5} {row[0] / row[1]:>17.2f} {row[0] / row[2]:>9.2f} {row[0]:>8.3f} {row[1]:>8.3f} {row[2]:>8.3f}"
              f" {diffs[0]:>11.3f} {diffs[1]:>7.1f} {diffs[2]:>12.3f} {diffs[3]:>8.1f}")


if __name__ == "__main__":
    main()
