"""The ``path_traced`` reference (DESIGN §2, §6): unbiased Monte Carlo with a standard-error image.

:func:`path_trace` runs the path tracer of :mod:`pv_ambient._kernels.pathtrace` progressively,
``batch`` samples per pixel at a time, keeping per-pixel float64 sums of ``x`` and ``x²`` so the
standard error of every pixel's mean is known at any point; with ``target_error`` it stops as
soon as the image's relative standard error reaches it. The estimator is documented in
:mod:`pv_ambient._kernels.pathtrace`; in short: delta tracking through the per-block majorant
grid, emission ``(1 − a)·Le`` at real collisions, next-event estimation to every light with
ratio-tracked shadow rays, RGB albedo as a path weight, phase-function importance sampling and
Russian roulette, background seen by primary rays only.

Results are a pure function of the scene, camera, options and ``seed``: random numbers are
counter-based, keyed by (seed, pixel, sample), and each pixel is accumulated in sample order,
so the image is bitwise the same for any thread count (``NUMBA_NUM_THREADS``).

This module imports neither pyvista nor vtk (the default camera, computed by VTK, is imported
only when ``camera`` is None).
"""

from __future__ import annotations

import time

import numpy as np

from ..inputs.validation import check_int, check_real, check_rgb
from ..backend import resolve_backend
from ..inputs.lights import pack_lights
from ..rendering.result import RenderResult

#: Majorant block size (samples per axis) of the trackers.
MAJORANT_BLOCK = 8
#: Russian roulette on the path throughput starts after this many collisions.
RR_DEPTH = 3
_NO_LIMIT = 2 ** 62


def relative_error(radiance, std_error, alpha):
    """The image's relative standard error: mean standard error over mean radiance, both over the
    non-background pixels (those whose primary ray hit the medium at least once) and channels.

    0 when nothing was hit or the image is black with zero error; ``inf`` for a black image with
    a non-zero error.
    """
    mask = alpha > 0
    if not np.any(mask):
        return 0.0
    se = float(np.mean(std_error[mask]))
    mean = float(np.mean(radiance[mask]))
    if mean <= 0.0:
        return 0.0 if se <= 0.0 else float("inf")
    return se / mean


def path_trace(renderer, camera=None, window_size=None, *, phase=None, samples_per_pixel=64, target_error=None,
               max_depth=None, seed=0, background=(0.0, 0.0, 0.0), progress_bar=False, batch=16,
               light_clamp=None, majorant_block=MAJORANT_BLOCK, rr_depth=RR_DEPTH, backend="cpu",
               time_limit=None) -> RenderResult:
    """Render the unbiased path-traced reference of a :class:`~pv_ambient.Renderer`'s scene.

    Parameters
    ----------
    renderer : pv_ambient.Renderer
        The volume, its optical properties and its lights (``renderer.lights``).
    camera : Camera, pyvista.Camera, pyvista.Plotter, dict or list, optional
        PyVista's default isometric view of the volume when None.
    window_size : (int, int), optional
        ``(width, height)``; as :meth:`Renderer.render`.
    phase : PhaseFunction, float or dict, optional
        Phase function (isotropic when None).
    samples_per_pixel : int, default: 64
        Samples per pixel; with ``target_error`` the cap.
    target_error : float, optional
        Stop once the relative standard error (:func:`relative_error`: mean standard error over
        mean radiance on the pixels that see the medium) is at most this; checked after each
        batch from the second sample on.
    max_depth : int, optional
        Maximum number of collisions per path (≥ 1): 1 is single scattering plus emission;
        unlimited when None (Russian roulette ends paths; its survival probability is capped at
        0.999, so paths end even in a conservative medium, see :mod:`pv_ambient._kernels.pathtrace`).
    seed : int, default: 0
    background : RGB, default: (0, 0, 0)
        Constant background radiance seen through the volume by camera rays (not a light:
        scattered rays that leave the volume add nothing).
    progress_bar : bool, default: False
        Show a tqdm progress bar over samples per pixel.
    batch : int, default: 16
        Samples per pixel per pass (the granularity of ``target_error`` and the progress bar).
    light_clamp : float, optional
        A point light's ``I/d²`` is evaluated at ``max(d, light_clamp)``; default a quarter of
        the ``"balanced"`` ray step, as :meth:`Renderer.render` uses. The clamp bounds the
        otherwise infinite variance of next-event estimation next to a point light inside the
        medium.
    majorant_block : int, default: 8
        Samples per majorant block (smaller: tighter majorants, more block crossings).
    rr_depth : int, default: 3
        Collisions before Russian roulette starts.
    time_limit : float, optional
        Stop adding samples (``samples_per_pixel`` stays the cap) once the next batch would end
        after this many seconds from the start; at least one sample is always taken. The first
        batch is a single sample, which times one pass.
    backend : {"auto", "cpu", "cuda"}, default: "cpu"
        Where the paths are traced (:mod:`pv_ambient.backend`): the same per-path kernel and
        counter-based random numbers on both, so a seed gives the same image up to rounding.

    Returns
    -------
    RenderResult
        ``radiance`` the per-pixel mean, ``alpha`` the fraction of primary rays that collided
        (an unbiased estimate of 1 − transmittance), ``std_error`` the per-pixel standard error
        of the mean (``(H, W, 3)``; ``inf`` after a single sample), and ``metadata`` with ``spp``, ``time``, ``seed``,
        ``max_depth``, ``relative_error`` and the options.

    Examples
    --------
    >>> import pv_ambient
    >>> from pv_ambient import datasets
    >>> from pv_ambient.stages.reference import path_trace
    >>> r = pv_ambient.Renderer(datasets.cloud(n=16), lights=[pv_ambient.PointLight((2, 2, 2), 5.0)])
    >>> res = path_trace(r, window_size=(8, 6), samples_per_pixel=4)
    >>> res.radiance.shape, res.std_error.shape, res.metadata["spp"]
    ((6, 8, 3), (6, 8, 3), 4)
    """
    from .._kernels import records as K
    from .._kernels.pathtrace import pathtrace_image
    from ..inputs.camera import as_camera
    from ..inputs.phase import as_phase

    cam, size = as_camera(camera, window_size=window_size, bounds=renderer.bounds)
    spp = check_int(samples_per_pixel, "samples_per_pixel", lo=1)
    batch = check_int(batch, "batch", lo=1)
    target = None if target_error is None else check_real(target_error, "target_error", lo=0.0, lo_open=True)
    depth = _NO_LIMIT if max_depth is None else check_int(max_depth, "max_depth", lo=1)
    seed = check_int(seed, "seed", lo=0)
    bg = check_rgb(background, "background")
    block = check_int(majorant_block, "majorant_block", lo=1)
    rr_depth = check_int(rr_depth, "rr_depth", lo=0)
    limit = None if time_limit is None else check_real(time_limit, "time_limit", lo=0.0)
    if light_clamp is None:
        light_clamp = 0.25 * renderer.default_step("balanced")
    light_clamp = check_real(light_clamp, "light_clamp", lo=0.0)
    ph = as_phase(phase)
    backend = resolve_backend(backend)

    t_start = time.perf_counter()
    w, h = size
    sum_rad = np.zeros((h, w, 3))
    sum_sq = np.zeros((h, w, 3))
    sum_hit = np.zeros((h, w))
    geom = renderer.geometry
    n = 0
    rel = float("inf")
    if geom.is_empty:
        sum_rad[:] = bg * spp
        sum_sq[:] = bg * bg * spp
        n = spp
    else:
        args = (K.view_of(cam, size, geom), K.medium_of(renderer.optics, renderer.majorant(block), block),
                K.lights_of(pack_lights(renderer.lights), ph, light_clamp * light_clamp),
                K.Paths(bg, depth, rr_depth, seed))
        bar = None
        sums = None
        if backend == "cuda":
            from .. import backend as bk

            bk.check_fits(renderer.device_cache, K.arrays(args),
                          sum_rad.nbytes + sum_sq.nbytes + sum_hit.nbytes)
            sums = bk.PathSums(h, w)
        if progress_bar:
            from tqdm.auto import tqdm

            bar = tqdm(total=spp, desc="path_traced", unit="spp")
        try:
            while n < spp:
                s1 = min(n + batch, spp)
                if limit is not None:
                    if n == 0:
                        s1 = 1  # time one pass
                    else:
                        elapsed = time.perf_counter() - t_start
                        fit = int((limit - elapsed) / (elapsed / n))
                        if fit < 1:
                            break
                        s1 = min(s1, n + fit)
                if sums is None:
                    pathtrace_image(*args, n, s1, 0, h, sum_rad, sum_sq, sum_hit)
                else:
                    bk.pathtrace(renderer.device_cache, args, n, s1, sums)
                if bar is not None:
                    bar.update(s1 - n)
                n = s1
                if target is not None and n >= 2:
                    if sums is not None:
                        sums.download(sum_rad, sum_sq, sum_hit)
                    mean, se = _moments(sum_rad, sum_sq, n)
                    rel = relative_error(mean, se, sum_hit)
                    if rel <= target:
                        break
        finally:
            if bar is not None:
                bar.close()
        if sums is not None:
            sums.download(sum_rad, sum_sq, sum_hit)
    mean, se = _moments(sum_rad, sum_sq, n)
    alpha = sum_hit / n
    if target is None or not np.isfinite(rel):
        rel = relative_error(mean, se, alpha)
    meta = {"model": "path_traced", "spp": n, "time": time.perf_counter() - t_start, "seed": seed,
            "max_depth": max_depth, "target_error": target, "relative_error": rel, "window_size": size,
            "phase": repr(ph), "lights": len(renderer.lights), "background": bg.tolist(),
            "light_clamp": light_clamp, "majorant_block": block, "rr_depth": rr_depth, "batch": batch,
            "time_limit": limit, "backend": backend, "device_memory": renderer._device.nbytes if backend == "cuda" else 0}
    return RenderResult(radiance=mean.astype(np.float32), alpha=alpha.astype(np.float32), camera=cam,
                        metadata=meta, std_error=se.astype(np.float32))


def _moments(sum_x, sum_x2, n):
    """Per-pixel mean and standard error of the mean from Σx, Σx² over ``n`` samples (float64)."""
    mean = sum_x / n
    if n < 2:
        return mean, np.full_like(mean, np.inf)
    var = np.maximum(sum_x2 - sum_x * mean, 0.0) / (n - 1)
    return mean, np.sqrt(var / n)
