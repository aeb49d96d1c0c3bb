"""Ambient scattering: cost of each kind of frame, as ratios to VTK's emission–absorption render.

For each volume size (benchmarks/speed.py's scene, ``supernova_centre`` of benchmarks/scenes.py:
the supernova under one point light at its centre; 512² by default) one run measures speed.py's
ambient-scattering rows with the chosen ``--propagation``, each interleaved frame by frame with VTK's
``fixed_point`` EA frame of the same TF, camera and step (benchmarks/timing.py's peer):

* a camera-move AS frame (every cache warm: only the ray cast runs);
* a relight (the light moves: its transmittance volume — and its front volume in tube mode — is
  recomputed, then the ray cast);
* a TF change (new classification, mean extinction, light volumes, ray cast; the table slice of the
  new albedo range is reused when cached);
* a table slice (``get_table`` for a new g, cache disabled), in seconds and as a ratio to the
  median of all the run's VTK frames at that size.

Each figure is the median of ``--repeats`` after a warm-up pair (Numba compilation excluded),
printed as a ratio to the VTK frames interleaved with it. (benchmarks/results/ambient.txt was
measured before issue 40: the default iso camera, VTK timed once per size.)

Usage: ``python benchmarks/ambient.py [--sizes 128 256] [--window 512] [--repeats 3]``
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
sys.path.insert(0, str(Path(__file__).resolve().parent))

import speed  # noqa: E402  (benchmarks/speed.py: its rows)
from pv_ambient.stages.preintegration import get_table  # noqa: E402
from timing import VtkPeer  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[128, 256])
    ap.add_argument("--window", type=int, default=512)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--propagation", default="beer_lambert", choices=("beer_lambert", "tube"))
    args = ap.parse_args(argv)
    size = (args.window, args.window)
    print(f"ambient scattering, {speed.SCENE}, {size[0]}x{size[1]}, point light at the centre, "
          f"propagation={args.propagation}; median of {args.repeats} after a warm-up pair; ratios to VTK "
          "fixed_point EA frames interleaved with each row")
    print(f"{'n':>5} {'VTK EA s':>9} {'camera':>8} {'relight':>8} {'TF chg':>8} {'table s':>8} {'table':>8}")
    for n in args.sizes:
        frames = speed.make_frames(n, size, {"propagation": args.propagation})
        with VtkPeer(frames.grid, frames.renderer, size, frames.step) as vtk:
            rows = speed.measure_rows(frames, vtk, args.repeats, kinds=("camera", "relight", "tf"), models=("AS",),
                                      count=False)
            t_vtk = vtk.median()
        ratio = {d["kind"]: d["ours"] / d["vtk"] for d in rows}
        t0 = time.perf_counter()
        get_table(0.5, albedo_range=(0.0, 0.9), cache=False)
        t_table = time.perf_counter() - t0
        print(f"{n:>5} {t_vtk:>9.3f} {ratio['camera']:>8.2f} {ratio['relight']:>8.2f} {ratio['tf']:>8.2f}"
              f" {t_table:>8.2f} {t_table / t_vtk:>8.1f}")


if __name__ == "__main__":
    main()
