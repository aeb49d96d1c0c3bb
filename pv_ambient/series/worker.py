"""What a worker runs: one frame of a series, rendered and written (docs/series.rst, "What is
shared and what is reused" and "Files, interruptions and re-runs").

Each frame runs the code path of ``pv-ambient render`` (a :class:`~pv_ambient.Renderer` and its
``render``), so a frame is the image the command writes for the same scene and volume. What every
frame shares travels once, as a :class:`FrameSpec`. A worker process keeps the preintegrated table
slices it has loaded and the renderer of the last volume it rendered (:data:`RENDERERS_PER_WORKER`):
the frames of an orbit after the first on a worker run the ray cast only.

Files are written atomically: each goes to a hidden temporary name (``.frame_0003.<run>.part.png``)
and is renamed when complete, the ``.npy`` before the ``.png``, so an interrupted run leaves only
whole frames and a re-run can tell a finished frame by its files. A frame's error is returned in its
record, not raised: one bad time step does not stop the others.
"""

from __future__ import annotations

import os
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path

from ..rendering.cache import SceneCache
from .volumes import load_volume

#: File name of frame ``i`` without its suffix.
FRAME_STEM = "frame_{:04d}"
#: Marker in the temporary names of files being written (``.frame_0003.<run>.part.png``).
PART = ".part"
#: How many :class:`~pv_ambient.Renderer` objects a worker keeps (the volumes it rendered last).
RENDERERS_PER_WORKER = 1


@dataclass(frozen=True)
class FrameSpec:
    """What every frame of one :func:`~pv_ambient.render_series` call shares; sent to each worker once."""

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
    from ..rendering.renderer import Renderer

    with _WORKER_LOCK:
        if _WORKER["run"] != spec.run:
            _WORKER["run"] = spec.run
            _WORKER["renderers"].clear()
        r = _WORKER["renderers"].get(key)
        if r is not None:
            _WORKER["renderers"].move_to_end(key)
            return r, True, 0.0, 0.0
    t = time.perf_counter()
    grid = load_volume(volume)
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


def forget_renderers() -> None:
    """Drop the renderers this process keeps: the client calls it after rendering frames itself
    (``client="synchronous"``), so that no volume stays in its memory after the call."""
    with _WORKER_LOCK:
        _WORKER["renderers"].clear()


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


def remove_parts(out_dir: Path, run: str | None = None) -> None:
    """Remove the temporary files of run ``run`` in ``out_dir`` (of every run when None: what a
    killed run left behind)."""
    pattern = f".frame_*.{run}{PART}.*" if run else f".frame_*{PART}.*"
    for p in out_dir.glob(pattern):
        p.unlink(missing_ok=True)


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

