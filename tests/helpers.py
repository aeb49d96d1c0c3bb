"""Scenes shared by test files in several folders: a cloud-like physical medium with two lights
seen by one camera (the camera-pass models, the path tracer), the scale-invariance scenes of
tests/acceptance/test_extremes.py (also the diffusion model's light-inside case), a box of constant
scalars (emission–absorption, the request's checks), a lit homogeneous box (denoising), and JSON
scene files (the scene format, the CLI, the request's memory check)."""

import json

import numpy as np
import pyvista as pv

import pv_ambient as pa
from pv_ambient.inputs.camera import Camera
from pv_ambient.inputs.lights import DirectionalLight, PointLight

CAM = Camera((0.2, -4.0, 0.3), (0, 0, 0), (0, 0, 1), view_angle=35)
SIZE = (24, 20)


def physical_grid(n=17, sigma=3.0, albedo=0.9, emission=(0.0, 0.0, 0.0), noise=True, seed=0):
    """A cloud-like physical medium on [−1, 1]³: σt (1/world unit), RGB albedo, emission."""
    g = pv.ImageData(dimensions=(n, n, n), spacing=(2 / (n - 1),) * 3, origin=(-1, -1, -1))
    rng = np.random.default_rng(seed)
    p = g.points
    base = np.clip(1.0 - np.linalg.norm(p, axis=1) / 1.1, 0, None)
    if noise:
        base *= 0.5 + rng.random(g.n_points)
    g["sigma_t"] = (sigma * base).astype(np.float32)
    g["albedo"] = np.tile(np.broadcast_to(np.asarray(albedo, np.float32), (3,)), (g.n_points, 1))
    g["emission"] = np.tile(np.asarray(emission, np.float32), (g.n_points, 1))
    return g


LIGHTS = [PointLight((0.3, -1.6, 0.9), intensity=(3.0, 2.5, 2.0)), DirectionalLight((0.2, 0.3, -1.0), irradiance=0.5)]


def renderer(grid, lights=LIGHTS):
    return pa.Renderer(grid, transfer_function=pa.TransferFunction.physical(), lights=lights)


def render(r, model, **kw):
    kw.setdefault("quality", "preview")
    return r.render(camera=CAM, window_size=SIZE, model=model, **kw).radiance.astype(np.float64)


def rel(a, b):
    return np.abs(a - b).max() / max(np.abs(b).max(), 1e-30)


def scaled_scene(kind, s):
    """Scene ``kind`` ("outside" or "inside") with space scaled by ``s``."""
    rng = np.random.default_rng(3)
    if kind == "outside":
        n = 12
        h = 1.0 / (n - 1)
        origin = np.array([-0.52, -0.47, -0.5])
        grid = pv.ImageData(dimensions=(n,) * 3, spacing=(h * s,) * 3, origin=tuple(origin * s))
        p = grid.points / s
        base = np.clip(1.0 - np.linalg.norm(p, axis=1) / 0.55, 0, None) * (0.5 + rng.random(grid.n_points))
        sigma = 6.0 * base
        # the first light sits at the centre of the grid, index (5.5, 5.5, 5.5), and the directional
        # light's x and y components tie: the light volumes' sweep choices must not hinge on rounding
        lights = [PointLight(tuple(np.array([-0.02, 0.03, 0.0]) * s), intensity=0.05 * s * s),
                  PointLight(tuple(np.array([-0.9, 0.4, 1.1]) * s), intensity=(2.0 * s * s, 1.5 * s * s, 1.0 * s * s)),
                  DirectionalLight((0.6, 0.6, -0.4), irradiance=0.7)]
        cam = Camera(tuple(np.array([0.7, -2.2, 0.9]) * s), tuple(np.array([0.02, 0.0, -0.01]) * s), (0, 0, 1),
                     view_angle=40)
        g, options = 0.6, {}
    else:
        n = 9
        h = 0.125
        origin = np.array([-0.5, -0.5, -0.5])
        grid = pv.ImageData(dimensions=(n,) * 3, spacing=(h * s,) * 3, origin=tuple(origin * s))
        sigma = 4.0 + 40.0 * rng.random(grid.n_points)  # ~45 optical depths across: ERT cuts rays
        on_sample = origin + h * np.array([3, 5, 4])
        lights = [PointLight(tuple(on_sample * s), intensity=0.02 * s * s),
                  PointLight(tuple(np.array([0.05, -0.3, 0.1]) * s), intensity=(0.01 * s * s, 0.02 * s * s, 0.0))]
        cam = Camera(tuple(np.array([0.06, -0.21, 0.03]) * s), tuple(np.array([0.1, 0.6, 0.0]) * s), (0, 0, 1),
                     view_angle=80)
        g, options = 0.3, {"radius": 0.3 * s}
    grid["sigma_t"] = (sigma / s).astype(np.float32)
    grid["albedo"] = np.tile(np.array([0.9, 0.8, 0.6], np.float32), (grid.n_points, 1))
    grid["emission"] = np.tile(np.array([0.2, 0.1, 0.05], np.float32), (grid.n_points, 1))
    r = pa.Renderer(grid, transfer_function=pa.TransferFunction.physical(), lights=lights)
    # the default quality (light grid: docs/ambient_scattering.rst §3's factor from σt·h); g = 0.6 and 0.3 at
    # "balanced" table quality are slices shipped with the package (nothing to compute)
    return r, cam, g, {"quality": "balanced", "table_quality": "balanced", **options}



def box_grid(dims=(20, 20, 20), spacing=0.1, origin=-0.95, value=1.0):
    """A box of constant scalars ``value`` (array "d"): by default 20³ points filling [−0.95, 0.95]³."""
    g = pv.ImageData(dimensions=dims, spacing=(spacing,) * 3, origin=(origin,) * 3)
    g["d"] = np.full(g.n_points, value, np.float32)
    return g


def lit_box():
    """A renderer of a 9³ homogeneous box on [−1, 1]³ (σt 1.5, albedo 0.8) lit by one point light:
    the denoising tests' scene."""
    g = pv.ImageData(dimensions=(9, 9, 9), spacing=(0.25,) * 3, origin=(-1, -1, -1))
    g["sigma_t"] = np.full(g.n_points, 1.5, np.float32)
    g["albedo"] = np.full((g.n_points, 3), 0.8, np.float32)
    return pa.Renderer(g, transfer_function=pa.TransferFunction.physical(),
                       lights=[pa.PointLight((0, -2, 1), intensity=4.0)])


#: The camera of the scene-file tests, in the JSON form.
SCENE_CAMERA = {"position": [0.0, -5.0, 0.0], "focal_point": [0.0, 0.0, 0.0], "view_up": [0.0, 0.0, 1.0],
                "view_angle": 30.0, "parallel_projection": False, "parallel_scale": 1.0}


def write_scene(tmp_path, scene, name="scene.json"):
    """``scene`` (a dict) written as ``tmp_path/name`` in JSON; returns the path."""
    p = tmp_path / name
    p.write_text(json.dumps(scene))
    return p


def scene_file(tmp_path, **extra):
    """A JSON scene file in ``tmp_path``: a 12³ cloud, single scattering, 16×12, with ``extra`` keys."""
    scene = {"version": 1, "volume": {"dataset": "cloud", "n": 12}, "model": "single_scattering",
             "image": {"width": 16, "height": 12}, **extra}
    return write_scene(tmp_path, scene)
