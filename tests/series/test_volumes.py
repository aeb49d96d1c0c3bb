"""The volumes of a series (pv_ambient.series.volumes): lists, globs, ``.pvd`` collections, bad inputs."""

import numpy as np
import pytest

from pv_ambient import datasets
from pv_ambient.series import render_series

pv = pytest.importorskip("pyvista")


def test_bad_volumes(tmp_path):
    with pytest.raises(FileNotFoundError, match="matched no file"):
        render_series(str(tmp_path / "*.vti"), out_dir=tmp_path, client="synchronous")
    with pytest.raises(TypeError, match=r"volumes\[1\]"):
        render_series([datasets.cloud(n=8), 3], out_dir=tmp_path, client="synchronous")


def test_pvd_collection_in_time_order(steps, tmp_path):
    pvd = tmp_path / "run.pvd"
    entries = "".join(f'<DataSet timestep="{t}" part="0" file="{steps[i]}"/>'
                      for t, i in ((2.0, 2), (0.5, 0), (1.0, 1)))
    pvd.write_text(f'<?xml version="1.0"?><VTKFile type="Collection"><Collection>{entries}</Collection></VTKFile>')
    res = render_series(str(pvd), out_dir=tmp_path / "out", client="synchronous", window_size=(12, 8),
                        radiance=True, progress_bar=False)
    assert [f.volume for f in res.frames] == [str(s) for s in steps[:3]]
    ref = render_series([str(s) for s in steps[:3]], out_dir=tmp_path / "ref", client="synchronous",
                        window_size=(12, 8), radiance=True, progress_bar=False)
    for a, b in zip(res.frames, ref.frames):
        np.testing.assert_array_equal(np.load(a.paths[0]), np.load(b.paths[0]))




def test_packed_image_keeps_every_digit_of_the_grid():
    # PyVista pickles an ImageData through VTK's legacy format (6 digits of spacing and origin);
    # what travels to a worker must be the very grid the client holds
    from pv_ambient.series import PackedImage
    from pv_ambient.series.volumes import for_worker, load_volume

    grid = pv.ImageData(dimensions=(5, 4, 3), spacing=(0.123456789012, 0.2, 0.3), origin=(-1.000000123, 0.5, 2.0))
    grid.point_data["density"] = np.arange(grid.n_points, dtype=np.float32)
    grid.cell_data["label"] = np.arange(grid.n_cells, dtype=np.int32)
    grid.set_active_scalars("density", preference="point")
    packed = for_worker(grid)
    assert isinstance(packed, PackedImage)
    back = load_volume(packed)
    assert back.spacing == grid.spacing and back.origin == grid.origin and back.dimensions == grid.dimensions
    np.testing.assert_array_equal(back.point_data["density"], grid.point_data["density"])
    np.testing.assert_array_equal(back.cell_data["label"], grid.cell_data["label"])
    assert back.active_scalars_name == "density"
    assert for_worker("step_0.vti") == "step_0.vti" and load_volume(back) is back
