"""Compute backends: ``"cpu"`` (Numba ``prange`` drivers) and ``"cuda"`` (the same scalar kernels
compiled for an NVIDIA GPU by numba-cuda, docs/architecture.rst), chosen by ``backend="auto" | "cpu" | "cuda"``.

``auto`` takes CUDA when the ``numba-cuda`` package is installed (``pip install
"pv_ambient[cuda]"``), can compile with this NumPy and a GPU is visible, and the CPU otherwise; the
render's metadata says which ran (``metadata["backend"]``). When numba-cuda is installed but cannot
run, ``auto`` says why in one RuntimeWarning per process; without numba-cuda it says nothing (the
CPU is then the installed backend). Asking for ``"cuda"`` when it cannot run raises an error that
says what is missing: the package (and the extra that installs it), a NumPy it can compile with,
or a device.

The CUDA side keeps a :class:`DeviceCache` per :class:`~pv_ambient.Renderer`: the volume, its
lookup tables, majorant, ball (σ̄) grid, preintegrated table and light volumes are uploaded once
and stay on the GPU between renders, so a camera move is one kernel launch and one image
download; a relight sweeps the new light's optical depth on the GPU and rebakes its slot of the
lights' in-scattering there (:func:`bake`; the rest stays resident).
``NUMBA_ENABLE_CUDASIM=1`` (set before numba is first imported) runs the CUDA drivers in Numba's
simulator — slow, pure Python, but the same code path: the test suite uses it on tiny scenes.

This module imports without pyvista, vtk or numba-cuda.

Examples
--------
>>> from pv_ambient.backend import resolve_backend
>>> resolve_backend("cpu")
'cpu'
>>> resolve_backend("auto") in ("cpu", "cuda")
True
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import sys
import warnings

import numpy as np


from .device_cache import (DeviceCache, DeviceMemoryError, check_free, free_device_memory, host_flat,  # noqa: F401
                           image_buffers, simulator)

BACKENDS = ("auto", "cpu", "cuda")


_BLAS = None


@contextlib.contextmanager
def blas_one_thread():
    """Run the enclosed code with the BLAS libraries (NumPy's and SciPy's OpenBLAS or MKL) on one
    thread, restoring their thread counts after.

    The renderer's own BLAS calls are small (norms and dot products of the diffusion solver's
    vectors, a coarse-grid product), but a multi-threaded BLAS keeps its worker threads spinning
    for a while after each call, and they take the cores from the Numba kernels that follow
    (docs/performance.rst, "BLAS threads"). With one BLAS thread there are no such workers. Uses
    :mod:`threadpoolctl`, which finds the loaded BLAS libraries; its controller is built once, at
    the first render.

    .. versionadded:: 0.4.0

    >>> import numpy as np
    >>> with blas_one_thread():
    ...     float(np.dot(np.ones(4), np.ones(4)))
    4.0
    """
    global _BLAS
    if _BLAS is None:
        import scipy.linalg  # noqa: F401  (SciPy's own BLAS: loaded before the controller looks)
        from threadpoolctl import ThreadpoolController

        _BLAS = ThreadpoolController()
    with _BLAS.limit(limits=1, user_api="blas"):
        yield


#: The BLAS limit of the render under way when it is entered on demand (:func:`blas_on_demand`).
_BLAS_SCOPE = contextvars.ContextVar("pv_ambient_blas_scope", default=None)


@contextlib.contextmanager
def blas_on_demand():
    """:func:`blas_one_thread` for a render whose kernels run on the GPU, entered only if the
    render computes a stage (:func:`blas_before_stage`, called by the scene cache on a miss).

    The limit exists for the CPU's Numba kernels, which spinning BLAS workers would slow
    (docs/performance.rst, "BLAS threads"); a CUDA camera move computes no stage, calls no BLAS
    and runs no CPU kernel, so it does not pay threadpoolctl's library calls (docs/performance.rst,
    "Host work of a frame").

    .. versionadded:: 0.4.0
    """
    scope = []
    token = _BLAS_SCOPE.set(scope)
    try:
        yield
    finally:
        _BLAS_SCOPE.reset(token)
        if scope:
            scope[0].__exit__(None, None, None)


def blas_before_stage():
    """Enter the BLAS limit of the render under way, if it waits for a stage (:func:`blas_on_demand`)."""
    scope = _BLAS_SCOPE.get()
    if scope is not None and not scope:
        limit = blas_one_thread()
        limit.__enter__()
        scope.append(limit)


#: Per process: ``"problem"``, :func:`cuda_problem`'s answer once asked, and ``"warned"`` once ``auto``
#: has said why it took the CPU.
_CUDA_STATE = {}


def cuda_problem():
    """None when the CUDA backend can run here, else the exception that says why not: a
    ModuleNotFoundError when numba-cuda is not installed, an ImportError when it cannot compile with
    this NumPy (:func:`numpy_clash`), a RuntimeError when no device is visible.

    Every render asks it, and a frame's host work is kept to what the frame needs
    (docs/performance.rst, "Installing the CUDA backend"): the answer is found once per process, the
    driver asked for a device once, not per frame. The simulator, an environment variable, is read
    each time.

    .. versionchanged:: 0.4.0
       Found once per process; a missing package is a ModuleNotFoundError.
    """
    if simulator():
        return None
    if "problem" not in _CUDA_STATE:
        _CUDA_STATE["problem"] = _find_cuda_problem()
    problem = _CUDA_STATE["problem"]
    # a new exception each time: one raised again and again would keep every raise's frames
    return None if problem is None else type(problem)(*problem.args)


def _find_cuda_problem():
    try:
        import numba_cuda  # noqa: F401  (the numba-cuda package: the [cuda] extra)
    except ImportError:
        return ModuleNotFoundError("backend='cuda' needs the numba-cuda package, which is not installed: "
                                   "pip install \"pv_ambient[cuda]\"")
    version = getattr(numba_cuda, "__version__", None)
    if version is None and getattr(numba_cuda, "__file__", None):  # an installed package: its metadata
        try:
            from importlib.metadata import version as dist_version

            version = dist_version("numba-cuda")
        except Exception:  # noqa: BLE001 - no metadata: nothing to check against
            version = None
    clash = numpy_clash(version)
    if clash is not None:
        return clash
    try:
        from numba import cuda

        ok = bool(cuda.is_available())
    except Exception:  # noqa: BLE001 - a broken driver reads as "no device"
        ok = False
    if not ok:
        return RuntimeError("backend='cuda': numba-cuda is installed but no CUDA device is visible "
                            "(numba.cuda.is_available() is False: check the NVIDIA driver and "
                            "CUDA_VISIBLE_DEVICES)")
    return None


#: The last numba-cuda release known to compile kernels through ``numpy.row_stack``, which NumPy 2.5
#: removed: with it the first kernel compilation fails (docs/performance.rst, "GPU"). Later
#: releases are not known to fail and are let through.
NUMBA_CUDA_ROW_STACK = (0, 30, 4)


def numpy_clash(numba_cuda_version):
    """An ImportError when numba-cuda ``numba_cuda_version`` cannot compile a kernel with this NumPy
    (it needs ``numpy.row_stack``, gone in NumPy 2.5), else None.

    .. versionadded:: 0.4.0

    >>> import numpy as np
    >>> numpy_clash("0.31.0") is None
    True
    >>> hasattr(np, "row_stack") or "numpy<2.5" in str(numpy_clash("0.30.4"))
    True
    """
    if hasattr(np, "row_stack") or not numba_cuda_version:
        return None
    try:
        release = tuple(int(p) for p in str(numba_cuda_version).split(".")[:3])
    except ValueError:
        return None
    if release > NUMBA_CUDA_ROW_STACK:
        return None
    return ImportError(f"backend='cuda': numba-cuda {numba_cuda_version} compiles kernels through "
                       f"numpy.row_stack, which NumPy {np.__version__} no longer has; install "
                       "\"numpy<2.5\" beside it (or a numba-cuda release that supports this NumPy)")


def kernel_compiled(kind) -> bool:
    """Whether the CPU driver of ``kind`` (``"raycast"`` or ``"path_trace"``) is compiled in this
    process or held by Numba's on-disk cache (else its first launch compiles it). True where this
    Numba keeps its cache elsewhere: say nothing rather than something wrong."""
    if kind == "path_trace":
        from ._kernels.pathtrace import pathtrace_image as fn
    else:  # the specialisations share one cache index
        from ._kernels.raycast import RAYCAST_DRIVERS

        fns = list(RAYCAST_DRIVERS.values())
        if any(f.signatures for f in fns):
            return True
        fn = fns[0]
    try:
        return bool(fn.signatures) or os.path.exists(fn._cache._cache_file._index_path)
    except AttributeError:
        return True


def check_backend(backend, name="backend") -> str:
    """``backend`` when it names a backend (:data:`BACKENDS`), else a ValueError that names the
    argument: the one check of a backend's name (the renderer, the scene format, the series and the
    command line ask it).

    >>> check_backend("cpu")
    'cpu'
    """
    if not isinstance(backend, str) or backend not in BACKENDS:
        raise ValueError(f"{name} must be one of {', '.join(map(repr, BACKENDS))}; got {backend!r}")
    return backend


def resolve_backend(backend="auto") -> str:
    """``"cpu"`` or ``"cuda"``: the backend ``backend`` stands for on this machine.

    Raises the :func:`cuda_problem` error for ``"cuda"`` when CUDA cannot run. ``"auto"`` then takes
    the CPU; when numba-cuda is installed (so the user meant to have the GPU) it says why in a
    RuntimeWarning, once per process — not per frame — and without numba-cuda it stays silent, as on
    any CPU-only install (docs/performance.rst, "Installing the CUDA backend").

    .. versionchanged:: 0.4.0
       ``"auto"`` warns once when numba-cuda is installed but cannot run.
    """
    if check_backend(backend) == "cpu":
        return "cpu"
    problem = cuda_problem()
    if problem is None:
        return "cuda"
    if backend == "cuda":
        raise problem
    if not isinstance(problem, ModuleNotFoundError) and not _CUDA_STATE.get("warned"):
        _CUDA_STATE["warned"] = True
        why = str(problem).removeprefix("backend='cuda': ")
        warnings.warn(f"backend='auto' renders on the CPU: {why}", RuntimeWarning, stacklevel=_caller_stacklevel())
    return "cpu"


def _caller_stacklevel() -> int:
    """The ``warnings.warn`` stacklevel, for the function that calls this one, of the first frame
    outside the package: the user's call, however deep in the package the warning is raised."""
    package = os.path.dirname(os.path.abspath(__file__))
    frame, level = sys._getframe(1), 1
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(package + os.sep):
        frame, level = frame.f_back, level + 1
    return level


def check_fits(cache: DeviceCache, arrays, extra_bytes=0):
    """Raise :class:`DeviceMemoryError` when uploading ``arrays`` plus ``extra_bytes`` of outputs
    would not fit in the GPU's free memory (the GPU is asked only when there is something to
    upload)."""
    need = cache.need(arrays) + int(extra_bytes)
    if need:
        check_free(need)


@contextlib.contextmanager
def launch_context():
    """Around kernel launches: wait for the GPU at the end; in the simulator, which runs the uint64
    hash in numpy scalars, silence their (intended) wrap-around warnings."""
    from numba import cuda

    with warnings.catch_warnings():
        if simulator():
            warnings.filterwarnings("ignore", "overflow encountered", RuntimeWarning)
        yield
        cuda.synchronize()


def raycast(cache: DeviceCache, args, row0, row1, rad, alpha):
    """Run the ray-cast kernel on rows [row0, row1) of ``rad``/``alpha`` (host arrays, filled in).

    ``args`` are :func:`pv_ambient._kernels.raycast.raycast_image`'s arguments before the rows
    and outputs: the model id and the records. Raises :class:`DeviceMemoryError` before any upload
    when the scene does not fit. The kernel writes into the cache's device image of this size
    (:meth:`DeviceCache.output`); a whole image whose ``rad`` and ``alpha`` come from
    :func:`image_buffers` comes home in one copy, other buffers in one copy each
    (docs/performance.rst, "Host work of a frame")."""
    from ._kernels.cuda import BLOCK, grid_for, raycast_kernel_for
    from .cuda_launch import launch

    h, w = alpha.shape
    kernel = raycast_kernel_for(args[0], args[5].baked, args[3].mode)  # the model's own (its id compiled in)
    dev_args = cache.args(args[1:], extra_bytes=cache.output_bytes(h, w))
    flat, d_rad, d_alpha = cache.output(h, w)
    with launch_context():
        launch(kernel, grid_for(w, row1 - row0), BLOCK, (*dev_args, d_rad, d_alpha, row0, row1), cache.launch_memo)
    host = host_flat(rad, alpha) if (row0, row1) == (0, h) else None
    if host is not None:
        flat.copy_to_host(host)
    else:
        d_rad[row0:row1].copy_to_host(rad[row0:row1])
        d_alpha[row0:row1].copy_to_host(alpha[row0:row1])
    cache.tick()


class PathSums:
    """Device-resident float64 sums of the path tracer (Σx, Σx², Σhit)."""

    def __init__(self, h, w):
        from numba import cuda

        self.sum_rad = cuda.to_device(np.zeros((h, w, 3)))
        self.sum_sq = cuda.to_device(np.zeros((h, w, 3)))
        self.sum_hit = cuda.to_device(np.zeros((h, w)))

    def download(self, sum_rad, sum_sq, sum_hit):
        sum_rad[:] = self.sum_rad.copy_to_host()
        sum_sq[:] = self.sum_sq.copy_to_host()
        sum_hit[:] = self.sum_hit.copy_to_host()


def pathtrace(cache: DeviceCache, args, s0, s1, sums: PathSums):
    """Add samples [s0, s1) of every pixel to the device sums (``args``: ``pathtrace_image``'s
    records, or ``residual_image``'s: the path tracer's four and a control variate's five)."""
    from ._kernels.cuda import BLOCK, grid_for, pathtrace_kernel, residual_kernel

    h, w = sums.sum_hit.shape
    kernel = pathtrace_kernel if len(args) == 4 else residual_kernel
    with launch_context():
        kernel[grid_for(w, h), BLOCK](*cache.args(args), s0, s1, sums.sum_rad, sums.sum_sq,
                                                sums.sum_hit, 0, h)
    cache.tick()


def sweep(cache: DeviceCache, sig_l, B, is_point, lx, ly, lz, sweeps, jump, out):
    """The optical-depth sweeps of :func:`pv_ambient.stages.propagation.optical_depth` on the GPU: one
    kernel launch per layer (the layers depend on each other), nodes of a layer in parallel.
    Fills the host array ``out`` and registers its device copy in ``cache``."""
    from numba import cuda

    from ._kernels.cuda import BLOCK, grid_for, sweep_layer_kernel
    from ._kernels.lightvol import sweep_start

    d_sig = cache.get(sig_l)
    d_B = cache.get(B)
    d_out = cuda.to_device(out)
    shape = sig_l.shape
    with launch_context():
        for a, s in sweeps:
            nb, nc = [shape[i] for i in range(3) if i != a]
            d_hist = cuda.to_device(np.zeros((jump + 1, nb, nc)))
            la = (lx, ly, lz)[a]
            k = sweep_start(shape[a], is_point, la, s)
            done = 0
            grid = grid_for(nc, nb)
            while 0 <= k < shape[a]:
                J = min(jump, done)
                sweep_layer_kernel[grid, BLOCK](d_sig, d_B, is_point, lx, ly, lz, a, k, J,
                                                d_hist[(done - J) % (jump + 1)], d_out, d_hist[done % (jump + 1)],
                                                0, nb)
                done += 1
                k += s
    out[:] = d_out.copy_to_host()
    cache.put(out, d_out)


def bake(cache: DeviceCache, model_id, parts, clear, fold, records, w2i, i2w, lo, step, nch, out, fresh):
    """The bake of :func:`pv_ambient.stages.bake.bake_incident` on the GPU, one thread per light-grid
    node (:data:`pv_ambient._kernels.cuda.BAKE_KERNELS`, the CPU's :func:`~pv_ambient._kernels.bake.bake_node`):
    the channel ranges ``clear`` ((first, count) pairs) set to 0, then each of ``parts`` —
    ``(q, lights, tau, phi)``: one light's Lights record, its optical depth and front (``phi`` None:
    the optical depth again) — added to slot ``q``, then ``fold`` — ``(diffusion, q)`` or None —
    added to slot ``q``. ``records`` are the light grid's and Ambient records (the grid's ``tau`` and
    ``phi`` placeholders, replaced per light).

    The bake is made in the device copy of ``out`` — a new device array when ``fresh`` (every slot is
    cleared and baked), else the copy the cache holds (a relight rebaking in place: the slots kept
    stay on the device) or an upload of ``out`` — and downloaded into ``out``; the cache then holds
    that device copy, so the ray cast that reads the bake uploads nothing. The optical depths come
    from the cache too (the GPU's sweep left them there). Raises :class:`DeviceMemoryError` before
    any upload or launch when the arrays would not fit."""
    from numba import cuda

    from ._kernels.cuda import BAKE_KERNELS, BLOCK3, clear_kernel, fold_kernel, grid3_for
    from ._kernels.records import arrays
    from .device_cache import device_reshape

    grec, arec = records
    inputs = [a for _q, _l, tau, phi in parts for a in (tau, phi) if a is not None] + arrays(arec)
    check_fits(cache, inputs + ([fold[0]] if fold is not None else []) + [out])
    d_out = cuda.device_array(out.shape, np.float32) if fresh else cache.get(out)
    d_w2i, d_i2w, d_lo, d_step = (cache.get(np.ascontiguousarray(a, np.float64)) for a in (w2i, i2w, lo, step))

    def volume(a):  # a light's volume as the records take it: (m0, m1, m2, channels)
        d = cache.get(a)
        return device_reshape(d, a.shape + (1,)) if a.ndim == 3 else d

    blocks = grid3_for(out.shape)
    kernel = BAKE_KERNELS[model_id]
    on_samples = bool(np.all(np.asarray(lo) == 0.0) and np.all(np.asarray(step) == 1.0)
                      and tuple(arec.ball.shape[:3]) == tuple(out.shape[:3]))  # as the CPU driver decides
    with launch_context():
        for q, n in clear:
            clear_kernel[blocks, BLOCK3](q, n, d_out)
        for q, lights, tau, phi in parts:
            d_tau = volume(tau)
            d_lights, d_ambient = cache.args((lights, arec))
            d_grid = cache.args((grec,))[0]._replace(tau=d_tau, phi=d_tau if phi is None else volume(phi))
            kernel[blocks, BLOCK3](d_lights, d_grid, d_ambient, d_w2i, d_i2w, d_lo, d_step, nch, q, on_samples, d_out)
        if fold is not None:
            fold_kernel[blocks, BLOCK3](cache.get(fold[0]), fold[1], nch, d_out)
    d_out.copy_to_host(out)
    cache.put(out, d_out)


def medium_grid(cache: DeviceCache, kind, args, out):
    """A grid of the medium on the GPU: kernel ``kind`` of :data:`pv_ambient._kernels.cuda.MEDIUM_KERNELS`
    (σt on the data samples or the light-grid nodes, a majorant grid) on ``args`` — its arguments
    before the output, arrays found in or uploaded to the cache (the field and the table the ray
    cast reads too) — one thread per entry of host array ``out``. ``out`` is filled by a download
    and the cache then holds its device copy, so the stages and the ray cast that read it upload
    nothing. Raises :class:`DeviceMemoryError` before any upload or launch when it does not fit."""
    from numba import cuda

    from ._kernels.cuda import BLOCK3, MEDIUM_KERNELS, grid3_for

    check_fits(cache, [a for a in args if isinstance(a, np.ndarray)] + [out])
    dev = [cache.get(a) if isinstance(a, np.ndarray) else a for a in args]
    d_out = cuda.device_array(out.shape, out.dtype)
    with launch_context():
        MEDIUM_KERNELS[kind][grid3_for(out.shape), BLOCK3](*dev, d_out)
    d_out.copy_to_host(out)
    cache.put(out, d_out)


def tiles(n, count):
    """``count`` (at most ``n``) row ranges [r0, r1) covering ``n`` rows."""
    edges = np.linspace(0, n, min(count, n) + 1).astype(int)
    return list(zip(edges[:-1], edges[1:]))


def run_raycast(args, rad, alpha, *, backend, asked, device_cache=None, progress_bar=False, name="") -> str:
    """The ray cast of a whole image on ``backend`` (``"cpu"`` or ``"cuda"``), filling ``rad`` and
    ``alpha``; returns the backend that ran — ``"cpu"`` after a fallback, when ``asked`` was
    ``"auto"`` and the scene does not fit in the GPU's free memory (with a warning).

    ``args`` are :func:`pv_ambient._kernels.raycast.raycast_image`'s arguments before the rows and
    outputs (the model id and the records). On the CPU the image is cast in row tiles, so Ctrl-C is
    seen between tiles and ``progress_bar`` counts them.
    """
    if backend == "cuda":
        try:  # the memory check comes before any upload, and only when there is something to upload
            raycast(device_cache, args, 0, rad.shape[0], rad, alpha)
        except DeviceMemoryError as exc:
            if asked == "cuda":
                raise
            warnings.warn(f"{exc}; rendering on the CPU instead", RuntimeWarning, stacklevel=5)
            backend = "cpu"
        else:
            return "cuda"
    from ._kernels.packet import raycast_image

    parts = tiles(rad.shape[0], 16 if progress_bar else 4)
    bar = None
    if progress_bar:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(parts), desc=name, unit="tile")
    try:
        for r0, r1 in parts:
            raycast_image(*args, r0, r1, rad, alpha)
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    return "cpu"
