"""The render layer: the :class:`~pv_ambient.Renderer` (:mod:`.renderer`), the one table of models,
options and quality presets (:mod:`.presets`), the scene cache (:mod:`.cache`) and the cached
per-scene stages (:mod:`.stages`), the checked request of one render (:mod:`.request`) and the
:class:`~pv_ambient.RenderResult` (:mod:`.result`).

Named ``rendering`` because ``pv_ambient.render`` is the public one-call function. Layer: above
``stages``, below the faces (``pyvista/``, ``scene.py``, ``cli.py``); imports no PyVista plotting
(docs/architecture.rst).
"""
