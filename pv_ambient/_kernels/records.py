"""The kernels' argument records: the ray-cast and path-tracing kernels take a few of these
instead of a ~40-argument list (docs/architecture.rst).

Each record is a ``namedtuple``: Numba compiles it as a heterogeneous tuple (for the CPU and for
CUDA, where a kernel argument may be a tuple of device arrays), the scalar functions read its
fields by name, and the constructor is the one place a record's layout is written. The CPU
drivers, the generated CUDA kernels (:mod:`.cuda`) and the callers in the rendering and stage
layers all pass the same records; :func:`arrays` lists the arrays inside them (device-memory
checks) and :func:`map_arrays` rebuilds them with every array replaced (the device copies of
:class:`pv_ambient.backend.DeviceCache`).

Unused parts are filled with small placeholder arrays of the right dtype and rank (:data:`NONE4`
and friends) so that every model compiles to one kernel signature.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

#: The camera and the medium's box: ``cam`` (:meth:`pv_ambient.Camera.params`), world → sample
#: index affine map ``w2i`` and the box in index space ``[lo, hi]``.
View = namedtuple("View", "cam w2i lo hi")

#: Ray marching: world step, jitter on/off and its seed, early-termination threshold, background
#: (rgb), ``t_end``, each ray's end (H, W) or one for all (1, 1), and ``opacity``, the medium's
#: step-corrected table for this step (:func:`.medium.step_table`; :data:`NONE_STEP` for a
#: GRID-mode medium).
March = namedtuple("March", "step jitter seed ert bg t_end opacity")

#: The medium (:mod:`.medium`): classification mode, scalar or σt field, table and its scalar
#: mapping, the GRID mode's albedo/emission/colour ``aux``, and the majorant grid with its block
#: size (:mod:`.majorant`).
Medium = namedtuple("Medium", "mode field table lut_lo lut_inv aux maj block")

#: The lights (``pack_lights``): kind (0 point, 1 directional), position or direction, power
#: (rgb); the phase function (kind, g) and the point lights' d² clamp ``d2min``.
Lights = namedtuple("Lights", "kind vec power pkind g d2min")

#: The light grid: its origin and inverse spacing in sample index space, the optical depth of
#: each light ``tau`` and, in tube mode, the front optical depth ``phi`` (else ``tau`` again);
#: ``baked`` non-zero when ``inc`` holds the lights' in-scattered light per unit albedo at the nodes
#: (isotropic phase; :func:`.bake.bake_incident`), which the ray cast then reads instead of
#: evaluating each light per sample: the number of channels per slot (1 grey, 3 rgb); 0 otherwise.
LightGrid = namedtuple("LightGrid", "lo inv_step tau phi inc baked")

#: Ambient occlusion / ambient scattering: ball radius, the ball grid (σ̄ and the ball's mean
#: albedo), ambient radiance, and the preintegrated table D with its albedo nodes and τ axis.
Ambient = namedtuple("Ambient", "radius ball amb D a_nodes tau_lo_log tau_dlog")

#: Diffusion: the (φ, F) field per channel and the mean cosine of the phase function.
Diffusion = namedtuple("Diffusion", "field g")

#: Path tracing: background (rgb), largest depth, Russian-roulette depth, seed, whether point
#: lights are also sampled by equiangular distance sampling (1) or by free flight alone (0), the
#: grid whose optical depth enters its MIS weights (the majorant) and the world radius around
#: each point light where it samples (:mod:`.pathtrace`).
Paths = namedtuple("Paths", "bg max_depth rr_depth seed equiangular eq_grid eq_radius")

#: Placeholders for the parts a model does not use.
NONE4 = np.zeros((1, 1, 1, 1), np.float32)
NONE3 = np.zeros((1, 1, 1), np.float32)
NONE1 = np.zeros(1, np.float64)
NONE12 = np.zeros((1, 1, 1, 12), np.float32)
NONE_STEP = np.zeros((2, 11), np.float32)


def view_of(camera, size, geometry):
    """The :class:`View` of ``camera`` (:class:`pv_ambient.Camera`) at ``size`` (w, h) on the
    medium's ``geometry`` (``world_to_index``, ``box_lo``, ``box_hi``)."""
    return View(camera.params(size), geometry.world_to_index, geometry.box_lo, geometry.box_hi)


def medium_of(optics, maj, block):
    """The :class:`Medium` of ``optics`` (``pv_ambient.inputs.transfer.Optics``) with majorant grid
    ``maj`` of block size ``block``."""
    return Medium(optics.mode, optics.field, optics.table, optics.lut_lo, optics.lut_inv, optics.aux, maj, block)


def lights_of(packed, phase, d2min):
    """The :class:`Lights` of ``packed`` = ``pack_lights(...)`` (kind, vec, power) and ``phase``
    (``kind``, ``g``), with the d² clamp ``d2min``."""
    kind, vec, power = packed
    return Lights(kind, vec, power, phase.kind, float(phase.g), d2min)


def arrays(record):
    """Every numpy array inside ``record`` (a record, or a tuple of records and values)."""
    if isinstance(record, np.ndarray):
        return [record]
    if isinstance(record, tuple):
        return [a for item in record for a in arrays(item)]
    return []


def map_arrays(fn, record):
    """``record`` with every numpy array ``a`` inside it (at any depth) replaced by ``fn(a)``."""
    if isinstance(record, np.ndarray):
        return fn(record)
    if isinstance(record, tuple):
        items = [map_arrays(fn, item) for item in record]
        return type(record)(*items) if hasattr(record, "_fields") else tuple(items)
    return record
