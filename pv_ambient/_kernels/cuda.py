"""CUDA drivers (docs/architecture.rst): one thread per pixel (or light-grid node), each running the same
scalar function as the CPU driver's loop body (:func:`.raycast.raycast_pixel`,
:func:`.pathtrace.pathtrace_pixel`, :func:`.residual.residual_pixel`, :func:`.lightvol.sweep_node`), compiled for the GPU by
:func:`._jit.cuda_kernel`. A kernel only finds its thread's pixel and calls that function: the
physics exists once, in the scalar functions.

The ray cast has one kernel per specialisation (:data:`.raycast.SPECIALISATIONS`: the model,
whether the lights' in-scattering is baked and the medium's classification mode, constants of the
kernel), as the CPU has one driver per
specialisation: no branch over models is left in a kernel's sample loop, and each keeps in
registers only what its model reads. Every kernel is defined here, in a module file, so that
Numba's disk cache keeps it: a new process compiles nothing (docs/performance.rst, "GPU").

A kernel takes its scalar's arguments minus the two thread indices, then ``row0, row1`` (the rows
it covers).

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
from .raycast import SPECIALISATIONS, raycast_pixel, specialisation
from .residual import residual_pixel

#: Threads per block (x: the fast index, image columns; y: rows).
BLOCK = (16, 8)


def raycast_kernel(model, baked, mode):
    """The ray-cast kernel of specialisation ``(model, baked, mode)`` (:data:`RAYCAST_KERNELS` holds them:
    use that, each is compiled once): one thread per pixel of rows [row0, row1)."""

    def raycast(view, march, medium, lights, grid, ambient, diffusion, out_rad, out_alpha, row0, row1):
        i, ty = cuda.grid(2)
        j = row0 + ty
        if i < out_alpha.shape[1] and j < row1:
            raycast_pixel(model, baked, mode, view, march, medium, lights, grid, ambient, diffusion, j, i, out_rad,
                          out_alpha)

    return cuda_kernel(raycast)


#: The ray-cast kernel of every specialisation (compiled at its first launch, or read from the cache).
RAYCAST_KERNELS = {spec: raycast_kernel(*spec) for spec in SPECIALISATIONS}


def raycast_kernel_for(model, baked, mode):
    """The kernel that renders ray-cast ``model`` (an id of :mod:`.models`) with the light grid's
    ``baked`` field on a medium of classification ``mode``."""
    return RAYCAST_KERNELS[specialisation(model, baked, mode)]


@cuda_kernel
def pathtrace_kernel(view, medium, lights, paths, s0, s1, sum_rad, sum_sq, sum_hit, row0, row1):
    """Samples [s0, s1) of every pixel of rows [row0, row1) added to the sums, one thread per pixel."""
    i, ty = cuda.grid(2)
    j = row0 + ty
    if i < sum_hit.shape[1] and j < row1:
        pathtrace_pixel(view, medium, lights, paths, s0, s1, j, i, sum_rad, sum_sq, sum_hit)


@cuda_kernel
def residual_kernel(view, medium, lights, paths, cmodel, clights, cgrid, cambient, cdiffusion, s0, s1, sum_rad, sum_sq,
                    sum_hit, row0, row1):
    """Residual samples [s0, s1) of every pixel of rows [row0, row1), one thread per pixel."""
    i, ty = cuda.grid(2)
    j = row0 + ty
    if i < sum_hit.shape[1] and j < row1:
        residual_pixel(view, medium, lights, paths, cmodel, clights, cgrid, cambient, cdiffusion, s0, s1, j, i,
                       sum_rad, sum_sq, sum_hit)


@cuda_kernel
def sweep_layer_kernel(sig, B, is_point, lx, ly, lz, a, k, J, prev, out, cur, row0, row1):
    """Layer ``k`` of a sweep along axis ``a``, one thread per node (``ic``, contiguous in memory,
    the fastest index of a warp)."""
    ic, ty = cuda.grid(2)
    ib = row0 + ty
    if ic < cur.shape[1] and ib < row1:
        sweep_node(sig, B, is_point, lx, ly, lz, a, k, J, prev, ib, ic, out, cur)


def grid_for(width, height, block=BLOCK):
    """Blocks per grid covering ``width × height`` threads."""
    return ((width + block[0] - 1) // block[0], (height + block[1] - 1) // block[1])
