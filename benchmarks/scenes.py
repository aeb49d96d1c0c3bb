"""The benchmark scenes, in one registry: ``scene(name, n)`` → (grid, transfer function, lights,
phase g, camera), ``n`` the data points per axis. No benchmark builds a scene of its own.

Five groups (``GROUPS``):

* ``trade`` — the speed–accuracy trade's scenes (benchmarks/trade.py, docs/trade.rst): the
  defaults of the models were chosen on them;
* ``floor`` — the out-of-sample scenes of the diffusion model's vacuum floor (its results:
  benchmarks/results/diffusion_notes.md; nothing else was chosen on them);
* ``new`` — three further out-of-sample scenes (issue 19, item 4), fixed before any model was
  evaluated on them and not to be changed afterwards: a thin forward-scattering haze lit from
  behind, a dense high-albedo object lit from the side, the CT phantom under four coloured lights;
* ``timing`` — the scenes of the frame-time benchmarks (speed.py, ambient.py, ea_vs_vtk.py, gpu.py,
  series.py): no reference, no error; some take options that vary the scene (a scaled density for
  the TF-change rows, a time step);
* ``path_tracer`` — the path tracer's estimator scene (light_in_core.py).

The nine scenes of ``trade``, ``floor`` and ``new`` (``REFERENCED``) have cached path-traced
references (benchmarks/references.py). Every scene function below is the scene exactly as its
benchmark had it (the ``trade`` and ``floor`` ones were moved here unchanged, the others when
issue 40 took them out of their scripts); its docstring is its one-line description
(``DESCRIPTIONS``: its first paragraph).

>>> import scenes
>>> list(scenes.SCENES)[:3], scenes.GROUPS["new"]
(['supernova', 'cloud', 'ct_phantom'], ('haze_backlit', 'dense_side', 'ct_coloured'))
"""

from __future__ import annotations

import importlib.util

import numpy as np

import pv_ambient as pa
from pv_ambient import datasets


def volume(name, n, seed=0):
    """Synthetic dataset ``name`` at n³ as ``pyvista.ImageData``, or, where pyvista is not installed,
    as :func:`array_volume` (the same samples and placement)."""
    if importlib.util.find_spec("pyvista") is None:
        return array_volume(name, n, seed)
    return datasets.load(name, n=n, seed=seed)


def array_volume(name, n, seed=0):
    """Synthetic dataset ``name`` at n³ as the array core's :class:`~pv_ambient.inputs.grid.Volume`
    (no pyvista)."""
    import datasets_synthetic

    from pv_ambient.inputs.grid import Volume

    v = datasets_synthetic.load(name, n=n, seed=seed)
    return Volume({v.scalars_name: v.values}, spacing=v.spacing, origin=v.origin)


def supernova_tf(density=1.0, clim=None):
    """The supernova's transfer function: its suggested style (density scale × ``density``; colour
    and opacity range ``clim`` when given), albedo 0.9 × the colour map."""
    st = datasets.suggested_style("supernova")
    if density != 1.0 or clim is not None:
        st = {**st, "density_scale": st["density_scale"] * density, "clim": clim or st["clim"]}
    return pa.TransferFunction(**st, albedo=0.9)


def front_camera(z):
    """The camera of most scenes: 3.6 in front of the centre (−y), at height ``z``, 30° view."""
    return pa.Camera((0.0, -3.6, z), (0, 0, 0), (0, 0, 1), view_angle=30)


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
    # the light sits in the shell's faint interior, off the dense core (a light inside the core
    # makes the reference's variance explode: next-event estimates from vertices next to it —
    # the path tracer's own scene, light_in_core below)
    return (g, supernova_tf(), [pa.PointLight((0.0, 0.0, 0.35), intensity=3.0)], 0.0, front_camera(0.6))


def cloud(n=64):
    """fBm cloud (density ×8/3 of its style) under a point light above it; g = 0.6, albedo 0.95 × the colour map."""
    g = datasets.cloud(n=n)
    st = datasets.suggested_style("cloud")
    return (g, pa.TransferFunction(**{**st, "density_scale": 8.0}, albedo=0.95),
            [pa.PointLight((0.4, 0.6, 2.2), intensity=6.0)], 0.6,
            front_camera(0.8))


def ct_phantom(n=64):
    """CT head phantom under a warm and a cool point light at the front sides; g = 0.3, albedo 0.8 × the colour map."""
    g = datasets.ct_phantom(n=n)
    st = datasets.suggested_style("ct_phantom")
    return (g, pa.TransferFunction(**st, albedo=0.8),
            [pa.PointLight((1.6, -1.2, 0.8), intensity=(5.0, 2.0, 1.0)),
             pa.PointLight((-1.6, -1.2, -0.4), intensity=(1.0, 2.0, 5.0))], 0.3,
            front_camera(0.4))


# -- the diffusion floor's out-of-sample scenes (was diffusion_floor.py) --------------------------------------
def smoke_plume(n=64):
    """Smoke plume under a point light at its upper front right; g = 0.3, albedo 0.9 × the colour map."""
    g = datasets.smoke_plume(n=n)
    st = datasets.suggested_style("smoke_plume")
    return (g, pa.TransferFunction(**st, albedo=0.9), [pa.PointLight((1.2, -0.8, 1.0), intensity=5.0)], 0.3,
            front_camera(0.5))


def marschner_lobb(n=64):
    """Marschner–Lobb volume lit by a point light at its centre; isotropic, albedo 0.9 × the colour map."""
    g = datasets.marschner_lobb(n=n)
    st = datasets.suggested_style("marschner_lobb")
    return (g, pa.TransferFunction(**st, albedo=0.9), [pa.PointLight((0.0, 0.0, 0.0), intensity=2.0)], 0.0,
            front_camera(1.0))


def cloud_sun(n=64):
    """The trade's cloud under a directional light from above (sun); g = 0.6, albedo 0.95 × the colour map."""
    g = datasets.cloud(n=n)
    st = datasets.suggested_style("cloud")
    return (g, pa.TransferFunction(**{**st, "density_scale": 8.0}, albedo=0.95),
            [pa.DirectionalLight((0.3, 0.4, -1.0), irradiance=2.0)], 0.6,
            front_camera(0.8))


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
            front_camera(0.0))


def dense_side(n=64):
    """Dense blob (τ ≈ 30 across) lit from the right by a point light outside it and outside the
    image; g = 0.3, grey albedo 0.99."""
    g = datasets.blob(n=n)
    st = datasets.suggested_style("blob")
    return (g, pa.TransferFunction(**{**st, "density_scale": 30.0}, albedo=(0.99, 0.99, 0.99)),
            [pa.PointLight((1.9, -0.3, 0.4), intensity=8.0)], 0.3,
            front_camera(0.5))


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


# -- the frame-time benchmarks' scenes (no reference) -------------------------------------------------------
def supernova_centre(n=64, density=1.0, clim=None):
    """Supernova shell under a point light (intensity 4) at its centre; isotropic, albedo 0.9 × the
    colour map; the trade's supernova camera.

    The scene of speed.py, ambient.py and ea_vs_vtk.py. ``density`` and ``clim``: the transfer
    function's density scale × ``density`` and its colour and opacity range (the TF-change rows,
    speed.py's sample-count check)."""
    return (volume("supernova", n), supernova_tf(density, clim), [pa.PointLight((0.0, 0.0, 0.0), intensity=4.0)],
            0.0, front_camera(0.6))


def supernova_table(n=64, density=1.0):
    """Supernova shell under a point light (intensity 3) at its centre, a table transfer function (σt
    20 and 40 per unit on the shell) on the array core's Volume; isotropic, albedo 0.9; the camera
    above its side.

    gpu.py's scene (:func:`table_tf`): no pyvista, vtk or matplotlib needed, for a GPU node.
    ``density``: σt × ``density``."""
    cam = pa.Camera((3.0 * np.cos(0.3), 3.0 * np.sin(0.3), 1.2), (0, 0, 0), (0, 0, 1), view_angle=30.0)
    return array_volume("supernova", n), table_tf(density), [pa.PointLight((0.0, 0.0, 0.0), 3.0)], 0.0, cam


def table_tf(density=1.0):
    """:func:`supernova_table`'s transfer function (no matplotlib or pyvista needed): σt 20 and 40 per
    unit on the shell × ``density``, albedo 0.9, faint emission colour."""
    return pa.TransferFunction.from_table([0.0, 0.15, 0.5, 1.0], sigma_t=[0.0, 0.0, 20.0 * density, 40.0 * density],
                                          albedo=0.9, color=[[0, 0, 0], [0.2, 0.05, 0.0], [0.9, 0.4, 0.1],
                                                             [1.0, 0.9, 0.6]])


def cloud_series(n=64, step=0):
    """fBm cloud under a point light (intensity 4) above and behind it; isotropic, albedo 0.9 × the
    colour map.

    series.py's time series: ``step`` is the time step (the cloud's noise seed)."""
    st = datasets.suggested_style("cloud")
    return (volume("cloud", n, seed=step), pa.TransferFunction(**st, albedo=0.9),
            [pa.PointLight((0.0, 0.5, 1.6), intensity=4.0)], 0.0,
            pa.Camera((0.4, -3.8, 1.0), (0, 0, 0), (0, 0, 1), view_angle=30.0))


# -- the path tracer's estimator scene ------------------------------------------------------------------------
def light_in_core(n=64):
    """Supernova shell under a point light (intensity 3) at the centre of its dense core, where
    next-event estimates have unbounded weights; isotropic, albedo 0.9 × the colour map; otherwise
    the trade's supernova.

    light_in_core.py's scene."""
    return (volume("supernova", n), supernova_tf(), [pa.PointLight((0.0, 0.0, 0.0), intensity=3.0)], 0.0,
            front_camera(0.6))


SCENES = {f.__name__: f for f in (supernova, cloud, ct_phantom, smoke_plume, marschner_lobb, cloud_sun,
                                  haze_backlit, dense_side, ct_coloured, supernova_centre, supernova_table,
                                  cloud_series, light_in_core)}
"""Name → scene function ``f(n=64, **options)`` → (grid, transfer function, lights, phase g, camera)."""

GROUPS = {"trade": ("supernova", "cloud", "ct_phantom"),
          "floor": ("smoke_plume", "marschner_lobb", "cloud_sun"),
          "new": ("haze_backlit", "dense_side", "ct_coloured"),
          "timing": ("supernova_centre", "supernova_table", "cloud_series"),
          "path_tracer": ("light_in_core",)}
"""The trade's scenes, the diffusion floor's out-of-sample scenes, the new out-of-sample scenes, the
frame-time benchmarks' scenes, the path tracer's estimator scene."""

OLD = GROUPS["trade"] + GROUPS["floor"]
NEW = GROUPS["new"]
REFERENCED = OLD + NEW
"""The nine scenes with a cached path-traced reference (benchmarks/references.py)."""

DESCRIPTIONS = {name: " ".join(f.__doc__.split("\n\n")[0].split()) for name, f in SCENES.items()}
"""Name → the scene's description (its function's docstring's first paragraph, on one line)."""


def scene(name, n=64, **options):
    """(grid, transfer function, lights, phase g, camera) of scene ``name`` at ``n`` points per axis
    (``options``: the scene function's own, e.g. ``density``)."""
    if name not in SCENES:
        raise ValueError(f"unknown scene {name!r}; the scenes are {list(SCENES)}")
    return SCENES[name](n, **options)


def of_group(group, n=64):
    """[(name, grid, transfer function, lights, phase g, camera)] of every scene of ``group``."""
    return [(name, *scene(name, n)) for name in GROUPS[group]]


def group_of(name) -> str:
    """The group of scene ``name`` (a key of ``GROUPS``)."""
    return next(k for k, v in GROUPS.items() if name in v)
