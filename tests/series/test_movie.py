"""Frames to a movie (pv_ambient.series.movie): a missing extra named before any work, .mp4 and .gif."""

import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from pv_ambient import datasets, orbit
from pv_ambient.series import render_series

pv = pytest.importorskip("pyvista")


def test_movie(tmp_path, monkeypatch):
    grid = datasets.supernova(n=16)
    kw = dict(out_dir=tmp_path, client="synchronous", window_size=(18, 13), progress_bar=False,
              cameras=orbit(grid, 4))
    # without the extra: a clear error naming it, before anything is rendered
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)
    with pytest.raises(ImportError, match=r"'movie' extra"):
        render_series(grid, movie=tmp_path / "orbit.mp4", **kw)
    assert not list(tmp_path.glob("frame_*"))
    monkeypatch.undo()
    imageio = pytest.importorskip("imageio.v2")
    ffmpeg = pytest.importorskip("imageio_ffmpeg")
    res = render_series(grid, movie=tmp_path / "orbit.mp4", fps=5, **kw)
    assert res.movie == tmp_path / "orbit.mp4"
    assert ffmpeg.count_frames_and_secs(str(res.movie)) == (4, 0.8)
    raw = subprocess.run([ffmpeg.get_ffmpeg_exe(), "-v", "error", "-i", str(res.movie), "-f", "rawvideo",
                          "-pix_fmt", "rgb24", "-"], capture_output=True, check=True).stdout
    assert len(raw) == 4 * 14 * 18 * 3  # 4 frames, the odd height padded to even for H.264
    first = np.frombuffer(raw, np.uint8)[: 14 * 18 * 3].reshape(14, 18, 3)[:13].astype(int)
    png = np.asarray(Image.open(res.paths[0])).astype(int)
    assert png.std() > 10 and np.corrcoef(first.ravel(), png.ravel())[0, 1] > 0.95  # lossy, the same picture
    gif = render_series(grid, movie=tmp_path / "orbit.gif", **kw).movie
    assert len(imageio.mimread(gif)) == 4

