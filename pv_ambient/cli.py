"""``pv-ambient`` command line: ``render SCENE.json``, ``series SCENE.json``, ``demo``, ``bench``.

The CLI and the Python API share one code path: ``render`` is :func:`pv_ambient.scene.render_scene`,
``series`` is :func:`pv_ambient.render_series` (:func:`series_from_scene`, docs/series.rst). Both
read their scene file through :mod:`pv_ambient.scene` (the JSON scene format), so a scene means the
same to both commands. Errors of the user's making (a bad scene, option or file) print one line and
exit with status 2, without a traceback.

Examples
--------
``pv-ambient render scene.json -o out.png --radiance out.npy``
``pv-ambient series scene.json --orbit 36 -o orbit --movie orbit.mp4``
``pv-ambient demo -o demo_output``
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

from .backend import BACKENDS
from .inputs.camera import orbit
from .rendering.presets import ALL_MODELS
from .rendering.result import TONEMAPS
from .series.driver import SeriesResult, render_series
from .series.volumes import resolve_volumes


#: What ``-o`` and ``--radiance`` may end in (checked before any work).
OUTPUT_SUFFIXES = (".png", ".npy", ".npz")
#: ``series --scheduler`` values besides an address, and the ``client`` of
#: :func:`pv_ambient.render_series` each gives.
CLIENTS = {"local": None, "synchronous": "synchronous"}
#: Schedulers of the command line besides an address.
SCHEDULERS = tuple(CLIENTS)


def _check_outputs(args):
    suffix = Path(args.output).suffix.lower()
    if suffix not in OUTPUT_SUFFIXES:
        raise ValueError(f"-o/--output must end in {', '.join(OUTPUT_SUFFIXES)}, got {args.output!r}")
    if args.radiance and Path(args.radiance).suffix.lower() != ".npy":
        raise ValueError(f"--radiance must end in .npy, got {args.radiance!r}")


def _exposure(text):
    """``--exposure``: a number of stops or ``auto``."""
    if text == "auto":
        return text
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number of stops or 'auto', got {text!r}") from None


def _cmd_render(args) -> int:
    from .scene import load_scene, render_scene

    _check_outputs(args)
    scene = load_scene(args.scene)
    if args.model:
        scene.render_kwargs["model"] = args.model
    if args.backend:
        scene.renderer_kwargs["backend"] = args.backend
    t = time.perf_counter()
    res = render_scene(scene, progress_bar=args.progress)
    elapsed = time.perf_counter() - t
    display = dict(scene.display)
    for key in ("exposure", "tonemap"):
        if getattr(args, key) is not None:
            display[key] = getattr(args, key)
    if args.srgb:
        display["srgb"] = True
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    res.save(out, **display)
    if args.radiance:
        Path(args.radiance).parent.mkdir(parents=True, exist_ok=True)
        res.save(args.radiance)
    print(f"rendered {res.metadata['model']} {res.window_size[0]}x{res.window_size[1]} on "
          f"{res.metadata.get('backend', 'cpu')} in {elapsed:.2f} s -> {out}"
          + (f", radiance -> {args.radiance}" if args.radiance else ""))
    return 0


def _cmd_demo(args) -> int:
    os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
    import pyvista as pv

    from . import datasets
    from .inputs.lights import PointLight
    from .pyvista.compare import compare
    from .rendering.renderer import Renderer

    pv.OFF_SCREEN = True
    outdir = Path(args.output)
    outdir.mkdir(parents=True, exist_ok=True)
    grid = datasets.supernova(n=args.n)
    style = datasets.suggested_style("supernova")
    tf = {"kind": "colormap", "cmap": style["cmap"], "clim": style["clim"], "opacity": style["opacity"],
          "density_scale": style["density_scale"]}
    t0 = time.perf_counter()
    tf["albedo"] = 0.9
    # the paper's Figure 1 set-up: a point light at the centre of the shell
    r = Renderer(grid, transfer_function=tf, lights=[PointLight((0.0, 0.0, 0.0), intensity=3.0)])
    models = ("emission_absorption", "ambient_scattering")
    size = (args.size, args.size)
    display = {"ambient_scattering": {"exposure": 3.0, "tonemap": "reinhard"}}
    pl = compare(grid, renderer=r, models=models, window_size=size, mapper="gpu", off_screen=True, display=display)
    t1 = time.perf_counter()
    path = outdir / "side_by_side.png"
    pl.screenshot(str(path))
    t_vtk0 = time.perf_counter()
    pl.render()
    t_vtk = time.perf_counter() - t_vtk0
    pl.close()
    for model, res in pl.results.items():
        res.save(outdir / f"{model}.png")
        res.save(outdir / f"{model}.npy")
        print(f"  {model:22s} prepare {res.metadata['time_prepare']:.3f} s, ray cast {res.metadata['time_render']:.3f} s")
    print(f"  VTK add_volume (whole window redraw) {t_vtk:.3f} s; set-up incl. compile {t1 - t0:.2f} s")
    print(f"wrote {path}")
    return 0


BENCHMARKS = {"trade": "trade.py", "ea": "ea_vs_vtk.py", "ambient": "ambient.py", "gpu": "gpu.py"}
BENCHMARK_HELP = {"trade": "every model against the path-traced reference: error against time (docs/trade.rst)",
                  "ea": "emission-absorption against VTK's fixed_point and gpu mappers: agreement and speed",
                  "ambient": "ambient scattering frame costs (camera move, relight, TF change, table slice)",
                  "gpu": "the CUDA backend against the CPU (needs numba-cuda and a GPU)"}


def _cmd_bench(args) -> int:
    rest = list(args.rest)
    if rest and rest[0] in ("-h", "--help"):
        args.bench_parser.print_help()
        return 0
    which = rest.pop(0) if rest and rest[0] in BENCHMARKS else "trade"
    if "--backend" in rest:  # ``bench --backend cuda``: the GPU benchmark (gpu.py)
        i = rest.index("--backend")
        if i + 1 < len(rest) and rest[i + 1] == "cuda":
            which = "gpu"
            del rest[i:i + 2]
    here = Path(__file__).resolve().parent.parent / "benchmarks" / BENCHMARKS[which]
    if not here.exists():
        print(f"the benchmark {BENCHMARKS[which]} is part of the source tree (its benchmarks folder); run from a "
              "checkout", file=sys.stderr)
        return 2
    import runpy

    sys.argv = [str(here)] + rest
    sys.path.insert(0, str(here.parent))  # as running the script itself would: its shared helpers
    runpy.run_path(str(here), run_name="__main__")
    return 0


# -- pv-ambient series: time series and orbits (pv_ambient.series, docs/series.rst) -------------------
def add_cli_parser(sub) -> argparse.ArgumentParser:
    """Add ``pv-ambient series`` to the CLI's sub-parsers."""
    s = sub.add_parser("series", help="render a time series (--volumes) or a camera orbit (--orbit) of a scene "
                                      "into numbered frames, on dask.distributed")
    s.add_argument("scene", help="scene file (JSON, as for render); its volume is used by --orbit")
    what = s.add_mutually_exclusive_group(required=True)
    what.add_argument("--volumes", help="time steps: a glob (quote it) or a .pvd collection; each replaces the "
                                        "scene's volume")
    what.add_argument("--orbit", type=int, metavar="N", help="N cameras on a circle around the scene's volume, "
                                                             "starting at the scene's camera")
    s.add_argument("-o", "--output", required=True, help="output folder (frame_0000.png, ...)")
    s.add_argument("--movie", help="also write the frames as a movie (.mp4, .gif; needs the 'movie' extra)")
    s.add_argument("--fps", type=float, default=10.0, help="movie frames per second (default 10)")
    s.add_argument("--scheduler", default="local",
                   help="'local' (a LocalCluster, default), 'synchronous' (this process) or a scheduler address")
    s.add_argument("--workers", type=int, help="worker processes of the local cluster (default: one per core)")
    s.add_argument("--radiance", action="store_true", help="also write frame_NNNN.npy (linear float32 radiance)")
    s.add_argument("--elevation", type=float, help="orbit elevation in degrees (default: the scene camera's)")
    s.add_argument("--overwrite", action="store_true", help="render frames whose files exist too")
    s.add_argument("--no-progress", action="store_true", help="no progress bar")
    s.set_defaults(func=cli_series)
    return s


def series_from_scene(scene_path, *, volumes=None, orbit_frames=None, elevation=None, **kwargs) -> SeriesResult:
    """:func:`render_series` of a JSON scene file (what ``pv-ambient series`` runs).

    With ``volumes`` (a glob, a ``.pvd`` or a list of paths) every file replaces the scene's
    ``volume``; with ``orbit_frames`` the scene's volume is seen by :func:`orbit` cameras that
    start at the scene's camera. ``kwargs`` go to :func:`render_series`.
    """
    from .scene import parse_scene, read_scene, scene_options

    scene_path = Path(scene_path)
    data = read_scene(scene_path)
    if (volumes is None) == (orbit_frames is None):
        raise ValueError("give volumes (a time series) or orbit_frames (an orbit), one of the two")
    base = scene_path.parent
    if volumes is not None:
        vols = resolve_volumes(volumes)
        # the options of the scene, checked once here; its volume is not read: the time steps stay
        # on the workers (each frame reads its own file)
        scene = scene_options(data, base_dir=base)
        cameras = None
    else:
        scene = parse_scene(data, base_dir=base)
        spec = data.get("volume")
        vols = [str(base / spec) if isinstance(spec, str) and not Path(spec).is_absolute() else
                spec if isinstance(spec, str) else scene.grid]
        cameras = orbit(scene.grid, orbit_frames, elevation=elevation, start=scene.render_kwargs.get("camera"))
    kw = dict(scene.render_kwargs)
    camera = kw.pop("camera", None)
    model = kw.pop("model", "emission_absorption")
    rk = scene.renderer_kwargs
    return render_series(vols, transfer_function=rk["transfer_function"], lights=rk["lights"],
                         scalars=rk["scalars"], preference=rk["preference"], nan_policy=rk["nan_policy"],
                         backend=rk["backend"], camera=None if cameras is not None else camera, cameras=cameras,
                         model=model, display=scene.display, **kw, **kwargs)


def cli_series(args) -> int:
    """``pv-ambient series``: exit status 0 when every frame is there, else the number that failed
    (at most 100); 130 when interrupted (re-run to render the missing frames)."""
    client = CLIENTS.get(args.scheduler, args.scheduler)
    if args.workers is not None and client is not None:
        print("pv-ambient: error: --workers sets the size of the local cluster (--scheduler local)", file=sys.stderr)
        return 2
    try:
        res = series_from_scene(args.scene, volumes=args.volumes, orbit_frames=args.orbit, elevation=args.elevation,
                                out_dir=args.output, client=client, workers=args.workers, radiance=args.radiance,
                                overwrite=args.overwrite, movie=args.movie, fps=args.fps,
                                progress_bar=not args.no_progress)
    except (ImportError, OSError) as exc:  # a missing extra, file or scheduler (OSError: no connection)
        print(f"pv-ambient: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        done = len(list(Path(args.output).glob("frame_*.png")))
        print(f"pv-ambient: interrupted; {done} frames are in {args.output} (no partial file); run the same "
              "command again to render the missing ones", file=sys.stderr)
        return 130
    for f in res.failed:
        print(f"pv-ambient: frame {f.index:04d} ({f.volume}) failed: {f.error}", file=sys.stderr)
    rendered = [f for f in res.frames if f.status == "rendered"]
    if rendered:
        total = np.array([f.times.get("total", 0.0) for f in rendered])
        print(f"per frame: mean {total.mean():.3f} s, min {total.min():.3f} s, max {total.max():.3f} s")
    if args.movie and res.n_failed:
        print(f"pv-ambient: no movie written: {res.n_failed} frames failed", file=sys.stderr)
    print(f"series: {res.summary()}")
    return res.exit_status


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="pv-ambient", description="Ambient volume scattering for PyVista volumes")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("render", help="render a JSON scene file")
    r.add_argument("scene", help="scene file (JSON, format documented in pv_ambient.scene)")
    r.add_argument("-o", "--output", required=True, help="output image (.png; .npy/.npz keep linear radiance)")
    r.add_argument("--radiance", help="also write linear float32 radiance (H, W, 3) to this .npy file")
    r.add_argument("--model", choices=ALL_MODELS, help="override the scene's model")
    r.add_argument("--exposure", type=_exposure, help="PNG exposure in stops, or 'auto' (the default of the lit "
                                                       "models; 0 for emission_absorption and ambient_occlusion)")
    r.add_argument("--tonemap", choices=TONEMAPS, help="PNG tone map")
    r.add_argument("--srgb", action="store_true", help="sRGB-encode the PNG")
    r.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="progress bars per stage: --progress at once, --no-progress never; default: a named bar "
                        "for each stage that runs longer than 2 s")
    r.add_argument("--backend", choices=BACKENDS,
                   help="where the kernels run (overrides the scene's 'backend'; default auto)")
    r.set_defaults(func=_cmd_render)
    d = sub.add_parser("demo", help="render the embedded supernova dataset (EA and ambient scattering) "
                                    "side by side with VTK")
    d.add_argument("-o", "--output", default="demo_output", help="output folder")
    d.add_argument("-n", type=int, default=96, help="grid resolution")
    d.add_argument("--size", type=int, default=400, help="panel size in pixels")
    d.set_defaults(func=_cmd_demo)
    b = sub.add_parser("bench", usage="pv-ambient bench [NAME] [OPTIONS]", add_help=False,
                       help="run a benchmark table (from a source checkout); 'bench NAME --help' lists its options",
                       description="Run one of the benchmark scripts of the source checkout; every "
                                   "argument after NAME goes to it: 'pv-ambient bench NAME --help' lists its options.",
                       formatter_class=argparse.RawDescriptionHelpFormatter,
                       epilog="benchmarks:\n" + "\n".join(f"  {k:8s} {v}" for k, v in BENCHMARK_HELP.items())
                              + "\n\n'pv-ambient bench --backend cuda' runs gpu.")
    b.add_argument("rest", nargs=argparse.REMAINDER, metavar="[NAME] [OPTIONS]",
                   help=f"NAME is one of {', '.join(BENCHMARKS)} (default trade); OPTIONS go to the benchmark")
    b.set_defaults(func=_cmd_bench, bench_parser=b)
    add_cli_parser(sub)
    return p


def main(argv=None) -> int:
    parser = build_parser()
    args, extra = parser.parse_known_args(argv)
    if extra:
        if args.command != "bench":
            parser.error(f"unrecognized arguments: {' '.join(extra)}")
        args.rest = extra + list(args.rest)  # `bench --backend cuda ...`: options go to the benchmark
    try:
        return args.func(args)
    except (ValueError, TypeError, FileNotFoundError, KeyError, MemoryError, ImportError) as exc:
        # one line, no traceback: a bad input, or an optional package an option needs (the message
        # names the extra to install)
        print(f"pv-ambient: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("pv-ambient: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
