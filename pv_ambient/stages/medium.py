"""Per-scene grids derived from the classified medium alone: the majorant of σt over blocks
(empty-space skipping and the path tracer's free-flight bound) and the light-grid nodes next to a
sample that scatters (whether a light can matter at all, docs/lights.rst)."""

from __future__ import annotations

import numpy as np


def on_device(device_cache, kind, args, out) -> bool:
    """Fill host array ``out`` on the GPU with the medium's kernel ``kind``
    (:func:`pv_ambient.backend.medium_grid`: the same scalar function per entry as the CPU's driver,
    the device copy kept in ``device_cache`` for the stages and the ray cast): True when it ran,
    False without a device cache or when the grid does not fit in the GPU's free memory (the
    caller then computes it on the CPU; the ray cast raises, or falls back under backend="auto")."""
    if device_cache is None:
        return False
    from ..backend import DeviceMemoryError, medium_grid

    try:
        medium_grid(device_cache, kind, args, out)
    except DeviceMemoryError:
        return False
    return True


def sigma_samples(optics, device_cache=None) -> np.ndarray:
    """σt at the data samples, float32 (:meth:`pv_ambient.inputs.transfer.Optics.sigma_grid`): the
    field itself in mode GRID (nothing to compute: the GPU uploads it once, for every stage and the
    ray cast); in mode LUT the table looked up per sample, on the GPU with a ``device_cache``
    (:func:`on_device`)."""
    from .._kernels.medium import MODE_LUT

    if optics.mode == MODE_LUT and device_cache is not None:
        out = np.empty(optics.field.shape, np.float32)
        if on_device(device_cache, "sigma_samples", (np.ascontiguousarray(optics.field), optics.table,
                                                     float(optics.lut_lo), float(optics.lut_inv)), out):
            return out
    return optics.sigma_grid()


def _majorant_shape(optics, block):
    return tuple(max(1, -(-(n - 1) // block)) for n in optics.field.shape)


def majorant_grid(optics, block, device_cache=None) -> np.ndarray:
    """Upper bound of σt over each block of ``block``³ samples: float32, one value per block (on the
    GPU with a ``device_cache``, :func:`on_device`)."""
    from .._kernels.majorant import build_majorant

    maj = np.zeros(_majorant_shape(optics, block), np.float32)
    args = (optics.mode, optics.field, optics.table, optics.lut_lo, optics.lut_inv, block)
    if not on_device(device_cache, "majorant", args, maj):
        build_majorant(*args, maj)
    return maj


#: The ray cast's empty blocks (:func:`cast_majorant`): those where no sample's σt exceeds this
#: fraction of the medium's largest. A skipped block adds at most this fraction of the optical depth
#: the densest medium would over the same path — far below a picture's precision, and a uniformly
#: thin medium (every block at the largest σt) is never skipped.
EMPTY_RATIO = 1e-12


def cast_majorant(optics, block, device_cache=None) -> np.ndarray:
    """The ray cast's majorant grid in ``block``³ samples (:func:`pv_ambient._kernels.majorant.build_cast_majorant`):
    the largest σt a sample of each block can take, 0 where that is at most :data:`EMPTY_RATIO` of
    the medium's largest (docs/performance.rst, "Empty space"). On the GPU with a ``device_cache``
    (:func:`on_device`) but for the medium's largest σt, a reduction kept on the host: in mode LUT
    it is over the table's few hundred entries, and in mode GRID over the field that the CPU holds
    anyway (one pass of NumPy's max, where a device reduction would need a kernel of its own)."""
    from .._kernels.majorant import build_cast_majorant
    from .._kernels.medium import MODE_LUT

    sigma = optics.table[:, 0] if optics.mode == MODE_LUT else optics.field
    top = float(np.max(sigma)) if np.size(sigma) else 0.0
    maj = np.zeros(_majorant_shape(optics, block), np.float32)
    args = (optics.mode, optics.field, optics.table, optics.lut_lo, optics.lut_inv, block,
            EMPTY_RATIO * top if np.isfinite(top) else 0.0)
    if not on_device(device_cache, "cast_majorant", args, maj):
        build_cast_majorant(*args, maj)
    return maj


def step_opacity(optics, step) -> np.ndarray:
    """The ray cast's step-corrected table of ``optics`` for world step ``step``
    (:func:`pv_ambient._kernels.medium.step_table`); the placeholder for a GRID-mode medium, which
    classifies per voxel and takes ``exp`` per sample."""
    from .._kernels.medium import MODE_LUT, step_table
    from .._kernels.records import NONE_STEP

    if optics.mode != MODE_LUT:
        return NONE_STEP
    return step_table(optics.table, step)


def scattering_nodes(optics, grid) -> np.ndarray:
    """The nodes of light grid ``grid`` nearest to a data sample that scatters (σt·albedo > 0):
    a boolean array of the grid's shape."""
    from .._kernels.medium import scattering_nodes as mark

    o = optics
    node = [np.clip(np.rint((np.arange(n) - grid.lo[a]) * grid.inv_step[a]).astype(np.intp), 0, grid.shape[a] - 1)
            for a, n in enumerate(o.field.shape)]
    mask = np.zeros(tuple(grid.shape), np.bool_)
    mark(o.mode, o.field, o.table, float(o.lut_lo), float(o.lut_inv), o.aux, *node, mask)
    return mask


def stack_volumes(parts) -> np.ndarray:
    """One light-grid array per light, (m0, m1, m2) or (m0, m1, m2, c), side by side along a last
    axis as the kernels' records take them (the one array itself for a single light)."""
    # reshape, not a[..., None]: the new axis gets a real stride (a zero stride makes numba-cuda
    # type the array as non-contiguous, and compile the ray cast once more for it)
    parts = [a if a.ndim == 4 else a.reshape(a.shape + (1,)) for a in parts]
    return parts[0] if len(parts) == 1 else np.concatenate(parts, axis=-1)


def least_where(values, mask) -> float:
    """The least of ``values`` where ``mask`` (a boolean array of the same 3-D shape) is true, inf
    where it never is — one parallel pass, without copying the selected values out."""
    from .._kernels.majorant import masked_min

    return float(masked_min(values, mask))
