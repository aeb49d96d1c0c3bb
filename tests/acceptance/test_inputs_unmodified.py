"""Tests that no entry point modifies its input, end to end: render, Renderer, the ``grid.ambient``
accessor, compare and add_ambient_volume (interactive) leave every array, the active scalars and
the geometry of the ImageData as they were (PyVista's filter habit)."""
import hashlib

import numpy as np
import pyvista as pv

import pv_ambient as pa


def _fingerprint(grid):
    h = hashlib.sha256()
    for kind, data in (("point", grid.point_data), ("cell", grid.cell_data), ("field", grid.field_data)):
        for name in sorted(data.keys()):
            arr = np.asarray(data[name])
            h.update(f"{kind}:{name}:{arr.dtype}:{arr.shape}".encode())
            h.update(np.ascontiguousarray(arr).tobytes())
    return (h.hexdigest(), grid.point_data.active_scalars_name, grid.cell_data.active_scalars_name,
            tuple(grid.origin), tuple(grid.spacing), tuple(grid.dimensions), tuple(grid.extent),
            np.asarray(grid.direction_matrix).tobytes())


def test_no_entry_point_modifies_its_input():
    grid = pv.ImageData(dimensions=(10, 9, 8), spacing=(0.2, 0.25, 0.3), origin=(-1.0, -1.1, -1.2),
                        direction_matrix=pv.Transform().rotate_z(20).matrix[:3, :3])
    rng = np.random.default_rng(0)
    grid.point_data["density"] = rng.random(grid.n_points).astype(np.float32)
    grid.point_data["other"] = rng.random(grid.n_points)
    grid.point_data["vec"] = rng.random((grid.n_points, 3))
    grid.cell_data["cells"] = rng.random(grid.n_cells)
    grid.field_data["note"] = np.array([1.0, 2.0])
    grid.set_active_scalars("density")
    before = _fingerprint(grid)
    opts = {"scalars": "other", "window_size": (16, 12)}
    calls = {
        "render": lambda: pa.render(grid, **opts),
        "render vector magnitude": lambda: pa.render(grid, scalars="vec", window_size=(16, 12)),
        "Renderer.render": lambda: pa.Renderer(grid, scalars="other").render(window_size=(16, 12)),
        "accessor render": lambda: grid.ambient.render(**opts),
        "accessor plane": lambda: grid.ambient.plane(**opts),
        "accessor compare": lambda: grid.ambient.compare(scalars="other", window_size=(16, 12)).close(),
        "compare": lambda: pa.compare(grid, scalars="other", window_size=(16, 12)).close(),
        "add_ambient_volume": lambda: _add_and_close(grid),
    }
    for name, call in calls.items():
        call()
        assert _fingerprint(grid) == before, f"{name} modified its input"
    cells = pv.ImageData(dimensions=(6, 5, 4))
    cells.cell_data["density"] = np.linspace(0.0, 1.0, cells.n_cells)
    before = _fingerprint(cells)
    pa.render(cells, window_size=(8, 6))
    _add_and_close(cells, scalars=None)
    assert _fingerprint(cells) == before


def _add_and_close(grid, scalars="other"):
    pl = pv.Plotter(off_screen=True, window_size=(16, 12))
    pl.add_mesh(pv.Sphere(radius=0.3))
    vol = pa.add_ambient_volume(pl, grid, scalars=scalars, interactive=True)
    pl.camera.Azimuth(10)
    vol.update()
    pl.close()
