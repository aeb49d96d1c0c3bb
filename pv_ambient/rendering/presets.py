"""The one table of render models, their options, the quality presets and the defaults.

Everything that names a model — the renderer, the JSON scene format, the CLI, the PyVista face —
reads it from here (docs/models.rst describes each model; the rule behind ``auto`` is
:meth:`pv_ambient.Renderer.choose_model`).
"""

from __future__ import annotations

from dataclasses import dataclass

from .._kernels import models


@dataclass(frozen=True)
class ModelSpec:
    """One render model.

    Attributes
    ----------
    name : str
        The name users pass as ``model=``.
    kernel_id : int or None
        The ray-cast kernel's model id (``pv_ambient._kernels.models``); None for models that are
        not a ray cast (``path_traced``) or stand for another (``auto``).
    lit : bool
        Whether the model uses the lights (and so builds light volumes).
    ball : bool
        Whether the model reads σ̄ over a ball of the ambient radius.
    radius_voxels : float
        Default ambient radius in units of the largest grid spacing (models with ``ball``).
    title : str
        A human title (plot panels, window titles).
    """

    name: str
    kernel_id: int | None
    lit: bool
    ball: bool = False
    radius_voxels: float = 4.0
    title: str = ""


#: The models, in the order documentation lists them. Ambient scattering's default radius (8 voxels,
#: Beer–Lambert fronts) is the one closest to the path-traced reference (docs/trade.rst).
MODEL_TABLE = (
    ModelSpec("emission_absorption", models.EMISSION_ABSORPTION, lit=False, title="emission-absorption"),
    ModelSpec("ambient_occlusion", models.AMBIENT_OCCLUSION, lit=False, ball=True, radius_voxels=4.0,
              title="ambient occlusion"),
    ModelSpec("single_scattering", models.SINGLE_SCATTERING, lit=True, title="single scattering"),
    ModelSpec("ambient_scattering", models.AMBIENT_SCATTERING, lit=True, ball=True, radius_voxels=8.0,
              title="ambient scattering"),
    ModelSpec("diffusion", models.DIFFUSION, lit=True, title="diffusion"),
    ModelSpec("path_traced", None, lit=True, title="path traced"),
    ModelSpec("progressive", None, lit=True, ball=True, radius_voxels=8.0, title="progressive"),
    ModelSpec("auto", None, lit=True, ball=True, radius_voxels=8.0, title="auto"),
)
MODEL_SPECS = {m.name: m for m in MODEL_TABLE}
#: The ray-cast kernel's model id of each camera-pass model.
MODEL_IDS = {m.name: m.kernel_id for m in MODEL_TABLE if m.kernel_id is not None}
#: Every name ``model=`` accepts.
ALL_MODELS = tuple(m.name for m in MODEL_TABLE)

#: Quality presets: what each sets when the knob is not given explicitly — ray step (smallest grid
#: spacings), light-grid nodes per data spacing (None: the default of docs/ambient_scattering.rst §3,
#: 2 where max σt·h > 0.3 else 1), preintegrated-table effort, samples per pixel of
#: ``path_traced``, and whether an isotropic phase function's direct light is baked on the light grid
#: once per light change (``bake_lights``; docs/models.rst, "Baked in-scattering") rather than
#: evaluated light by light at every sample, and the relative residual at which the diffusion solve
#: stops (``diffusion_tol``; docs/diffusion.rst, "Solver tolerance": at 1e-3 an image moves by
#: about 2e-4 of its mean, far below the model's own error), and whether plain diffusion may be
#: solved on a grid twice as coarse where the medium is optically thin per coarse cell
#: (``diffusion_coarse``; docs/diffusion.rst, "Solve resolution"), and whether, with the transport
#: sweeps, the light scattered more often than they carry may be diffused on that coarser grid (the
#: swept orders stay at the data resolution; ``sweep_remainder_coarse``, the same section). Cost
#: and error per preset: docs/trade.rst.
QUALITY_PRESETS = {
    "preview": {"step": 1.0, "light_resolution": 1.0, "table_quality": "preview", "samples_per_pixel": 16,
                "bake_lights": True, "diffusion_tol": 1e-2, "diffusion_coarse": True, "sweep_remainder_coarse": True},
    "balanced": {"step": 0.5, "light_resolution": None, "table_quality": "balanced", "samples_per_pixel": 64,
                 "bake_lights": True, "diffusion_tol": 1e-3, "diffusion_coarse": True, "sweep_remainder_coarse": True},
    "accurate": {"step": 0.25, "light_resolution": 2.0, "table_quality": "balanced", "samples_per_pixel": 256,
                 "bake_lights": False, "diffusion_tol": 1e-4, "diffusion_coarse": False,
                 "sweep_remainder_coarse": True},
}
QUALITIES = tuple(QUALITY_PRESETS)
DEFAULT_QUALITY = "balanced"
#: Ray step per quality preset, in units of the smallest grid spacing.
QUALITY_STEP = {q: p["step"] for q, p in QUALITY_PRESETS.items()}
#: Samples per pixel of ``path_traced`` when neither the call nor a preset says otherwise.
DEFAULT_SPP = QUALITY_PRESETS[DEFAULT_QUALITY]["samples_per_pixel"]

#: Options that belong to particular models (accepted by every render call, used where they apply).
MODEL_OPTIONS = frozenset({"propagation", "samples_per_pixel", "max_depth", "denoise", "flux_limited",
                           "sweep_orders", "target_error", "time_budget", "base_model", "unbiased"})
#: The noise-free models ``progressive`` can refine (its ``base_model``; docs/progressive.rst) and its default.
PROGRESSIVE_BASES = ("single_scattering", "ambient_scattering", "diffusion")
DEFAULT_PROGRESSIVE_BASE = "diffusion"
#: The ``progressive`` model's control picture :math:`N'` (docs/progressive.rst) is marched at this
#: fraction of the ray step, once per view when samples are first taken: the picture converges to
#: the transfer equation's answer up to that march's quadrature error, which halving the step cuts
#: by about four (midpoint rule); a quarter of the step would cut it further at twice the cost
#: (docs/progressive.rst, "The estimator").
CONTROL_STEP_FRACTION = 0.5
#: Every option a scene file may carry at top level besides the common ones.
SCENE_OPTIONS = MODEL_OPTIONS | {"radius", "light_resolution", "ambient_radiance", "table_quality"}
#: Light propagation modes of ambient scattering (docs/ambient_scattering.rst §3) and the default
#: (the one measured closer to the path-traced reference).
PROPAGATION_MODES = ("beer_lambert", "tube")
DEFAULT_PROPAGATION = "beer_lambert"

#: Optical depth above which a light counts as blocked (e^-700 underflows double precision soon after).
TAU_OPAQUE = 700.0
#: Block size (samples) of the majorant grid used for empty-space skipping.
MAJORANT_BLOCK = 8
#: Default early-ray-termination threshold on the transmittance.
ERT = 1e-5
#: Scattering orders that ``auto`` carries by transport sweeps with ``quality="accurate"``
#: (flux-limited diffusion for the rest; docs/diffusion.rst §5, docs/models.rst): of 4, 6, 8 and
#: 12, the count with the lowest worst error against the path-traced reference (the sweeps are
#: view-independent: no camera-move cost).
AUTO_SWEEP_ORDERS = 8
#: Diffusion's most accurate options (flux limiting and the transport sweeps): ``auto``'s choice at
#: quality "accurate" and the ``progressive`` model's default base except at "preview"; options the
#: caller gives take precedence.
ACCURATE_DIFFUSION = {"flux_limited": True, "sweep_orders": AUTO_SWEEP_ORDERS}
#: ``auto`` at quality "balanced": diffusion with its first ``BALANCED_SWEEP_ORDERS`` scattering
#: orders by transport sweeps and flux limiting where the volume has at most
#: ``BALANCED_SWEEP_SAMPLES`` samples, plain diffusion above. The balanced budget for a first
#: frame's stages is what plain diffusion's cost on a 256³ volume; the sweeps' cost grows with the
#: samples, and below this count four orders fit in it, lowering the error several-fold on the
#: scenes the project measures (docs/trade.rst, "What auto renders").
BALANCED_SWEEP_ORDERS = 4
BALANCED_SWEEP_SAMPLES = 64 ** 3
BALANCED_DIFFUSION = {"flux_limited": True, "sweep_orders": BALANCED_SWEEP_ORDERS}
#: Cap of samples per pixel when ``auto`` spends a ``time_budget`` on the path tracer.
BUDGET_MAX_SPP = 4096


def step_for(quality, spacing_min) -> float:
    """The ray step (world units) of a quality preset for a grid whose smallest spacing is ``spacing_min``."""
    return QUALITY_STEP[quality] * float(spacing_min)


def light_resolution_for(optics, geometry, quality=None, light_resolution=None) -> float:
    """The light grid's nodes per data spacing — the one place that decides it: ``light_resolution``
    when given; else the preset's (``QUALITY_PRESETS``), where a preset of None and no preset at all
    mean the default of docs/ambient_scattering.rst §3 (2 where max σt·h > 0.3, else 1:
    trilinear interpolation of a coarse transmittance is biased upward), and ``"accurate"`` never
    goes below that default."""
    from ..stages.propagation import default_factor

    if light_resolution is not None:
        return light_resolution
    preset = None if quality is None else QUALITY_PRESETS[quality]["light_resolution"]
    if preset is None:
        return default_factor(optics, geometry)
    return max(preset, default_factor(optics, geometry) if quality == "accurate" else 0.0)
