"""The benchmark scenes, in one registry: ``scene(name, n)`` → (grid, transfer function, lights,
phase g, camera), ``n`` the data points per axis.

Three groups (``GROUPS``):

* ``trade`` — the speed–accuracy trade's scenes (benchmarks/trade.py, docs/trade.rst): the
  defaults of the models were chosen on them;
* ``floor`` — the out-of-sample scenes of benchmarks/diffusion_floor.py, used to check the
  diffusion model's vacuum floor (nothing else was chosen on them);
* ``new`` — three further out-of-sample scenes (issue 19, item 4), fixed before any model was
  evaluated on them and not to be changed afterwards: a thin forward-scattering haze lit from
  behind, a dense high-albedo object lit from the side, the CT phantom under four coloured lights.

Every scene function below is the scene exactly as its benchmark had it (the ``trade`` and
``floor`` ones were moved here unchanged); its docstring is its one-line description
(``DESCRIPTIONS``).

>>> import scenes
>>> list(scenes.SCENES)[:3], scenes.GROUPS["new"]
(['supernova', 'cloud', 'ct_phantom'], ('haze_backlit', 'dense_side', 'ct_coloured'))
"""

from __future__ import annotations

import numpy as np

import pv_ambient as pa
from pv_ambient import datasets


def orbit(cam, degrees):
    """``cam`` turned by ``degrees`` about the axis through its focal point along its view-up (a
    camera move: the benchmarks time frames from such cameras)."""
    pos, foc = np.array(cam.position), np.array(cam.focal_point)
    k = np.array(cam.view_up, float)
    k /= np.linalg.norm(k)
    v, a = pos - foc, np.radians(degrees)
    v = v * np.cos(a) + np.cross(k, v) * np.sin(a) + k * np.dot(k, v) * (1 - np.cos(a))
    return pa.Camera(tuple(foc + v), cam.focal_point, cam.view_up, view_angle=cam.view_angle)


# -- the trade (benchmarks/trade.py) -------------------------------------------------------------------------
def supernova(n=64):
    """Supernova shell lit by a point light in its faint interior, off the dense core; isotropic,
    albedo 0.9 × the colour map."""
    g = datasets.supernova(n=n)
    st = datasets.suggested_style("supernova")
    # the light sits in the shell's faint interior, off the dense core (a light inside the core
    # makes the reference's variance explode: next-event estimates from vertices next to it)
    return (g, pa.TransferFunction(**st, albedo=0.9), [pa.PointLight((0.0, 0.0, 0.35), intensity=3.0)],
            0.0, pa.Camera((0.0, -3.6, 0.6), (0, 0, 0), (0, 0, 1), view_angle=30))


def cloud(n=64):
    """fBm cloud (density ×8/3 of its style) under a point light above it; g = 0.6, albedo 0.95 × the colour map."""
    g = datasets.cloud(n=n)
    st = datasets.suggested_style("cloud")
    return (g, pa.TransferFunction(**{**st, "density_scale": 8.0}, albedo=0.95),
            [pa.PointLight((0.4, 0.6, 2.2), intensity=6.0)], 0.6,
            pa.Camera((0.0, -3.6, 0.8), (0, 0, 0), (0, 0, 1), view_angle=30))


def ct_phantom(n=64):
    """CT head phantom under a warm and a cool point light at the front sides; g = 0.3, albedo 0.8 × the colour map."""
    g = datasets.ct_phantom(n=n)
    st = datasets.suggested_style("ct_phantom")
    return (g, pa.TransferFunction(**st, albedo=0.8),
            [pa.PointLight((1.6, -1.2, 0.8), intensity=(5.0, 2.0, 1.0)),
             pa.PointLight((-1.6, -1.2, -0.4), intensity=(1.0, 2.0, 5.0))], 0.3,
            pa.Camera((0.0, -3.6, 0.4), (0, 0, 0), (0, 0, 1), view_angle=30))


# -- diffusion_floor.py's out-of-sample scenes ----------------------------------------------------------------
def smoke_plume(n=64):
    """Smoke plume under a point light at its upper front right; g = 0.3, albedo 0.9 × the colour map."""
    g = datasets.smoke_plume(n=n)
    st = datasets.suggested_style("smoke_plume")
    return (g, pa.TransferFunction(**st, albedo=0.9), [pa.PointLight((1.2, -0.8, 1.0), intensity=5.0)], 0.3,
            pa.Camera((0, -3.6, 0.5), (0, 0, 0), (0, 0, 1), view_angle=30))


def marschner_lobb(n=64):
    """Marschner–Lobb volume lit by a point light at its centre; isotropic, albedo 0.9 × the colour map."""
    g = datasets.marschner_lobb(n=n)
    st = datasets.suggested_style("marschner_lobb")
    return (g, pa.TransferFunction(**st, albedo=0.9), [pa.PointLight((0.0, 0.0, 0.0), intensity=2.0)], 0.0,
            pa.Camera((0, -3.6, 1.0), (0, 0, 0), (0, 0, 1), view_angle=30))


def cloud_sun(n=64):
    """The trade's cloud under a directional light from above (sun); g = 0.6, albedo 0.95 × the colour map."""
    g = datasets.cloud(n=n)
    st = datasets.suggested_style("cloud")
    return (g, pa.TransferFunction(**{**st, "density_scale": 8.0}, albedo=0.95),
            [pa.DirectionalLight((0.3, 0.4, -1.0), irradiance=2.0)], 0.6,
            pa.Camera((0, -3.6, 0.8), (0, 0, 0), (0, 0, 1), view_angle=30))


# -- new out-of-sample scenes (issue 19, item 4): fixed before any model was evaluated on them ----------------
def haze_backlit(n=64):
    """Thin haze filling the box (τ ≈ 0.8 across), lit from behind by a directional light 29° off
    the view axis (outside the image); g = 0.85, grey albedo 0.95."""
    g = datasets.haze(n=n)
    st = datasets.suggested_style("haze")  # density_scale 1: median optical depth ≈ 0.8 along the view axis
    # the light travels toward the camera, down and to the left: the light source direction is
    # 29° from the view axis, outside the 30° field of view (whose corners are at 21°)
    return (g, pa.TransferFunction(**st, albedo=(0.95, 0.95, 0.95)),
            [pa.DirectionalLight((-0.25, -0.87, -0.42), irradiance=2.0)], 0.85,
            pa.Camera((0.0, -3.6, 0.0), (0, 0, 0), (0, 0, 1), view_angle=30))


def dense_side(n=64):
    """Dense blob (τ ≈ 30 across) lit from the right by a point light outside it and outside the
    image; g = 0.3, grey albedo 0.99."""
    g = datasets.blob(n=n)
    st = datasets.suggested_style("blob")
    return (g, pa.TransferFunction(**{**st, "density_scale": 30.0}, albedo=(0.99, 0.99, 0.99)),
            [pa.PointLight((1.9, -0.3, 0.4), intensity=8.0)], 0.3,
            pa.Camera((0.0, -3.6, 0.5), (0, 0, 0), (0, 0, 1), view_angle=30))


def ct_coloured(n=64):
    """The trade's CT phantom TF under four coloured point lights: red left, green right, blue
    above-behind, amber front-below; g = 0.3, albedo 0.8 × the colour map."""
    g = datasets.ct_phantom(n=n)
    st = datasets.suggested_style("ct_phantom")
    return (g, pa.TransferFunction(**st, albedo=0.8),
            [pa.PointLight((-1.8, -0.4, 0.3), intensity=(6.0, 1.2, 0.8)),
             pa.PointLight((1.8, 0.3, -0.2), intensity=(1.0, 5.0, 1.5)),
             pa.PointLight((0.3, 1.0, 1.8), intensity=(1.0, 1.5, 6.0)),
             pa.PointLight((-0.5, -1.6, -1.2), intensity=(3.0, 2.4, 1.2))], 0.3,
            pa.Camera((1.2, -3.4, 0.9), (0, 0, 0), (0, 0, 1), view_angle=30))


SCENES = {f.__name__: f for f in (supernova, cloud, ct_phantom, smoke_plume, marschner_lobb, cloud_sun,
                                  haze_backlit, dense_side, ct_coloured)}
"""Name → scene function ``f(n=64)`` → (grid, transfer function, lights, phase g, camera)."""

GROUPS = {"trade": ("supernova", "cloud", "ct_phantom"),
          "floor": ("smoke_plume", "marschner_lobb", "cloud_sun"),
          "new": ("haze_backlit", "dense_side", "ct_coloured")}
"""The trade's scenes, diffusion_floor.py's out-of-sample scenes, the new out-of-sample scenes."""

OLD = GROUPS["trade"] + GROUPS["floor"]
NEW = GROUPS["new"]

DESCRIPTIONS = {name: " ".join(f.__doc__.split()) for name, f in SCENES.items()}
"""Name → the scene's description (its function's docstring on one line)."""


def scene(name, n=64):
    """(grid, transfer function, lights, phase g, camera) of scene ``name`` at ``n`` points per axis."""
    if name not in SCENES:
        raise ValueError(f"unknown scene {name!r}; the scenes are {list(SCENES)}")
    return SCENES[name](n)


def group_of(name) -> str:
    """``"trade"``, ``"floor"`` or ``"new"``."""
    return next(k for k, v in GROUPS.items() if name in v)
