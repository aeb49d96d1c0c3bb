"""The cameras of an orbit movie (pv_ambient.inputs.camera.orbit, exported as pv_ambient.orbit)."""

import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient import datasets
from pv_ambient.inputs.camera import orbit

pv = pytest.importorskip("pyvista")


def test_orbit_cameras():
    start = pa.Camera((0.0, -4.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), view_angle=25.0)
    cams = orbit(None, 8, start=start)
    assert len(cams) == 8
    np.testing.assert_allclose(cams[0].position, start.position, atol=1e-12)
    for c in cams:
        p = np.array(c.position)
        assert np.isclose(np.linalg.norm(p), np.linalg.norm(start.position)) and np.isclose(p[2], 1.0)
        assert c.view_angle == 25.0 and c.focal_point == (0.0, 0.0, 0.0)
    np.testing.assert_allclose(cams[4].position, (0.0, 4.0, 1.0), atol=1e-12)  # half way round
    up = orbit(None, 3, start=start, elevation=80.0, distance=2.0)
    assert all(np.isclose(c.position[2], 2.0 * np.sin(np.radians(80.0))) for c in up)
    assert all(np.isclose(np.linalg.norm(c.position), 2.0) for c in up)
    grid = datasets.cloud(n=8)
    default = orbit(grid, 2)
    np.testing.assert_allclose(default[0].position, pa.render(grid, window_size=(4, 4)).camera.position)
    with pytest.raises(ValueError, match="n_frames"):
        orbit(grid, 0)
    with pytest.raises(ValueError, match="elevation"):
        orbit(grid, 4, elevation=120)

