"""Emission–absorption: pv_ambient's Numba ray marcher against VTK's volume mappers.

For each volume size, one run renders the same scene (``--scene`` of benchmarks/scenes.py,
``supernova_centre`` by default: its dataset, transfer function and camera), sample distance and
image size with VTK's ``fixed_point`` and ``gpu`` mappers (linear interpolation, explicit sample
distance, off-screen, image read back inside the clock: benchmarks/timing.py's peer) and with
``pv_ambient`` (a camera-move frame: caches warm). For each mapper, VTK's frames and ours are
interleaved, the camera turned by one degree per frame, after one warm-up pair; each timing is the
median of ``--repeats``. Printed as ratios (ours / VTK) measured in this run; absolute times are
printed for context only. Also prints the image agreement at the last camera (uint8, mean and p99 of
the absolute difference).

Usage: ``python benchmarks/ea_vs_vtk.py [--sizes 128 256] [--window 512] [--repeats 5]``
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402

import pv_ambient as pa  # noqa: E402
import scenes  # noqa: E402  (benchmarks/scenes.py)
from timing import VtkPeer, interleaved  # noqa: E402

MAPPERS = ("fixed_point", "gpu")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[128, 256])
    ap.add_argument("--window", type=int, default=512)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--scene", default="supernova_centre", choices=[s for s in scenes.SCENES if s != "supernova_table"])
    args = ap.parse_args(argv)
    size = (args.window, args.window)
    print(f"EA frame at {size[0]}x{size[1]}, scene {args.scene}, median of {args.repeats} after a warm-up pair, "
          "interleaved with each mapper's frames")
    print(f"{'n':>5} {'ours/fixed_point':>17} {'ours/gpu':>9} {'ours s':>8} {'fixed s':>8} {'gpu s':>8}"
          f" {'|d| mean fp':>11} {'p99 fp':>7} {'|d| mean gpu':>12} {'p99 gpu':>8}")
    for n in args.sizes:
        grid, tf, _, _, cam = scenes.scene(args.scene, n)
        r = pa.Renderer(grid, transfer_function=tf)
        step = r.default_step()

        def ours(k):
            r.render(camera=scenes.orbit(cam, k), window_size=size, step=step)

        ratios, ours_s, vtk_s, diffs = [], [], [], []
        for mapper in MAPPERS:
            with VtkPeer(grid, r, size, step, mapper=mapper, read_back=True) as vtk:
                t_ours, t_vtk = interleaved(vtk, ours, lambda k: scenes.orbit(cam, k), args.repeats)
                img = vtk.image  # the last frame's: the camera turned by --repeats degrees
            mine = r.render(camera=scenes.orbit(cam, args.repeats), window_size=size, step=step).to_uint8()
            d = np.abs(mine.astype(int) - img.astype(int))
            ratios.append(t_ours / t_vtk)
            ours_s.append(t_ours)
            vtk_s.append(t_vtk)
            diffs += [d.mean(), np.percentile(d, 99)]
        print(f"{n:>5} {ratios[0]:>17.2f} {ratios[1]:>9.2f} {np.median(ours_s):>8.3f} {vtk_s[0]:>8.3f} {vtk_s[1]:>8.3f}"
              f" {diffs[0]:>11.3f} {diffs[1]:>7.1f} {diffs[2]:>12.3f} {diffs[3]:>8.1f}")


if __name__ == "__main__":
    main()
