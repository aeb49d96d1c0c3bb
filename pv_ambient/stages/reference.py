"""The ``path_traced`` reference (docs/models.rst, docs/trade.rst): unbiased Monte Carlo with a standard-error image.

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
from typing import NamedTuple

import numpy as np

from ..inputs.validation import check_bool, check_int, check_real, check_rgb
from ..backend import resolve_backend
from ..inputs.lights import pack_lights

#: Majorant block size (samples per axis) of the trackers.
MAJORANT_BLOCK = 8
#: Equiangular sampling's default radius around a point light, as a fraction of the box diagonal.
EQ_RADIUS = 0.25
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


class Traced(NamedTuple):
    """What :func:`path_trace` returns: the per-pixel mean ``radiance`` (H, W, 3), ``alpha`` the
    fraction of primary rays that collided (an unbiased estimate of 1 − transmittance),
    ``std_error`` the per-pixel standard error of the mean (``inf`` after a single sample), all
    float32, and ``metadata`` (``spp``, ``time``, ``seed``, ``max_depth``, ``relative_error`` and
    the options)."""

    radiance: np.ndarray
    alpha: np.ndarray
    std_error: np.ndarray
    metadata: dict


def path_trace(geometry, optics, majorant, lights, camera, window_size, *, samples_per_pixel, block=MAJORANT_BLOCK,
               phase=None, target_error=None, max_depth=None, seed=0, background=(0.0, 0.0, 0.0), progress_bar=False,
               batch=16, light_clamp=None, rr_depth=RR_DEPTH, backend="cpu", time_limit=None,
               device_cache=None, equiangular=True, equiangular_radius=None, control=None,
               base=None, first_sample=0) -> Traced:
    """Trace the unbiased reference image of a scene (:meth:`pv_ambient.Renderer.path_trace` is the
    public entry point; it passes its cached arrays).

    Parameters
    ----------
    geometry : pv_ambient.inputs.grid.GridGeometry
        The grid's placement in the world.
    optics : pv_ambient.inputs.transfer.Optics
        The resolved optical properties.
    majorant : numpy.ndarray
        float32 upper bound of σt per ``block``³ samples (``pv_ambient._kernels.majorant``).
    lights : sequence of PointLight or DirectionalLight
    camera : pv_ambient.Camera
    window_size : (int, int)
        ``(width, height)``.
    samples_per_pixel : int
        Samples per pixel; with ``target_error`` the cap.
    block : int, default: 8
        Samples per majorant block of ``majorant``.
    phase : PhaseFunction, float or dict, optional
        Phase function (isotropic when None).
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
        the ``"balanced"`` ray step (half the smallest spacing), as the ray-cast models use. The
        clamp bounds the otherwise infinite variance of next-event estimation next to a point
        light inside the medium.
    rr_depth : int, default: 3
        Collisions before Russian roulette starts.
    backend : {"cpu", "cuda"}, default: "cpu"
        Where the paths are traced (:mod:`pv_ambient.backend`): the same per-path kernel and
        counter-based random numbers on both, so a seed gives the same image up to rounding.
    time_limit : float, optional
        Stop adding samples (``samples_per_pixel`` stays the cap) once the next batch would end
        after this many seconds from the start; at least one sample is always taken. The first
        batch is a single sample, which times one pass.
    device_cache : pv_ambient.backend.DeviceCache, optional
        The scene's arrays resident on the GPU (``backend="cuda"``).
    equiangular : bool, default: True
        Also sample each path segment's distance toward every point light equiangularly (Kulla &
        Fajardo 2012) and combine it with the free-flight collision's next-event estimate by
        multiple importance sampling (:mod:`pv_ambient._kernels.pathtrace`): finite variance for
        a point light inside the medium, where free flight alone gives fireflies. Near such a
        light, scattered directions are also drawn about it, the Russian roulette spares paths
        and paths that still carry much of their throughput split into copies
        (docs/path_tracer.rst). Same expectation either way; no effect (and the same random
        numbers) without point lights.
    equiangular_radius : float, optional
        World distance from a point light within which ``equiangular`` samples distances and
        directions toward it (and boosts the roulette and splits paths); default a quarter of the
        box's diagonal.
    control : tuple, optional
        A noise-free ray-cast model as a control variate (the ``progressive`` model,
        :mod:`pv_ambient._kernels.residual`): its kernel model id and its Lights, LightGrid,
        Ambient and Diffusion records. The samples are then path samples minus the model's source
        at their first collision, and ``radiance`` their mean (the residual to add to the model's
        picture); ``std_error`` is that mean's, ``alpha`` unchanged.
    base : numpy.ndarray, optional
        With ``control``: the model's picture (H, W, 3), to which the relative error (and
        ``target_error``) refers — the residual's own mean is near zero.
    first_sample : int, default: 0
        Index of the first sample of every pixel: the random numbers are keyed by (seed, pixel,
        sample), so samples ``[k, k + n)`` of one seed continue a render of its first ``k`` — two
        calls ``(n1, 0)`` and ``(n2, n1)`` trace exactly the samples of one call with ``n1 + n2``
        (the ``progressive`` model's held-out halves, docs/progressive.rst).
    """
    from .._kernels import records as K
    from .._kernels.pathtrace import pathtrace_image
    from .._kernels.residual import residual_image
    from ..inputs.phase import as_phase

    cam, size = camera, window_size
    spp = check_int(samples_per_pixel, "samples_per_pixel", lo=1)
    batch = check_int(batch, "batch", lo=1)
    target = None if target_error is None else check_real(target_error, "target_error", lo=0.0, lo_open=True)
    depth = _NO_LIMIT if max_depth is None else check_int(max_depth, "max_depth", lo=1)
    seed = check_int(seed, "seed", lo=0)
    first = check_int(first_sample, "first_sample", lo=0)
    bg = check_rgb(background, "background")
    block = check_int(block, "block", lo=1)
    rr_depth = check_int(rr_depth, "rr_depth", lo=0)
    limit = None if time_limit is None else check_real(time_limit, "time_limit", lo=0.0)
    if light_clamp is None:
        light_clamp = 0.25 * 0.5 * float(np.min(geometry.spacing))
    light_clamp = check_real(light_clamp, "light_clamp", lo=0.0)
    ph = as_phase(phase)
    backend = resolve_backend(backend)
    eq = check_bool(equiangular, "equiangular")
    eq_radius = (EQ_RADIUS * geometry.diagonal if equiangular_radius is None
                 else check_real(equiangular_radius, "equiangular_radius", lo=0.0))

    t_start = time.perf_counter()
    w, h = size
    sum_rad = np.zeros((h, w, 3))
    sum_sq = np.zeros((h, w, 3))
    sum_hit = np.zeros((h, w))
    geom = geometry
    n = 0
    rel = float("inf")
    if geom.is_empty:
        if control is None:  # a control variate sees the same background: its residual is 0
            sum_rad[:] = bg * spp
            sum_sq[:] = bg * bg * spp
        n = spp
    else:
        args = (K.view_of(cam, size, geom), K.medium_of(optics, majorant, block),
                K.lights_of(pack_lights(lights), ph, light_clamp * light_clamp), K.Paths(bg, depth, rr_depth, seed, int(eq), majorant, eq_radius))
        kernel = pathtrace_image
        if control is not None:
            args = args + tuple(control)
            kernel = residual_image
        bar = None
        sums = None
        if backend == "cuda":
            from .. import backend as bk

            bk.check_fits(device_cache, K.arrays(args),
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
                    kernel(*args, first + n, first + s1, 0, h, sum_rad, sum_sq, sum_hit)
                else:
                    bk.pathtrace(device_cache, args, first + n, first + s1, sums)
                if bar is not None:
                    bar.update(s1 - n)
                n = s1
                if target is not None and n >= 2:
                    if sums is not None:
                        sums.download(sum_rad, sum_sq, sum_hit)
                    mean, se = _moments(sum_rad, sum_sq, n)
                    rel = relative_error(mean if base is None else mean + base, se, sum_hit)
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
        rel = relative_error(mean if base is None else mean + base, se, alpha)
    meta = {"model": "path_traced", "spp": n, "time": time.perf_counter() - t_start, "seed": seed,
            "first_sample": first,
            "max_depth": max_depth, "target_error": target, "relative_error": rel, "window_size": size,
            "phase": repr(ph), "lights": len(lights), "background": bg.tolist(),
            "light_clamp": light_clamp, "majorant_block": block, "rr_depth": rr_depth, "batch": batch,
            "time_limit": limit, "equiangular": eq, "equiangular_radius": eq_radius, "control_variate": control is not None, "backend": backend, "device_memory": device_cache.nbytes if backend == "cuda" else 0}
    return Traced(mean.astype(np.float32), alpha.astype(np.float32), se.astype(np.float32), meta)


def _moments(sum_x, sum_x2, n):
    """Per-pixel mean and standard error of the mean from Σx, Σx² over ``n`` samples (float64)."""
    mean = sum_x / n
    if n < 2:
        return mean, np.full_like(mean, np.inf)
    var = np.maximum(sum_x2 - sum_x * mean, 0.0) / (n - 1)
    return mean, np.sqrt(var / n)


class Accumulator:
    """Running per-pixel sums of radiance, its square and alpha over passes of a progressive
    render: the mean and its standard error of all samples so far, as :func:`path_trace` keeps
    them within one call.

    Each pass is given as its own estimate (mean radiance, standard error of the mean, alpha)
    over ``samples`` samples per pixel; its sums are recovered as ``Σx = n·mean``,
    ``Σx² = (n − 1)·s² + n·mean²`` with the sample variance ``s² = n·se²`` (0 where the error
    is not finite) and ``Σhit = n·alpha``.

    Attributes
    ----------
    sum_radiance, sum_square, sum_alpha : numpy.ndarray or None
        float64 sums of ``x``, ``x²`` and the hit indicator (None before the first pass).
    samples : int
        Samples per pixel so far.
    passes : int
        Passes added so far.

    Examples
    --------
    >>> import numpy as np
    >>> from pv_ambient.stages.reference import Accumulator
    >>> acc = Accumulator()
    >>> acc.add(np.array([1.0]), np.array([0.0]), np.array([1.0]), samples=2)
    >>> acc.add(np.array([3.0]), np.array([0.0]), np.array([1.0]), samples=2)
    >>> acc.samples, acc.passes, acc.mean.tolist(), acc.alpha.tolist()
    (4, 2, [2.0], [1.0])
    >>> round(float(acc.std_error[0]), 6)
    0.57735
    """

    def __init__(self):
        self.sum_radiance = None
        self.sum_square = None
        self.sum_alpha = None
        self.samples = 0
        self.passes = 0

    def add(self, radiance, std_error, alpha, samples):
        """Add one pass: its per-pixel mean ``radiance``, ``std_error`` of that mean and ``alpha``
        over ``samples`` samples per pixel."""
        n = int(samples)
        mean = np.asarray(radiance).astype(np.float64)
        se = np.asarray(std_error).astype(np.float64)
        var_n = np.where(np.isfinite(se), se * se * n, 0.0)  # sample variance
        s1, s2, hit = n * mean, (n - 1) * var_n + n * mean * mean, n * np.asarray(alpha).astype(np.float64)
        if self.sum_radiance is None:
            self.sum_radiance, self.sum_square, self.sum_alpha = s1, s2, hit
        else:
            self.sum_radiance += s1
            self.sum_square += s2
            self.sum_alpha += hit
        self.samples += n
        self.passes += 1

    @property
    def mean(self):
        """float64 mean radiance of all samples so far."""
        return _moments(self.sum_radiance, self.sum_square, self.samples)[0]

    @property
    def std_error(self):
        """float64 standard error of :attr:`mean` (``inf`` below two samples)."""
        return _moments(self.sum_radiance, self.sum_square, self.samples)[1]

    @property
    def alpha(self):
        """float64 fraction of samples whose primary ray hit the medium."""
        return self.sum_alpha / self.samples

    @property
    def relative_error(self):
        """The image's :func:`relative_error` of all samples so far."""
        return relative_error(self.mean, self.std_error, self.alpha)
