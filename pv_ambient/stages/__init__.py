"""Array-in/array-out stages of the render: mean extinction over balls (:mod:`.sat`), per-light
volumes (:mod:`.propagation`), the preintegrated ball tables (:mod:`.preintegration`), the
diffusion solve (:mod:`.diffusion`), the path tracer (:mod:`.reference`) and denoising
(:mod:`.denoise`). Stages take arrays and small records — never a renderer or a PyVista object —
and the render layer caches their results on their inputs.

Layer: above ``inputs``, below ``rendering`` (docs/architecture.rst).
"""
