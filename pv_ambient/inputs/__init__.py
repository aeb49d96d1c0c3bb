"""Validated inputs: what users hand the renderer, checked once and converted to plain records and
arrays — transfer functions (:mod:`.transfer`), phase functions (:mod:`.phase`), lights
(:mod:`.lights`), the camera (:mod:`.camera`), the one ImageData ↔ numpy converter (:mod:`.grid`)
and the argument checks whose messages name the argument (:mod:`.validation`).

Layer: above ``_kernels`` and ``backend``, below ``stages`` (docs/architecture.rst).
"""
