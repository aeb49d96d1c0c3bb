"""The noise-free models against the path-traced reference on nine scenes: the measurement base of
issue 19 (its item 2, the noise-free model's acceptance, is judged on this table).

Scenes (benchmarks/scenes.py; their one-line descriptions are printed with each):

* ``trade`` — supernova, cloud, ct_phantom: the speed–accuracy trade's scenes, on which the
  models' defaults were chosen;
* ``floor`` — smoke_plume, marschner_lobb, cloud_sun: the diffusion floor's out-of-sample scenes;
* ``new`` — haze_backlit (thin, strongly forward-scattering haze lit from behind), dense_side
  (a dense, high-albedo object lit from the side), ct_coloured (the CT phantom under four
  coloured lights): out-of-sample scenes that nothing is chosen on. They were fixed before any
  model was evaluated on them, and are reported untouched: neither they nor a model may be
  changed after seeing their numbers here. Only their references were looked at (exposure).

For each scene, at 64×64 pixels and 64³ data points:

* the ``path_traced`` reference: 4096 samples per pixel or 1 % relative standard error, whichever
  comes first (seed 99; benchmarks/references.py). Printed: its samples per pixel, time, relative
  error reached, 4×4-block noise (its standard error over 4×4 blocks, relative to the image
  mean: it must stay well below the errors it measures), image mean and the share of the
  light held by the brightest 1 % of the pixels (a well-exposed reference is not dominated by a
  few pixels). References are cached (:func:`references.reference`); a key that does not match
  (or ``--recompute-refs``) traces it again.
* every noise-free model at its defaults (``quality="balanced"``): ``single_scattering``,
  ``ambient_scattering`` with ``propagation="beer_lambert"`` (its default) and ``"tube"``,
  ``diffusion`` plain, flux-limited and with 4, 6, 8 and 12 transport sweeps + flux limiting
  (``AUTO_SWEEP_ORDERS`` of them, marked ``*``: ``auto``'s choice at ``quality="accurate"`` and the
  ``progressive`` model's default base — the count with the lowest worst block error over the six
  old scenes), and ``model="auto"`` at each quality preset (what it chose in brackets).

Columns of a scene's table:

``block``
    4×4-block relative RMSE against the reference (:func:`pv_ambient.metrics.block_relative_rmse`);
``bias``
    relative bias of the image mean (:func:`pv_ambient.metrics.relative_bias`); both with a 7×7
    window around each point light's projection masked (:func:`pv_ambient.metrics.light_mask`;
    the new scenes' lights all project outside the image);
``first s``
    the first frame's time in seconds, every cache of the scene cold (Numba compiled and loaded:
    every model renders a tiny scene first);
``move ms``, ``move/SS``
    a camera move: the median time of 3 frames from cameras orbited by 1°, 2° and 3° about the
    focal point (caches warm), and its ratio to ``single_scattering``'s on the same scene.

A warning a model's frames raised (e.g. a diffusion solve that did not converge) is printed under
its row.

The summary table gives, per model, the worst block error over the six old scenes (``trade`` and
``floor``) and over the three new ones, the range of biases over each, and the median camera-move
ratio to single scattering over the scenes run.

Usage::

    python benchmarks/noise_free.py [--scenes NAME ...] [--recompute-refs] [--refs-only] [--out PATH]

With all nine scenes the output goes to ``benchmarks/results/noise_free.txt`` (first line: the
command), with ``--scenes`` only to ``--out`` when given.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from pathlib import Path

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np  # noqa: E402

import pv_ambient as pa  # noqa: E402
from pv_ambient import metrics  # noqa: E402
from pv_ambient.rendering.presets import AUTO_SWEEP_ORDERS  # noqa: E402

import references as refs  # noqa: E402  (benchmarks/: the script's directory is on sys.path)
import scenes as scene_registry  # noqa: E402
from references import N, RESULTS, REF_ERROR, REF_SEED, REF_SPP, ROOT, SIZE  # noqa: E402

MOVES_DEG = (1.0, 2.0, 3.0)

#: (label, model, options): every noise-free model at its defaults.
#: The transport sweep counts measured (``AUTO_SWEEP_ORDERS`` among them).
SWEEP_COUNTS = (4, 6, 8, 12)
MODELS = (
    ("single_scattering", "single_scattering", {}),
    ("AS beer_lambert", "ambient_scattering", {"propagation": "beer_lambert"}),
    ("AS tube", "ambient_scattering", {"propagation": "tube"}),
    ("diffusion", "diffusion", {}),
    ("diffusion FL", "diffusion", {"flux_limited": True}),
    *((f"diffusion {k} sweeps+FL" + ("*" if k == AUTO_SWEEP_ORDERS else ""), "diffusion",
       {"flux_limited": True, "sweep_orders": k}) for k in SWEEP_COUNTS),
    ("auto preview", "auto", {"quality": "preview"}),
    ("auto", "auto", {}),
    ("auto accurate", "auto", {"quality": "accurate"}),
)


def chosen(meta):
    """What ``auto`` rendered, from its metadata: the model, and diffusion's sweeps and flux limiting."""
    if meta["model"] != "diffusion":
        return meta["model"]
    k, fl = meta.get("sweep_orders", 0), meta.get("flux_limited", False)
    return "diffusion" + (f" {k} sweeps" if k else "") + ("+FL" if fl else "")


def exposure(ref, mask):
    """Image mean, and the share of the summed radiance held by the brightest 1 % of the pixels."""
    lum = ref.mean(axis=-1)[mask]
    top = np.sort(lum)[::-1][: max(1, lum.size // 100)]
    return float(lum.mean()), float(top.sum() / max(lum.sum(), 1e-300))


def run_model(grid, tf, lights, g, cam, model, opts, share_from, size=SIZE):
    """Score frame at ``cam`` (first frame, caches cold) and the median time of the orbit frames."""
    r = pa.Renderer(grid, transfer_function=tf, lights=lights)
    r.cache.share(share_from.cache)  # the preintegrated table slices (the disk cache's role)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        t = time.perf_counter()
        res = r.render(camera=cam, window_size=size, model=model, phase=g, progress_bar=False, **opts)
        first = time.perf_counter() - t
        times = []
        for deg in MOVES_DEG:
            c = scene_registry.orbit(cam, deg)
            t = time.perf_counter()
            r.render(camera=c, window_size=size, model=model, phase=g, progress_bar=False, **opts)
            times.append(time.perf_counter() - t)
    share_from.cache.share(r.cache)
    return res, first, float(np.median(times)), list(dict.fromkeys(str(w.message) for w in caught))


def warm_up(name):
    """Every model once on a tiny version of scene ``name``: the first scene's "first s" times then
    hold no loading of compiled kernels."""
    grid, tf, lights, g, cam = scene_registry.scene(name, 8)
    r = pa.Renderer(grid, transfer_function=tf, lights=lights)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r.render(camera=cam, window_size=(8, 8), model="path_traced", phase=g, samples_per_pixel=2)
        for _, model, opts in MODELS:
            r.render(camera=cam, window_size=(8, 8), model=model, phase=g, progress_bar=False, **opts)


def fmt_range(values):
    v = np.asarray(values, float)
    if v.size == 0:
        return "—"
    if np.any(~np.isfinite(v)):
        return "NaN"
    return f"{v.min():+.3f}…{v.max():+.3f}"


def fmt_max(values):
    v = np.asarray(values, float)
    if v.size == 0:
        return "—"
    return "NaN" if np.any(~np.isfinite(v)) else f"{v.max():.3f}"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="+", default=None, choices=list(scene_registry.REFERENCED),
                    help="scenes to run (default: all nine)")
    ap.add_argument("--recompute-refs", action="store_true", help="trace every reference again")
    ap.add_argument("--refs-only", action="store_true",
                    help="only the references and their figures (exposure), no model: how a new scene's "
                         "reference is checked before any model is evaluated on it")
    ap.add_argument("--out", default=None, help="results file (default: benchmarks/results/noise_free.txt when "
                                                "all nine scenes run at the default sizes, none otherwise)")
    ap.add_argument("--n", type=int, default=N, help=argparse.SUPPRESS)  # quick checks of the script only:
    ap.add_argument("--size", type=int, default=SIZE[0], help=argparse.SUPPRESS)  # a non-default --n, --size
    ap.add_argument("--ref-spp", type=int, default=REF_SPP, help=argparse.SUPPRESS)  # or --ref-spp caches nothing
    args = ap.parse_args(argv)
    size = (args.size, args.size)
    default = args.n == N and size == SIZE and args.ref_spp == REF_SPP
    names = list(scene_registry.REFERENCED) if args.scenes is None else list(dict.fromkeys(args.scenes))
    out = Path(args.out) if args.out else (RESULTS / "noise_free.txt" if args.scenes is None and default
                                           and not args.refs_only else None)
    shown = " ".join(sys.argv[1:] if argv is None else argv)
    log = refs.Log(out, f"python benchmarks/noise_free.py {shown}".rstrip())
    log(f"pv_ambient at {refs.commit()}; {size[0]}×{size[1]} pixels, {args.n}³ data points; reference "
        f"{args.ref_spp} spp or {REF_ERROR:.0%} relative error (seed {REF_SEED}); models at quality 'balanced' unless labelled")
    warm_up(names[0])
    rows = []
    for name in names:
        grid, tf, lights, g, cam = scene_registry.scene(name, args.n)
        r = pa.Renderer(grid, transfer_function=tf, lights=lights)
        mask = metrics.light_mask(size[::-1], cam, size, lights)
        ref, info, how = refs.reference(name, r, lights, g, cam, mask, args.recompute_refs, size, args.ref_spp, default)
        mean, top = exposure(ref, mask)
        log(f"\n{name} [{scene_registry.group_of(name)}]: {scene_registry.DESCRIPTIONS[name]}")
        log(f"  reference ({how}): {info['spp']} spp in {info['time']:.1f} s (at {info['commit']}), relative error "
            f"{info['relative_error']:.4f}, block noise {info['block_noise']:.4f}; mean {mean:.4g}, brightest 1 % of "
            f"pixels hold {top:.1%}; {int((~mask).sum())} pixels masked")
        if args.refs_only:
            continue
        log(f"  {'model':26s} {'block':>7} {'bias':>7} {'first s':>8} {'move ms':>8} {'move/SS':>8}")
        t_ss = None
        for label, model, opts in MODELS:
            res, first, move, warned = run_model(grid, tf, lights, g, cam, model, opts, r, size)
            img = res.radiance
            finite = bool(np.all(np.isfinite(img)))
            block = metrics.block_relative_rmse(img, ref, mask) if finite else float("nan")
            bias = metrics.relative_bias(img, ref, mask) if finite else float("nan")
            if model == "single_scattering":
                t_ss = move
            shown_label = f"{label} (→{chosen(res.metadata)})" if model == "auto" else label
            rows.append(dict(scene=name, group=scene_registry.group_of(name), model=label, block=block, bias=bias,
                             first=first, move=move, ratio=move / t_ss))
            log(f"  {shown_label:26s} {block:>7.3f} {bias:>+7.3f} {first:>8.2f} {move * 1e3:>8.1f} {move / t_ss:>8.2f}"
                + ("" if finite else "   (non-finite pixels)"))
            for w in warned:  # e.g. a diffusion solve that did not converge: part of the result
                log(f"      warning: {w}")
    if args.refs_only:
        return
    old = [n for n in names if n in scene_registry.OLD]
    new = [n for n in names if n in scene_registry.NEW]
    log(f"\nsummary over {len(old)} old scene(s) ({', '.join(old) or '—'}) and {len(new)} new "
        f"({', '.join(new) or '—'}):")
    log(f"  {'model':22s} {'worst block old':>15} {'worst block new':>15} {'bias range old':>16} {'bias range new':>16}"
        f" {'move/SS':>8}")
    for label, _, _ in MODELS:
        sub = [x for x in rows if x["model"] == label]
        o = [x for x in sub if x["scene"] in old]
        w = [x for x in sub if x["scene"] in new]
        log(f"  {label:22s} {fmt_max([x['block'] for x in o]):>15} {fmt_max([x['block'] for x in w]):>15}"
            f" {fmt_range([x['bias'] for x in o]):>16} {fmt_range([x['bias'] for x in w]):>16}"
            f" {np.median([x['ratio'] for x in sub]):>8.2f}")
    if out is not None:
        log(f"\nwrote {out.resolve().relative_to(ROOT) if out.resolve().is_relative_to(ROOT) else out}")


if __name__ == "__main__":
    main()
