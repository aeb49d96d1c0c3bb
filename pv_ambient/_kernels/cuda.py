"""CUDA drivers (docs/architecture.rst): one thread per pixel (or light-grid node), each running the same
scalar function as the CPU driver's loop body (:func:`.raycast.raycast_pixel`,
:func:`.pathtrace.pathtrace_pixel`, :func:`.residual.residual_pixel`, :func:`.lightvol.sweep_node`,
:func:`.bake.bake_node`, :func:`.bake.fold_node`, :func:`.bake.clear_node`, and the medium's grids:
:func:`.medium.sigma_sample_node`, :func:`.lightvol.sigma_node`, :func:`.majorant.majorant_block`,
:func:`.majorant.cast_majorant_block`; the ball grid's :func:`.medium.scattering_sample`,
:func:`.sat.box_mean_line`, :func:`.sat.ball_channel_node`), compiled for the GPU by
:func:`._jit.cuda_kernel`. A kernel only finds its thread's pixel and calls that function: the
physics exists once, in the scalar functions.

The ray cast has one kernel per specialisation (:data:`.raycast.SPECIALISATIONS`: the model,
whether the lights' in-scattering is baked and the medium's classification mode, constants of the
kernel), as the CPU has one driver per
specialisation: no branch over models is left in a kernel's sample loop, and each keeps in
registers only what its model reads. Every kernel is defined here, in a module file, so that
Numba's disk cache keeps it: a new process compiles nothing (docs/performance.rst, "GPU").

A kernel takes its scalar's arguments minus the two thread indices, then ``row0, row1`` (the rows
it covers); the bake's kernels, one thread per light-grid node on a 3-D grid, take their scalar's
arguments minus the node's three indices.

Importing this module imports ``numba.cuda``: the backend layer (:mod:`pv_ambient.backend`) does
so only when the CUDA backend is asked for. With ``NUMBA_ENABLE_CUDASIM=1`` (set before numba is
imported) the kernels run in Numba's CUDA simulator, which is how the test suite checks them on a
machine without a GPU.
"""

from __future__ import annotations

from numba import cuda

from ._jit import cuda_kernel
from .bake import bake_node, clear_node, fold_node
from .lightvol import sigma_node, sweep_node
from .majorant import cast_majorant_block, majorant_block
from .medium import scattering_sample, sigma_sample_node
from .pathtrace import pathtrace_pixel
from .raycast import SPECIALISATIONS, raycast_pixel, specialisation
from .models import AMBIENT_SCATTERING, DIFFUSION, SINGLE_SCATTERING
from .residual import residual_pixel
from .sat import ball_channel_node, box_mean_line

#: Threads per block (x: the fast index, image columns; y: rows).
BLOCK = (16, 8)
#: Threads per block of the bake's node kernels (x: the light grid's last index, contiguous in memory).
BLOCK3 = (32, 4, 2)


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


def bake_kernel(model):
    """The bake kernel of ray-cast ``model`` (:data:`BAKE_KERNELS` holds them: use that): one thread
    per light-grid node, each adding its lights' in-scattering to slot ``q``
    (:func:`.bake.bake_node`, the CPU's :func:`.bake.bake_incident` loop body). The model is a
    constant of the kernel, as the ray cast's: single scattering's and diffusion's bake keep no
    ball term."""

    def bake(lights, grid, ambient, w2i, i2w, lo, step, nch, q, on_samples, out):
        k, j, i = cuda.grid(3)
        if i < out.shape[0] and j < out.shape[1] and k < out.shape[2]:
            bake_node(model, lights, grid, ambient, w2i, i2w, lo, step, nch, q, on_samples, i, j, k, out)

    return cuda_kernel(bake)


#: The bake kernel of every model whose lights are baked (compiled at its first launch).
BAKE_KERNELS = {m: bake_kernel(m) for m in (SINGLE_SCATTERING, AMBIENT_SCATTERING, DIFFUSION)}


@cuda_kernel
def fold_kernel(diff, q, nch, out):
    """Diffusion's ``max(φ, 0)/4π`` added to slot ``q`` of the bake, one thread per node
    (:func:`.bake.fold_node`, the CPU's :func:`.bake.bake_diffusion` loop body)."""
    k, j, i = cuda.grid(3)
    if i < out.shape[0] and j < out.shape[1] and k < out.shape[2]:
        fold_node(diff, q, nch, i, j, k, out)


@cuda_kernel
def clear_kernel(q, n, out):
    """Channels ``q … q + n − 1`` of the bake set to 0, one thread per node (:func:`.bake.clear_node`)."""
    k, j, i = cuda.grid(3)
    if i < out.shape[0] and j < out.shape[1] and k < out.shape[2]:
        clear_node(q, n, i, j, k, out)


@cuda_kernel
def sigma_samples_kernel(field, table, lut_lo, lut_inv, out):
    """σt of a LUT-mode medium at every data sample, one thread per sample (:func:`.medium.sigma_sample_node`,
    the CPU's :func:`.medium.classify_columns` loop body)."""
    k, j, i = cuda.grid(3)
    if i < out.shape[0] and j < out.shape[1] and k < out.shape[2]:
        sigma_sample_node(field, table, lut_lo, lut_inv, i, j, k, out)


@cuda_kernel
def sigma_nodes_kernel(mode, field, table, lut_lo, lut_inv, lo, step, out):
    """σt at every light-grid node, one thread per node (:func:`.lightvol.sigma_node`, the CPU's
    :func:`.lightvol.sample_sigma_grid` loop body)."""
    k, j, i = cuda.grid(3)
    if i < out.shape[0] and j < out.shape[1] and k < out.shape[2]:
        sigma_node(mode, field, table, lut_lo, lut_inv, lo, step, i, j, k, out)


@cuda_kernel
def majorant_kernel(mode, field, table, lut_lo, lut_inv, block, out):
    """The path tracer's majorant grid, one thread per block (:func:`.majorant.majorant_block`, the
    CPU's :func:`.majorant.build_majorant` loop body)."""
    c, b, a = cuda.grid(3)
    if a < out.shape[0] and b < out.shape[1] and c < out.shape[2]:
        out[a, b, c] = majorant_block(mode, field, table, lut_lo, lut_inv, block, a, b, c)


@cuda_kernel
def cast_majorant_kernel(mode, field, table, lut_lo, lut_inv, block, sigma_min, out):
    """The ray cast's majorant grid, one thread per block (:func:`.majorant.cast_majorant_block`, the
    CPU's :func:`.majorant.build_cast_majorant` loop body)."""
    c, b, a = cuda.grid(3)
    if a < out.shape[0] and b < out.shape[1] and c < out.shape[2]:
        out[a, b, c] = cast_majorant_block(mode, field, table, lut_lo, lut_inv, block, sigma_min, a, b, c)


#: The kernels of the medium's per-scene grids by name (:func:`pv_ambient.backend.medium_grid`), each
#: taking the grid's arguments then its output, one thread per output entry.
MEDIUM_KERNELS = {"sigma_samples": sigma_samples_kernel, "sigma_nodes": sigma_nodes_kernel,
                  "majorant": majorant_kernel, "cast_majorant": cast_majorant_kernel}


@cuda_kernel
def scattering_kernel(mode, field, table, lut_lo, lut_inv, aux, col, sigma, out):
    """σs of one albedo column at every data sample, one thread per sample (:func:`.medium.scattering_sample`,
    the CPU's :func:`.medium.scattering_column` loop body): the ball grid's mean-scattering input."""
    k, j, i = cuda.grid(3)
    if i < out.shape[0] and j < out.shape[1] and k < out.shape[2]:
        out[i, j, k] = scattering_sample(mode, field, table, lut_lo, lut_inv, aux, col, sigma, i, j, k)


@cuda_kernel
def box_mean_kernel(src, dst, axis, i0, f0, i1, f1, inv_len):
    """One axis of a separable box mean, ``src`` into ``dst``: one thread per line along ``axis``
    (:func:`.sat.box_mean_line`, the CPU's :func:`.sat.box_mean_plane` / :func:`.sat.box_mean_z`);
    x indexes the last of the other two axes, the one contiguous in memory for axes 0 and 1."""
    q, p = cuda.grid(2)
    n_p = src.shape[1] if axis == 0 else src.shape[0]
    n_q = src.shape[1] if axis == 2 else src.shape[2]
    if p < n_p and q < n_q:
        box_mean_line(src, dst, axis, i0, f0, i1, f1, inv_len, p, q)


@cuda_kernel
def ball_channel_kernel(src, c, ball):
    """Channel ``c`` of the (nx, ny, nz, 4) ball grid from the box mean ``src``, one thread per
    sample (:func:`.sat.ball_channel_node`: σ̄ itself for ``c = 0``, else the ball's mean albedo, the
    CPU's :func:`.sat.ball_albedo_into`)."""
    k, j, i = cuda.grid(3)
    if i < ball.shape[0] and j < ball.shape[1] and k < ball.shape[2]:
        ball_channel_node(src, c, ball, i, j, k)


def grid3_for(shape, block=BLOCK3):
    """Blocks per grid covering the nodes of a light grid of ``shape`` (m0, m1, m2): x the last index."""
    m0, m1, m2 = shape[:3]
    return ((m2 + block[0] - 1) // block[0], (m1 + block[1] - 1) // block[1], (m0 + block[2] - 1) // block[2])


def grid_for(width, height, block=BLOCK):
    """Blocks per grid covering ``width × height`` threads."""
    return ((width + block[0] - 1) // block[0], (height + block[1] - 1) // block[1])
