"""The checked inputs of one render: :class:`RenderRequest`, built by
:meth:`pv_ambient.Renderer.request` (every argument of :meth:`pv_ambient.Renderer.render` checked
once), the checks of its array inputs and sizes (``ray_end``, the memory a ``window_size`` needs,
a grid's thickness), the feedback a render gives (unused lights and options, a black lit
picture: docs/lights.rst) and its progress (one named bar per stage, a compile notice)."""

from __future__ import annotations

import os
import sys
import warnings
from contextlib import contextmanager
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
    progress_bar: bool | None
    asked: str
    backend: str
    time_budget: float | None
    options: dict = field(default_factory=dict)
    explicit: frozenset = frozenset()
    draft: bool = False


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
    "samples_per_pixel": ("path_traced", "progressive"), "target_error": ("path_traced", "progressive"),
    "max_depth": ("path_traced", "progressive"), "denoise": ("path_traced", "progressive"),
    "flux_limited": ("diffusion", "progressive"), "sweep_orders": ("diffusion", "progressive"),
    "propagation": ("ambient_scattering", "progressive"), "base_model": ("progressive",), "unbiased": ("progressive",),
    "radius": ("ambient_occlusion", "ambient_scattering", "progressive"), "ambient_radiance": ("ambient_occlusion",),
}
#: Bytes per pixel a render holds at its peak (image buffers, float64 sums and their conversion):
#: the ray cast's radiance and alpha, the path tracer's sums, moments and float32 copies.
BYTES_PER_PIXEL = {"path_traced": 200, "auto": 200, "progressive": 264}
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
    says why — no lights given, every light dropped, or a transfer function that does not scatter.
    Returns whether the picture decided it (False when the volume covers no pixel)."""
    alpha = result.alpha
    if not np.any(alpha > 0.0):
        return False
    rest = result.radiance.astype(np.float64) - (1.0 - alpha.astype(np.float64))[..., None] * np.asarray(background)
    if np.max(rest) > 1e-5 * float(np.max(background)):  # float32 rounding of T·background
        return True
    if not renderer.lights:
        cause = "no lights were given (lights=() or []); leave lights out for the default light rig"
    elif not renderer.optics.has_scattering:
        cause = "the transfer function does not scatter (albedo 0 wherever σt > 0) and emits nothing"
    else:
        cause = (f"none of the {len(renderer.lights)} lights reaches the volume: zero intensity, or behind material "
                 "of optical depth > 700")
    warnings.warn(f"model={result.metadata.get('requested_model', result.metadata.get('model'))!r} rendered black: "
                  f"{cause}", UserWarning, stacklevel=4)
    return True


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


#: The largest image-buffer size known to fit: one eighth of the memory available when it was
#: checked at most, so a later request that could fail is checked again.
_FITTED = [0]


def check_image_memory(size, model):
    """Raise MemoryError (naming ``window_size`` and the bytes) before any work when a render of
    ``size`` pixels would not fit in the memory available."""
    w, h = size
    need = int(w) * int(h) * BYTES_PER_PIXEL.get(model, BYTES_PER_PIXEL_RAYCAST)
    if need <= _FITTED[0]:  # no larger than buffers that fitted before: not asked again at every frame
        return
    have = available_memory()
    if need <= have:
        _FITTED[0] = max(_FITTED[0], min(need, have // 8))
    else:
        raise MemoryError(f"window_size={(int(w), int(h))} needs about {need / 2**30:.3g} GiB ({need} bytes) for "
                          f"the image buffers of model={model!r}, more than the {have / 2**30:.3g} GiB available; "
                          "render a smaller image")


#: ``progress_bar=None`` (the default): a stage's bar appears only once it has run this long (s).
PROGRESS_DELAY = 2.0


class _NoBar:
    def update(self, n=1):
        pass

    def set_postfix_str(self, text):
        pass


class _Watcher:
    """The one thread that shows and refreshes every delayed bar of the process: a stage's bar costs
    a list entry, not a thread started and joined (a camera move enters a few stages, each cached,
    and its host work is kept to what the frame needs: docs/performance.rst, "Host work of a
    frame"). Started at the first delayed bar; a daemon that sleeps while no bar is open."""

    def __init__(self):
        import threading

        self.cond = threading.Condition()
        self.bars = []
        self._thread = None
        self._wake = None  # when the thread wakes next (None: when notified)

    def add(self, bar):
        import threading

        with self.cond:
            self.bars.append(bar)
            if self._thread is None or not self._thread.is_alive():  # (a forked child has none)
                self._thread = threading.Thread(target=self._run, name="pv_ambient stage bars", daemon=True)
                self._thread.start()
            elif self._wake is None or bar.start + bar.delay < self._wake:
                self.cond.notify()  # it sleeps past this bar's time: wake it to plan again

    def remove(self, bar):
        with self.cond:
            bar.closed = True
            if bar in self.bars:
                self.bars.remove(bar)

    def _run(self):
        import time

        every = 1.0 if getattr(sys.stderr, "isatty", lambda: False)() else 10.0  # a log file: fewer lines
        with self.cond:
            while True:
                now = time.monotonic()
                self._wake = None
                for bar in self.bars:
                    if bar.bar is None and now >= bar.start + bar.delay:
                        bar.show(now)
                        bar.next_refresh = now + every
                    elif bar.bar is not None and now >= bar.next_refresh:
                        bar.bar.refresh()
                        bar.next_refresh = now + every
                    due = bar.start + bar.delay if bar.bar is None else bar.next_refresh
                    self._wake = due if self._wake is None else min(self._wake, due)
                self.cond.wait(None if self._wake is None else max(self._wake - now, 0.0))


_WATCHER = _Watcher()
if hasattr(os, "register_at_fork"):  # a forked child (a process pool) starts its own, with no bar open
    os.register_at_fork(after_in_child=lambda: globals().update(_WATCHER=_Watcher()))


class _DelayedBar:
    """A tqdm bar that appears only after ``delay`` seconds and then refreshes its elapsed time
    every second (every 10 s when stderr is not a terminal): a stage may run long without a step to
    report. Shown and refreshed by the process's one :class:`_Watcher` thread."""

    def __init__(self, name, total, delay):
        import time

        self.name, self.total, self.n, self.bar, self.closed = name, total, 0, None, False
        self.start, self.delay, self.next_refresh = time.monotonic(), delay, 0.0
        _WATCHER.add(self)

    def show(self, now):
        """Called by the watcher (its lock held) once the delay has passed."""
        from tqdm.auto import tqdm

        fmt = {"bar_format": "{desc}: {elapsed} elapsed"} if self.total == 1 else {}  # one step: the time
        self.bar = tqdm(total=self.total, desc=self.name, initial=self.n, leave=False, **fmt)
        if hasattr(self.bar, "start_t"):  # a disabled bar (TQDM_DISABLE=1) keeps no clock
            self.bar.start_t -= now - self.start  # elapsed time counts from the start of the stage

    def update(self, n=1):
        with _WATCHER.cond:
            self.n += n
            if self.bar is not None:
                self.bar.update(n)

    def set_postfix_str(self, text):
        with _WATCHER.cond:
            if self.bar is not None:
                self.bar.set_postfix_str(text)

    def close(self):
        _WATCHER.remove(self)
        if self.bar is not None:
            self.bar.close()


@contextmanager
def stage_bar(progress_bar, name, total=1):
    """A tqdm bar for one named render stage (light volumes, table, diffusion solve, ray cast,
    samples): shown at once with ``progress_bar=True``, never with False, and with None (the
    default) only once the stage has run :data:`PROGRESS_DELAY` seconds — and never under pytest
    (``PYTEST_CURRENT_TEST``)."""
    if progress_bar is False or (progress_bar is None and "PYTEST_CURRENT_TEST" in os.environ):
        yield _NoBar()
        return
    if progress_bar is None:
        bar = _DelayedBar(name, total, PROGRESS_DELAY)
    else:
        from tqdm.auto import tqdm

        bar = tqdm(total=total, desc=name)
    try:
        yield bar
    finally:
        bar.close()


_NOTICED = []


def compile_notice(model):
    """One line on stderr, once per process, before the first render whose kernels are neither
    compiled in this process nor in Numba's on-disk cache: compiling takes from about 15 s
    (emission–absorption) to over a minute (diffusion, the ``auto`` default) once per machine
    (docs/performance.rst, "Compile time")."""
    if _NOTICED:
        return
    _NOTICED.append(True)
    from ..backend import kernel_compiled

    if not kernel_compiled("path_trace" if model == "path_traced" else "raycast"):
        print("pv_ambient: compiling the rendering kernels for this machine (first use only: 15 s to a few minutes "
              "by model; then cached)", file=sys.stderr, flush=True)


def check_thickness(geometry, dimensions=None):
    """Raise a ValueError for a grid without thickness: a single point, or a 2-D grid (one point
    along an axis). Such a box has zero volume and would render nothing; VTK's mappers draw a 2-D
    grid face-on but not edge-on (measured with the gpu mapper), not as a slab, so no thickness is
    guessed here."""
    if not geometry.is_empty:
        return
    dims = tuple(int(d) for d in (dimensions if dimensions is not None else geometry.shape))
    flat = [ax for ax, (lo, hi) in enumerate(zip(geometry.box_lo, geometry.box_hi)) if hi <= lo]
    if len(flat) == 3:
        raise ValueError(f"the grid holds a single point or cell (dimensions {dims}): a volume needs at least two "
                         "points along every axis")
    names = " and ".join("xyz"[ax] for ax in flat)
    example = tuple(2 if ax in flat else d for ax, d in enumerate(dims))
    raise ValueError(f"the grid is 2-D (dimensions {dims}: one point along {names}), so the volume has no thickness "
                     "and would render nothing; pv_ambient does not guess one (VTK's mappers draw such a grid "
                     "face-on but not edge-on). Give it one: e.g. an ImageData of dimensions "
                     f"{example} holding the layer twice, the spacing along {names} its thickness — or show a 2-D "
                     "image with Plotter.add_mesh")


def resolve_radius(radius, model, spacing) -> float:
    """The ambient radius in world units: the model's default (``radius_voxels`` of the model
    table, in units of the largest spacing) when None, ``"N voxels"`` in those units, else a
    number >= 0."""
    from ..inputs.validation import check_real
    from .presets import MODEL_SPECS

    h = float(np.max(spacing))
    if radius is None:
        return MODEL_SPECS[model].radius_voxels * h
    if isinstance(radius, str):
        parts = radius.split()
        if len(parts) == 2 and parts[1] in ("voxel", "voxels"):
            try:
                return check_real(float(parts[0]), "radius", lo=0.0) * h
            except ValueError:
                pass
        raise ValueError(f"radius must be a number (world units) or 'N voxels', got {radius!r}")
    return check_real(radius, "radius", lo=0.0)


def check_model_options(model, options) -> dict:
    """Check the model options (``MODEL_OPTIONS``) of a render of ``model``: unknown names are a
    TypeError, flags must be bools, and the optional packages an option needs are checked here,
    before any work (``denoise=True`` needs ``pyoidn``: an ImportError that names the extra)."""
    from ..inputs.validation import check_bool, check_choice, check_int
    from .presets import MODEL_OPTIONS, PROGRESSIVE_BASES

    unknown = set(options) - MODEL_OPTIONS
    if unknown:
        raise TypeError(f"render() got unknown options {sorted(unknown)}; model options are {sorted(MODEL_OPTIONS)}")
    for flag in ("denoise", "unbiased"):  # a bool, not 0/1 or a string that happens to compare equal
        if flag in options:
            options[flag] = check_bool(options[flag], flag)
    if "sweep_orders" in options:
        check_int(options["sweep_orders"], "sweep_orders", lo=0)
    if "base_model" in options:
        check_choice(options["base_model"], "base_model", PROGRESSIVE_BASES)
    if model == "progressive" and options.get("unbiased") and options.get("denoise"):
        raise ValueError("unbiased=True returns the unbiased picture as it is; denoise=True chooses between it "
                         "denoised and thresholded (docs/progressive.rst): give one of them")
    if options.get("denoise") and model in ("path_traced", "progressive", "auto"):
        from ..stages.denoise import require

        require()  # the ImportError that names the extra
    return options


def build_request(renderer, *, camera, window_size, model, quality, step, jitter, seed, background, early_termination,
                  phase, progress_bar, radius, light_resolution, ambient_radiance, propagation, table_quality,
                  ray_end, backend, model_options, draft=False) -> RenderRequest:
    """Check :meth:`pv_ambient.Renderer.render`'s arguments once (for ``renderer``'s scene) into a
    frozen :class:`RenderRequest`."""
    from ..backend import check_backend, resolve_backend
    from ..inputs.camera import as_camera
    from ..inputs.phase import as_phase
    from ..inputs.validation import check_choice, check_int, check_real, check_rgb
    from .presets import ALL_MODELS, PROPAGATION_MODES, QUALITIES, QUALITY_PRESETS, light_resolution_for, step_for

    cam, size = as_camera(camera, window_size=window_size, bounds=renderer.bounds)
    check_choice(model, "model", ALL_MODELS)
    check_image_memory(size, model)
    given = given_options(radius=radius, propagation=propagation, ambient_radiance=ambient_radiance)
    check_choice(quality, "quality", QUALITIES)
    check_choice(propagation, "propagation", PROPAGATION_MODES)
    preset = QUALITY_PRESETS[quality]
    table_quality = check_choice(preset["table_quality"] if table_quality is None else table_quality,
                                 "table_quality", QUALITIES)
    light_resolution = light_resolution_for(renderer.optics, renderer.geometry, quality, light_resolution)
    model_options = dict(model_options)
    explicit = frozenset(model_options) | given
    model_options.setdefault("samples_per_pixel", preset["samples_per_pixel"])
    budget = model_options.pop("time_budget", None)
    check_model_options(model, model_options)
    step = (step_for(quality, np.min(renderer.geometry.spacing)) if step is None
            else check_real(step, "step", lo=0.0, lo_open=True))
    asked = renderer.backend if backend is None else check_backend(backend)
    if budget is not None:
        budget = check_real(budget, "time_budget", lo=0.0, lo_open=True)
        if model != "auto":
            raise ValueError(f"time_budget chooses the model: use it with model='auto', not {model!r}")
    if model in ("path_traced", "progressive") and ray_end is not None:
        raise ValueError(f"ray_end (opaque geometry) is supported by the ray-cast models, not by {model}")
    return RenderRequest(
        camera=cam, window_size=size, model=model, quality=quality, step=step, jitter=bool(jitter),
        seed=check_int(seed, "seed", lo=0), background=check_rgb(background, "background"),
        early_termination=check_real(early_termination, "early_termination", lo=0.0, hi=1.0),
        ambient_radiance=check_real(ambient_radiance, "ambient_radiance", lo=0.0), phase=as_phase(phase),
        radius=resolve_radius(radius, model, renderer.geometry.spacing), t_end=check_ray_end(ray_end, size),
        light_resolution=light_resolution, table_quality=table_quality, propagation=propagation,
        bake_lights=bool(preset["bake_lights"]), asked=asked, progress_bar=None if progress_bar is None else bool(progress_bar),
        backend=resolve_backend(asked), time_budget=budget, options=model_options, explicit=explicit,
        draft=bool(draft))
