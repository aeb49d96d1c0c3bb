"""Time series and camera orbits: many frames of one scene, rendered on ``dask.distributed``.

:func:`render_series` renders one frame per volume of a time series (a list of
``pyvista.ImageData``, a list of files, a glob or a ``.pvd`` collection), or one frame per
camera of one volume (an orbit, :func:`orbit`), and writes ``frame_0000.png``,
``frame_0001.png``, … (with ``radiance=True`` also ``frame_0000.npy``: the linear float32
``(H, W, 3)`` radiance that ``pv-ambient render --radiance`` writes). Each frame is the image
``pv-ambient render`` gives for the same scene and volume: a worker runs the same
:class:`~pv_ambient.Renderer` code path.

Where the frames are rendered (``client``):

* ``None``: a ``distributed.LocalCluster`` with one worker process per core (``workers``), one
  thread and one Numba thread each, started and closed by the call;
* ``"synchronous"``: one frame after the other in this process (no Dask needed);
* an address (``"tcp://scheduler:8786"``) or a ``distributed.Client``: an existing cluster.

Workers read volume files themselves (the paths travel, not the arrays). What every frame shares
is built once: the transfer function and lights are checked on the client and sent to every
worker once; each worker keeps the preintegrated table slices it has loaded, and one
:class:`~pv_ambient.Renderer` for the last volume it rendered, so the frames of an orbit that land
on a worker after its first reuse its light volumes, ball grid and diffusion solve (only the ray
cast runs again).

Outputs are written atomically: each file goes to a hidden temporary name in ``out_dir``
(``.frame_0003.<run>.part.png``) and is renamed when complete, so an interrupted run leaves no
half-written frame; a re-run skips the frames whose files all exist (``overwrite=False``) and
removes temporary files a killed run left behind. A frame whose input is bad (a missing or
corrupt file, NaN scalars) is reported with its error; the others finish. A worker that dies
during a frame is replaced by the cluster and the frame is rendered again elsewhere.

The command line (``pv-ambient series``) is the same function::

    pv-ambient series scene.json --volumes "run/step_*.vti" -o frames --movie run.mp4
    pv-ambient series scene.json --orbit 36 -o orbit --scheduler tcp://scheduler:8786

Examples
--------
>>> import tempfile
>>> import pv_ambient as pa
>>> from pv_ambient import datasets
>>> steps = [datasets.supernova(n=16, seed=s) for s in range(3)]
>>> out = tempfile.mkdtemp()
>>> summary = pa.render_series(steps, out_dir=out, client="synchronous", window_size=(16, 12),
...                            progress_bar=False)
>>> summary.n_rendered, summary.n_failed, [p.name for p in summary.paths]
(3, 0, ['frame_0000.png', 'frame_0001.png', 'frame_0002.png'])
>>> pa.render_series(steps, out_dir=out, client="synchronous", window_size=(16, 12),
...                  progress_bar=False).n_skipped   # a re-run skips the frames already written
3
"""

from __future__ import annotations

import argparse
import glob as globmod
import inspect
import os
import sys
import threading
import time
import uuid
import warnings
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .inputs.camera import Camera, as_camera, default_camera
from .inputs.lights import as_lights, default_lights
from .inputs.transfer import as_transfer_function
from .inputs.validation import check_choice, check_int, check_real
from .rendering.cache import SceneCache
from .rendering.presets import ALL_MODELS, MODEL_OPTIONS, MODEL_SPECS

#: File name of frame ``i`` without its suffix.
FRAME_STEM = "frame_{:04d}"
#: Marker in the temporary names of files being written (``.frame_0003.<run>.part.png``).
PART = ".part"
#: How many :class:`~pv_ambient.Renderer` objects a worker keeps (the volumes it rendered last).
RENDERERS_PER_WORKER = 1
#: Display keys a PNG accepts (``RenderResult.to_uint8``).
DISPLAY_KEYS = ("exposure", "tonemap", "srgb")
#: Schedulers of the command line besides an address.
SCHEDULERS = ("local", "synchronous")

MISSING_DISTRIBUTED = ("render_series with client={!r} needs dask.distributed: install the 'distributed' extra "
                       "(pip install 'pv_ambient[distributed]'), or pass client='synchronous' to render in this "
                       "process")
MISSING_MOVIE = ("movie={!r} needs imageio{}: install the 'movie' extra (pip install 'pv_ambient[movie]': "
                 "imageio and imageio-ffmpeg)")


# -- cameras ------------------------------------------------------------------------------------
def orbit(grid, n_frames, *, elevation=None, start=None, view_up=None, distance=None, degrees=360.0):
    """Cameras on a circle around the volume: the camera path of an orbit movie.

    As PyVista's ``Plotter.generate_orbital_path``, the cameras move on a circle in the plane
    normal to ``view_up`` around the focal point, looking at it; here the circle starts at a
    camera (``start``: PyVista's default view of the volume when None) so frame 0 is the view
    the user set up, and the frames are ``degrees / n_frames`` apart (360: the last frame is one
    step before the first, so the movie loops).

    Parameters
    ----------
    grid : pyvista.ImageData, pv_ambient.inputs.grid.Volume or sequence of 6 float
        The volume (or its bounds); it places the default start camera.
    n_frames : int
        Number of cameras (≥ 1).
    elevation : float, optional
        Angle in degrees of the cameras above the orbit's plane through the focal point; the
        start camera's when None.
    start : Camera, pyvista.Camera, dict or list, optional
        The first camera (its focal point, distance, view angle and projection are kept).
    view_up : sequence of 3 float, optional
        The orbit's axis and every camera's view-up; the start camera's when None.
    distance : float, optional
        Camera distance from the focal point; the start camera's when None.
    degrees : float, default: 360.0
        The arc the orbit covers.

    Returns
    -------
    list of Camera

    Examples
    --------
    >>> import numpy as np
    >>> from pv_ambient.series import orbit
    >>> cams = orbit([-1, 1, -1, 1, -1, 1], 4, elevation=0.0,
    ...              start={"position": [0, -4, 0], "focal_point": [0, 0, 0], "view_up": [0, 0, 1]})
    >>> [(np.round(c.position, 6) + 0.0).tolist() for c in cams]
    [[0.0, -4.0, 0.0], [4.0, 0.0, 0.0], [0.0, 4.0, 0.0], [-4.0, 0.0, 0.0]]
    """
    n = check_int(n_frames, "n_frames", lo=1)
    degrees = check_real(degrees, "degrees")
    if start is None:
        bounds = getattr(grid, "bounds", None)
        if bounds is None and getattr(grid, "geometry", None) is not None:
            bounds = grid.geometry.bounds
        if bounds is None:
            bounds = grid
        try:
            bounds = [float(b) for b in bounds]
        except TypeError:
            raise TypeError(f"grid must be an ImageData, a Volume or 6 bounds, got {type(grid).__name__}") from None
        if len(bounds) != 6:
            raise ValueError(f"grid bounds must be 6 numbers, got {len(bounds)}")
        start = default_camera(bounds)
    else:
        start, _ = as_camera(start)
    focal = np.array(start.focal_point)
    axis = np.array(start.view_up if view_up is None else view_up, dtype=np.float64)
    if axis.shape != (3,) or not np.all(np.isfinite(axis)) or np.linalg.norm(axis) == 0:
        raise ValueError(f"view_up must be a non-zero 3-vector, got {view_up!r}")
    axis = axis / np.linalg.norm(axis)
    offset = np.array(start.position) - focal
    radius = np.linalg.norm(offset) if distance is None else check_real(distance, "distance", lo=0.0, lo_open=True)
    height = float(offset @ axis)
    flat = offset - height * axis
    if np.linalg.norm(flat) < 1e-12 * np.linalg.norm(offset):
        # the start camera looks along the axis: begin the circle on any direction normal to it
        flat = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 = flat / np.linalg.norm(flat)
    e2 = np.cross(axis, e1)
    if elevation is None:
        elev = np.arctan2(height, np.linalg.norm(offset - height * axis))
    else:
        elev = np.radians(check_real(elevation, "elevation", lo=-90.0, hi=90.0, lo_open=True, hi_open=True))
    cams = []
    for k in range(n):
        phi = np.radians(degrees) * k / n
        ring = np.cos(phi) * e1 + np.sin(phi) * e2
        pos = focal + radius * (np.cos(elev) * ring + np.sin(elev) * axis)
        cams.append(Camera(position=tuple(pos), focal_point=tuple(focal), view_up=tuple(axis),
                           view_angle=start.view_angle, parallel_projection=start.parallel_projection,
                           parallel_scale=start.parallel_scale))
    return cams


# -- inputs -------------------------------------------------------------------------------------
def _is_grid(obj) -> bool:
    return hasattr(obj, "GetDimensions") or type(obj).__name__ == "Volume"


def pvd_files(path) -> list:
    """The data files of a ``.pvd`` collection in time order (paths relative to the ``.pvd``).

    Only part 0 of a multi-part collection is used (one volume per time step).
    """
    import xml.etree.ElementTree as ET

    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"volumes collection {str(path)!r} does not exist")
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise ValueError(f"volumes collection {str(path)!r} is not valid XML: {exc}") from None
    steps = []
    for i, ds in enumerate(root.iter("DataSet")):
        if ds.get("file") is None:
            raise ValueError(f"volumes collection {str(path)!r}: DataSet {i} has no 'file' attribute")
        if int(ds.get("part", "0") or 0) != 0:
            continue
        t = ds.get("timestep")
        steps.append((float(t) if t not in (None, "") else float(i), i, str(path.parent / ds.get("file"))))
    if not steps:
        raise ValueError(f"volumes collection {str(path)!r} lists no DataSet")
    return [p for _, _, p in sorted(steps)]


def resolve_volumes(volumes) -> list:
    """The volume list of :func:`render_series`: each item a file path (str) or an in-memory grid.

    ``volumes`` is one grid, a list of grids and/or paths, a glob pattern, a ``.pvd`` collection
    or one file path. A glob is sorted by name; a ``.pvd`` is in time order.
    """
    if _is_grid(volumes):
        return [volumes]
    if isinstance(volumes, (str, os.PathLike)):
        text = os.fspath(volumes)
        if text.lower().endswith(".pvd"):
            return pvd_files(text)
        if any(ch in text for ch in "*?["):
            found = sorted(globmod.glob(text))
            if not found:
                raise FileNotFoundError(f"volumes glob {text!r} matched no file")
            return found
        return [text]
    try:
        items = list(volumes)
    except TypeError:
        raise TypeError("volumes must be an ImageData, a list of ImageData or file paths, a glob or a .pvd path; "
                        f"got {type(volumes).__name__}") from None
    if not items:
        raise ValueError("volumes is empty: give at least one volume")
    out = []
    for i, v in enumerate(items):
        if isinstance(v, (str, os.PathLike)):
            out.append(os.fspath(v))
        elif _is_grid(v):
            out.append(v)
        else:
            raise TypeError(f"volumes[{i}] must be an ImageData or a file path, got {type(v).__name__}")
    return out


@dataclass
class PackedImage:
    """An in-memory ImageData in plain numpy arrays, for the trip to a worker.

    PyVista pickles an ImageData through VTK's legacy format, which keeps 6 digits of its spacing
    and origin; this keeps every number, so a worker renders the very grid the client holds.
    """

    dimensions: tuple
    origin: tuple
    spacing: tuple
    direction: np.ndarray
    point: dict
    cell: dict
    active: tuple  # (name, "point" | "cell") or None

    @classmethod
    def of(cls, grid) -> "PackedImage":
        import pyvista as pv

        image = pv.wrap(grid)
        info = image.active_scalars_info
        active = None
        if info is not None and info.name is not None:
            active = (info.name, "point" if "POINT" in str(info.association).upper() else "cell")
        return cls(tuple(image.dimensions), tuple(image.origin), tuple(image.spacing),
                   np.array(image.direction_matrix, dtype=np.float64),
                   {k: np.array(image.point_data[k]) for k in image.point_data.keys()},
                   {k: np.array(image.cell_data[k]) for k in image.cell_data.keys()}, active)

    def unpack(self):
        import pyvista as pv

        image = pv.ImageData(dimensions=self.dimensions, spacing=self.spacing, origin=self.origin)
        image.direction_matrix = self.direction
        for k, v in self.point.items():
            image.point_data[k] = v
        for k, v in self.cell.items():
            image.cell_data[k] = v
        if self.active is not None:
            image.set_active_scalars(self.active[0], preference=self.active[1])
        return image


def read_volume(path):
    """Read one volume file as a ``pyvista.ImageData``, or raise an error that names the file."""
    import pyvista as pv
    from vtkmodules.vtkCommonCore import vtkObject

    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"volume file {str(path)!r} does not exist")
    shown = vtkObject.GetGlobalWarningDisplay()
    vtkObject.GlobalWarningDisplayOff()  # a corrupt file is reported once, by the error below
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            data = pv.read(path)
    except Exception as exc:  # noqa: BLE001 - any reader failure is this file's error
        raise ValueError(f"volume file {str(path)!r} could not be read: {exc}") from None
    finally:
        vtkObject.SetGlobalWarningDisplay(shown)
    if not isinstance(data, pv.ImageData):
        raise TypeError(f"volume {str(path)!r} holds a {type(data).__name__}, not an ImageData")
    if data.n_points == 0:
        why = f": {caught[0].message}" if caught else ""
        raise ValueError(f"volume file {str(path)!r} could not be read (no points){why}")
    return data


# -- what a worker runs -------------------------------------------------------------------------
@dataclass(frozen=True)
class FrameSpec:
    """What every frame of one :func:`render_series` call shares; sent to each worker once."""

    renderer_kwargs: dict
    render_kwargs: dict
    display: dict
    radiance: bool
    numba_threads: int | None
    run: str


#: Per-process state of the workers: the renderers of the last volumes and the table slices.
_WORKER = {"run": None, "renderers": OrderedDict(), "tables": SceneCache()}
_WORKER_LOCK = threading.Lock()


def _worker_name() -> str:
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):
        return "local"


def _renderer_for(spec, volume, key):
    """This process's :class:`Renderer` of ``volume`` (built, or reused from the last frames)."""
    from .rendering.renderer import Renderer

    with _WORKER_LOCK:
        if _WORKER["run"] != spec.run:
            _WORKER["run"] = spec.run
            _WORKER["renderers"].clear()
        r = _WORKER["renderers"].get(key)
        if r is not None:
            _WORKER["renderers"].move_to_end(key)
            return r, True, 0.0, 0.0
    t = time.perf_counter()
    if isinstance(volume, str):
        grid = read_volume(volume)
    elif isinstance(volume, PackedImage):
        grid = volume.unpack()
    else:
        grid = volume
    t_load = time.perf_counter() - t
    t = time.perf_counter()
    r = Renderer(grid, **spec.renderer_kwargs)
    r.cache.share(_WORKER["tables"])  # the preintegrated table slices this worker holds
    t_build = time.perf_counter() - t
    with _WORKER_LOCK:
        _WORKER["renderers"][key] = r
        while len(_WORKER["renderers"]) > RENDERERS_PER_WORKER:
            _WORKER["renderers"].popitem(last=False)
    return r, False, t_load, t_build


def frame_outputs(out_dir, index, radiance) -> list:
    """The files frame ``index`` writes: ``[frame_NNNN.npy,] frame_NNNN.png`` (the PNG last)."""
    stem = Path(out_dir) / FRAME_STEM.format(index)
    return ([stem.with_suffix(".npy")] if radiance else []) + [stem.with_suffix(".png")]


def _write_atomic(res, path: Path, run: str, display: dict) -> None:
    tmp = path.with_name(f".{path.stem}.{run}{PART}{path.suffix}")
    try:
        res.save(tmp, **(display if path.suffix == ".png" else {}))
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def render_frame(spec: FrameSpec, index: int, volume, key: str, camera, out_dir: str) -> dict:
    """Render frame ``index`` and write its files; return its record (errors are returned, not raised)."""
    t0 = time.perf_counter()
    rec = {"index": index, "worker": _worker_name(), "pid": os.getpid(), "error": None, "reused": False,
           "times": {}}
    threads = None
    try:
        if spec.numba_threads:
            import numba

            threads = numba.get_num_threads()  # put back afterwards (this process may be the client)
            numba.set_num_threads(min(spec.numba_threads, numba.config.NUMBA_NUM_THREADS))
        r, reused, t_load, t_build = _renderer_for(spec, volume, key)
        t = time.perf_counter()
        res = r.render(camera=camera, **spec.render_kwargs)
        t_render = time.perf_counter() - t
        _WORKER["tables"].share(r.cache)
        t = time.perf_counter()
        display = dict(spec.display)
        display["exposure"] = res.display_exposure(display.get("exposure"))  # "auto" resolved: reported
        for path in frame_outputs(out_dir, index, spec.radiance):
            _write_atomic(res, path, spec.run, display)
        rec.update(reused=reused, model=res.metadata.get("model"), exposure=display["exposure"],
                   times={"load": t_load, "classify": t_build, "prepare": res.metadata.get("time_prepare", 0.0),
                          "render": t_render, "write": time.perf_counter() - t})
    except Exception as exc:  # noqa: BLE001 - the frame's error is reported, the others go on
        rec["error"] = f"{type(exc).__name__}: {exc}"
    finally:
        if threads is not None:
            import numba

            numba.set_num_threads(threads)
    rec["times"]["total"] = time.perf_counter() - t0
    return rec


# -- the summary --------------------------------------------------------------------------------
@dataclass
class FrameRecord:
    """One frame of a series: what was rendered, where, how long it took, or why it failed."""

    index: int
    volume: str
    status: str  # "rendered", "skipped" or "failed"
    paths: list
    worker: str | None = None
    times: dict = field(default_factory=dict)
    error: str | None = None
    reused: bool = False


@dataclass
class SeriesResult:
    """What :func:`render_series` returns: one :class:`FrameRecord` per frame, in frame order."""

    out_dir: Path
    frames: list
    wall_time: float
    workers: int
    movie: Path | None = None

    @property
    def paths(self) -> list:
        """The PNG of every frame that exists (rendered now or before)."""
        return [f.paths[-1] for f in self.frames if f.status != "failed"]

    def _count(self, status):
        return sum(f.status == status for f in self.frames)

    n_rendered = property(lambda self: self._count("rendered"), doc="frames rendered by this call")
    n_skipped = property(lambda self: self._count("skipped"), doc="frames whose files existed already")
    n_failed = property(lambda self: self._count("failed"), doc="frames that failed")

    @property
    def failed(self) -> list:
        return [f for f in self.frames if f.status == "failed"]

    @property
    def exit_status(self) -> int:
        """The command line's exit status: the number of failed frames (at most 100), 0 when none."""
        return min(self.n_failed, 100)

    @property
    def fps(self) -> float:
        """Frames rendered per second of wall time."""
        return self.n_rendered / self.wall_time if self.wall_time > 0 else 0.0

    def summary(self) -> str:
        s = (f"{len(self.frames)} frames: {self.n_rendered} rendered, {self.n_skipped} skipped, "
             f"{self.n_failed} failed in {self.wall_time:.2f} s on {self.workers} worker"
             f"{'s' if self.workers != 1 else ''} -> {self.out_dir}")
        return s + (f", movie -> {self.movie}" if self.movie else "")

    def __repr__(self):
        return f"SeriesResult({self.summary()})"


# -- the driver ---------------------------------------------------------------------------------
def _render_parameters() -> set:
    from .rendering.renderer import Renderer

    params = set(inspect.signature(Renderer.render).parameters) - {"self", "model_options", "camera"}
    return params | set(MODEL_OPTIONS) | {"time_budget"}


def _get_client(client, workers, numba_threads=None):
    """(client, things to close afterwards, number of workers, Numba threads per worker: ``numba_threads``,
    1 when None on the cluster started here, None — the workers' own setting — on an existing one)."""
    try:
        import dask
        from distributed import Client, LocalCluster
    except ImportError:
        raise ImportError(MISSING_DISTRIBUTED.format(client)) from None
    if client is None:
        n = (os.cpu_count() or 1) if workers is None else check_int(workers, "workers", lo=1)
        threads = numba_threads or 1
        # the workers' Numba thread pool no larger than the threads used: idle OpenMP threads of a
        # larger pool spin after each parallel region and take cycles from the other workers. The
        # config entry reaches every worker the nannies spawn (restarts too); dask takes its value
        # from this process' environment when the variable is set there, hence the variable set
        # too — and put back once the nannies (which copy it into this process) have started.
        before = os.environ.get("NUMBA_NUM_THREADS")
        os.environ["NUMBA_NUM_THREADS"] = str(threads)
        try:
            with dask.config.set({"distributed.nanny.pre-spawn-environ.NUMBA_NUM_THREADS": str(threads)}):
                # the HTTP server on a free port: none taken from another cluster, no "port in use" warning
                cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0")
        finally:
            if before is None:
                os.environ.pop("NUMBA_NUM_THREADS", None)
            else:
                os.environ["NUMBA_NUM_THREADS"] = before
        c = Client(cluster)
        return c, [c, cluster], n, threads
    if isinstance(client, str):
        c = Client(client)
        return c, [c], len(c.scheduler_info().get("workers", {})), numba_threads
    if isinstance(client, Client):
        return client, [], len(client.scheduler_info().get("workers", {})), numba_threads
    raise TypeError(f"client must be None, 'synchronous', a scheduler address or a distributed.Client, "
                    f"got {type(client).__name__}")


def _remove_parts(out_dir: Path, run: str | None = None) -> None:
    pattern = f".frame_*.{run}{PART}.*" if run else f".frame_*{PART}.*"
    for p in out_dir.glob(pattern):
        p.unlink(missing_ok=True)


def render_series(volumes, *, out_dir, transfer_function=None, lights=None, camera=None,
                  model="emission_absorption", cameras=None, client=None, scalars=None, component=None,
                  preference="point", nan_policy="raise", backend="auto", radiance=False, display=None,
                  overwrite=False, movie=None, fps=10, workers=None, numba_threads=None, progress_bar=True,
                  **render_options) -> SeriesResult:
    """Render a time series or a camera orbit into ``out_dir``, one frame per file, on Dask.

    Parameters
    ----------
    volumes : ImageData, list of ImageData or file paths, glob str or ``.pvd`` path
        The time steps (frame ``i`` renders volume ``i``), or one volume for an orbit.
    out_dir : str or Path
        Folder of ``frame_0000.png``, … (created when missing).
    transfer_function, lights, scalars, component, preference, nan_policy, backend
        As :class:`pv_ambient.Renderer`; the same for every frame (checked once, here). ``lights``
        None (not given): a lit model gets the default light rig (docs/lights.rst), placed once from
        the first frame's camera, so an orbit keeps its lighting; ``()``: no light.
    camera : Camera, pyvista.Camera, dict or list, optional
        The camera of every frame (PyVista's default view of each volume when None).
    model : str, default: "emission_absorption"
        As :meth:`pv_ambient.Renderer.render`.
    cameras : list of cameras, optional
        One camera per frame: with one volume, an orbit (:func:`orbit`); with as many volumes as
        cameras, camera ``i`` views volume ``i``.
    client : None, "synchronous", str or distributed.Client
        Where frames render: a new ``LocalCluster`` (``workers`` processes, one thread and one
        Numba thread each), this process, a scheduler address, or a client of an existing cluster.
    radiance : bool, default: False
        Also write ``frame_NNNN.npy`` (linear float32 ``(H, W, 3)``, as ``render --radiance``).
    display : dict, optional
        PNG conversion (``exposure``, ``tonemap``, ``srgb``), as the scene's ``display``. Without
        ``exposure`` a lit model's PNGs take the ``"auto"`` exposure of the first frame rendered
        (rendered before the others), the same for every frame: no flicker. The ``.npy`` radiance
        never depends on it.
    overwrite : bool, default: False
        Render every frame again; by default frames whose files all exist are skipped.
    movie : str or Path, optional
        Also write the frames as a movie (``.mp4``, ``.gif``, …; needs the ``movie`` extra) at
        ``fps`` frames per second, when every frame is there.
    workers : int, optional
        Processes of the ``LocalCluster`` that ``client=None`` starts (default: one per core).
    numba_threads : int, optional
        Numba threads of each worker (``numba.set_num_threads``): 1 on the ``LocalCluster`` that
        ``client=None`` starts, the workers' own setting on an existing cluster or in this process
        when None.
    progress_bar : bool, default: True
        One tqdm bar over the frames, as they complete.
    **render_options
        The other arguments of :meth:`pv_ambient.Renderer.render` (``window_size``, ``quality``,
        ``step``, ``phase``, ``background``, model options, …).

    Returns
    -------
    SeriesResult
        Per frame: status (``"rendered"``, ``"skipped"``, ``"failed"``), files, the worker that
        rendered it, its timings (load, classify, prepare, render, write, total; seconds) and
        its error; with ``n_failed`` and ``exit_status``.

    Examples
    --------
    An orbit of one volume, rendered in this process:

    >>> import tempfile
    >>> import pv_ambient as pa
    >>> from pv_ambient import datasets
    >>> grid = datasets.cloud(n=16)
    >>> s = pa.render_series(grid, cameras=pa.orbit(grid, 3, elevation=20), out_dir=tempfile.mkdtemp(),
    ...                      client="synchronous", window_size=(12, 12), progress_bar=False)
    >>> [(f.index, f.status, f.reused) for f in s.frames]
    [(0, 'rendered', False), (1, 'rendered', True), (2, 'rendered', True)]
    """
    from tqdm.auto import tqdm

    t_start = time.perf_counter()
    if out_dir is None:
        raise TypeError("out_dir is required: the folder the frames are written to")
    out = Path(out_dir)
    vols = resolve_volumes(volumes)
    if cameras is not None:
        if _is_grid(cameras) or isinstance(cameras, (str, dict, Camera)):
            raise TypeError(f"cameras must be a list of cameras, got {type(cameras).__name__}")
        cams = [as_camera(c)[0] for c in cameras]
        if not cams:
            raise ValueError("cameras is empty: give at least one camera (or None)")
        if camera is not None:
            raise ValueError("give camera (one for every frame) or cameras (one per frame), not both")
        if len(vols) == 1:
            vols = vols * len(cams)
        elif len(cams) != len(vols):
            raise ValueError(f"cameras has {len(cams)} cameras for {len(vols)} volumes: give one camera per "
                             "volume, or one volume (an orbit)")
    else:
        cams = [None if camera is None else as_camera(camera)[0]] * len(vols)
    check_choice(model, "model", ALL_MODELS)
    unknown = set(render_options) - _render_parameters()
    if unknown:
        raise TypeError(f"render_series() got unknown options {sorted(unknown)}; render options are "
                        f"{sorted(_render_parameters())}")
    display = dict(display or {})
    if set(display) - set(DISPLAY_KEYS):
        raise ValueError(f"display must hold only {', '.join(DISPLAY_KEYS)}; got {sorted(display)}")
    if movie is not None:
        _check_movie_support(movie)
        fps = check_real(fps, "fps", lo=0.0, lo_open=True)
    sync = isinstance(client, str) and client == "synchronous"
    if numba_threads is not None:
        numba_threads = check_int(numba_threads, "numba_threads", lo=1)
    run = uuid.uuid4().hex[:12]
    if lights is None and MODEL_SPECS[model].lit:
        # the default light rig (docs/lights.rst), placed once from the first frame's camera so that
        # every frame, on every worker, is lit the same (directional lights: the bounds do not matter)
        first = cams[0] if cams[0] is not None else as_camera(None, window_size=(1, 1),
                                                              bounds=(-1.0, 1.0, -1.0, 1.0, -1.0, 1.0))[0]
        lights = default_lights(first)
    renderer_kwargs = {"transfer_function": as_transfer_function(transfer_function), "scalars": scalars,
                       "component": component, "lights": as_lights(lights if lights is not None else ()),
                       "preference": preference,
                       "nan_policy": nan_policy, "backend": backend}
    check_choice(preference, "preference", ("point", "cell"))
    check_choice(nan_policy, "nan_policy", ("raise", "vacuum"))
    render_kwargs = dict(render_options, model=model, progress_bar=False)

    out.mkdir(parents=True, exist_ok=True)
    _remove_parts(out)  # what a killed run left behind
    names = [v if isinstance(v, str) else f"<{type(v).__name__} {i}>" for i, v in enumerate(vols)]
    keys, memory = [], {}
    for v in vols:  # one key per distinct volume: the worker's renderer cache
        if isinstance(v, str):
            keys.append("path:" + os.path.abspath(v))
        else:
            memory.setdefault(id(v), v)
            keys.append(f"memory:{id(v)}")
    records = {}
    todo = []
    for i in range(len(vols)):
        paths = frame_outputs(out, i, radiance)
        if not overwrite and all(p.exists() for p in paths):
            records[i] = FrameRecord(i, names[i], "skipped", paths)
        else:
            todo.append(i)

    def record(rec):
        i = rec["index"]
        status = "failed" if rec["error"] else "rendered"
        records[i] = FrameRecord(i, names[i], status, frame_outputs(out, i, radiance), worker=rec["worker"],
                                 times=rec["times"], error=rec["error"], reused=rec["reused"])

    n_workers = 1
    bar = tqdm(total=len(todo), desc="frames", unit="frame", disable=not progress_bar or not todo)
    # PNG exposure not given: "auto" for the lit models — resolved on the first frame rendered and
    # kept for the others, so the frames do not flicker (pass display={"exposure": …} to fix it)
    fix_exposure = "exposure" not in display and MODEL_SPECS[model].lit and bool(todo)
    try:
        if fix_exposure:
            spec = FrameSpec(renderer_kwargs, render_kwargs, display, bool(radiance), numba_threads, run)
            rec = render_frame(spec, todo[0], vols[todo[0]], keys[todo[0]], cams[todo[0]], str(out)) if sync else \
                _first_on_cluster(client, workers, spec, todo[0], vols, keys, cams, out)
            record(rec)
            bar.update()
            todo = todo[1:]
            if rec.get("exposure") is not None:
                display = dict(display, exposure=rec["exposure"])
        if sync or not todo:
            spec = FrameSpec(renderer_kwargs, render_kwargs, display, bool(radiance), numba_threads, run)
            try:
                for i in todo:
                    record(render_frame(spec, i, vols[i], keys[i], cams[i], str(out)))
                    bar.update()
            finally:
                with _WORKER_LOCK:
                    _WORKER["renderers"].clear()  # this process keeps no volume after the call
        else:
            c, owned, n_workers, threads = _get_client(client, workers, numba_threads)
            try:
                n_workers = _run_on_cluster(c, FrameSpec(renderer_kwargs, render_kwargs, display, bool(radiance),
                                                         threads, run),
                                            todo, vols, keys, memory, cams, out, names, record, bar) or n_workers
            finally:
                for thing in owned:
                    try:
                        thing.close()
                    except Exception:  # noqa: BLE001 - closing after an interrupt may fail; nothing to save
                        pass
    finally:
        bar.close()
        _remove_parts(out, run)
    result = SeriesResult(out_dir=out, frames=[records[i] for i in sorted(records)],
                          wall_time=time.perf_counter() - t_start, workers=n_workers)
    if movie is not None and result.n_failed == 0:
        result.movie = write_movie(result.paths, movie, fps=fps)
    return result


def _first_on_cluster(client, workers, spec, i, vols, keys, cams, out):
    """Frame ``i`` rendered alone (on the cluster when one is given: its worker keeps the renderer),
    its record returned: the frame whose exposure the others take."""
    if client is None:  # no cluster yet: render it here (the cluster starts for the rest)
        try:
            return render_frame(spec, i, vols[i], keys[i], cams[i], str(out))
        finally:
            with _WORKER_LOCK:
                _WORKER["renderers"].clear()
    c, owned, _, _ = _get_client(client, workers)
    try:
        v = vols[i] if isinstance(vols[i], str) else (vols[i] if type(vols[i]).__name__ == "Volume"
                                                      else PackedImage.of(vols[i]))
        return c.submit(render_frame, spec, i, v, keys[i], cams[i], str(out), pure=False).result()
    finally:
        for thing in owned:
            thing.close()


def _run_on_cluster(c, spec, todo, vols, keys, memory, cams, out, names, record, bar):
    from distributed import as_completed

    spec_f = c.scatter(spec, broadcast=True, hash=False)
    mem_f = {}
    n_workers = len(c.scheduler_info().get("workers", {}))
    if memory:
        ids = list(memory)
        fs = c.scatter([memory[k] if type(memory[k]).__name__ == "Volume" else PackedImage.of(memory[k])
                        for k in ids], hash=False)
        if n_workers > 1:  # two copies: a worker that dies takes no volume with it
            c.replicate(fs, n=2)
        mem_f = dict(zip(ids, fs))
    futures = {}
    for i in todo:
        v = vols[i] if isinstance(vols[i], str) else mem_f[id(vols[i])]
        f = c.submit(render_frame, spec_f, i, v, keys[i], cams[i], str(out), pure=False,
                     key=f"pv-ambient-frame-{i:04d}-{spec.run}")
        futures[f] = i
    try:
        for f in as_completed(futures):
            i = futures[f]
            if f.status == "finished":
                record(f.result())
            else:
                try:
                    exc = f.exception()
                    err = f"{type(exc).__name__}: {exc}"
                except Exception as e:  # noqa: BLE001 - a cancelled or lost future
                    err = f"{type(e).__name__}: {e}"
                record({"index": i, "worker": None, "times": {}, "error": err, "reused": False})
            bar.update()
    except BaseException:
        c.cancel(list(futures), force=True)
        raise
    return len(c.scheduler_info().get("workers", {}))


# -- movie --------------------------------------------------------------------------------------
def _check_movie_support(movie):
    try:
        import imageio  # noqa: F401
    except ImportError:
        raise ImportError(MISSING_MOVIE.format(str(movie), "")) from None
    if Path(movie).suffix.lower() not in (".gif",):
        try:
            import imageio_ffmpeg  # noqa: F401
        except ImportError:
            raise ImportError(MISSING_MOVIE.format(str(movie), " with its ffmpeg plugin")) from None


def write_movie(frames, path, *, fps=10) -> Path:
    """Write PNG ``frames`` (in order) as a movie: ``.gif`` through Pillow, other suffixes through
    ffmpeg (``.mp4``: H.264). Needs the ``movie`` extra (imageio, imageio-ffmpeg)."""
    _check_movie_support(path)
    import imageio.v2 as imageio
    from PIL import Image

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    images = [np.asarray(Image.open(p).convert("RGB")) for p in frames]
    if not images:
        raise ValueError("no frames to write into a movie")
    if path.suffix.lower() == ".gif":
        imageio.mimsave(path, images, duration=1000.0 / fps, loop=0)
        return path
    h, w = images[0].shape[:2]
    if h % 2 or w % 2:  # H.264 in yuv420p needs even sizes: repeat the last row/column
        images = [np.pad(im, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge") for im in images]
    with imageio.get_writer(path, fps=fps, macro_block_size=1) as writer:
        for im in images:
            writer.append_data(im)
    return path


# -- the command line ---------------------------------------------------------------------------
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
    import json

    from .scene import parse_scene

    scene_path = Path(scene_path)
    try:
        data = json.loads(scene_path.read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"scene file {str(scene_path)!r} is not valid JSON: {exc}") from None
    if not isinstance(data, dict):
        raise TypeError(f"a scene must be a JSON object, got {type(data).__name__}")
    if (volumes is None) == (orbit_frames is None):
        raise ValueError("give volumes (a time series) or orbit_frames (an orbit), one of the two")
    base = scene_path.parent
    if volumes is not None:
        vols = resolve_volumes(volumes)
        # the options of the scene, checked once here; a small stand-in volume keeps the time steps
        # on the workers (each frame reads its own file)
        scene = parse_scene(dict(data, volume={"dataset": "cloud", "n": 2}), base_dir=base)
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
    client = {"local": None, "synchronous": "synchronous"}.get(args.scheduler, args.scheduler)
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
