"""Baked in-scattering (docs/models.rst, "Baked in-scattering"): for an isotropic phase function
the light a sample scatters toward the camera does not depend on the view, so the lights' share
per unit albedo is computed once per light change on the light grid and read by every camera
move instead of evaluating every light at every sample."""

from __future__ import annotations

import numpy as np

from .._kernels import records as K


def incident_channels(power, ball, diffusion=None) -> int:
    """1 when every channel of the baked light is equal (grey lights, a grey ball albedo and a
    grey or absent diffusion field), else 3."""
    from .._kernels.raycast import diffusion_layout

    grey = bool(np.all(power[:, 0:1] == power)) and (ball.shape[3] < 4 or bool(
        np.array_equal(ball[..., 1], ball[..., 2]) and np.array_equal(ball[..., 1], ball[..., 3])))
    if diffusion is not None and diffusion_layout(diffusion.shape[3])[1] == 3:
        grey = False  # coloured diffusion solution
    return 1 if grey else 3


def bake_incident(model_id, records, geometry, grid, diffusion=None) -> tuple:
    """The in-scattered light of the lights per unit albedo at the nodes of ``grid``, ``(array,
    nch)``: float32 (m0, m1, m2, slots·nch), a slot per point light (times d²) and one for the
    directional lights, ``nch`` from :func:`incident_channels`
    (:func:`pv_ambient._kernels.raycast.bake_incident`): single scattering's direct light, plus
    ambient scattering's ball term.

    ``records`` are the kernel's Lights, LightGrid and Ambient records; ``diffusion`` a diffusion
    field on the data samples, which must be the light-grid nodes, added as ``max(φ, 0)/4π``."""
    from .._kernels.raycast import bake_incident as bake

    lrec, grec, arec = records
    nch = incident_channels(lrec.power, arec.ball, diffusion)
    # a slot per point light, one for all directional lights (and the diffusion term)
    slots = int(np.sum(lrec.kind == 0)) + int(np.any(lrec.kind != 0) or diffusion is not None)
    out = np.zeros(tuple(grid.shape) + (slots * nch,), np.float32)
    diff = K.NONE12 if diffusion is None else diffusion
    bake(model_id, lrec, grec, arec, geometry.world_to_index, geometry.index_to_world, grid.lo, grid.step, nch, diff,
         diffusion is not None, out)
    return out, nch
