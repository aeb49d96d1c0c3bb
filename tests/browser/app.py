"""The trame app the browser tests load: the synthetic supernova with ambient scattering in
PyVista's trame view (:func:`pv_ambient.pyvista.jupyter.ambient_ui`), server or client rendering.

    python tests/browser/app.py --mode server --port 8080 --n 64 --log renders.jsonl

Each picture the volume renders is logged as a JSON line (time, duration, camera, size, drag
frame or not, ray step), so the test can render the same view directly and time the frames.
"""

from __future__ import annotations

import argparse
import json
import os
import time

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")

import pyvista as pv  # noqa: E402

import pv_ambient as pa  # noqa: E402
from pv_ambient import datasets  # noqa: E402

MODEL = "ambient_scattering"


def scene(n):
    """The grid and the renderer's options the app and the test's direct renders share."""
    grid = datasets.supernova(n=n)
    return grid, dict(transfer_function=pa.TransferFunction(**datasets.suggested_style("supernova")),
                      model=MODEL)


def camera_record(cam):
    return dict(position=list(cam.position), focal_point=list(cam.focal_point), up=list(cam.up),
                view_angle=cam.view_angle, parallel_projection=bool(cam.parallel_projection),
                parallel_scale=cam.parallel_scale)


def instrument(vol, path):
    """Log every picture ``vol`` renders to ``path`` (JSON lines)."""
    update = vol.update

    def logged(force=False):
        t0 = time.time()
        step = vol._moving_step()
        rendered = update(force)
        if rendered:
            rec = dict(t_start=t0, t_end=time.time(), seconds=time.time() - t0, moving=bool(vol.moving),
                       size=list(vol.result.window_size), step=vol.volume_result.metadata.get("step", step),
                       camera=camera_record(vol.plotter.camera), renders=vol.renders)
            with open(path, "a") as f:
                f.write(json.dumps(rec) + "\n")
        return rendered

    vol.update = logged


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--mode", choices=("server", "client", "trame"), required=True,
                   help="trame: the switchable view, started in client rendering")
    p.add_argument("--port", type=int, required=True)
    p.add_argument("--n", type=int, default=32)
    p.add_argument("--log", required=True)
    p.add_argument("--via", choices=("ambient_ui", "show"), default="ambient_ui",
                   help="build the view with ambient_ui, or as plotter.show() does in Jupyter (then linked)")
    a = p.parse_args(argv)

    from trame.app import get_server
    from trame.ui.vuetify3 import SinglePageLayout

    from pv_ambient.pyvista.jupyter import ambient_ui, link

    server = get_server(client_type="vue3")
    grid, opts = scene(a.n)
    pl = pv.Plotter(off_screen=True)
    vol = pa.add_ambient_volume(pl, grid, interactive=True, **opts)
    instrument(vol, a.log)
    path = "/"
    if a.via == "show":  # what pv_ambient.pyvista.jupyter.show does inside plotter.show()
        from trame_pyvista.jupyter import initialize

        viewer = initialize(server, pl, mode=a.mode, add_menu=False, default_server_rendering=a.mode != "trame")
        for view in viewer.views:
            link(view, pl)
        viewer.layout.flush_content()
        path = f"/index.html?ui={pl._id_name}"
    else:
        with SinglePageLayout(server) as layout:
            layout.title.set_text("pv_ambient")
            with layout.content:
                ambient_ui(pl, mode=a.mode, add_menu=False, default_server_rendering=a.mode != "trame")
    with open(a.log, "a") as f:
        f.write(json.dumps(dict(ready=time.time(), path=path,
                                first_render=vol.volume_result.metadata.get("time_render"))) + "\n")
    server.start(port=a.port, host="127.0.0.1", open_browser=False, show_connection_info=False, timeout=0)


if __name__ == "__main__":
    main()
