"""One frame on a worker (pv_ambient.series.worker): a bad input is that frame's error, the others finish."""

import numpy as np
import pytest

from pv_ambient import datasets
from pv_ambient.series import render_series

pv = pytest.importorskip("pyvista")


def test_bad_frames_reported_the_others_finish(steps, tmp_path):
    nan = datasets.cloud(n=24, seed=0)
    nan.point_data[nan.active_scalars_name][5] = np.nan
    nan_path = tmp_path / "nan.vti"
    nan.save(nan_path)
    vols = [str(steps[0]), str(tmp_path / "missing.vti"), str(nan_path), steps[1]]
    res = render_series(vols, out_dir=tmp_path / "out", client="synchronous", window_size=(16, 12),
                        progress_bar=False)
    assert [f.status for f in res.frames] == ["rendered", "failed", "failed", "rendered"]
    assert "FileNotFoundError" in res.frames[1].error and "missing.vti" in res.frames[1].error
    assert "ValueError" in res.frames[2].error and "nan" in res.frames[2].error.lower()
    assert res.exit_status == 2
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["frame_0000.png", "frame_0003.png"]



def test_frame_files_npy_before_png_and_only_this_runs_parts_removed(tmp_path):
    from pv_ambient.series import frame_outputs
    from pv_ambient.series.worker import remove_parts

    assert [p.name for p in frame_outputs(tmp_path, 3, True)] == ["frame_0003.npy", "frame_0003.png"]
    assert [p.name for p in frame_outputs(tmp_path, 12, False)] == ["frame_0012.png"]
    mine, other = tmp_path / ".frame_0001.aaaaaaaaaaaa.part.png", tmp_path / ".frame_0002.bbbbbbbbbbbb.part.npy"
    for p in (mine, other):
        p.write_bytes(b"half")
    remove_parts(tmp_path, "aaaaaaaaaaaa")
    assert not mine.exists() and other.exists()
    remove_parts(tmp_path)  # every run's: what a killed run left behind
    assert not other.exists()
