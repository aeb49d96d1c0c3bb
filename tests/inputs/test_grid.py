"""Tests pv_ambient/inputs/grid.py, the ImageData ↔ numpy converter: order, spacing, origin, direction,
extent offset, cell data, bad input."""
import numpy as np
import pytest
import pyvista as pv
from vtkmodules.vtkCommonDataModel import vtkImageData

from pv_ambient.inputs.grid import Volume, image_geometry, select_scalars, volume_from_image


def rotated_grid():
    g = pv.ImageData(dimensions=(4, 5, 6), spacing=(0.5, 0.25, 2.0), origin=(1.0, -2.0, 3.0))
    c, s = np.cos(0.4), np.sin(0.4)
    g.direction_matrix = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
    g.offset = (2, -1, 3)
    g["v"] = np.arange(g.n_points, dtype=np.float64)
    return g


def test_point_values_sit_at_their_points():
    g = rotated_grid()
    vol = volume_from_image(g)
    a = vol.arrays["v"]
    assert a.shape == (4, 5, 6)
    ijk = np.array([[1, 2, 3], [3, 0, 5], [0, 4, 0]])
    world = vol.geometry.to_world(ijk)
    for (i, j, k), x in zip(ijk, world):
        pid = g.find_closest_point(x)
        assert np.allclose(g.points[pid], x, atol=1e-9)
        assert a[i, j, k] == g["v"][pid]


def test_reshape_is_a_view():
    g = rotated_grid()
    vol = volume_from_image(g)
    assert np.shares_memory(vol.arrays["v"], g.point_data["v"])


def test_cell_data_sits_at_cell_centres():
    g = rotated_grid()
    g.cell_data["c"] = np.arange(g.n_cells, dtype=np.float32)
    g.point_data.clear()
    vol = volume_from_image(g)
    assert vol.association == "cell" and vol.arrays["c"].shape == (3, 4, 5)
    centres = g.cell_centers().points
    ijk = np.array([[2, 3, 4], [0, 1, 2]])
    for (i, j, k), x in zip(ijk, vol.geometry.to_world(ijk)):
        cid = int(vol.arrays["c"][i, j, k])
        assert np.allclose(centres[cid], x, atol=1e-9)
    # the medium box of cell data is the grid's bounds
    assert np.allclose(vol.geometry.bounds, g.bounds, atol=1e-9)


def test_bounds_match_pyvista():
    g = rotated_grid()
    assert np.allclose(image_geometry(g).bounds, g.bounds, atol=1e-9)


def test_raw_vtk_image_is_wrapped():
    raw = vtkImageData()
    raw.SetDimensions(3, 3, 3)
    from vtkmodules.util.numpy_support import numpy_to_vtk

    arr = numpy_to_vtk(np.ones(27))
    arr.SetName("x")
    raw.GetPointData().AddArray(arr)
    vol = volume_from_image(raw)
    assert vol.arrays["x"].shape == (3, 3, 3)


@pytest.mark.parametrize("obj, name", [
    (pv.Sphere(), "PolyData"),
    (pv.ImageData(dimensions=(3, 3, 3)).cast_to_unstructured_grid(), "UnstructuredGrid"),
    (pv.RectilinearGrid(np.arange(3.0), np.arange(3.0), np.arange(3.0)), "RectilinearGrid"),
    (np.zeros((3, 3, 3)), "ndarray"),
])
def test_other_types_are_refused_with_a_hint(obj, name):
    with pytest.raises(TypeError, match=rf"grid must be a pyvista.ImageData.*{name}.*[Rr]esample"):
        volume_from_image(obj)


def test_empty_and_missing():
    with pytest.raises(ValueError, match="empty"):
        volume_from_image(pv.ImageData(dimensions=(0, 0, 0)))
    g = pv.ImageData(dimensions=(3, 3, 3))
    with pytest.raises(ValueError, match="no point or cell arrays"):
        volume_from_image(g)
    g["a"] = np.zeros(27)
    vol = volume_from_image(g)
    with pytest.raises(ValueError, match=r"scalars='nope' is not an array.*available: \['a'\]"):
        select_scalars(vol, "nope")


def test_multicomponent_magnitude_and_component():
    g = pv.ImageData(dimensions=(3, 3, 3))
    v = np.random.default_rng(0).normal(size=(27, 3))
    g["vec"] = v
    vol = volume_from_image(g)
    mag = select_scalars(vol, "vec")
    assert np.allclose(mag.ravel(order="F"), np.linalg.norm(v, axis=1))
    assert np.allclose(select_scalars(vol, "vec", component=1).ravel(order="F"), v[:, 1])
    with pytest.raises(ValueError, match="component"):
        select_scalars(vol, "vec", component=5)


def test_string_array_refused():
    g = pv.ImageData(dimensions=(2, 2, 2))
    g["n"] = np.arange(8.0)
    vol = volume_from_image(g)
    vol.arrays["s"] = np.array(["a"] * 8).reshape(2, 2, 2)
    with pytest.raises(TypeError, match="numeric"):
        select_scalars(vol, "s")


def test_volume_from_numpy():
    vol = Volume(np.zeros((2, 3, 4)), spacing=(1, 2, 3), origin=(1, 1, 1))
    assert np.allclose(vol.geometry.to_world([[1, 1, 1]]), [[2, 3, 4]])
    with pytest.raises(ValueError, match="spacing"):
        Volume(np.zeros((2, 3, 4)), spacing=(1, 0, 3))
    with pytest.raises(ValueError, match="empty"):
        Volume(np.zeros((0, 3, 4)))


def test_preference_cell_wins_over_active_point_scalars():
    # explicit preference="cell" reads the cell arrays even when the active scalars are point data
    import pyvista as pv

    import pv_ambient as pa

    g = pv.ImageData(dimensions=(5, 5, 5))
    g.point_data["p"] = np.zeros(g.n_points, np.float32)
    g.cell_data["c"] = np.arange(g.n_cells, dtype=np.float32)
    g.set_active_scalars("p", preference="point")
    r = pa.Renderer(g, scalars="c", preference="cell")
    assert r.volume.association == "cell" and r.volume.geometry.shape == (4, 4, 4)
    assert pa.Renderer(g).volume.association == "point"


def test_distance_to_the_box_matches_brute_force():
    """A rotated, anisotropically spaced grid: the per-axis clamp in index space against the
    smallest distance to a dense sample of the box's surface (its nearest point is on the surface
    or the point is inside: 0); a sheared map gives a lower bound."""
    from pv_ambient.inputs.grid import geometry_from_spacing, make_geometry

    rng = np.random.default_rng(3)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    if np.linalg.det(q) < 0:
        q[:, 0] *= -1
    g = geometry_from_spacing((5, 4, 3), spacing=(0.3, 0.5, 0.7), origin=(0.2, -0.1, 0.4), direction=q)
    u = np.linspace(0.0, 1.0, 81)
    a, b = np.meshgrid(u, u, indexing="ij")
    faces = []
    for axis in range(3):
        for side in (0.0, 1.0):
            f = np.empty(a.shape + (3,))
            others = [k for k in range(3) if k != axis]
            f[..., axis] = side
            f[..., others[0]], f[..., others[1]] = a, b
            faces.append(f.reshape(-1, 3))
    t = np.concatenate(faces)
    surface = g.to_world(g.box_lo + t * (g.box_hi - g.box_lo))
    pts = g.to_world(g.box_lo - 2.0 + rng.random((40, 3)) * (g.box_hi - g.box_lo + 4.0))
    inside = np.all((g.to_index(pts) >= g.box_lo) & (g.to_index(pts) <= g.box_hi), axis=1)
    brute = np.where(inside, 0.0, np.min(np.linalg.norm(pts[:, None] - surface[None], axis=2), axis=1))
    got = g.distance_to(pts)
    h = 1.0 / 80 * float(np.max(g.spacing * (g.box_hi - g.box_lo)))  # the surface sample's spacing
    assert np.all(got <= brute + 1e-12) and np.all(brute - got <= h)
    assert inside.any() and (~inside).any()
    m = np.eye(4)
    m[:3, :3] = [[1.0, 0.6, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]  # sheared: a lower bound
    s = make_geometry((4, 4, 4), m)
    sheared = s.to_world(s.box_lo - 1.0 + rng.random((30, 3)) * (s.box_hi - s.box_lo + 2.0))
    surface = s.to_world(s.box_lo + t * (s.box_hi - s.box_lo))
    ins = np.all((s.to_index(sheared) >= s.box_lo) & (s.to_index(sheared) <= s.box_hi), axis=1)
    true = np.where(ins, 0.0, np.min(np.linalg.norm(sheared[:, None] - surface[None], axis=2), axis=1))
    assert np.all(s.distance_to(sheared) <= true + 1e-12)
