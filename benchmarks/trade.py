"""The speed–accuracy trade (docs/trade.rst): every model and preset against a converged path-traced
reference, timed against VTK's emission–absorption render measured in the same run.

For each synthetic scene (supernova shell lit from its centre, a forward-scattering cloud under a
point light, a CT-like phantom with two coloured point lights):

* a ``path_traced`` reference to ``--ref-error`` relative standard error (its 4×4-block noise is
  printed: it must stay well below the errors it measures);
* VTK ``fixed_point`` EA of the same TF and camera: the time unit;
* ``single_scattering`` at each quality preset, ``ambient_scattering`` for both propagation modes
  and several radii, ``diffusion`` plain, flux-limited and with ``AUTO_SWEEP_ORDERS`` (8) transport sweeps + flux
  limiting, ``progressive`` at 0, 16 and 64 samples, ``path_traced`` at 1, 2, 4, … spp (and with
  the denoiser when ``pyoidn`` is installed): first-frame time (all caches
  cold but Numba compiled, the frame scored) and camera-move time (view-independent caches warm,
  cameras orbited by 1°, 2°, …: ``progressive`` keeps its base picture per view), median of ``--repeats``, as ratios
  to the VTK frame; 4×4-block and per-pixel relative RMSE, relative bias of the mean, SSIM, each
  against the reference with a small window around each light's projection masked;
* the time the path tracer needs for the same block error (interpolated on its own curve);
* for the Monte Carlo rows (``path_traced`` up to 64 spp, with and without the denoiser), the
  *bias* proper — the relative error of the image mean averaged over ``--bias-seeds`` seeds, with
  its standard error — and the share of single frames whose mean is within 3 % of the
  reference's. A single frame's mean error (the ``bias`` column) is Monte Carlo scatter plus bias;
  for the deterministic models it is the bias.

Writes ``trade.csv`` and ``trade.png`` (error vs time, one curve per model: the Pareto front) to
``--out``. Usage: ``python benchmarks/trade.py [--size 96] [--n 64] [--ref-error 0.01]``.
"""

from __future__ import annotations

import argparse
import csv
import os
import time
from pathlib import Path

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np  # noqa: E402

import pv_ambient as pa  # noqa: E402
from pv_ambient import metrics  # noqa: E402
from pv_ambient.rendering.presets import AUTO_SWEEP_ORDERS  # noqa: E402

import references as refs  # noqa: E402  (benchmarks/: the script's directory is on sys.path)
import scenes as scene_registry  # noqa: E402
from timing import VtkPeer  # noqa: E402

REF_SEED = 12345  # the references' seed (baked.py traces the same references)


def scenes(n):
    """(name, grid, transfer function, lights, phase, camera) of the trade's scenes (benchmarks/scenes.py;
    the name benchmarks/identity.py imports)."""
    return scene_registry.of_group("trade", n)


def vtk_time(grid, r, cam, size, step, repeats):
    """The time unit: the median of ``repeats`` VTK frames of the scene's view after a warm-up frame
    (benchmarks/timing.py's peer)."""
    with VtkPeer(grid, r, size, step, camera=cam) as vtk:
        return vtk.unit(cam, repeats)


def configurations(quick):
    cfg = [("single_scattering", q, {"quality": q}) for q in ("preview", "balanced", "accurate")]
    cfg += [("ambient_scattering", q, {"quality": q}) for q in ("preview", "accurate")]  # defaults: BL, r = 8 vx
    cfg += [("diffusion", "plain", {"quality": "balanced"}),
            ("diffusion", "flux-limited", {"quality": "balanced", "flux_limited": True}),
            ("diffusion", f"{AUTO_SWEEP_ORDERS} sweeps + FL",
             {"quality": "balanced", "flux_limited": True, "sweep_orders": AUTO_SWEEP_ORDERS})]
    # the progressive model (its default base: diffusion with the sweeps + FL): the first frame and after samples
    cfg += [("progressive", f"{spp} spp", {"quality": "balanced", "samples_per_pixel": spp, "seed": 7})
            for spp in ((0, 64) if quick else (0, 16, 64))]
    radii = (2, 4, 8) if not quick else (8,)
    for prop in ("beer_lambert", "tube"):
        for rv in radii:
            cfg.append(("ambient_scattering", f"{prop} r={rv}", {"quality": "balanced", "propagation": prop,
                                                               "radius": f"{rv} voxels"}))
    return cfg


def reference_options(ap):
    """The trade's image size, volume size and reference settings as options of ``ap`` (baked.py
    scores against the same references)."""
    ap.add_argument("--size", type=int, default=96)
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--ref-error", type=float, default=0.01)
    ap.add_argument("--ref-max-spp", type=int, default=8192)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    reference_options(ap)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--scenes", nargs="+", default=None)
    ap.add_argument("--quick", action="store_true", help="fewer configurations")
    ap.add_argument("--bias-seeds", type=int, default=16,
                    help="seeds over which the Monte Carlo rows' bias is averaged (0: skip)")
    ap.add_argument("--out", default="benchmark_output")
    args = ap.parse_args(argv)
    outdir = Path(args.out)
    outdir.mkdir(parents=True, exist_ok=True)
    size = (args.size, args.size)
    rows = []
    for name, grid, tf, lights, g, cam in scenes(args.n):
        if args.scenes and name not in args.scenes:
            continue
        r = pa.Renderer(grid, transfer_function=tf, lights=lights)
        step = r.default_step()
        t_vtk = vtk_time(grid, r, cam, size, step, args.repeats)
        ref, mask, ref_block_noise, t_ref = refs.trace(r, cam, size, g, lights, seed=REF_SEED,
                                                       spp=args.ref_max_spp, target_error=args.ref_error)
        print(f"\n{name}: reference {ref.metadata['spp']} spp in {t_ref:.1f} s, block noise {ref_block_noise:.4f};"
              f" VTK fixed_point EA frame {t_vtk * 1e3:.1f} ms")
        print(f"  {'model':20s} {'preset':18s} {'first/VTK':>9} {'move/VTK':>9} {'blockRMSE':>9} {'pixRMSE':>8}"
              f" {'bias':>7} {'SSIM':>6} {'PT same err/VTK':>15}")

        def score(img):
            return (metrics.block_relative_rmse(img, ref.radiance, mask), metrics.relative_rmse(img, ref.radiance, mask),
                    metrics.relative_bias(img, ref.radiance, mask), metrics.ssim(img, ref.radiance))

        nan3 = dict(bias_seeds=float("nan"), bias_se=float("nan"), within_3pct=float("nan"))

        def seed_bias(spp, **kw):
            """Mean and standard error of the image-mean error over seeds, share within 3 %."""
            if args.bias_seeds <= 0 or spp > 64:
                return nan3
            b = np.array([metrics.relative_bias(r.render(camera=cam, window_size=size, model="path_traced", phase=g,
                                                         seed=1000 + k, samples_per_pixel=spp, **kw).radiance,
                                                ref.radiance, mask) for k in range(args.bias_seeds)])
            return dict(bias_seeds=float(b.mean()), bias_se=float(b.std(ddof=1) / np.sqrt(b.size)),
                        within_3pct=float(np.mean(np.abs(b) <= 0.03)))

        def pt_row(spp, **kw):
            """The path tracer at ``spp`` (each repeat its own seed): its row, and its (time, block error)."""
            times = []
            for k in range(args.repeats):
                t = time.perf_counter()
                res = r.render(camera=cam, window_size=size, model="path_traced", phase=g, seed=k + 1,
                               samples_per_pixel=spp, **kw)
                times.append(time.perf_counter() - t)
            tm = float(np.median(times))
            sc = score(res.radiance)
            rows.append(dict(scene=name, model="path_traced+denoise" if kw else "path_traced", preset=f"{spp} spp",
                             first=tm / t_vtk, move=tm / t_vtk, block_rmse=sc[0], pixel_rmse=sc[1], bias=sc[2],
                             ssim=sc[3], pt_same=float("nan") if kw else tm / t_vtk, **seed_bias(spp, **kw)))
            return tm, sc[0]

        # path tracer curve (no denoiser), 1, 2, 4, … 256 spp
        pt = [pt_row(2 ** i) for i in range(9)]

        from pv_ambient.stages.denoise import available

        if available():  # path tracing + OIDN (the optional extra "denoise")
            for spp in (1, 2, 4, 16, 64):
                pt_row(spp, denoise=True)
        else:
            print("  (pyoidn not installed: no denoised path-tracing curve; pip install 'pv_ambient[denoise]')")

        def pt_time_for(err):
            ts, es = np.array([p[0] for p in pt]), np.array([p[1] for p in pt])
            if err >= es[0]:
                return ts[0] * es[0] ** 2 / err ** 2 if err > 0 else np.inf  # error ∝ 1/sqrt(time)
            if err < es[-1]:
                return ts[-1] * (es[-1] / err) ** 2
            k = np.nonzero(es <= err)[0][0]
            return float(np.exp(np.interp(np.log(err), np.log(es[[k, k - 1]]), np.log(ts[[k, k - 1]]))))

        for model, preset, opts in configurations(args.quick):
            r2 = pa.Renderer(grid, transfer_function=tf, lights=lights)
            r2.cache.share(r.cache)  # the table slices: the disk cache's role
            t = time.perf_counter()
            res = r2.render(camera=cam, window_size=size, model=model, phase=g, **opts)
            t_first = time.perf_counter() - t
            times = []
            for k in range(args.repeats):  # camera moves: cameras orbited by 1°, 2°, … (nothing per view reused)
                c = scene_registry.orbit(cam, 1.0 + k)
                t = time.perf_counter()
                r2.render(camera=c, window_size=size, model=model, phase=g, **opts)
                times.append(time.perf_counter() - t)
            r.cache.share(r2.cache)
            t_move = float(np.median(times))
            sc = score(res.radiance)
            t_pt = pt_time_for(sc[0])
            rows.append(dict(scene=name, model=model, preset=preset, first=t_first / t_vtk, move=t_move / t_vtk,
                             block_rmse=sc[0], pixel_rmse=sc[1], bias=sc[2], ssim=sc[3], pt_same=t_pt / t_vtk,
                             **nan3))
            print(f"  {model:20s} {preset:18s} {t_first / t_vtk:>9.2f} {t_move / t_vtk:>9.2f} {sc[0]:>9.3f}"
                  f" {sc[1]:>8.3f} {sc[2]:>+7.3f} {sc[3]:>6.3f} {t_pt / t_vtk:>15.2f}")
        if args.bias_seeds > 0:
            print(f"  (Monte Carlo rows, last columns: bias over {args.bias_seeds} seeds ± standard error; share of"
                  " frames whose mean is within 3 %)")
        for row in rows:
            if row["scene"] == name and row["model"].startswith("path_traced"):
                extra = (f" {'':>15} {row['bias_seeds']:>+7.3f} ±{row['bias_se']:.3f} {row['within_3pct']:>5.0%}"
                         if np.isfinite(row["bias_seeds"]) else "")
                print(f"  {row['model']:20s} {row['preset']:18s} {row['first']:>9.2f} {row['move']:>9.2f}"
                      f" {row['block_rmse']:>9.3f} {row['pixel_rmse']:>8.3f} {row['bias']:>+7.3f} {row['ssim']:>6.3f}"
                      + extra)
    with open(outdir / "trade.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    plot(rows, outdir / "trade.png")
    print(f"\nwrote {outdir / 'trade.csv'} and {outdir / 'trade.png'}")


def plot(rows, path):
    """Error against time, one panel per scene and time axis (docs/trade.rst): the first frame (every
    cache cold) on the top row, a camera move (caches warm) on the bottom row."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = sorted({r["scene"] for r in rows}, key=[r["scene"] for r in rows].index)
    fig, axes = plt.subplots(2, len(names), figsize=(4.2 * len(names), 7.0), squeeze=False)
    for row_axes, key, what in ((axes[0], "first", "first frame"), (axes[1], "move", "camera-move frame")):
        for ax, name in zip(row_axes, names):
            sub = [r for r in rows if r["scene"] == name]
            groups = {}
            for r in sub:
                label = r["model"] if r["model"] != "ambient_scattering" else "AS " + r["preset"].split()[0]
                if label in ("AS preview", "AS accurate"):
                    label = "AS presets"
                if r["model"] == "diffusion":
                    label = "diffusion " + r["preset"]
                groups.setdefault(label, []).append(r)
            for label, rs in groups.items():
                x = [float(r[key]) for r in rs]
                y = [float(r["block_rmse"]) for r in rs]
                style = "-o" if label.startswith("path_traced") else "o"
                ax.loglog(x, y, style, label=label, ms=4)
            ax.set_title(f"{name}: {what}")
            ax.set_xlabel(f"{what} time / VTK EA frame")
            ax.set_ylabel("4×4-block relative RMSE")
            ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def plot_csv(csv_path, path):
    """Redraw the plot from a ``trade.csv`` (no rendering)."""
    with open(csv_path, newline="") as f:
        plot(list(csv.DictReader(f)), path)


if __name__ == "__main__":
    main()
