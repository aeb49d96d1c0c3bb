"""pv_ambient volumes in PyVista's Jupyter backends (trame), right in each (docs/jupyter.rst):
:func:`show` is ``plotter.show()`` in a notebook, :func:`ambient_ui` is ``plotter_ui`` in a trame
app, and both :func:`link` PyVista's view to the plotter's ambient volumes.

* **server** (``mode="server"``): the plotter renders on the server and the browser shows its
  images; the volume re-renders from the render window's own frames (interactive mode). A page
  settling its layout resizes the view several times: the volume renders once, when the size has
  stopped changing for ``resize_delay`` seconds.
* **client** (``mode="client"``): vtk.js draws the scene in the browser and the camera lives
  there, so no server frame ever starts a re-render. The view reports the browser's camera and
  canvas size when a camera interaction ends; the volume re-renders from that camera at that size
  on the server and the picture is sent back on a new plane (:meth:`Follow.browser_camera`). While
  the camera is being dragged the browser turns the last picture as a flat card; it is replaced
  when the drag ends.
* **trame** (``mode="trame"``, switchable): kept in server rendering; switched to client rendering
  it turns back, with a one-line warning (its client side applies only the server's full scenes,
  which leave a replaced plane in the browser beside the new one).

trame is optional (``pip install "pv_ambient[jupyter]"``): this module imports it only when a view
is built.
"""

from __future__ import annotations

import asyncio
import math
import warnings
import weakref

#: Seconds a view's size must stay unchanged before the volume renders at it: longer than the gaps
#: between the resizes of a page settling its layout, short beside a render.
RESIZE_DELAY = 0.25

#: The views :func:`ambient_ui` builds, by the mode PyVista's ``plotter_ui`` names them.
MODES = ("trame", "server", "client")

_VOLUMES = weakref.WeakKeyDictionary()  # plotter → its AmbientVolumes (registered by add_ambient_volume)


#: The backends whose view :func:`show` links (``"html"`` it turns into the static picture).
TRAME_BACKENDS = ("trame", "server", "client", "html")


def register(volume):
    """Remember ``volume`` (an :class:`~pv_ambient.pyvista.plotter.AmbientVolume`) as one of its
    plotter's volumes (:func:`add_ambient_volume` calls it), and route the plotter's own ``show``
    through :func:`show` in a notebook (:func:`route_show`)."""
    _VOLUMES.setdefault(volume.plotter, weakref.WeakSet()).add(volume)
    route_show(volume.plotter)


def route_show(plotter):
    """Make ``plotter.show()`` in a notebook, with a trame backend (given, the theme's, or PyVista's
    own pick when neither names one), go through :func:`show`, so that
    ``pl.show(jupyter_backend="client")`` re-renders the volume from the browser's camera as
    ``show(pl, jupyter_backend="client")`` does rather than turn a flat card.
    Outside a notebook (``plotter.notebook`` false: scripts, off-screen renders) and for the
    ``"static"``/``"none"`` backends ``plotter.show`` is PyVista's, unchanged. Set once per plotter,
    as an attribute of the instance.

    Examples
    --------
    >>> import pyvista as pv
    >>> import pv_ambient
    >>> from pv_ambient import datasets
    >>> pl = pv.Plotter(off_screen=True, window_size=(32, 24))
    >>> vol = pv_ambient.add_ambient_volume(pl, datasets.cloud(n=12), interactive=True)
    >>> "show" in vars(pl)  # routed; off-screen it calls PyVista's show
    True
    """
    if "show" in vars(plotter):
        return
    ref = weakref.ref(plotter)

    def routed(*args, **kwargs):
        pl = ref()
        backend = kwargs.get("jupyter_backend")
        if backend is None:
            import pyvista

            backend = pyvista.global_theme.jupyter_backend
        # None: PyVista picks the backend when it displays (a trame one where trame is installed)
        trame = backend is None or str(backend).lower() in TRAME_BACKENDS
        if pl is not None and not args and getattr(pl, "notebook", False) and trame and volumes_of(pl):
            return show(pl, **kwargs)
        return type(pl).show(pl, *args, **kwargs)  # PyVista's (the class's: looked up now)

    routed.__doc__ = type(plotter).show.__doc__
    plotter.show = routed


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
        As ``plotter_ui``'s (default: the plotter theme's ``trame.default_mode``): ``"server"``
        renders on the server; ``"client"`` draws with vtk.js in the browser, the volume
        re-rendered on the server from the browser's camera when a camera interaction ends;
        ``"trame"`` is kept in server rendering (module docstring).
    resize_delay : float, default: 0.25
        Seconds the view's size must hold before the volume renders at it (0: at once).
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
            ambient_ui(pl, mode="client")
        server.start()
    """
    mode = mode if mode is not None else plotter._theme.trame.default_mode
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    _check_delay(resize_delay)  # before the UI is built
    view = plotter_ui(plotter, mode=mode, **kwargs)
    link(view, plotter, resize_delay=resize_delay)
    return view


def _check_delay(resize_delay):
    if not (isinstance(resize_delay, (int, float)) and math.isfinite(resize_delay) and resize_delay >= 0):
        raise ValueError(f"resize_delay must be a number of seconds >= 0, got {resize_delay!r}")


def view_mode(view):
    """``"server"``, ``"client"`` or ``"trame"``: the kind of PyVista trame view ``view`` is."""
    from trame_vtk.widgets.vtk import VtkLocalView, VtkRemoteLocalView

    if isinstance(view, VtkRemoteLocalView):
        return "trame"
    return "client" if isinstance(view, VtkLocalView) else "server"


def link(view, plotter, *, resize_delay=RESIZE_DELAY):
    """Keep ``plotter``'s ambient volumes right in ``view``, one of PyVista's trame views of it
    (``plotter_ui``'s, or those ``plotter.show()`` builds in Jupyter: :func:`show`): bind the
    browser's camera and size reports of a client view (:meth:`Follow.browser_camera`) and defer
    the volumes' re-renders on resizes. Call it before the page loads (while the layout is built,
    or before it is flushed). Returns the :class:`Follow` (also ``view.ambient_follow``)."""
    _check_delay(resize_delay)
    follow = Follow(plotter, view_mode(view), resize_delay)
    if follow.mode == "trame":
        _server_rendering_only(view, plotter)
    if follow.mode == "client":
        # the browser's camera and canvas size (CSS pixels × devicePixelRatio, as vtk.js sizes it);
        # the camera is null while the view has no renderer yet (its first resize precedes its scene)
        ref = f"trame.refs['{view_ref(view, plotter)}']"
        camera = f"(() => {{ try {{ return {ref}.getCamera() }} catch (e) {{ return null }} }})()"
        report = f"[{camera}, {ref}.$el.clientWidth, {ref}.$el.clientHeight, utils.get('devicePixelRatio')]"
        view.EndAnimation = (follow.browser_camera, report)
        view.resize = (follow.browser_resize, report)
    follow.attach(view)
    view.ambient_follow = follow
    return follow


def _server_rendering_only(view, plotter):
    """Keep trame's switchable view in server rendering: switched to client rendering it builds
    its scene from the server's full scenes only, which leave a replaced plane in the browser (the
    new picture then shows beside the old), so the view switches back, with a one-line warning."""
    from trame_pyvista.ui import get_viewer

    key, state = get_viewer(plotter).SERVER_RENDERING, view.server.state
    state[key] = True

    @state.change(key)
    def _back_to_server(**_):
        if not state[key]:
            warnings.warn("pv_ambient: the ambient volume is rendered on the server in this view; "
                          "back to server rendering", UserWarning, stacklevel=2)
            state[key] = True


def view_ref(view, plotter):
    """The name the browser knows ``view`` by (PyVista's views: ``view_<plotter id>``)."""
    return f"view_{plotter._id_name}"


def show(plotter, *, jupyter_backend=None, resize_delay=RESIZE_DELAY, **kwargs):
    """``plotter.show()`` in Jupyter with its ambient volumes kept right in every trame backend
    (``"trame"``, ``"server"``, ``"client"``): PyVista builds its view as usual and :func:`link`
    binds it before the page loads. ``"static"`` and ``"none"`` are ``plotter.show()``'s own;
    ``"html"`` (a vtk.js scene exported without a server, whose camera would turn the picture as a
    flat card) shows the ``"static"`` picture, with a one-line warning. ``kwargs`` as
    ``plotter.show`` (a ``handler`` in ``jupyter_kwargs`` still builds the output).

    Examples
    --------
    In a notebook cell::

        pl = pv.Plotter()
        pv_ambient.add_ambient_volume(pl, grid, model="ambient_scattering", interactive=True)
        show(pl, jupyter_backend="client")
    """
    if jupyter_backend == "html" and volumes_of(plotter):
        # the exported vtk.js scene has no server behind it: its camera would turn a flat card
        warnings.warn("pv_ambient: the 'html' backend cannot re-render an ambient volume from its camera; "
                      "showing the picture instead (jupyter_backend='static')", UserWarning, stacklevel=2)
        jupyter_backend = "static"
    jupyter_kwargs = dict(kwargs.pop("jupyter_kwargs", None) or {})
    handler = jupyter_kwargs.pop("handler", None)

    def linked(viewer, src, **kw):
        for view in list(viewer.views):
            link(view, plotter, resize_delay=resize_delay)
        if getattr(viewer, "layout", None) is not None:
            viewer.layout.flush_content()  # the bindings reach the page's template
        if handler is not None:
            return handler(viewer, src, **kw)
        from trame_pyvista.jupyter import Widget

        return Widget(viewer, src, **kw)

    # PyVista's own show (the class's: the plotter's may be routed here, route_show)
    return type(plotter).show(plotter, jupyter_backend=jupyter_backend,
                              jupyter_kwargs={**jupyter_kwargs, "handler": linked}, **kwargs)


class Follow:
    """The link between a plotter's ambient volumes and its trame view (made by :func:`link`).

    Attributes
    ----------
    plotter : pyvista.Plotter
    mode : str
        ``"server"``, ``"client"`` or ``"trame"``.
    view
        The trame view.
    renders : int
        How many times new pictures were sent to the view.
    """

    def __init__(self, plotter, mode, resize_delay=RESIZE_DELAY):
        self.plotter = plotter
        self.mode = mode
        self.resize_delay = float(resize_delay)
        self.view = None
        self.renders = 0
        self._pending = None
        self._sent = {}  # id(volume) → its render count when its picture was last sent

    def attach(self, view):
        """Link ``view``: the server's frames defer resizes (:meth:`defer`)."""
        self.view = view
        self._sent = {id(vol): vol.renders for vol in volumes_of(self.plotter)}  # the page loads these
        if self.resize_delay > 0:
            for vol in volumes_of(self.plotter):
                vol.defer_resize = self.defer

    def defer(self, settle, push=True):
        """Call ``settle`` once the view's size has held for ``resize_delay`` seconds (each call
        restarts the wait), then (``push``) send the view the new picture when it rendered.
        Outside an event loop: at once."""
        if self._pending is not None:
            self._pending.cancel()
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:
            settle()
            return

        def run():
            self._pending = None
            if settle() and push and self.view is not None:
                self._send()

        self._pending = loop.call_later(self.resize_delay, run)

    def browser_camera(self, camera, width, height, pixel_ratio=1.0):
        """Client rendering: the browser's camera (vtk.js ``getCamera()``: position, focalPoint,
        viewUp, viewAngle, parallelProjection, parallelScale) and its canvas size in CSS pixels
        when a camera interaction ends. Puts that camera and size on the plotter, re-renders its
        volumes and sends the view the new plane and picture. Returns whether it rendered."""
        if camera is None or self.view is None or self.mode != "client":
            return False  # no camera yet, or the server's own frames follow its camera
        cam = self.plotter.camera
        cam.position = tuple(camera["position"])
        cam.focal_point = tuple(camera["focalPoint"])
        cam.up = tuple(camera["viewUp"])
        cam.view_angle = float(camera.get("viewAngle", cam.view_angle))
        cam.parallel_projection = bool(camera.get("parallelProjection", False))
        cam.parallel_scale = float(camera.get("parallelScale", cam.parallel_scale))
        ratio = float(pixel_ratio or 1.0)
        # vtk.js: canvas = floor(max(CSS size · devicePixelRatio, 10))
        size = (max(10, math.floor(float(width) * ratio)), max(10, math.floor(float(height) * ratio)))
        self.plotter.ren_win.SetSize(*size)
        for vol in volumes_of(self.plotter):
            vol.update()
        return self._send()

    def browser_resize(self, camera, width, height, pixel_ratio=1.0):
        """Client rendering: the browser's view was resized (a page settling its layout, a
        window resized): :meth:`browser_camera` once the size has held for ``resize_delay``."""
        self.defer(lambda: self.browser_camera(camera, width, height, pixel_ratio), push=False)

    def _send(self):
        """Send the view the volumes' pictures rendered since the last time; returns whether there
        were any. A view that can draw in the browser gets each new picture on a new plane actor:
        vtk.js uploads a texture's image once, and an actor's textures accumulate there (the first
        drawn), so a texture updated in place would not show. The old actor stays in the renderer,
        collapsed to a point and its image dropped, so VTK never hands its address — the browser's
        id for it — to a new object."""
        new = [vol for vol in volumes_of(self.plotter) if self._sent.get(id(vol)) != vol.renders]
        if not new:
            return False
        for vol in new:
            if self.mode == "client":
                old = vol.new_plane()
                _drop_image(old.GetTexture())
            self._sent[id(vol)] = vol.renders
        self.renders += 1
        self.view.update()
        return True


def _drop_image(texture):
    """Replace ``texture``'s image by a 1×1 one (a retired plane keeps its object, not its memory)."""
    from vtkmodules.vtkCommonDataModel import vtkImageData
    from vtkmodules.vtkCommonCore import VTK_UNSIGNED_CHAR

    img = vtkImageData()
    img.SetDimensions(1, 1, 1)
    img.AllocateScalars(VTK_UNSIGNED_CHAR, 3)
    texture.SetInputDataObject(img)
