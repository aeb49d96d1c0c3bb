"""The driver of a series: :func:`render_series` checks what every frame shares once, plans the
frames, renders them in this process or on ``dask.distributed``, and returns a record per frame
(docs/series.rst).

Everything a frame needs is checked here, on the client, before any work: a bad argument is one
error for the call, not one per frame on the workers. The default light rig of a lit model is
placed once, from the first frame's camera, by its owner (:func:`pv_ambient.inputs.lights.as_lights`,
as :meth:`pv_ambient.Renderer.place_lights` places it), so every frame on every worker is lit alike.
A lit model's PNG exposure, when not given, is the ``"auto"`` exposure of the first frame rendered,
kept for the others: the frames of a movie do not flicker. Frames whose files all exist are skipped,
so a re-run renders only what an interrupted run left out.
"""

from __future__ import annotations

import inspect
import os
import time
import uuid
from dataclasses import dataclass, field, replace
from pathlib import Path

from ..inputs.camera import Camera, as_camera
from ..inputs.lights import as_lights, default_view_lights
from ..inputs.transfer import as_transfer_function
from ..inputs.validation import check_choice, check_int, check_real
from ..rendering.presets import ALL_MODELS, MODEL_OPTIONS, MODEL_SPECS
from ..rendering.result import DISPLAY_KEYS, unknown_display_keys  # noqa: F401 (DISPLAY_KEYS: re-exported)
from .movie import check_movie_support, write_movie
from .volumes import for_worker, is_grid, resolve_volumes
from .worker import FrameSpec, forget_renderers, frame_outputs, remove_parts, render_frame


MISSING_DISTRIBUTED = ("render_series with client={!r} needs dask.distributed: install the 'distributed' extra "
                       "(pip install 'pv_ambient[distributed]'), or pass client='synchronous' to render in this "
                       "process")


# -- what a call returns ---------------------------------------------------------------------------
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

def open_client(client, workers, numba_threads=None):
    """The cluster of ``client`` (None: a new ``LocalCluster`` of ``workers`` processes; an address;
    a ``distributed.Client``): (client, things to close afterwards, number of workers, Numba threads
    per worker: ``numba_threads``, 1 when None on the cluster started here, None — the workers' own
    setting — on an existing one)."""
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


# -- checks made once, on the client --------------------------------------------------------------
def _render_parameters() -> set:
    from ..rendering.renderer import Renderer

    params = set(inspect.signature(Renderer.render).parameters) - {"self", "model_options", "camera"}
    return params | set(MODEL_OPTIONS) | {"time_budget"}


def _frames_and_cameras(vols, camera, cameras):
    """(volume, camera) of every frame: ``cameras`` one per frame (one volume repeated: an orbit),
    else ``camera`` (None: each volume's default view) for every volume."""
    if cameras is None:
        return vols, [None if camera is None else as_camera(camera)[0]] * len(vols)
    if is_grid(cameras) or isinstance(cameras, (str, dict, Camera)):
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
    return vols, cams


def _check_options(model, render_options, display, movie, fps, numba_threads):
    """The model, render options, display, movie and Numba threads checked: (display, fps, numba_threads)."""
    check_choice(model, "model", ALL_MODELS)
    unknown = set(render_options) - _render_parameters()
    if unknown:
        raise TypeError(f"render_series() got unknown options {sorted(unknown)}; render options are "
                        f"{sorted(_render_parameters())}")
    display = dict(display or {})
    if unknown_display_keys(display):
        raise ValueError(f"display must hold only {', '.join(DISPLAY_KEYS)}; got {sorted(display)}")
    if movie is not None:
        check_movie_support(movie)
        fps = check_real(fps, "fps", lo=0.0, lo_open=True)
    if numba_threads is not None:
        numba_threads = check_int(numba_threads, "numba_threads", lo=1)
    return display, fps, numba_threads


def _renderer_kwargs(model, first_camera, *, transfer_function, lights, scalars, component, preference,
                     nan_policy, backend) -> dict:
    """The :class:`~pv_ambient.Renderer` arguments of every frame, checked once. Lights not given
    (None) and a lit model: the default rig (docs/lights.rst) from its owner, placed once from the
    first frame's camera (or PyVista's default view: the volumes' bounds are known on the workers
    only, and one rig lights every frame), so an orbit keeps its lighting."""
    if lights is None and MODEL_SPECS[model].lit:
        lights = as_lights(None, camera=first_camera) if first_camera is not None else default_view_lights()
    kwargs = {"transfer_function": as_transfer_function(transfer_function), "scalars": scalars,
              "component": component, "lights": as_lights(lights if lights is not None else ()),
              "preference": preference, "nan_policy": nan_policy, "backend": backend}
    check_choice(preference, "preference", ("point", "cell"))
    check_choice(nan_policy, "nan_policy", ("raise", "vacuum"))
    return kwargs


# -- the frames to render ------------------------------------------------------------------------
@dataclass
class _Plan:
    """The frames of one call: volume, camera, name and renderer key of each, the in-memory volumes
    (one per distinct grid), the records so far and the indices still to render."""

    out: Path
    vols: list
    cams: list
    radiance: bool
    names: list = field(default_factory=list)
    keys: list = field(default_factory=list)
    memory: dict = field(default_factory=dict)
    records: dict = field(default_factory=dict)
    todo: list = field(default_factory=list)

    def record(self, rec: dict) -> None:
        """Keep the record a worker returned for its frame."""
        i = rec["index"]
        status = "failed" if rec["error"] else "rendered"
        self.records[i] = FrameRecord(i, self.names[i], status, frame_outputs(self.out, i, self.radiance),
                                      worker=rec["worker"], times=rec["times"], error=rec["error"],
                                      reused=rec["reused"])

    def failed(self, i: int, error: str) -> None:
        """Record frame ``i`` as failed where no worker returned a record (a lost or cancelled task)."""
        self.record({"index": i, "worker": None, "times": {}, "error": error, "reused": False})


def _plan_frames(out: Path, vols, cams, radiance, overwrite) -> _Plan:
    """Create ``out``, remove what a killed run left there, and plan the frames: those whose files
    all exist are skipped (unless ``overwrite``)."""
    out.mkdir(parents=True, exist_ok=True)
    remove_parts(out)  # what a killed run left behind
    plan = _Plan(out, vols, cams, radiance)
    plan.names = [v if isinstance(v, str) else f"<{type(v).__name__} {i}>" for i, v in enumerate(vols)]
    for v in vols:  # one key per distinct volume: the worker's renderer cache
        if isinstance(v, str):
            plan.keys.append("path:" + os.path.abspath(v))
        else:
            plan.memory.setdefault(id(v), v)
            plan.keys.append(f"memory:{id(v)}")
    for i in range(len(vols)):
        paths = frame_outputs(out, i, radiance)
        if not overwrite and all(p.exists() for p in paths):
            plan.records[i] = FrameRecord(i, plan.names[i], "skipped", paths)
        else:
            plan.todo.append(i)
    return plan


# -- rendering them ------------------------------------------------------------------------------
def _render_frames(plan: _Plan, spec: FrameSpec, *, client, workers, sync, fix_exposure, progress_bar) -> int:
    """Render the planned frames (the first alone when its exposure is to be kept for the others);
    return the number of workers. The run's temporary files are removed however it ends."""
    from tqdm.auto import tqdm

    n_workers = 1
    bar = tqdm(total=len(plan.todo), desc="frames", unit="frame", disable=not progress_bar or not plan.todo)
    try:
        if fix_exposure:
            spec = _first_frame(plan, spec, client, workers, sync)
            bar.update()
        if sync or not plan.todo:
            _render_here(plan, spec, bar)
        else:
            n_workers = _render_on_cluster(plan, spec, client, workers, bar)
    finally:
        bar.close()
        remove_parts(plan.out, spec.run)
    return n_workers


def _first_frame(plan: _Plan, spec: FrameSpec, client, workers, sync) -> FrameSpec:
    """Render the first frame to do alone; return ``spec`` with its ``"auto"`` exposure fixed for
    the PNGs of the other frames (no flicker)."""
    i = plan.todo.pop(0)
    rec = render_frame(spec, i, plan.vols[i], plan.keys[i], plan.cams[i], str(plan.out)) if sync else \
        _first_on_cluster(client, workers, spec, i, plan)
    plan.record(rec)
    if rec.get("exposure") is not None:
        spec = replace(spec, display=dict(spec.display, exposure=rec["exposure"]))
    return spec


def _first_on_cluster(client, workers, spec, i, plan):
    """Frame ``i`` rendered alone (on the cluster when one is given: its worker keeps the renderer),
    its record returned: the frame whose exposure the others take."""
    if client is None:  # no cluster yet: render it here (the cluster starts for the rest)
        try:
            return render_frame(spec, i, plan.vols[i], plan.keys[i], plan.cams[i], str(plan.out))
        finally:
            forget_renderers()
    c, owned, _, _ = open_client(client, workers)
    try:
        return c.submit(render_frame, spec, i, for_worker(plan.vols[i]), plan.keys[i], plan.cams[i], str(plan.out),
                        pure=False).result()
    finally:
        for thing in owned:
            thing.close()


def _render_here(plan: _Plan, spec: FrameSpec, bar) -> None:
    """Render the frames one after the other in this process (``client="synchronous"``)."""
    try:
        for i in plan.todo:
            plan.record(render_frame(spec, i, plan.vols[i], plan.keys[i], plan.cams[i], str(plan.out)))
            bar.update()
    finally:
        forget_renderers()  # this process keeps no volume after the call


def _render_on_cluster(plan: _Plan, spec: FrameSpec, client, workers, bar) -> int:
    """Render the frames on the cluster of ``client`` (started and closed here for None); return
    the number of its workers."""
    c, owned, n_workers, threads = open_client(client, workers, spec.numba_threads)
    try:
        return _run_on_cluster(c, replace(spec, numba_threads=threads), plan, bar) or n_workers
    finally:
        for thing in owned:
            try:
                thing.close()
            except Exception:  # noqa: BLE001 - closing after an interrupt may fail; nothing to save
                pass


def _run_on_cluster(c, spec, plan, bar):
    from distributed import as_completed

    spec_f = c.scatter(spec, broadcast=True, hash=False)
    mem_f = {}
    n_workers = len(c.scheduler_info().get("workers", {}))
    if plan.memory:
        ids = list(plan.memory)
        fs = c.scatter([for_worker(plan.memory[k]) for k in ids], hash=False)
        if n_workers > 1:  # two copies: a worker that dies takes no volume with it
            c.replicate(fs, n=2)
        mem_f = dict(zip(ids, fs))
    futures = {}
    for i in plan.todo:
        v = plan.vols[i] if isinstance(plan.vols[i], str) else mem_f[id(plan.vols[i])]
        f = c.submit(render_frame, spec_f, i, v, plan.keys[i], plan.cams[i], str(plan.out), pure=False,
                     key=f"pv-ambient-frame-{i:04d}-{spec.run}")
        futures[f] = i
    try:
        for f in as_completed(futures):
            i = futures[f]
            if f.status == "finished":
                plan.record(f.result())
            else:
                try:
                    exc = f.exception()
                    err = f"{type(exc).__name__}: {exc}"
                except Exception as e:  # noqa: BLE001 - a cancelled or lost future
                    err = f"{type(e).__name__}: {e}"
                plan.failed(i, err)
            bar.update()
    except BaseException:
        c.cancel(list(futures), force=True)
        raise
    return len(c.scheduler_info().get("workers", {}))


# -- the function --------------------------------------------------------------------------------
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
        One camera per frame: with one volume, an orbit (:func:`~pv_ambient.orbit`); with as many volumes as
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
    t_start = time.perf_counter()
    if out_dir is None:
        raise TypeError("out_dir is required: the folder the frames are written to")
    out = Path(out_dir)
    vols, cams = _frames_and_cameras(resolve_volumes(volumes), camera, cameras)
    display, fps, numba_threads = _check_options(model, render_options, display, movie, fps, numba_threads)
    sync = isinstance(client, str) and client == "synchronous"
    renderer_kwargs = _renderer_kwargs(model, cams[0], transfer_function=transfer_function, lights=lights,
                                       scalars=scalars, component=component, preference=preference,
                                       nan_policy=nan_policy, backend=backend)
    spec = FrameSpec(renderer_kwargs, dict(render_options, model=model, progress_bar=False), display,
                     bool(radiance), numba_threads, uuid.uuid4().hex[:12])
    plan = _plan_frames(out, vols, cams, radiance, overwrite)
    # PNG exposure not given: "auto" for the lit models — resolved on the first frame rendered and
    # kept for the others, so the frames do not flicker (pass display={"exposure": …} to fix it)
    fix_exposure = "exposure" not in display and MODEL_SPECS[model].lit and bool(plan.todo)
    n_workers = _render_frames(plan, spec, client=client, workers=workers, sync=sync, fix_exposure=fix_exposure,
                               progress_bar=progress_bar)
    result = SeriesResult(out_dir=out, frames=[plan.records[i] for i in sorted(plan.records)],
                          wall_time=time.perf_counter() - t_start, workers=n_workers)
    if movie is not None and result.n_failed == 0:
        result.movie = write_movie(result.paths, movie, fps=fps)
    return result
