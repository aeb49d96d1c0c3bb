"""The checked inputs of one render: :class:`RenderRequest`, built by
:meth:`pv_ambient.Renderer.request` (every argument of :meth:`pv_ambient.Renderer.render` checked
once), and the checks of its array inputs."""

from __future__ import annotations

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
    bake_lights: bool
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


