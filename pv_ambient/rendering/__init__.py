"""The render layer: the :class:`~pv_ambient.Renderer` (:mod:`.renderer`), the one table of models,
options and quality presets (:mod:`.presets`), the scene cache (:mod:`.cache`) and the per-scene
stages the renderer owns (:mod:`.scene_stages`), the checked request of one render
(:mod:`.request`), one module per model family — the camera-pass models (:mod:`.camera_pass`),
the path tracer (:mod:`.path_traced`), the progressive model (:mod:`.progressive`) — and the
:class:`~pv_ambient.RenderResult` (:mod:`.result`).

Named ``rendering`` because ``pv_ambient.render`` is the public one-call function. Layer: above
``stages``, below the faces (``pyvista/``, ``scene.py``, ``cli.py``); imports no PyVista plotting
(docs/architecture.rst).
"""
