"""The ``progressive`` model (docs/progressive.rst): a noise-free model's picture, refined by
residual path samples that use that model's source as a control variate.

At zero samples it is the base model's picture. After that it is the same model marched at
``CONTROL_STEP_FRACTION`` of the step (the control picture, once per view) plus the mean of the
residual samples (:mod:`pv_ambient._kernels.residual`), shown as the base plus the part of the
correction that stands out of its noise — or that picture's denoised twin, whichever held-out
halves of the samples find closer (:mod:`pv_ambient.stages.refine`). Both pictures of a view are
cached, so the interactive mode's refinement passes add samples without marching it again.
"""

from __future__ import annotations

import math
import time

import numpy as np

from .. import backend
from ..inputs.lights import POINT
from ..inputs.validation import check_int
from ..stages.reference import EQ_RADIUS, relative_error
from ..stages import refine
from ..stages.refine import HeldOutPasses, progressive_picture
from .camera_pass import render_camera_pass
from .presets import (ACCURATE_DIFFUSION, CONTROL_STEP_FRACTION, DEFAULT_PROGRESSIVE_BASE, DEFAULT_SPP,
                      MAJORANT_BLOCK)
from .request import stage_bar
from .result import RenderResult


def _base_options(req, options) -> tuple:
    """The base model and its options: diffusion gets the transport sweeps and flux limiting
    except at quality "preview" (as ``auto``'s accurate choice); options given take precedence."""
    base = options.get("base_model", DEFAULT_PROGRESSIVE_BASE)
    base_options = {k: options[k] for k in ("flux_limited", "sweep_orders") if k in options}
    if base == "diffusion" and req.quality != "preview":
        base_options = {**ACCURATE_DIFFUSION, **base_options}
    return base, base_options


def _view_key(renderer, req, base, base_options) -> tuple:
    """What the base and control pictures of a view depend on."""
    cam, size = req.camera, req.window_size
    return ("progressive_base", base, tuple(sorted(base_options.items())), tuple(renderer.lights),
            np.asarray(cam.params(size), np.float64).tobytes(), tuple(size), req.step, req.radius,
            req.propagation, req.phase.canonical(), req.light_resolution, req.table_quality, req.bake_lights,
            req.early_termination, req.background.tobytes(), req.backend,
            (req.jitter, req.seed if req.jitter else None), req.draft)  # (the seed moves a jittered march)


def _control(renderer, req, records):
    """The control picture N' (docs/progressive.rst): the base model's records marched at
    ``CONTROL_STEP_FRACTION`` of the step, with the table corrected for that step (a full step
    reads its opacity, :func:`pv_ambient._kernels.medium.step_table`), point lights' I/d² clamped
    at the equiangular radius (the path tracer samples the singular part near a light; the control
    stays smooth there; for a light farther than that radius from the box the clamp changes
    nothing). Returns the picture and the records it was marched with."""
    args = list(records[0])
    lrec = args[4]
    rc = EQ_RADIUS * renderer.geometry.diagonal
    points = np.asarray(lrec.vec)[np.asarray(lrec.kind) == POINT]
    if len(points) and rc * rc > lrec.d2min and float(np.min(renderer.geometry.distance_to(points))) < rc:
        args[4] = lrec._replace(d2min=rc * rc)
    step = args[2].step * CONTROL_STEP_FRACTION  # the step-corrected table goes with the step
    args[2] = args[2]._replace(step=step, opacity=renderer.stages.step_opacity(step))
    args = tuple(args)
    w, h = req.window_size
    image = np.zeros((h, w, 3), np.float32)
    backend.run_raycast(args, image, np.zeros((h, w), np.float32), backend=req.backend, asked=req.asked,
                device_cache=renderer.stages.device_for(req.backend), progress_bar=False, name="ray cast (control)")
    return image, [args]


def _view(renderer, req, base, base_options, spp):
    """The view's base picture, kernel records and control picture (cached: one view at a time, a
    camera move replaces it), and whether they came from the cache."""
    key = _view_key(renderer, req, base, base_options)
    cache = renderer.stages.cache
    cached = key in cache
    if cached:
        nf, records, control_image = cache[key]
    else:
        records = []
        nf = render_camera_pass(renderer, req, base, base_options, records=records)
        control_image = None
    if control_image is None and records and spp > 0:  # the first samples: the control's picture
        control_image, records = _control(renderer, req, records)
    for old in list(cache.keys("progressive_base")):
        if old != key:
            del cache[old]
    cache[key] = (nf, records, control_image)
    return nf, records, control_image, cached


def render_progressive(renderer, req, options) -> RenderResult:
    """The ``progressive`` model for checked request ``req`` (``unbiased`` and ``denoise`` were
    checked when the request was made)."""
    from ..stages.reference import path_trace

    t_start = time.perf_counter()
    base, base_options = _base_options(req, options)
    spp = check_int(options.get("samples_per_pixel", DEFAULT_SPP), "samples_per_pixel", lo=0)
    nf, records, control_image, cached = _view(renderer, req, base, base_options, spp)
    # this call's own preparation: none when the base picture came from the cache
    meta = dict(nf.metadata, model="progressive", requested_model=req.model, base_model=base,
                time_base=time.perf_counter() - t_start,
                time_prepare=0.0 if cached else nf.metadata.get("time_prepare", 0.0))
    if not records or spp == 0:  # the base picture: the first frame (or exact: nothing to march)
        meta.update(spp=0, relative_error=0.0, time_render=time.perf_counter() - t_start - meta["time_prepare"])
        return RenderResult(radiance=nf.radiance, alpha=nf.alpha, camera=req.camera, metadata=meta,
                            std_error=np.zeros_like(nf.radiance))
    kernel_model, _, _, _, lrec, grec, arec, drec = records[0]
    unbiased, denoise = options.get("unbiased", False), options.get("denoise", False)
    target = options.get("target_error")

    def trace(n, target_error, first_sample=0):
        return path_trace(renderer.geometry, renderer.optics, renderer.stages.majorant(MAJORANT_BLOCK, req.backend),
                          renderer.lights, req.camera, req.window_size, phase=req.phase, samples_per_pixel=n,
                          target_error=target_error, max_depth=options.get("max_depth"), seed=req.seed,
                          background=req.background, progress_bar=req.progress_bar is True,
                          light_clamp=0.25 * req.step, backend=req.backend,
                          device_cache=renderer.stages.device_for(req.backend),
                          control=(kernel_model, lrec, grec, arec, drec), base=control_image,
                          first_sample=first_sample)

    control = control_image.astype(np.float64)
    with stage_bar(False if req.progress_bar else req.progress_bar, "residual samples"):
        if denoise and spp >= 2 * refine.HELD_OUT_MIN_SAMPLES:  # two halves of one seed's samples: the held-out choice
            out = trace(spp // 2, None if target is None else target * math.sqrt(2.0))
            na = out.metadata["spp"]
            other = trace(na if target is not None else spp - na, None, first_sample=na)
            passes = HeldOutPasses()
            for o in (out, other):
                passes.add(o.radiance, o.std_error, o.alpha, samples=o.metadata["spp"])
            acc = passes.all
            std_error = acc.std_error.astype(np.float32)
            out.metadata.update(spp=acc.samples, target_error=target, time=out.metadata["time"] + other.metadata["time"],
                                relative_error=relative_error(control + acc.mean, acc.std_error, acc.alpha))
            radiance, pm = passes.picture(nf.radiance, offset=control, denoise=True)
        else:
            out = trace(spp, target)
            std_error = out.std_error
            estimate = control + out.radiance
            if unbiased:
                radiance, pm = estimate, dict(kept=1.0, residual="unbiased")
            else:  # the correction where it stands out of its noise (docs/progressive.rst)
                radiance, pm = progressive_picture(nf.radiance, [(estimate, out.std_error, out.metadata["spp"])])
    meta.update(pm, denoised=pm["residual"] == "denoised")
    meta.update({k: out.metadata[k] for k in ("spp", "seed", "max_depth", "target_error", "relative_error",
                                              "light_clamp", "rr_depth", "equiangular")})
    meta.update(time_samples=out.metadata["time"], time_render=time.perf_counter() - t_start - meta["time_prepare"])
    return RenderResult(radiance=radiance.astype(np.float32), alpha=nf.alpha, camera=req.camera, metadata=meta,
                        std_error=std_error)
