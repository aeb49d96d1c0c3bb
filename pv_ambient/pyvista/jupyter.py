"""pv_ambient volumes in PyVista's Jupyter backends (trame): :func:`ambient_ui` builds PyVista's
trame view of a plotter and keeps the plotter's ambient volumes right in it (docs/jupyter.rst).

* **server** (``mode="server"``): the plotter renders on the server and the browser shows its
  images; the volume re-renders from the render window's own frames (interactive mode). A page
  settling its layout resizes the view several times: the volume renders once, when the size has
  stopped changing for ``resize_delay`` seconds.
* **client** (``mode="client"``, and ``"trame"`` when switched to client rendering): vtk.js draws
  the scene in the browser and the camera lives there, so no server frame ever starts a
  re-render, and a new texture sent to the browser is not shown (vtk.js keeps the picture it
  uploaded first): the textured plane would turn as a flat card. :func:`ambient_ui` therefore
  builds a server view for these modes, with a one-line warning.

trame is optional (``pip install "pv_ambient[jupyter]"``): this module imports it only when a view
is built.
"""

from __future__ import annotations

import asyncio
import math
import warnings
import weakref

#: Seconds a view's size must stay unchanged before the volume renders at it (a notebook page
#: settles its layout within about 0.1 s; a person resizing a window pauses longer).
RESIZE_DELAY = 0.25

#: The views :func:`ambient_ui` builds, by the mode PyVista's ``plotter_ui`` names them.
MODES = ("trame", "server", "client")

_VOLUMES = weakref.WeakKeyDictionary()  # plotter → its AmbientVolumes (registered by add_ambient_volume)


def register(volume):
    """Remember ``volume`` (an :class:`~pv_ambient.pyvista.plotter.AmbientVolume`) as one of its
    plotter's volumes (:func:`add_ambient_volume` calls it)."""
    _VOLUMES.setdefault(volume.plotter, weakref.WeakSet()).add(volume)


def volumes_of(plotter):
    """The interactive ambient volumes shown in ``plotter``, a list (empty when none).

    Examples
    --------
    >>> import pyvista as pv
    >>> import pv_ambient
    >>> from pv_ambient import datasets
    >>> from pv_ambient.pyvista.jupyter import volumes_of
    >>> pl = pv.Plotter(off_screen=True, window_size=(32, 24))
    >>> vol = pv_ambient.add_ambient_volume(pl, datasets.cloud(n=12), interactive=True)
    >>> volumes_of(pl) == [vol]
    True
    """
    return [v for v in _VOLUMES.get(plotter, ()) if v.observer is not None]


def plotter_ui(plotter, **kwargs):
    """PyVista's trame UI for ``plotter``: ``trame_pyvista.ui.plotter_ui`` (PyVista ≥ 0.49, where
    ``pyvista.trame.ui`` is a deprecated shim) or, before it, ``pyvista.trame.ui.plotter_ui``.
    ``kwargs`` as that function's."""
    try:
        from trame_pyvista.ui import plotter_ui as ui
    except ImportError:
        try:
            from pyvista.trame.ui import plotter_ui as ui
        except ImportError as exc:
            raise ImportError("pv_ambient's Jupyter views need trame: pip install \"pv_ambient[jupyter]\" "
                              "(pyvista[jupyter], trame-vtk, trame-pyvista)") from exc
    return ui(plotter, **kwargs)


def ambient_ui(plotter, *, mode=None, resize_delay=RESIZE_DELAY, **kwargs):
    """PyVista's trame view of ``plotter`` (:func:`plotter_ui`) with its ambient volumes kept
    right in it: call it where you would call ``plotter_ui``, inside a trame layout.

    Parameters
    ----------
    plotter : pyvista.Plotter
        Holds one or more :func:`~pv_ambient.add_ambient_volume` volumes with ``interactive=True``.
    mode : {"trame", "server", "client"}, optional
        As ``plotter_ui``'s (default: the plotter theme's ``trame.default_mode``). The view
        renders on the server whatever the mode: ``"client"`` and ``"trame"`` (which can switch
        to client rendering) warn once and build a ``"server"`` view (module docstring).
    resize_delay : float, default: 0.25
        Server rendering: seconds a size must hold before the volume renders at it (0: at once).
    **kwargs
        Passed to ``plotter_ui`` (``server=``, ``add_menu=``, …).

    Returns
    -------
    trame view
        ``plotter_ui``'s view; ``view.ambient_follow`` is the :class:`Follow` that links them.

    Examples
    --------
    A trame app (``python app.py --port 8080``, then open the page)::

        import pyvista as pv
        from trame.app import get_server
        from trame.ui.vuetify3 import SinglePageLayout
        import pv_ambient
        from pv_ambient import datasets
        from pv_ambient.pyvista.jupyter import ambient_ui

        server = get_server(client_type="vue3")
        pl = pv.Plotter(off_screen=True)
        pv_ambient.add_ambient_volume(pl, datasets.supernova(n=64), model="ambient_scattering",
                                      interactive=True)
        with SinglePageLayout(server) as layout, layout.content:
            ambient_ui(pl, mode="server")
        server.start()
    """
    mode = mode if mode is not None else plotter._theme.trame.default_mode
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    if not (isinstance(resize_delay, (int, float)) and math.isfinite(resize_delay) and resize_delay >= 0):
        raise ValueError(f"resize_delay must be a number of seconds >= 0, got {resize_delay!r}")
    if mode != "server":
        # vtk.js keeps the texture it uploaded first: a re-render from the browser's camera reaches
        # the browser as the new plane with the old picture on it (docs/jupyter.rst, "Client rendering")
        warnings.warn(f"pv_ambient: mode={mode!r} shows the ambient volume as a flat card in the browser; "
                      "this view renders on the server (mode='server')", UserWarning, stacklevel=2)
        mode = "server"
    follow = Follow(plotter, mode, resize_delay)
    view = plotter_ui(plotter, mode=mode, **kwargs)
    follow.attach(view)
    view.ambient_follow = follow
    return view


class Follow:
    """The link between a plotter's ambient volumes and its trame view (built by :func:`ambient_ui`).

    Attributes
    ----------
    plotter : pyvista.Plotter
    mode : str
        The view's mode (``"server"``).
    view
        The trame view.
    """

    def __init__(self, plotter, mode, resize_delay=RESIZE_DELAY):
        self.plotter = plotter
        self.mode = mode
        self.resize_delay = float(resize_delay)
        self.view = None
        self._pending = None

    def attach(self, view):
        """Link ``view``: server rendering defers resizes (:meth:`defer`)."""
        self.view = view
        if self.resize_delay > 0:
            for vol in volumes_of(self.plotter):
                vol.defer_resize = self.defer

    def defer(self, settle):
        """Call ``settle`` once the view's size has held for ``resize_delay`` seconds (each call
        restarts the wait), then send the view the new picture. Outside an event loop: at once."""
        if self._pending is not None:
            self._pending.cancel()
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:
            settle()
            return

        def run():
            self._pending = None
            if settle() and self.view is not None:
                self.view.update()

        self._pending = loop.call_later(self.resize_delay, run)
