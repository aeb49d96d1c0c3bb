"""Point and directional lights (docs/conventions.rst "Lights").

A point light has a position and an RGB radiant intensity ``I`` in W/sr: its unoccluded
irradiance at distance d is ``I/d²``. A directional light has a direction of *propagation* and an
RGB irradiance ``E`` (W per unit area perpendicular to it). Kernels receive lights packed into
arrays by :func:`pack_lights`.

Not giving lights (``lights=None``) and giving none (``lights=()``) differ: for the lit models
the first gets the default light rig of :func:`default_lights`, placed from the camera of the
first render (docs/lights.rst); the second renders without light. A ``pyvista.Light`` is
accepted too (:func:`from_pyvista_light`).
"""

from __future__ import annotations

import warnings
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


#: Irradiance (per unit area across the light) of the default rig's key light, and of a
#: ``pyvista.Light`` of intensity 1 at the volume: ``8π`` makes a white, non-absorbing medium lit
#: and seen head-on shine with radiance 1 in single scattering (``a·E/(8π)`` for a semi-infinite
#: isotropic medium), whatever the world unit.
REFERENCE_IRRADIANCE = 8.0 * np.pi

#: The default rig, after VTK's light kit (``vtkLightKit``, what PyVista's ``lighting="light kit"``
#: uses): (name, elevation°, azimuth° relative to the camera, irradiance / REFERENCE_IRRADIANCE).
#: The key light comes from above and right of the camera, the fill light (key-to-fill ratio 3)
#: from below and left; the light kit's back lights and head light are left out (each light costs
#: a light volume; a head light casts no visible shadow).
DEFAULT_RIG = (("key", 50.0, 10.0, 1.0), ("fill", -75.0, -10.0, 1.0 / 3.0))


def light_kit_direction(camera, elevation, azimuth):
    """The direction of travel of a light at ``elevation``/``azimuth`` degrees relative to the
    camera (``vtkLight.SetDirectionAngle``'s convention: elevation towards the camera's up,
    azimuth towards its right; (0, 0) shines along the view direction)."""
    fwd, right, up = camera.basis()
    e, a = np.radians(elevation), np.radians(azimuth)
    towards_light = np.cos(e) * (np.cos(a) * -fwd + np.sin(a) * right) + np.sin(e) * up
    return tuple(float(v) for v in -towards_light)


def default_lights(camera):
    """The default light rig for ``camera``: directional key and fill lights (:data:`DEFAULT_RIG`).

    Directional lights make the rig independent of the world unit: the radiance they give depends
    on optical depths only, so a volume in millimetres and one in metres are lit alike.

    Examples
    --------
    >>> from pv_ambient.inputs.camera import Camera
    >>> from pv_ambient.inputs.lights import default_lights
    >>> key, fill = default_lights(Camera((0, -4, 0), (0, 0, 0), (0, 0, 1)))
    >>> [round(v, 3) for v in key.direction], round(key.irradiance[0] / fill.irradiance[0], 6)
    ([-0.112, 0.633, -0.766], 3.0)
    """
    return tuple(DirectionalLight(light_kit_direction(camera, el, az), REFERENCE_IRRADIANCE * k)
                 for _, el, az, k in DEFAULT_RIG)


def default_view_lights():
    """The default rig for PyVista's default (isometric) view of a volume, whatever its bounds:
    the rig depends on the view's direction alone. What lights every frame of a series whose
    frames have no camera (docs/series.rst).

    >>> from pv_ambient.inputs.camera import as_camera
    >>> default_view_lights() == default_lights(as_camera(None, bounds=(0, 5, 0, 2, 0, 9))[0])
    True
    """
    from .camera import as_camera

    return default_lights(as_camera(None, bounds=(-1.0, 1.0, -1.0, 1.0, -1.0, 1.0))[0])


def is_pyvista_light(spec) -> bool:
    """Whether ``spec`` is a ``vtkLight`` (a ``pyvista.Light``), told by its VTK methods."""
    return all(hasattr(spec, m) for m in ("GetPositional", "GetLightType", "GetIntensity", "GetFocalPoint"))


def needs_camera(lights) -> bool:
    """Whether resolving ``lights`` needs the render's camera: the default rig (None) or a
    ``pyvista.Light`` that is a head light or camera light."""
    if lights is None:
        return True
    items = [lights] if is_pyvista_light(lights) or isinstance(lights, (PointLight, DirectionalLight, dict)) else lights
    return any(is_pyvista_light(lt) and lt.GetLightType() in (1, 2) for lt in items)


def from_pyvista_light(light, *, center, camera=None, index=0):
    """A ``pyvista.Light`` (or ``vtkLight``) as a physical light.

    A positional light becomes a :class:`PointLight` at its position, a non-positional one a
    :class:`DirectionalLight` shining from its position towards its focal point. VTK's light
    intensity is a brightness, not a physical unit: intensity 1 becomes an irradiance of
    :data:`REFERENCE_IRRADIANCE` at ``center`` (the volume's centre; a point light's intensity is
    scaled by its squared distance to it), in the light's diffuse colour. A head light sits at
    the camera and looks at its focal point; a camera light's position and focal point are in
    VTK's camera frame (camera at (0, 0, 1) looking at the origin, y up, lengths in units of the
    camera's distance to its focal point). Both are placed with ``camera`` — the camera of the
    render that first uses them — and stay there (a camera move does not relight). A switched
    off light has zero intensity; spot cones and attenuation are not modelled (a warning).
    """
    where = f"lights[{index}]"
    kind = light.GetLightType()
    pos, foc = np.array(light.GetPosition(), float), np.array(light.GetFocalPoint(), float)
    if kind in (1, 2):
        if camera is None:
            raise ValueError(f"{where} is a pyvista head/camera light: it needs a camera to be placed")
        fwd, right, up = camera.basis()
        cpos, cfoc = np.array(camera.position), np.array(camera.focal_point)
        if kind == 1:  # head light
            pos, foc = cpos, cfoc
        else:
            d = camera.distance
            to_world = lambda p: cfoc + d * (p[0] * right + p[1] * up - p[2] * fwd)  # noqa: E731
            pos, foc = to_world(pos), to_world(foc)
    colour = np.array(light.GetDiffuseColor(), float) * float(light.GetIntensity()) * bool(light.GetSwitch())
    positional = bool(light.GetPositional())
    if positional and (light.GetConeAngle() < 90.0 or tuple(light.GetAttenuationValues()) != (1.0, 0.0, 0.0)):
        warnings.warn(f"{where}: a pyvista.Light's spot cone and attenuation are not modelled; it is rendered as "
                      "an isotropic point light (1/d² fall-off)", UserWarning, stacklevel=4)
    if positional:
        d2 = float(np.sum((pos - np.asarray(center, float)) ** 2))
        return PointLight(tuple(pos), tuple(colour * REFERENCE_IRRADIANCE * d2))
    if not np.any(foc != pos):
        raise ValueError(f"{where}: a directional pyvista.Light needs a focal point away from its position")
    return DirectionalLight(tuple(foc - pos), tuple(colour * REFERENCE_IRRADIANCE))


def as_light(spec, index=0, *, center=None, camera=None):
    """A light from a light object, its JSON dict form or a ``pyvista.Light`` (placed with the
    volume's ``center`` and the render's ``camera``: :func:`from_pyvista_light`)."""
    if isinstance(spec, (PointLight, DirectionalLight)):
        return spec
    where = f"lights[{index}]"
    if is_pyvista_light(spec):
        return from_pyvista_light(spec, center=(0.0, 0.0, 0.0) if center is None else center, camera=camera,
                                  index=index)
    if not isinstance(spec, dict):
        raise TypeError(f"{where} must be a PointLight, DirectionalLight, pyvista.Light or dict, "
                        f"got {type(spec).__name__}")
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


def as_lights(lights, *, center=None, camera=None):
    """A tuple of lights from one light, or a sequence of lights / dicts / ``pyvista.Light``.

    None (lights not given) is the default rig (:func:`default_lights`) when a ``camera`` is
    given, else no light; ``center`` and ``camera`` place ``pyvista.Light`` objects.
    """
    if lights is None:
        return default_lights(camera) if camera is not None else ()
    if isinstance(lights, (PointLight, DirectionalLight, dict)) or is_pyvista_light(lights):
        lights = [lights]
    if isinstance(lights, (str, bytes)) or not hasattr(lights, "__iter__"):
        raise TypeError(f"lights must be a sequence of lights (or one light), got {type(lights).__name__}")
    return tuple(as_light(s, i, center=center, camera=camera) for i, s in enumerate(lights))


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
