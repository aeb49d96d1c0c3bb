"""The JSON scene format (version 1) shared by the CLI and the Python API.

A scene file is a JSON object. Keys (all but ``volume`` optional)::

    {"version": 1,
     "volume": "data.vti",                  # path relative to the JSON file, read with pyvista.read
                                            # or {"dataset": "supernova", "n": 64, "seed": 0}
     "scalars": "density",                  # array to classify (active scalars when absent)
     "transfer_function": {"kind": "colormap", "cmap": "magma", "clim": [0, 1], "opacity": "sigmoid",
                           "opacity_unit_distance": 0.05, "albedo": 0.9, "emission": 0.0},
                           # or {"kind": "physical"}: point arrays sigma_t (1/world unit),
                           # albedo (1 or 3 components), optional emission (3 components, radiance)
     "phase": {"kind": "hg", "g": 0.6},     # "isotropic" | "hg" | "schlick" | "rayleigh"
     "lights": [{"kind": "point", "position": [0, 0, 0], "intensity": [1, 1, 1]},          # W/sr
                {"kind": "directional", "direction": [0, 0, -1], "irradiance": [1, 1, 1]}],
                                            # no "lights" key: the default rig (lit models); []: no light
     "camera": {"position": [0, -4, 0], "focal_point": [0, 0, 0], "view_up": [0, 0, 1],
                "view_angle": 30.0, "parallel_projection": false, "parallel_scale": 1.0},
     "image": {"width": 256, "height": 256},
     "model": "ambient_scattering",         # see pv_ambient.rendering.presets.ALL_MODELS
     "quality": "balanced",                 # "preview" | "balanced" | "accurate"
     "background": [0, 0, 0],               # constant background radiance
     "step": null, "seed": 0, "jitter": false,
     "backend": "auto",                     # "auto" | "cpu" | "cuda" (since pv_ambient 0.2.0)
     "display": {"exposure": "auto", "tonemap": "clip", "srgb": false}}   # PNG conversion only

Units (docs/conventions.rst): world units are the grid's; σt in 1/world unit; a point light's intensity in
W/sr gives irradiance I/d² at distance d; a directional light's irradiance is per unit area;
``view_angle`` is VTK's vertical angle in degrees. The radiance written by
``--radiance OUT.npy`` is float32 ``(H, W, 3)``, linear, top row first, background included.

``backend`` (added in pv_ambient 0.2.0, optional, format version unchanged: files without it
render as before) says where the kernels run (:mod:`pv_ambient.backend`); the images of the two
backends agree to float rounding.

Since pv_ambient 0.3.0 (format version unchanged) a scene without a ``lights`` key gives the lit
models the default light rig (docs/lights.rst: directional key and fill lights placed from the
camera), where 0.2.0 rendered them black; ``"lights": []`` still means no light (black, with a
warning). The PNG's default ``exposure`` is ``"auto"`` for the lit models (docs/display.rst) and
0 for emission–absorption and ambient occlusion, as before; a number or ``"auto"`` may be given.
With ``lights`` given, the radiance (``--radiance``) is what 0.2.0 wrote, bit for bit (tested).

A model's options go at top level too (``pv_ambient.rendering.presets.SCENE_OPTIONS``:
``"samples_per_pixel"``, ``"radius"``, ``"flux_limited"``, ``"sweep_orders"``, …); since
pv_ambient 0.4.0 (format version unchanged) ``"model": "progressive"`` with its
``"base_model"`` and ``"unbiased"``, and ``"denoise"`` (with ``pyoidn``) (docs/progressive.rst).

Unknown top-level keys are reported with a warning and ignored (a newer file read by an older
version); unknown keys inside ``camera``, ``lights``, ``transfer_function``, ``image`` and
``display`` are errors.
"""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass, field
from pathlib import Path

from .inputs.validation import check_choice, check_real, check_window_size
from .backend import check_backend
from .rendering.result import DISPLAY_KEYS, unknown_display_keys
from .rendering.presets import QUALITIES
from .rendering.request import check_image_memory
from .rendering.presets import SCENE_OPTIONS as MODEL_KEYS

SCENE_VERSION = 1
TOP_KEYS = {"version", "volume", "scalars", "transfer_function", "phase", "lights", "camera", "image", "model",
            "quality", "background", "step", "seed", "jitter", "display", "preference", "nan_policy",
            "backend"}
#: extra render knobs a scene may carry at top level (model options)


@dataclass
class Scene:
    """A parsed scene: the grid (None from :func:`scene_options`) and the keyword arguments for
    Renderer and render."""

    grid: object
    renderer_kwargs: dict = field(default_factory=dict)
    render_kwargs: dict = field(default_factory=dict)
    display: dict = field(default_factory=dict)
    source: str = ""


def _load_volume(spec, base: Path):
    if isinstance(spec, dict):
        from . import datasets

        spec = dict(spec)
        name = spec.pop("dataset", None)
        if name is None:
            raise ValueError("volume must be a path or {'dataset': name, ...}; got a dict without 'dataset'")
        fn = getattr(datasets, str(name), None)
        if fn is None or name.startswith("_") or name not in datasets.NAMES:
            raise ValueError(f"volume dataset {name!r} is unknown; available: {list(datasets.NAMES)}")
        return fn(**spec)
    if not isinstance(spec, str):
        raise TypeError(f"volume must be a path string or a dataset dict, got {type(spec).__name__}")
    import pyvista as pv

    path = Path(spec)
    if not path.is_absolute():
        path = base / path
    if not path.exists():
        raise FileNotFoundError(f"volume file {str(path)!r} does not exist (paths are relative to the scene file)")
    data = pv.read(path)
    if not isinstance(data, pv.ImageData):
        raise TypeError(f"volume {str(path)!r} holds a {type(data).__name__}, not an ImageData")
    return data


def parse_scene(data, base_dir=".") -> Scene:
    """Parse a scene dict (the JSON object) into a :class:`Scene`."""
    return _parse(data, Path(base_dir), read_volume=True)


def scene_options(data, base_dir=".") -> Scene:
    """Parse a scene dict without its volume: a :class:`Scene` whose ``grid`` is None.

    Every key is checked as :func:`parse_scene` checks it but ``volume``, which is neither
    required nor read: ``pv-ambient series --volumes`` replaces it by each time step, read by the
    worker that renders the frame (docs/series.rst, "The command line").
    """
    return _parse(data, Path(base_dir), read_volume=False)


def _parse(data, base: Path, *, read_volume: bool) -> Scene:
    if not isinstance(data, dict):
        raise TypeError(f"a scene must be a JSON object, got {type(data).__name__}")
    version = data.get("version", SCENE_VERSION)
    if version != SCENE_VERSION:
        raise ValueError(f"scene version {version!r} is not supported (this is version {SCENE_VERSION})")
    unknown = set(data) - TOP_KEYS - MODEL_KEYS
    if unknown:
        warnings.warn(f"scene keys {sorted(unknown)} are not part of scene format {SCENE_VERSION}; ignored",
                      UserWarning, stacklevel=3)
    if read_volume and "volume" not in data:
        raise ValueError("scene needs a 'volume' (a .vti path or {'dataset': name})")
    image = data.get("image", {"width": 512, "height": 512})
    if not isinstance(image, dict) or set(image) - {"width", "height"}:
        raise ValueError(f"image must be {{'width': int, 'height': int}}, got {image!r}")
    size = check_window_size((image.get("width", 512), image.get("height", 512)), "image width/height")
    check_image_memory(size, data.get("model", "emission_absorption"))  # before the volume is read
    grid = _load_volume(data["volume"], base) if read_volume else None
    rk = {"transfer_function": data.get("transfer_function"), "scalars": data.get("scalars"),
          "lights": data.get("lights"), "preference": data.get("preference", "point"),
          "nan_policy": data.get("nan_policy", "raise"),
          "backend": check_backend(data.get("backend", "auto"))}
    quality = check_choice(data.get("quality", "balanced"), "quality", QUALITIES)
    kw = {"camera": data.get("camera"), "window_size": size, "model": data.get("model", "emission_absorption"),
          "background": data.get("background", (0.0, 0.0, 0.0)), "seed": data.get("seed", 0),
          "jitter": data.get("jitter", False), "quality": quality}
    if data.get("step") is not None:
        kw["step"] = data["step"]
    if "phase" in data:
        kw["phase"] = data["phase"]
    for k in MODEL_KEYS:
        if k in data:
            kw[k] = data[k]
    display = data.get("display", {})
    if not isinstance(display, dict) or unknown_display_keys(display):
        raise ValueError(f"display must hold only {', '.join(DISPLAY_KEYS)}; got {display!r}")
    if display.get("exposure", "auto") != "auto":
        check_real(display["exposure"], "display exposure (a number of stops or 'auto')")
    return Scene(grid=grid, renderer_kwargs=rk, render_kwargs=kw, display=dict(display))


def read_scene(path) -> dict:
    """The JSON object of a scene file, not yet checked (:func:`parse_scene`, :func:`scene_options`):
    the one place scene files are read, by ``pv-ambient render`` and ``pv-ambient series``."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"scene file {str(path)!r} is not valid JSON: {exc}") from None
    if not isinstance(data, dict):
        raise TypeError(f"a scene must be a JSON object, got {type(data).__name__}")
    return data


def load_scene(path) -> Scene:
    """Read a scene file."""
    path = Path(path)
    scene = parse_scene(read_scene(path), base_dir=path.parent)
    scene.source = str(path)
    return scene


def render_scene(scene, *, progress_bar=None):
    """Render a :class:`Scene`, a scene dict, or a path to a scene file → RenderResult
    (``progress_bar`` as :meth:`pv_ambient.Renderer.render`: None shows a bar per stage that runs
    longer than 2 s)."""
    from .rendering.renderer import Renderer
    from .rendering.request import warn_unused_lights

    if isinstance(scene, (str, Path)):
        scene = load_scene(scene)
    elif isinstance(scene, dict):
        scene = parse_scene(scene)
    warn_unused_lights(scene.renderer_kwargs.get("lights"), scene.render_kwargs.get("model"))
    r = Renderer(scene.grid, **scene.renderer_kwargs)
    return r.render(progress_bar=progress_bar, **scene.render_kwargs)
