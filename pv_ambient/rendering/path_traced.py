"""The ``path_traced`` model (docs/path_tracer.rst): the unbiased Monte Carlo reference of the
scene, optionally denoised by OIDN with a noise-free albedo guide, and ``auto``'s choice for a
still image with a time budget."""

from __future__ import annotations

import time
import warnings

import numpy as np

from ..inputs.camera import as_camera
from ..inputs.validation import check_int
from .presets import DEFAULT_SPP, MAJORANT_BLOCK
from .request import check_image_memory, stage_bar
from .result import RenderResult


def path_trace(renderer, camera=None, window_size=None, *, backend="cpu", block=MAJORANT_BLOCK,
               target_error=None, samples_per_pixel=DEFAULT_SPP, time_limit=None, **options) -> RenderResult:
    """:meth:`pv_ambient.Renderer.path_trace` on a resolved ``backend`` (its arguments, checked
    there): the samples, and a warning when ``target_error`` was not reached within the cap."""
    from ..stages.reference import path_trace as trace

    cam, size = as_camera(camera, window_size=window_size, bounds=renderer.bounds)
    check_image_memory(size, "path_traced")
    renderer.place_lights(cam)
    block = check_int(block, "majorant_block", lo=1)
    out = trace(renderer.geometry, renderer.optics, renderer.stages.majorant(block, backend), renderer.lights, cam,
                size, block=block, samples_per_pixel=samples_per_pixel, target_error=target_error, backend=backend,
                time_limit=time_limit, device_cache=renderer.stages.device_for(backend), **options)
    reached, target = out.metadata.get("relative_error"), out.metadata.get("target_error")
    if target is not None and time_limit is None and not reached <= target:
        warnings.warn(f"target_error={target:g} was not reached: the relative error is {reached:.3g} after "
                      f"{out.metadata['spp']} samples per pixel (samples_per_pixel={samples_per_pixel} is the "
                      f"cap; the error falls as 1/√samples, so about "
                      f"{int(np.ceil(out.metadata['spp'] * (reached / target) ** 2))} would reach it)",
                      UserWarning, stacklevel=3)
    return RenderResult(radiance=out.radiance, alpha=out.alpha, camera=cam, metadata=out.metadata,
                        std_error=out.std_error)


def render_path_traced(renderer, req, options) -> RenderResult:
    """The ``path_traced`` model for checked request ``req`` (and ``auto`` with a time budget:
    ``options["time_limit"]``); ``denoise`` needs ``pyoidn``, checked when the request was made."""
    denoise = options.get("denoise", False)
    with stage_bar(False if req.progress_bar else req.progress_bar, "path-traced samples"):
        res = path_trace(renderer, req.camera, req.window_size, phase=req.phase,
                         samples_per_pixel=options.get("samples_per_pixel", DEFAULT_SPP),
                         target_error=options.get("target_error"), max_depth=options.get("max_depth"),
                         seed=req.seed, background=req.background, progress_bar=req.progress_bar is True,
                         light_clamp=0.25 * req.step, backend=req.backend, time_limit=options.get("time_limit"))
    if "time_limit" in options:
        res.metadata["requested_model"] = "auto"
        res.metadata["time_budget"] = options["time_limit"]
    res.metadata.setdefault("time_prepare", 0.0)
    res.metadata.setdefault("time_render", res.metadata.get("time", 0.0))
    res.metadata["denoised"] = bool(denoise)
    if denoise:
        from ..stages.denoise import denoise_radiance

        t = time.perf_counter()
        # guided by the first-collision albedo × coverage (noise-free) and mean-preserving
        # (docs/path_tracer.rst, "Denoising"); std_error stays the un-denoised one
        guide = renderer.albedo_guide(req.camera, req.window_size, step=req.step)
        res.radiance = denoise_radiance(res.radiance, albedo=guide)
        res.metadata["denoise_guide"] = "albedo"
        res.metadata["time_denoise"] = time.perf_counter() - t
        res.metadata["time_render"] += res.metadata["time_denoise"]
    return res
