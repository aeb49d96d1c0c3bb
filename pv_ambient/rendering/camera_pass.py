"""The camera-pass models — emission–absorption, ambient occlusion, single scattering, ambient
scattering and diffusion (docs/models.rst): one ray cast per frame over the per-scene stages.

:func:`render_camera_pass` gathers what the model reads from the renderer's
:class:`~pv_ambient.rendering.scene_stages.SceneStages` (light volumes, the ball grid, the table
slice, tube fronts, the diffusion field, baked in-scattering), packs the ray-cast kernel's
records (:mod:`pv_ambient._kernels.records`) and runs it through :mod:`pv_ambient.backend`.
Everything but the ray cast is cached, so a camera move re-runs only the kernel.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .._kernels import records as K
from .. import backend
from ..inputs.lights import pack_lights
from .draft import draft_applies, draft_args
from .record import record_applies, record_args
from .presets import MAJORANT_BLOCK, MODEL_IDS, MODEL_SPECS, QUALITY_PRESETS
from .request import stage_bar
from .result import RenderResult
from .scene_stages import NO_GRID


@dataclass
class _Inputs:
    """What a camera-pass model reads besides the camera: the active lights, their light grid,
    optical depths and fronts, the ball and table, the diffusion field and its solve's information."""

    grid: object = None
    lights: tuple = ()
    taus: tuple = ()
    ball: np.ndarray = field(default_factory=lambda: K.NONE4)
    table: tuple = (K.NONE3, K.NONE1, 0.0, 1.0)
    # each light's tube front; None: Beer–Lambert (the τ grids read at the ball's entry point)
    fronts: object = None
    diffusion: np.ndarray = field(default_factory=lambda: K.NONE12)
    diffusion_info: dict | None = None
    # ambient scattering's D per sample, read by its bake instead of the ball (SceneStages.ball_d)
    dgrid: np.ndarray | None = None


def _lights(renderer, req, model, inputs):
    """The lights that matter and their optical depths (computed and cached while the active
    lights are sorted out)."""
    stages, progress_bar = renderer.stages, req.progress_bar
    lit = MODEL_SPECS[model].lit and bool(renderer.lights)
    with stage_bar(progress_bar if lit else False, f"light volumes ({len(renderer.lights)} lights)") as bar:
        inputs.lights = stages.active_lights(renderer.lights, inputs.grid, req.backend) if lit else ()
        inputs.taus = tuple(stages.optical_depth(lt, inputs.grid, req.backend) for lt in inputs.lights)
        bar.update()


def _ambient(renderer, req, model, inputs):
    """Ambient scattering's table slice and, in tube mode, its fronts."""
    stages, ph, radius, grid = renderer.stages, req.phase, req.radius, inputs.grid
    with stage_bar(req.progress_bar if req.progress_bar is not True else False, "preintegrated table"):
        tab = stages.table(ph, radius, quality=req.table_quality, progress_bar=req.progress_bar is True)
    D, _, a_nodes, lo_log, dlog = tab.lookup_args()
    inputs.table = (D, a_nodes, lo_log, dlog)
    if req.propagation == "tube":
        inputs.fronts = tuple(stages.front_depth(lt, grid, radius, ph, req.table_quality) for lt in inputs.lights)


def _diffusion(renderer, req, options, inputs):
    """The diffusion field of the active lights (one cached solve per light)."""
    with stage_bar(req.progress_bar, "diffusion solve") as bar:
        inputs.diffusion, info = renderer.stages.diffusion(
            inputs.lights, inputs.grid, req.phase, flux_limited=options.get("flux_limited", False),
            progress_bar=req.progress_bar is True, backend=req.backend, sweep_orders=options.get("sweep_orders", 0),
            tol=QUALITY_PRESETS[req.quality]["diffusion_tol"], coarse=QUALITY_PRESETS[req.quality]["diffusion_coarse"],
            coarse_remainder=QUALITY_PRESETS[req.quality]["sweep_remainder_coarse"])
        if info is not None:
            bar.set_postfix_str(f"{info['iterations']} iterations, residual {info['residual']:.2g}")
        inputs.diffusion_info = info
        bar.update()


def _bakes_lights(req, inputs) -> bool:
    """Whether the lights' in-scattering is baked: an isotropic phase function, lights that matter,
    and the quality preset's ``bake_lights``."""
    return bool(req.bake_lights and inputs.lights and req.phase.canonical()[2])


def _reads_ball_d(renderer, req, model, inputs) -> bool:
    """Whether ambient scattering's bake reads D per sample (:meth:`SceneStages.ball_d`) instead of
    the ball grid: the row driver's case (:func:`pv_ambient.stages.bake.rows_apply`) — baked lights,
    a light grid on the data samples, the Beer–Lambert front and a table slice without an angle axis."""
    from ..stages.bake import table_applies

    return (model == "ambient_scattering" and _bakes_lights(req, inputs) and req.propagation != "tube"
            and inputs.grid.on_samples(renderer.optics.field.shape) and min(inputs.grid.shape) >= 2
            and table_applies(renderer.stages.table(req.phase, req.radius, quality=req.table_quality)))


def gather_inputs(renderer, req, model, options):
    """Every per-scene input of ``model`` for request ``req`` (computed or found in the cache)."""
    inputs = _Inputs(grid=renderer.stages.light_grid(req.light_resolution) if model != "emission_absorption" else None)
    _lights(renderer, req, model, inputs)
    if model == "ambient_scattering" and inputs.lights:
        # the table's key reads the ball grid's albedo range: the ball grid on the render's backend
        renderer.stages.albedo_range(req.radius, req.backend)
        _ambient(renderer, req, model, inputs)
    if MODEL_SPECS[model].ball:
        if inputs.lights and _reads_ball_d(renderer, req, model, inputs):
            inputs.dgrid = renderer.stages.ball_d(req.radius, req.phase, req.table_quality, req.backend)
        else:
            inputs.ball = renderer.stages.ball_grid(req.radius, req.backend)
    if model == "diffusion" and inputs.lights:
        _diffusion(renderer, req, options, inputs)
    return inputs


def _bake(renderer, req, model, options, inputs, records):
    """Bake the lights' in-scattering on the light grid (isotropic phase): the light-grid record
    that reads it, and the kernel's model id (single scattering's when diffusion's φ/4π joins the
    bake, which it does exactly where the light-grid nodes are the data samples: trilinear
    interpolation is linear)."""
    stages, grid, ph, radius = renderer.stages, inputs.grid, req.phase, req.radius
    lrec, grec, arec = records
    tkey = stages.table_key(ph, radius, req.table_quality) if model == "ambient_scattering" else None
    fold = model == "diffusion" and grid.on_samples(renderer.optics.field.shape)
    dkey = ((bool(options.get("flux_limited", False)), fold)
            + ((int(options["sweep_orders"]),) if options.get("sweep_orders", 0) else ())
            if model == "diffusion" else None)
    # the d² clamp follows the ray step, but a point light's slot holds its fall-off times the
    # clamped d² (its intensity, whatever the clamp: :func:`pv_ambient._kernels.bake.bake_node`), so
    # the bake does not depend on the step: an interactive drag's longer steps (docs/jupyter.rst,
    # "Server rendering") do not re-bake
    with stage_bar(req.progress_bar, "baked in-scattering") as bar:
        inc, nch = stages.incident(MODEL_IDS[model], inputs.lights, grid, (lrec, grec, arec),
                                   (model, radius, tkey, req.propagation, ph.canonical(), dkey),
                                   inputs.taus, inputs.fronts, diffusion=inputs.diffusion if fold else None,
                                   dgrid=inputs.dgrid, backend=req.backend)
        bar.update()
    return grec._replace(inc=inc, baked=nch), MODEL_IDS["single_scattering" if fold else model]


def raycast_records(renderer, req, model, options, inputs):
    """The ray-cast kernel's arguments (:mod:`pv_ambient._kernels.records`, after the model id)
    for ``model``, and whether the lights' in-scattering was baked."""
    stages, ph = renderer.stages, req.phase
    d2min = (0.25 * req.step) ** 2  # a point light's I/d² clamped at a quarter step
    # isotropic phase: the lights' in-scattering does not depend on the view; bake it once
    bake = _bakes_lights(req, inputs)
    lg = inputs.grid if inputs.grid is not None else NO_GRID
    lrec = K.lights_of(pack_lights(inputs.lights), ph, d2min)
    D, a_nodes, lo_log, dlog = inputs.table
    arec = K.Ambient(req.radius, inputs.ball, req.ambient_radiance, D, a_nodes, lo_log, dlog)
    kernel_model = MODEL_IDS[model]
    if bake:
        # the bake reads each light's volumes; the baked ray cast reads neither them nor the ball
        # (placeholders: no stacked copy is made, and a GPU does not hold them for the camera)
        grec = K.LightGrid(lg.lo, lg.inv_step, K.NONE4, K.NONE4, K.NONE4, 0)
        grec, kernel_model = _bake(renderer, req, model, options, inputs, (lrec, grec, arec))
        arec = arec._replace(ball=K.NONE4)
    else:
        tau = stages.stacked("tau_stack", inputs.lights, inputs.grid, inputs.taus) if inputs.taus else K.NONE4
        phi = tau if inputs.fronts is None else stages.stacked(
            "front_stack", inputs.lights, inputs.grid, inputs.fronts,
            extra=(float(req.radius), stages.table_key(ph, req.radius, req.table_quality)))
        grec = K.LightGrid(lg.lo, lg.inv_step, tau, phi, K.NONE4, 0)
    args = (kernel_model,
            K.view_of(req.camera, req.window_size, renderer.geometry),
            K.March(req.step, req.jitter, req.seed, req.early_termination, req.background, req.t_end,
                    stages.step_opacity(req.step)),
            K.medium_of(renderer.optics, stages.cast_majorant(backend=req.backend), MAJORANT_BLOCK),
            lrec, grec, arec,
            K.Diffusion(inputs.diffusion, float(ph.mean_cosine)))
    return args, bake


def render_camera_pass(renderer, req, model, options, records=None) -> RenderResult:
    """A camera-pass model's picture for checked request ``req``; ``records``: a list to receive
    the kernel's arguments (the model id and the records after it) when there is a medium to march
    (the progressive model's control reads them)."""
    t_start = time.perf_counter()
    w, h = req.window_size
    # one buffer for both (the GPU's image comes home in one copy); the ray cast writes every pixel
    rad, alpha = backend.image_buffers(h, w, zero=renderer.geometry.is_empty)
    inputs = gather_inputs(renderer, req, model, options)
    t_prep = time.perf_counter() - t_start
    bake, used, draft = False, req.backend, False
    if not renderer.geometry.is_empty:
        args, bake = raycast_records(renderer, req, model, options, inputs)
        if records is not None:
            records.append(args)
        scale = 1.0
        if draft_applies(req, args):
            (args, scale), draft = draft_args(renderer, args), True
        elif record_applies(req, args):
            args = record_args(renderer, args)
        t_prep = time.perf_counter() - t_start
        inner = req.progress_bar is True  # the kernel's own bar (image tiles)
        with stage_bar(req.progress_bar if not inner else False, f"ray cast ({model})"):
            used = backend.run_raycast(args, rad, alpha, backend=req.backend, asked=req.asked,
                                       device_cache=renderer.stages.device_for(req.backend), progress_bar=inner,
                                       name=f"ray cast ({model})")
        if scale != 1.0:  # a lit draft's source is stored over a scale (rendering/draft.py)
            rad *= np.float32(scale)
    else:
        rad[:] = req.background
    meta = _metadata(renderer, req, model, options, inputs, bake, used)
    meta["draft"] = draft
    meta.update(time_prepare=t_prep, time_render=time.perf_counter() - t_start - t_prep)
    return RenderResult(radiance=rad, alpha=alpha, camera=req.camera, metadata=meta)


def _metadata(renderer, req, model, options, inputs, bake, used) -> dict:
    diffusion = model == "diffusion"
    return {"model": model, "requested_model": req.model, "quality": req.quality, "step": req.step,
            "window_size": req.window_size, "jitter": req.jitter, "seed": req.seed, "backend": used,
            "device_memory": renderer.stages.device_nbytes if used == "cuda" else 0,
            "lights": len(inputs.lights), "radius": req.radius, "phase": repr(req.phase),
            "propagation": req.propagation if model == "ambient_scattering" else None,
            "baked_lights": bake,
            "flux_limited": bool(options.get("flux_limited", False)) if diffusion else None,
            "sweep_orders": int(options.get("sweep_orders", 0)) if diffusion else None,
            "diffusion_solver": inputs.diffusion_info if diffusion else None,
            "light_grid": None if inputs.grid is None else inputs.grid.shape,
            "early_termination": req.early_termination}
