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

The command line (``pv-ambient series``, in :mod:`pv_ambient.cli`) is the same function::

    pv-ambient series scene.json --volumes "run/step_*.vti" -o frames --movie run.mp4
    pv-ambient series scene.json --orbit 36 -o orbit --scheduler tcp://scheduler:8786

One module a job: :mod:`.volumes` (volume lists, globs, ``.pvd``, packing and reading),
:mod:`.worker` (one frame rendered and written), :mod:`.driver` (:func:`render_series`, clusters,
result records), :mod:`.movie` (:func:`write_movie`); the cameras of an orbit are
:func:`pv_ambient.inputs.camera.orbit`, beside the other camera helpers.

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

from ..inputs.camera import orbit
from .driver import DISPLAY_KEYS, MISSING_DISTRIBUTED, FrameRecord, SeriesResult, render_series
from .movie import MISSING_MOVIE, write_movie
from .volumes import PackedImage, pvd_files, read_volume, resolve_volumes
from .worker import FRAME_STEM, PART, RENDERERS_PER_WORKER, FrameSpec, frame_outputs, render_frame

#: The ``pv-ambient series`` command's names, which live in :mod:`pv_ambient.cli` (the command line
#: reads scene files through :mod:`pv_ambient.scene`) and stay importable from here.
COMMAND_LINE = ("SCHEDULERS", "add_cli_parser", "cli_series", "series_from_scene")

__all__ = ["DISPLAY_KEYS", "FRAME_STEM", "FrameRecord", "FrameSpec", "MISSING_DISTRIBUTED", "MISSING_MOVIE", "PART",
           "PackedImage", "RENDERERS_PER_WORKER", "SeriesResult", "frame_outputs", "orbit", "pvd_files", "read_volume",
           "render_frame", "render_series", "resolve_volumes", "write_movie", *COMMAND_LINE]


def __getattr__(name):
    # imported when asked for, not with this package: the command line sits above the series
    if name in COMMAND_LINE:
        from .. import cli

        return getattr(cli, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
