"""CUDA drivers (docs/architecture.rst): one thread per pixel (or light-grid node), each running the same
scalar function as the CPU driver's loop body (:func:`.raycast.raycast_pixel`,
:func:`.pathtrace.pathtrace_pixel`, :func:`.residual.residual_pixel`, :func:`.lightvol.sweep_node`), compiled for the GPU by
:func:`._jit.cuda_kernel`.

The kernels are generated from the scalar functions' own signatures (:func:`grid_kernel`), so
neither the maths nor the argument lists are written a second time: a kernel takes the scalar's
arguments minus the two thread indices, then ``row0, row1`` (the rows it covers).

Importing this module imports ``numba.cuda``: the backend layer (:mod:`pv_ambient.backend`) does
so only when the CUDA backend is asked for. With ``NUMBA_ENABLE_CUDASIM=1`` (set before numba is
imported) the kernels run in Numba's CUDA simulator, which is how the test suite checks them on a
machine without a GPU.
"""

from __future__ import annotations

import inspect

from numba import cuda

from ._jit import cuda_kernel
from .lightvol import sweep_node
from .pathtrace import pathtrace_pixel
from .raycast import raycast_pixel
from .residual import residual_pixel

#: Threads per block (x: the fast index, image columns; y: rows).
BLOCK = (16, 8)


def grid_source(scalar, x_name, y_name, shape_of):
    """Python source of a kernel running ``scalar`` once per thread of a 2-D grid: thread x is
    argument ``x_name``, ``row0`` + thread y is ``y_name``; threads outside ``shape_of``'s first
    two dimensions (rows, columns) or past ``row1`` do nothing."""
    params = list(inspect.signature(scalar.py_func).parameters)
    args = [p for p in params if p not in (x_name, y_name)]
    return (f"def kernel({', '.join(args)}, row0, row1):\n"
            f"    {x_name}, _ty = cuda.grid(2)\n"
            f"    {y_name} = row0 + _ty\n"
            f"    if {x_name} < {shape_of}.shape[1] and {y_name} < row1:\n"
            f"        scalar({', '.join(params)})\n")


def grid_function(scalar, x_name, y_name, shape_of):
    """The plain Python function of :func:`grid_source` (``scalar`` still the CPU dispatcher)."""
    ns = {"cuda": cuda, "scalar": scalar}
    exec(grid_source(scalar, x_name, y_name, shape_of), ns)  # noqa: S102 - source built above
    return ns["kernel"]


def grid_kernel(scalar, x_name, y_name, shape_of):
    """:func:`grid_function` compiled as a CUDA kernel (its call of ``scalar`` goes to the device
    version)."""
    return cuda_kernel(grid_function(scalar, x_name, y_name, shape_of))


KERNELS = {"raycast": (raycast_pixel, "i", "j", "out_alpha"),
           "pathtrace": (pathtrace_pixel, "i", "j", "sum_hit"),
           "residual": (residual_pixel, "i", "j", "sum_hit"),
           "sweep_layer": (sweep_node, "ic", "ib", "cur")}  # ic: contiguous in memory, fastest in a warp

raycast_kernel = grid_kernel(*KERNELS["raycast"])
pathtrace_kernel = grid_kernel(*KERNELS["pathtrace"])
residual_kernel = grid_kernel(*KERNELS["residual"])
sweep_layer_kernel = grid_kernel(*KERNELS["sweep_layer"])


def grid_for(width, height, block=BLOCK):
    """Blocks per grid covering ``width × height`` threads."""
    return ((width + block[0] - 1) // block[0], (height + block[1] - 1) // block[1])
