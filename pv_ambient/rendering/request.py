"""The checked inputs of one render: :class:`RenderRequest`, built by
:meth:`pv_ambient.Renderer.request` (every argument of :meth:`pv_ambient.Renderer.render` checked
once), and the checks of its array inputs."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class RenderRequest:
    """One render's inputs, checked (:meth:`Renderer.request`): what the stages and the kernels get.

    Every field is a validated value (a :class:`~pv_ambient.Camera`, a ``(width, height)`` tuple,
    floats, a phase function, arrays); ``options`` holds the model options (``MODEL_OPTIONS``)
    with the preset's ``samples_per_pixel`` filled in, ``explicit`` the option names the caller gave.
    """

    camera: object
    window_size: tuple
    model: str
    quality: str
    step: float
    jitter: bool
    seed: int
    background: np.ndarray
    early_termination: float
    ambient_radiance: float
    phase: object
    radius: float
    t_end: np.ndarray
    light_resolution: float | None
    table_quality: str
    propagation: str
    progress_bar: bool
    asked: str
    backend: str
    time_budget: float | None
    options: dict = field(default_factory=dict)
    explicit: frozenset = frozenset()


def check_ray_end(ray_end, size):
    """The ``t_end`` array of the ray-cast driver: (1, 1) inf, or the validated (H, W) ``ray_end``."""
    if ray_end is None:
        return np.full((1, 1), np.inf)
    w, h = size
    arr = np.asarray(ray_end, dtype=np.float64)
    if arr.shape != (h, w):
        raise ValueError(f"ray_end must have shape (height, width) = {(h, w)}, got {arr.shape}")
    if np.isnan(arr).any() or (arr < 0).any():
        raise ValueError("ray_end must hold distances >= 0 (inf where no geometry), found NaN or negative values")
    return np.ascontiguousarray(arr)




#: The models that use each model option (an option given to another model earns a warning).
#: ``phase``, ``light_resolution`` and ``table_quality`` describe the medium and the effort, not a
#: model: they may be given to every model (one scene, many models) without a warning.
OPTION_MODELS = {
    "samples_per_pixel": ("path_traced",), "target_error": ("path_traced",), "max_depth": ("path_traced",),
    "denoise": ("path_traced",), "flux_limited": ("diffusion",), "propagation": ("ambient_scattering",),
    "radius": ("ambient_occlusion", "ambient_scattering"), "ambient_radiance": ("ambient_occlusion",),
}
#: Bytes per pixel a render holds at its peak (image buffers, float64 sums and their conversion):
#: the ray cast's radiance and alpha, the path tracer's sums, moments and float32 copies.
BYTES_PER_PIXEL = {"path_traced": 200, "auto": 200}
BYTES_PER_PIXEL_RAYCAST = 64


def given_options(*, radius, propagation, ambient_radiance) -> frozenset:
    """The names of :meth:`Renderer.render`'s model knobs given a value other than their default."""
    from .presets import DEFAULT_PROPAGATION

    given = {"radius": radius is not None, "propagation": propagation != DEFAULT_PROPAGATION,
             "ambient_radiance": ambient_radiance != 1.0}
    return frozenset(k for k, v in given.items() if v)


def warn_unused_options(req, model):
    """Warn about options the caller gave that ``model`` (the one rendered) does not use."""
    unused = sorted(k for k in req.explicit if k in OPTION_MODELS and model not in OPTION_MODELS[k])
    if unused:
        chose = f"model={req.model!r} chose {model!r}, which" if req.model != model else f"model={model!r}"
        users = "; ".join(f"{k}: {', '.join(OPTION_MODELS[k])}" for k in unused)
        warnings.warn(f"{', '.join(unused)} not used: {chose} does not use {'it' if len(unused) == 1 else 'them'} "
                      f"(the models that do — {users})", UserWarning, stacklevel=4)


def warn_unused_lights(lights, model):
    """Warn when lights were given explicitly with a model that ignores lights."""
    from .presets import MODEL_SPECS

    if lights is None or model not in MODEL_SPECS or MODEL_SPECS[model].lit:
        return
    try:
        n = len(lights)
    except TypeError:
        n = 1
    if n:
        lit = ", ".join(m.name for m in MODEL_SPECS.values() if m.lit)
        warnings.warn(f"{n} light{'s' if n > 1 else ''} given but model={model!r} does not use lights (it renders "
                      f"without lighting); the lit models are {lit}", UserWarning, stacklevel=3)


def warn_black(renderer, result, background):
    """Warn when a lit render holds no light at all (only the background where the volume is):
    says why — no lights given, every light dropped, or a transfer function that does not scatter."""
    alpha = result.alpha
    if not np.any(alpha > 0.0):
        return
    rest = result.radiance.astype(np.float64) - (1.0 - alpha.astype(np.float64))[..., None] * np.asarray(background)
    if np.max(rest) > 1e-5 * float(np.max(background)):  # float32 rounding of T·background
        return
    if not renderer.lights:
        cause = "no lights were given (lights=() or []); leave lights out for the default light rig"
    elif not renderer.optics.has_scattering:
        cause = "the transfer function does not scatter (albedo 0 wherever σt > 0) and emits nothing"
    else:
        cause = (f"none of the {len(renderer.lights)} lights reaches the volume: zero intensity, or behind material "
                 "of optical depth > 700")
    warnings.warn(f"model={result.metadata.get('requested_model', result.metadata.get('model'))!r} rendered black: "
                  f"{cause}", UserWarning, stacklevel=4)


def available_memory() -> int:
    """Bytes of memory available to a new allocation (Linux ``MemAvailable``; else physical memory)."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        import os

        return int(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - non-POSIX
        return 1 << 62


def check_image_memory(size, model):
    """Raise MemoryError (naming ``window_size`` and the bytes) before any work when a render of
    ``size`` pixels would not fit in the memory available."""
    w, h = size
    need = int(w) * int(h) * BYTES_PER_PIXEL.get(model, BYTES_PER_PIXEL_RAYCAST)
    have = available_memory()
    if need > have:
        raise MemoryError(f"window_size={(int(w), int(h))} needs about {need / 2**30:.3g} GiB ({need} bytes) for "
                          f"the image buffers of model={model!r}, more than the {have / 2**30:.3g} GiB available; "
                          "render a smaller image")
