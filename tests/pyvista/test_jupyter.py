"""Tests pv_ambient/pyvista/jupyter.py without a browser: the link between a plotter's ambient
volumes and its trame view (issue 46). Client rendering: the browser's camera and canvas size
re-render the volume on a new plane; resizes are debounced; the trame imports warn nothing.
tests/browser drive the same code from headless Chromium (make test-browser)."""

import asyncio
import os
import warnings

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
import pyvista as pv  # noqa: E402

import pv_ambient as pa  # noqa: E402
from pv_ambient import datasets  # noqa: E402
from pv_ambient.pyvista.jupyter import TRAME_BACKENDS, Follow, ambient_ui, volumes_of  # noqa: E402

from .helpers import plotter  # noqa: E402

SIZE = (40, 30)


class FakeView:
    """What Follow asks of a trame view: update() sends the scene to the browser."""

    def __init__(self):
        self.updates = 0

    def update(self):
        self.updates += 1


@pytest.fixture(scope="module")
def grid():
    return datasets.cloud(n=16)


def browser_camera(position, angle=30.0):
    """A camera as vtk.js getCamera() reports it."""
    return dict(position=list(position), focalPoint=[0.0, 0.0, 0.0], viewUp=[0.0, 0.0, 1.0], viewAngle=angle,
                parallelProjection=False, parallelScale=1.0, centerOfRotation=[0.0, 0.0, 0.0])


def test_volumes_of_lists_the_interactive_volumes(grid):
    pl = plotter(SIZE)
    still = pa.add_ambient_volume(pl, grid)
    live = pa.add_ambient_volume(pl, grid, interactive=True)
    assert volumes_of(pl) == [live] and still.observer is None
    live.remove_observer()
    assert volumes_of(pl) == []
    pl.close()


def test_the_browser_camera_re_renders_at_the_canvas_size_on_a_new_plane(grid):
    """Why: with vtk.js the camera lives in the browser and no server frame starts a re-render —
    the plane turned as a flat card at the plotter's 1024×768. The reported camera and canvas size
    (CSS pixels × devicePixelRatio) re-render the volume there, on a new plane actor (vtk.js keeps
    a texture's first image), and the view is sent the scene."""
    pl = plotter(SIZE)
    vol = pa.add_ambient_volume(pl, grid, interactive=True)
    follow, view = Follow(pl, "client"), FakeView()
    follow.attach(view)
    old = vol.actor
    cam = browser_camera((3.0, -2.0, 1.5), angle=35.0)
    assert follow.browser_camera(cam, 25, 20, 2.0)  # a 2× screen: a 50×40 canvas
    assert vol.result.window_size == (50, 40) and view.updates == 1 and follow.renders == 1
    assert vol.actor is not old and pl.renderer.HasViewProp(vol.actor) and vol.actor.GetVisibility()
    assert pl.renderer.HasViewProp(old)  # its id kept, its plane collapsed to a point: it draws nothing
    assert np.ptp(pv.wrap(old.GetMapper().GetInputDataObject(0, 0)).points, axis=0).max() == 0
    assert old.GetTexture().GetInput().GetDimensions() == (1, 1, 1)  # the retired plane's image dropped
    ref = vol.renderer.render(camera=pa.Camera((3.0, -2.0, 1.5), (0, 0, 0), (0, 0, 1), view_angle=35.0),
                              window_size=(50, 40))
    np.testing.assert_allclose(vol.volume_result.radiance, ref.radiance, rtol=0, atol=1e-6)
    assert not follow.browser_camera(cam, 25, 20, 2.0) and view.updates == 1  # nothing changed: no render
    assert not follow.browser_camera(None, 25, 20)  # no camera yet (the view's first resize)
    pl.close()


def test_resizes_are_debounced_in_an_event_loop(grid):
    """A settling page reports several sizes within a fraction of a second: one render, at the
    last size, ``resize_delay`` after the last report; outside an event loop each size renders."""
    pl = plotter(SIZE)
    vol = pa.add_ambient_volume(pl, grid, interactive=True)
    follow, view = Follow(pl, "client", resize_delay=0.05), FakeView()
    follow.attach(view)
    cam = browser_camera((2.0, 2.0, 2.0))

    async def settle():
        for w in (12, 30, 44):
            follow.browser_resize(cam, w, 20)
        await asyncio.sleep(0.3)

    asyncio.run(settle())
    assert vol.renders == 2 and vol.result.window_size == (44, 20) and view.updates == 1
    follow.browser_resize(cam, 36, 24)  # no loop: at once
    assert vol.renders == 3 and vol.result.window_size == (36, 24)
    pl.close()


@pytest.mark.parametrize("kwargs,match", [(dict(mode="vtk.js"), "mode"), (dict(resize_delay=-1), "resize_delay"),
                                          (dict(resize_delay=float("nan")), "resize_delay")])
def test_ambient_ui_checks_its_arguments(grid, kwargs, match):
    pl = plotter(SIZE)
    pa.add_ambient_volume(pl, grid, interactive=True)
    with pytest.raises(ValueError, match=match):
        ambient_ui(pl, **kwargs)
    pl.close()


@pytest.mark.parametrize("mode", ["server", "client", "trame"])
def test_ambient_ui_builds_pyvistas_view_without_deprecation_warnings(grid, mode):
    """pv_ambient imports plotter_ui from trame_pyvista.ui (pyvista.trame.ui is a deprecated shim in
    PyVista 0.49): building each view warns nothing (the suite turns warnings into errors)."""
    pytest.importorskip("trame_pyvista")
    from trame.app import get_server
    from trame.ui.vuetify3 import SinglePageLayout

    pl = plotter(SIZE)
    vol = pa.add_ambient_volume(pl, grid, interactive=True)
    server = get_server(f"pv-ambient-test-{mode}", client_type="vue3")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")  # the suite's filters ignore pyvista's own DeprecationWarnings
        with SinglePageLayout(server) as layout, layout.content:
            view = ambient_ui(pl, mode=mode, server=server, add_menu=False)
    assert not [w for w in caught if "deprecat" in str(w.message).lower()], [str(w.message) for w in caught]
    follow = view.ambient_follow
    assert follow.view is view and follow.mode == mode and vol.defer_resize == follow.defer
    pl.close()


def test_show_links_the_views_plotter_show_builds(grid, monkeypatch):
    """``show(pl, jupyter_backend=...)`` is ``pl.show()`` with a handler that links each view PyVista
    built (here the Jupyter path's ``initialize``, without a notebook) before the page loads, then
    builds the output as the user's handler (or PyVista's iframe widget) would."""
    pytest.importorskip("trame_pyvista")
    from trame.app import get_server
    from trame_pyvista.jupyter import initialize

    from pv_ambient.pyvista.jupyter import show

    pl = plotter(SIZE)
    vol = pa.add_ambient_volume(pl, grid, interactive=True)
    asked = {}

    def fake_show(self, **kwargs):  # what PyVista's show does with the handler in Jupyter
        asked.update(kwargs)
        viewer = initialize(get_server("pv-ambient-test-show", client_type="vue3"), self, mode="client")
        return kwargs["jupyter_kwargs"]["handler"](viewer, "http://x/index.html", width="100%")

    monkeypatch.setattr(type(pl), "show", fake_show)
    out = show(pl, jupyter_backend="client", jupyter_kwargs=dict(handler=lambda viewer, src, **kw: (viewer, src, kw)))
    viewer, src, kw = out
    assert asked["jupyter_backend"] == "client" and src == "http://x/index.html" and kw == {"width": "100%"}
    (view,) = viewer.views
    assert view.ambient_follow.mode == "client" and vol.defer_resize == view.ambient_follow.defer
    pl.close()


def test_show_turns_the_html_backend_into_the_static_picture(grid, monkeypatch):
    """The 'html' backend exports the vtk.js scene without a server: its camera would turn the
    picture as a flat card, so show() warns in one line and shows the static picture."""
    from pv_ambient.pyvista.jupyter import show

    pl = plotter(SIZE)
    pa.add_ambient_volume(pl, grid, interactive=True)
    asked = {}
    monkeypatch.setattr(type(pl), "show", lambda self, **kw: asked.update(kw))
    with pytest.warns(UserWarning, match="'html' backend cannot re-render"):
        show(pl, jupyter_backend="html")
    assert asked["jupyter_backend"] == "static"
    pl.close()


@pytest.mark.parametrize("notebook, backend, routed", [(True, "client", True), (True, None, True),
                                                      (True, "static", False), (False, "client", False)])
def test_plotter_show_goes_through_show_in_a_notebook(grid, monkeypatch, notebook, backend, routed):
    """Once the plotter holds an interactive ambient volume, its own ``show()`` in a notebook with a
    trame backend (given, or the theme's) is :func:`show`'s — the view gets linked, no flat card;
    outside a notebook, or with the static backend, it is PyVista's show, untouched."""
    pl = plotter(SIZE)
    pa.add_ambient_volume(pl, grid, interactive=True)
    asked = []
    monkeypatch.setattr(type(pl), "show", lambda self, **kw: asked.append(kw))
    if backend is None:  # the theme's backend decides (setting it would need IPython); None: PyVista's pick
        theme = pv.global_theme.jupyter_backend
        routed = notebook and (theme is None or str(theme).lower() in TRAME_BACKENDS)
    pl.notebook = notebook
    pl.show(**({} if backend is None else {"jupyter_backend": backend}))
    (kw,) = asked
    assert ("handler" in kw.get("jupyter_kwargs", {})) == routed
    pl.notebook = False
    pl.close()


def test_the_switchable_view_stays_in_server_rendering(grid):
    """trame's switchable view, switched to client rendering, would leave a replaced plane in the
    browser beside the new one: pv_ambient starts it in server rendering and switches it back, with
    a one-line warning."""
    pytest.importorskip("trame_pyvista")
    from trame.app import get_server
    from trame.ui.vuetify3 import SinglePageLayout
    from trame_pyvista.ui import get_viewer

    pl = plotter(SIZE)
    pa.add_ambient_volume(pl, grid, interactive=True)
    server = get_server("pv-ambient-test-switch", client_type="vue3")
    with SinglePageLayout(server) as layout, layout.content:
        ambient_ui(pl, mode="trame", server=server, add_menu=False, default_server_rendering=False)
    key = get_viewer(pl).SERVER_RENDERING
    assert server.state[key] is True
    server.state.ready()  # (change callbacks run once the state is ready, as when a page connects)
    server.state[key] = False  # the user ticks client rendering
    with pytest.warns(UserWarning, match="rendered on the server in this view"):
        server.state.flush()
    assert server.state[key] is True
    pl.close()
