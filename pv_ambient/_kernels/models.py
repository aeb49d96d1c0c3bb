"""The ray-cast models' ids: the one enumeration of them (docs/models.rst lists the models).

The ray cast (:mod:`.raycast`) and its control variate (:mod:`.residual`) branch on these ids,
and the model table (:mod:`pv_ambient.rendering.presets`) reads them from here. They are plain
``int`` constants rather than an ``IntEnum``: Numba freezes a module-level integer into the
compiled code as a constant, so a kernel branching on one compiles as if the literal were written
there, for the CPU and for CUDA alike.
"""

from __future__ import annotations

#: Max's emission–absorption: the source is the transfer function's colour.
EMISSION_ABSORPTION = 0
#: Emission–absorption plus ambient light attenuated over a ball (docs/ambient_scattering.rst §5).
AMBIENT_OCCLUSION = 1
#: Each light's direct light scattered once toward the camera.
SINGLE_SCATTERING = 2
#: Single scattering plus the ball's multiply scattered light (docs/ambient_scattering.rst §4).
AMBIENT_SCATTERING = 3
#: Single scattering plus the diffusion solve's multiply scattered light (docs/diffusion.rst).
DIFFUSION = 4

#: Every ray-cast model id, in the order docs/models.rst lists the models.
RAYCAST_MODELS = (EMISSION_ABSORPTION, AMBIENT_OCCLUSION, SINGLE_SCATTERING, AMBIENT_SCATTERING, DIFFUSION)

#: Not a model: a draft frame's ray cast (:mod:`.draft`), which reads each sample's source from a
#: record shaded beforehand on every other data sample instead of evaluating the model there —
#: what an interactive drag renders for any lit model whose source does not depend on the view.
DRAFT = 5

#: Not a model either: a lit camera pass that reads the lights' in-scattered light from one packed
#: record per data sample (:mod:`.record`) beside the transfer function's table — how the CPU
#: marches a baked lit model on a light grid whose nodes are the data samples.
RECORD = 6

#: Not a model: the lit record of a bake of two rgb slots — a point light's and the other lights'
#: with diffusion's field — kept apart in four 32-bit words (:func:`.record.pair_light`).
RECORD_PAIR = 7

#: Not a model: the lit record of a grey bake of one slot — a white point light's or the directional
#: lights' in-scattering under a grey albedo — in one 32-bit word per data sample
#: (:func:`.record.grey_light`): one gather per corner, as an emission–absorption sample.
RECORD_GREY = 8
