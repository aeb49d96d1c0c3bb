"""Diffusion model cost against single scattering's, as ratios measured in one run (issue: "the
diffusion solve ≤ 5× the light-volume time of single_scattering and the camera-move frame ≤ 1.5×
single_scattering's").

Supernova shell (n³), one point light at the centre, window w², quality "balanced"; medians of
``--repeats`` after a warm-up (compilation excluded):

* light volume: single scattering's optical-depth sweep for one light (a relight of SS);
* diffusion solve: the first-collision source and the P1 (or flux-limited) solve of one light;
* camera-move frames of both models (every cache warm: only the ray cast runs).

Usage: ``python benchmarks/diffusion_cost.py [--n 128] [--window 512] [--repeats 3]``
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import datasets_synthetic as ds  # noqa: E402
import pv_ambient as pa  # noqa: E402
from pv_ambient.inputs.grid import Volume  # noqa: E402
from pv_ambient.inputs.phase import as_phase  # noqa: E402
from _timing import median_time  # noqa: E402


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--n", type=int, default=128)
    p.add_argument("--window", type=int, default=512)
    p.add_argument("--repeats", type=int, default=3)
    args = p.parse_args(argv)
    v = ds.load("supernova", n=args.n)
    st = ds.style("supernova")
    vol = Volume(v.values, spacing=v.spacing, origin=v.origin)
    tf = pa.TransferFunction(cmap=st["cmap"], clim=st["clim"], opacity=st["opacity"],
                             density_scale=st["density_scale"], albedo=0.9)
    cams = [pa.Camera((3 * np.cos(a), 3 * np.sin(a), 1.2), (0, 0, 0), (0, 0, 1), view_angle=30) for a in
            np.linspace(0.2, 1.5, 6)]
    size = (args.window, args.window)
    rows = []
    for flux in (False, True):
        r = pa.Renderer(vol, transfer_function=tf, lights=[pa.PointLight((0, 0, 0), 3.0)], backend="cpu")
        r.render(camera=cams[0], window_size=size, model="single_scattering")
        r.render(camera=cams[0], window_size=size, model="diffusion", flux_limited=flux)
        grid = r.light_grid()

        def light_volume(k):
            r.optical_depth(pa.PointLight((0.01 * (k + 1), 0, 0), 3.0), grid)

        def solve(k):
            r.diffusion([pa.PointLight((0.01 * (k + 1), 0, 0), 3.0)], grid, as_phase(None), flux_limited=flux)
        t_lv = median_time(light_volume, args.repeats)
        t_solve = median_time(solve, args.repeats)
        t_ss = median_time(lambda k: r.render(camera=cams[k % 6], window_size=size, model="single_scattering"),
                   args.repeats)
        t_df = median_time(lambda k: r.render(camera=cams[k % 6], window_size=size, model="diffusion", flux_limited=flux),
                   args.repeats)
        rows.append((("flux-limited" if flux else "plain"), t_lv, t_solve, t_ss, t_df))
    print(f"supernova {args.n}³, {args.window}², one point light, balanced; medians of {args.repeats}")
    print(f"{'diffusion':14s} {'solve / SS light volume':>24s} {'camera move / SS':>18s}")
    for name, t_lv, t_solve, t_ss, t_df in rows:
        print(f"{name:14s} {t_solve / t_lv:24.2f} {t_df / t_ss:18.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
