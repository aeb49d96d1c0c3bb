"""Point and directional lights (docs/conventions.rst "Lights").

A point light has a position and an RGB radiant intensity ``I`` in W/sr: its unoccluded
irradiance at distance d is ``I/d²``. A directional light has a direction of *propagation* and an
RGB irradiance ``E`` (W per unit area perpendicular to it). Kernels receive lights packed into
arrays by :func:`pack_lights`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .validation import check_rgb, check_vector

POINT, DIRECTIONAL = 0, 1


@dataclass(frozen=True)
class PointLight:
    """Isotropic point light.

    Parameters
    ----------
    position : sequence of float
        World position.
    intensity : float or sequence of float, default: 1.0
        RGB radiant intensity in W/sr (a scalar means white).

    Examples
    --------
    >>> from pv_ambient.inputs.lights import PointLight
    >>> PointLight((0, 0, 0), intensity=(1.0, 0.5, 0.2)).intensity
    (1.0, 0.5, 0.2)
    """

    position: tuple
    intensity: tuple = (1.0, 1.0, 1.0)

    def __post_init__(self):
        object.__setattr__(self, "position", tuple(float(v) for v in check_vector(self.position, "light position")))
        object.__setattr__(self, "intensity", tuple(float(v) for v in check_rgb(self.intensity, "light intensity")))

    @property
    def power(self):
        return self.intensity

    def to_dict(self):
        return {"kind": "point", "position": list(self.position), "intensity": list(self.intensity)}


@dataclass(frozen=True)
class DirectionalLight:
    """Distant light with parallel rays.

    Parameters
    ----------
    direction : sequence of float
        Direction in which the light *travels* (normalised here).
    irradiance : float or sequence of float, default: 1.0
        RGB irradiance on a plane perpendicular to ``direction``.
    """

    direction: tuple
    irradiance: tuple = (1.0, 1.0, 1.0)

    def __post_init__(self):
        d = check_vector(self.direction, "light direction", nonzero=True)
        object.__setattr__(self, "direction", tuple(float(v) for v in d / np.linalg.norm(d)))
        object.__setattr__(self, "irradiance", tuple(float(v) for v in check_rgb(self.irradiance, "light irradiance")))

    @property
    def power(self):
        return self.irradiance

    def to_dict(self):
        return {"kind": "directional", "direction": list(self.direction), "irradiance": list(self.irradiance)}


def as_light(spec, index=0):
    """A light from a light object or its JSON dict form."""
    if isinstance(spec, (PointLight, DirectionalLight)):
        return spec
    where = f"lights[{index}]"
    if not isinstance(spec, dict):
        raise TypeError(f"{where} must be a PointLight, DirectionalLight or dict, got {type(spec).__name__}")
    kind = spec.get("kind", "point")
    d = {k: v for k, v in spec.items() if k != "kind"}
    allowed = {"point": {"position", "intensity"}, "directional": {"direction", "irradiance"}}
    if kind not in allowed:
        raise ValueError(f"{where}['kind'] must be 'point' or 'directional', got {kind!r}")
    unknown = set(d) - allowed[kind]
    if unknown:
        raise ValueError(f"{where} ({kind}) has unknown keys {sorted(unknown)}; allowed: {sorted(allowed[kind])}")
    try:
        return PointLight(**d) if kind == "point" else DirectionalLight(**d)
    except TypeError as exc:
        raise ValueError(f"{where}: {exc}") from None


def as_lights(lights):
    """A tuple of lights from None, one light, or a sequence of lights / dicts."""
    if lights is None:
        return ()
    if isinstance(lights, (PointLight, DirectionalLight, dict)):
        lights = [lights]
    return tuple(as_light(s, i) for i, s in enumerate(lights))


def pack_lights(lights):
    """Arrays for kernels: ``kind`` (n,) int64, ``vec`` (n, 3) position or unit direction,
    ``power`` (n, 3) intensity or irradiance."""
    n = len(lights)
    kind = np.zeros(max(n, 1), np.int64)
    vec = np.zeros((max(n, 1), 3))
    power = np.zeros((max(n, 1), 3))
    for i, lt in enumerate(lights):
        if isinstance(lt, PointLight):
            kind[i], vec[i], power[i] = POINT, lt.position, lt.intensity
        else:
            kind[i], vec[i], power[i] = DIRECTIONAL, lt.direction, lt.irradiance
    return kind[:n] if n else kind[:0], vec[:n], power[:n]
