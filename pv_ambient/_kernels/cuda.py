"""CUDA drivers (DESIGN §5b): one thread per pixel, each running the same scalar function as the
CPU driver's loop body (:func:`.raycast.raycast_pixel`, :func:`.pathtrace.pathtrace_pixel`,
:func:`.lightvol.sweep_node`), compiled for the GPU by :func:`._jit.cuda_kernel`.

Importing this module imports ``numba.cuda``: the backend layer (:mod:`pv_ambient.backend`) does
so only when the CUDA backend is asked for. With ``NUMBA_ENABLE_CUDASIM=1`` (set before numba is
imported) the kernels run in Numba's CUDA simulator, which is how the test suite checks them on a
machine without a GPU.
"""

from __future__ import annotations

from numba import cuda

from ._jit import cuda_kernel
from .lightvol import sweep_node
from .pathtrace import pathtrace_pixel
from .raycast import raycast_pixel

#: Threads per block (x: image columns, y: rows).
BLOCK = (16, 8)


def _raycast(model, cam, w2i, lo, hi, step, jitter, seed, ert, bg, t_end, row0, row1,
             mode, field, table, lut_lo, lut_inv, aux, maj, block,
             lkind, lvec, lpow, llo, linv, tau, pkind, g, d2min,
             radius, ball, amb,
             phi, D, a_nodes, tau_lo_log, tau_dlog, diff, gdiff,
             out_rad, out_alpha):
    i, jj = cuda.grid(2)
    j = row0 + jj
    if i < out_alpha.shape[1] and j < row1:
        raycast_pixel(model, cam, w2i, lo, hi, step, jitter, seed, ert, bg, t_end, j, i,
                      mode, field, table, lut_lo, lut_inv, aux, maj, block,
                      lkind, lvec, lpow, llo, linv, tau, pkind, g, d2min,
                      radius, ball, amb, phi, D, a_nodes, tau_lo_log, tau_dlog, diff, gdiff,
                      out_rad, out_alpha)


def _pathtrace(cam, w2i, lo, hi, mode, field, table, lut_lo, lut_inv, aux, maj, block,
               lkind, lvec, lpow, pkind, g, d2min, bg, max_depth, rr_depth, seed, s0, s1, row0, row1,
               sum_rad, sum_sq, sum_hit):
    i, jj = cuda.grid(2)
    j = row0 + jj
    if i < sum_hit.shape[1] and j < row1:
        pathtrace_pixel(cam, w2i, lo, hi, mode, field, table, lut_lo, lut_inv, aux, maj, block,
                        lkind, lvec, lpow, pkind, g, d2min, bg, max_depth, rr_depth, seed, s0, s1, j, i,
                        sum_rad, sum_sq, sum_hit)


def _sweep_layer(sig, B, is_point, lx, ly, lz, a, k, J, prev, out, cur):
    ic, ib = cuda.grid(2)  # ic (contiguous in memory) varies fastest across a warp
    if ib < cur.shape[0] and ic < cur.shape[1]:
        sweep_node(sig, B, is_point, lx, ly, lz, a, k, J, prev, ib, ic, out, cur)


raycast_kernel = cuda_kernel(_raycast)
pathtrace_kernel = cuda_kernel(_pathtrace)
sweep_layer_kernel = cuda_kernel(_sweep_layer)


def grid_for(width, height, block=BLOCK):
    """Blocks per grid covering ``width × height`` threads."""
    return ((width + block[0] - 1) // block[0], (height + block[1] - 1) // block[1])
