"""The ``progressive`` model on the camera-move axis (docs/progressive.rst): its error after each
budget against every other model's, on the six scenes of the trade and of the diffusion floor.

For each scene (benchmarks/scenes.py: supernova, cloud, ct_phantom, smoke_plume, marschner_lobb,
cloud_sun) at 64×64 pixels and 64³ data points, against the cached ``path_traced`` reference of
benchmarks/noise_free.py (4096 spp or 1 % relative error, seed 99; traced when the cache is stale):

* the time unit: VTK's ``fixed_point`` emission–absorption frame of the same view, measured
  *interleaved* with the models: before each timed render, ``VTK_FRAMES`` VTK frames (the camera
  turned a little and back in turn; benchmarks/timing.py's peer), and the render's time is divided
  by their median; a model's time is the median of these ratios. The load of this shared
  machine drifts over seconds; one unit measured once per scene moved the ratios of the same
  render by up to 2.7× between runs. The printed VTK frame is the median of all of a scene's;
* every model's *camera-move* frames (the view-independent stages — light volumes, diffusion
  solves, bakes — cached, as after a camera move): the noise-free models (single scattering,
  ambient scattering, diffusion plain / flux-limited / with ``AUTO_SWEEP_ORDERS`` transport sweeps) once each, and
  each also as its *drag frame* in interactive mode (half the window per axis, twice the ray
  step with jittered ray starts, seed 0, shown on the full-size plane: upsampled linearly, as the
  texture is); ``path_traced`` (and
  ``path_traced+OIDN``) at 1, 2, 4, … ``--max-spp`` samples per pixel; ``progressive`` (its
  default base: diffusion with those sweeps and flux limiting) and ``progressive, diffusion
  base`` (plain diffusion) as a user sees them after a camera move: the drag frame, then the
  resting frames at 0, 1, 2, 4, … samples (the drag frame and the 0-sample resting frame are its
  base model's, measured once — the same renders, checked to give the same picture;
  as for the noise-free models, the drag frame and each resting frame are timed on their own —
  in interactive mode the drag frames are shown while the camera moves, and the resting frame
  starts when it stops);
  time: median of ``--repeats`` renders, error: the 4×4-block relative RMSE
  (:func:`pv_ambient.metrics.block_relative_rmse`) with a 7×7 window at each light's projection
  masked, one seed per sample count;
* per budget B (in VTK frames: 3, 5, 10, 20, 50, 100), each model's error at B: the error of its
  most expensive frame that takes at most B — the picture a user has after that time (a model with
  no frame within B has none); printed per scene with ``*`` on the lowest, and whether each
  ``progressive`` row is at or below every other model (the other ``progressive`` rows excluded;
  ``tie``: above, but equal at the table's three decimals — below the reference's own block noise;
  after ``tie`` and ``NO`` the margin above the lowest other model's error);
* the bias at ``--max-spp``: the relative error of the image mean against the reference's, with
  its standard error from the per-pixel standard errors, for ``path_traced`` and each
  ``progressive`` row — its default (thresholded) picture and its unbiased one
  (``unbiased=True``, same samples).

The path tracer's denoised curve (``denoise=True``) is measured when ``pyoidn`` is installed and
reported as absent otherwise.

Writes ``benchmarks/results/progressive.txt`` (the table; first line the command) and
``progressive.png`` (error against camera-move time per scene, the budgets shaded) unless
``--out`` names another directory. Usage::

    python benchmarks/progressive.py [--scenes NAME ...] [--max-spp 256] [--repeats 3] [--out DIR]
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import noise_free as nf  # noqa: E402  (benchmarks/: the script's directory is on sys.path)
import pv_ambient as pa
import references as refs
import scenes as scene_registry
from pv_ambient import metrics
from pv_ambient.rendering.presets import AUTO_SWEEP_ORDERS
from timing import VtkPeer

SCENES = scene_registry.GROUPS["trade"] + scene_registry.GROUPS["floor"]
BUDGETS = (3, 5, 10, 20, 50, 100)
#: The progressive rows and their base models' rows (whose drag frame is theirs: the same render).
SWEEPS = f"diffusion {AUTO_SWEEP_ORDERS} sweeps+FL"
PROGRESSIVE = {"progressive": SWEEPS, "progressive+OIDN": SWEEPS,
               "progressive, diffusion base": "diffusion"}
NOISE_FREE = (
    ("single_scattering", "single_scattering", {}),
    ("AS", "ambient_scattering", {}),
    ("diffusion", "diffusion", {}),
    ("diffusion FL", "diffusion", {"flux_limited": True}),
    (SWEEPS, "diffusion", {"flux_limited": True, "sweep_orders": AUTO_SWEEP_ORDERS}),
)


def have_oidn() -> bool:
    from pv_ambient.stages.denoise import available

    return available()


#: VTK frames rendered before each timed render: its time unit (their median).
VTK_FRAMES = 3


def timed(r, cam, size, g, model, opts, repeats, clock):
    """The camera-move frame of ``model``: the scored render at ``cam`` (it warms the view-independent
    caches), then renders from ``repeats`` cameras orbited by 1°, 2°, … (a camera move: nothing
    view-dependent is reused) are timed, each right after ``clock``'s VTK frames; returns the
    scored image and the median of their times in those VTK frames."""
    res = r.render(camera=cam, window_size=size, model=model, phase=g, progress_bar=False, **opts)
    ratios = []
    for k in range(repeats):
        c = scene_registry.orbit(cam, 1.0 + k)
        unit = clock.unit(cam, VTK_FRAMES)
        t = time.perf_counter()
        r.render(camera=c, window_size=size, model=model, phase=g, progress_bar=False, **opts)
        ratios.append((time.perf_counter() - t) / unit)
    return res, float(np.median(ratios))


def preview(r, cam, size, g, model, opts, repeats, clock):
    """The model's drag frame in interactive mode: half the window per axis (``add_ambient_volume``'s
    default ``interactive_resolution``) and twice the ray step (its drag step after one doubling:
    it starts at the resting step and doubles while frames are slower than the window's desired
    rate, up to ``interactive_step``), marched from jittered starts as the interactive mode does at
    a lengthened step (its default ``seed``, 0); shown on the full-size plane
    with linear texture interpolation — here the same upsampling by ``scipy.ndimage.zoom``. Returns
    the full-size image and the median time of the half-size render in VTK frames (the upsampling
    is the texture's, not counted)."""
    half = (max(1, size[0] // 2), max(1, size[1] // 2))
    o = dict(opts, step=2.0 * r.default_step(), jitter=True, seed=0)
    res, t = timed(r, cam, half, g, model, o, repeats, clock)
    return upsampled(res.radiance, size, half), t


def upsampled(img, size, half):
    """A ``half``-size picture shown on the ``size`` plane: linear interpolation, as the texture's."""
    from scipy import ndimage

    f = (size[1] / half[1], size[0] / half[0], 1)
    return ndimage.zoom(img.astype(np.float64), f, order=1, grid_mode=True, mode="nearest")


def spp_ladder(max_spp, start=1):
    out = [0] if start == 0 else []
    s = 1
    while s <= max_spp:
        out.append(s)
        s *= 2
    return out


def best_within(points, budget):
    """The error of the model's picture after ``budget``: that of its most expensive frame (most
    samples) within the budget — what a user sees once that much time has passed (None: no frame
    fits). The progressive model's later frames are not replaced by its earlier, lower-error ones."""
    within = [(t, e) for t, e in points if t <= budget]
    return max(within)[1] if within else None


def mean_bias(img, se, ref, mask):
    """Relative error of the image mean against the reference's, and its standard error (pixels independent)."""
    m = mask[..., None] & np.ones(3, bool)
    ref_mean = float(np.mean(ref[m]))
    bias = float(np.mean(img[m])) / ref_mean - 1.0
    err = float(np.sqrt(np.sum(se[m].astype(np.float64) ** 2)) / m.sum()) / ref_mean
    return bias, err


def run_scene(name, n, size, max_spp, repeats, log):
    grid, tf, lights, g, cam = scene_registry.scene(name, n)
    r = pa.Renderer(grid, transfer_function=tf, lights=lights)
    mask = metrics.light_mask(size[::-1], cam, size, lights)
    ref, info, how = refs.reference(name, r, lights, g, cam, mask, False, size)
    # VTK's frames of the scene's view, interleaved with the timed renders (six warm-up frames)
    clock = VtkPeer(grid, r, size, r.default_step(), camera=cam, warm_up=6)
    curves = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # unconverged solves etc.: benchmarks/noise_free.py prints them
        previews, bases = {}, {}
        for label, model, opts in NOISE_FREE:
            img, tp = previews[label] = preview(r, cam, size, g, model, opts, repeats, clock)
            res, t = timed(r, cam, size, g, model, opts, repeats, clock)
            bases[label] = res.radiance
            curves[label] = [(tp, metrics.block_relative_rmse(img, ref, mask)),
                             (t, metrics.block_relative_rmse(res.radiance, ref, mask))]
        pt_models = [("path_traced", "path_traced", {}, 1), ("progressive", "progressive", {}, 0),
                     ("progressive, diffusion base", "progressive", {"flux_limited": False, "sweep_orders": 0}, 0)]
        if have_oidn():
            pt_models.insert(1, ("path_traced+OIDN", "path_traced", {"denoise": True}, 1))
            pt_models.insert(3, ("progressive+OIDN", "progressive", {"denoise": True}, 0))
        final = {}
        for label, model, opts, start in pt_models:
            pts = []
            ladder = spp_ladder(max_spp, start)
            if model == "progressive":  # its drag frame and 0-sample resting frame are its base's (the same
                img, t0 = previews[PROGRESSIVE[label]]  # renders, measured once), then the resting frames
                pts.append((t0, metrics.block_relative_rmse(img, ref, mask)))
                res = r.render(camera=cam, window_size=size, model=model, phase=g, progress_bar=False,
                               **dict(opts, samples_per_pixel=0))
                if not np.array_equal(res.radiance, bases[PROGRESSIVE[label]]):
                    raise RuntimeError(f"{label} at 0 samples is not its base's picture")
                pts.append(curves[PROGRESSIVE[label]][1])
                ladder = ladder[1:]
            for spp in ladder:
                o = dict(opts, samples_per_pixel=spp, seed=1000 + spp)
                res, t = timed(r, cam, size, g, model, o, repeats, clock)
                pts.append((t, metrics.block_relative_rmse(res.radiance, ref, mask)))
                final[label] = res
            if model == "progressive" and not opts.get("denoise"):  # (the same samples as progressive's)
                res = r.render(camera=cam, window_size=size, model=model, phase=g, progress_bar=False,
                               samples_per_pixel=max_spp, seed=1000 + max_spp, unbiased=True, **opts)
                final[label + " (unbiased)"] = res
            curves[label] = pts
    unit = clock.median()
    clock.close()
    log(f"\n{name}: {scene_registry.DESCRIPTIONS[name]}")
    log(f"  reference ({how}): {info['spp']} spp, relative error {info['relative_error']:.4f}, block noise "
        f"{info['block_noise']:.4f}; VTK frame {unit * 1e3:.2f} ms (median of {len(clock.times)}, "
        f"{np.percentile(clock.times, 10) * 1e3:.2f}–{np.percentile(clock.times, 90) * 1e3:.2f} ms from the 10th "
        "to the 90th percentile)")
    for label in final:
        res = final[label]
        b, e = mean_bias(res.radiance, res.std_error, ref, mask)
        log(f"  {label} at {res.metadata['spp']} spp: bias of the mean {b:+.4f} ± {e:.4f} (1 s.e.)")
    log("  curves (time in VTK frames : block error):")
    for label, pts in curves.items():
        log(f"    {label:28s} " + "  ".join(f"{t:.3g}:{e:.3f}" for t, e in pts))
    log(f"  error at budget (VTK frames; * lowest; — none within the budget):")
    log(f"    {'model':28s} " + " ".join(f"{b:>8d}" for b in BUDGETS))
    table = {label: [best_within(pts, b) for b in BUDGETS] for label, pts in curves.items()}
    lows = [min((v[i] for v in table.values() if v[i] is not None), default=None) for i in range(len(BUDGETS))]
    for label, vals in table.items():
        cells = [("       —" if v is None else f"{v:7.3f}{'*' if v == lows[i] else ' '}") for i, v in enumerate(vals)]
        log(f"    {label:28s} " + " ".join(cells))
    ok, ok3 = {}, {}
    for row in PROGRESSIVE:
        if row not in table:
            continue
        ok[row], ok3[row], gaps = [], [], []
        for i, b in enumerate(BUDGETS):
            p = table[row][i]
            others = [v[i] for k, v in table.items() if not k.startswith("progressive") and v[i] is not None]
            ok[row].append(p is not None and all(p <= o for o in others))
            ok3[row].append(p is not None and all(round(p, 3) <= round(o, 3) for o in others))
            gaps.append(None if p is None or not others else p - min(others))
        log(f"    {row} at or below every other model: "
            + " ".join(f"{b}:{'yes' if o else ('tie' if t else 'NO')}" + ("" if o or gap is None else f"({gap:+.1e})")
                       for b, o, t, gap in zip(BUDGETS, ok[row], ok3[row], gaps)))
    return dict(name=name, curves=curves, ok=ok, ok3=ok3, unit=unit)


def plot(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 3, figsize=(13.5, 8.0), squeeze=False)
    for ax, row in zip(axes.flat, rows):
        for label, pts in row["curves"].items():
            x = [max(t, 1e-2) for t, _ in pts]
            y = [e for _, e in pts]
            style = "-o" if len(pts) > 1 else "s"
            ax.loglog(x, y, style, label=label, ms=4, lw=2.2 if label in ("progressive", "progressive+OIDN") else 1.0)
        ax.axvspan(BUDGETS[0], BUDGETS[-1], color="0.92", zorder=0)
        ax.set_title(f"{row['name']}")
        ax.set_xlabel("camera-move time / VTK EA frame")
        ax.set_ylabel("4×4-block relative RMSE")
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    refs.add_scene_options(ap, SCENES, "progressive")
    ap.add_argument("--max-spp", type=int, default=256)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    log = refs.results_log("progressive", args.out, argv)
    log(f"pv_ambient at {refs.commit()}; {refs.SIZE[0]}×{refs.SIZE[1]} pixels, {refs.N}³ data points, quality 'balanced'; "
        f"denoised path tracer: {'measured' if have_oidn() else 'not measured (pyoidn not installed)'}")
    nf.warm_up(args.scenes[0])
    rows = [run_scene(name, refs.N, refs.SIZE, args.max_spp, args.repeats, log) for name in args.scenes]
    for which in PROGRESSIVE:
        if which not in rows[0]["ok"]:
            continue
        log(f"\nsummary: {which} at or below every other model's error at each budget (VTK frames); in brackets,"
            " also counting a tie at the table's three decimals ('tie' above: equal when rounded)")
        for b_i, b in enumerate(BUDGETS):
            good = [row["name"] for row in rows if row["ok"][which][b_i]]
            ties = [row["name"] for row in rows if row["ok3"][which][b_i] and not row["ok"][which][b_i]]
            log(f"  {b:>4d}: {len(good)} of {len(rows)} scenes" + (f" ({', '.join(good)})" if good else "")
                + f" [{len(good) + len(ties)} of {len(rows)}" + (f"; ties: {', '.join(ties)}" if ties else "") + "]")
        every = [row["name"] for row in rows if all(row["ok"][which])]
        every3 = [row["name"] for row in rows if all(row["ok3"][which])]
        log(f"  scene by scene, at every budget: {len(every)} of {len(rows)}" + (f" ({', '.join(every)})" if every else "")
            + f" [{len(every3)} of {len(rows)}" + (f": {', '.join(every3)}" if every3 else "") + "]")
    plot(rows, log.path.with_suffix(".png"))


if __name__ == "__main__":
    main()
