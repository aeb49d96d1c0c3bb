"""Per-scene stages on the GPU beyond the medium's grids (:func:`pv_ambient.backend.medium_grid`):
ambient scattering's ball grid (docs/performance.rst, "What runs on the device").

Like the other launches of :mod:`pv_ambient.backend`, each takes its inputs from the renderer's
:class:`pv_ambient.device_cache.DeviceCache` (uploading only what is not there), runs kernels of
:mod:`pv_ambient._kernels.cuda` that call the CPU's scalar functions, downloads the result into a
host array and registers the device copy with :meth:`~pv_ambient.device_cache.DeviceCache.put`, so
the stages and the ray cast that read it upload nothing. The caller (:mod:`pv_ambient.stages`)
prepares the arrays and falls back to the CPU on :class:`pv_ambient.backend.DeviceMemoryError`.

This module imports ``numba.cuda`` only inside its launches.
"""

from __future__ import annotations

import numpy as np

from .backend import check_fits, launch_context


def ball_grid(cache, medium, sigma, passes, cols, same, out):
    """The ball grid of :func:`pv_ambient.stages.ball.ball_grid` on the GPU into host array ``out``
    (float32 (nx, ny, nz, 4): σ̄, then the ball's mean albedo per channel).

    ``medium`` is ``(mode, field, table, lut_lo, lut_inv, aux)`` (the records' medium arrays, which
    the ray cast reads too); ``sigma`` σt on the samples (float32, in the cache when the GPU made
    it); ``passes`` the separable box mean's axes, ``(axis, i0, f0, i1, f1, inv_len)`` each
    (:func:`pv_ambient.stages.sat.axis_weights`; none for a radius inside a sample's cell);
    ``cols[c]`` the albedo column of channel ``c`` (:func:`pv_ambient._kernels.medium.scattering_sample`);
    ``same[c]`` that channel ``c`` equals channel ``c − 1``, whose box mean then serves it again.

    Besides ``out``'s device copy the launch holds two float32 volumes (the box mean's source and
    destination in turn: one thread per line reads its line whole, so a pass cannot write in place).
    Raises :class:`pv_ambient.backend.DeviceMemoryError` before any upload when that does not fit."""
    from numba import cuda

    from ._kernels.cuda import BLOCK, BLOCK3, ball_channel_kernel, box_mean_kernel, grid3_for, grid_for, \
        scattering_kernel

    mode, field, table, lut_lo, lut_inv, aux = medium
    weights = [w for p in passes for w in p[1:5]]
    check_fits(cache, [sigma, field, table, aux], extra_bytes=out.nbytes + 2 * sigma.size * 4
               + sum(w.nbytes for w in weights))
    d_sigma, d_field, d_table, d_aux = (cache.get(a) for a in (sigma, field, table, aux))
    d_passes = [(p[0], *(cuda.to_device(w) for w in p[1:5]), p[5]) for p in passes]
    d_out = cuda.device_array(out.shape, np.float32)
    bufs = [cuda.device_array(sigma.shape, np.float32) for _ in range(2)]
    nx, ny, nz = sigma.shape
    blocks = grid3_for(sigma.shape)

    def mean(src):
        """The box mean of device array ``src`` through the passes: the buffer that holds it."""
        cur = src
        for axis, i0, f0, i1, f1, inv_len in d_passes:
            dst = bufs[1] if cur is bufs[0] else bufs[0]
            lines = ((nz, ny), (nz, nx), (ny, nx))[axis]
            box_mean_kernel[grid_for(*lines), BLOCK](cur, dst, axis, i0, f0, i1, f1, inv_len)
            cur = dst
        return cur

    with launch_context():
        ball_channel_kernel[blocks, BLOCK3](mean(d_sigma), 0, d_out)
        ms = None
        for c in range(3):
            if ms is None or not same[c]:
                scattering_kernel[blocks, BLOCK3](mode, d_field, d_table, lut_lo, lut_inv, d_aux, cols[c], d_sigma,
                                                  bufs[0])
                ms = mean(bufs[0])
            ball_channel_kernel[blocks, BLOCK3](ms, 1 + c, d_out)
    d_out.copy_to_host(out)
    cache.put(out, d_out)
