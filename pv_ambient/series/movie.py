"""Frames to a movie: :func:`write_movie` (docs/series.rst).

Movies need the ``movie`` extra (imageio, and imageio-ffmpeg for anything but ``.gif``).
:func:`check_movie_support` is called by :func:`~pv_ambient.render_series` before any frame is
rendered, so a missing extra is one clear error at once, not after an hour of frames.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

MISSING_MOVIE = ("movie={!r} needs imageio{}: install the 'movie' extra (pip install 'pv_ambient[movie]': "
                 "imageio and imageio-ffmpeg)")


def check_movie_support(movie) -> None:
    """Raise an ImportError naming the ``movie`` extra when ``movie``'s format cannot be written here."""
    try:
        import imageio  # noqa: F401
    except ImportError:
        raise ImportError(MISSING_MOVIE.format(str(movie), "")) from None
    if Path(movie).suffix.lower() not in (".gif",):
        try:
            import imageio_ffmpeg  # noqa: F401
        except ImportError:
            raise ImportError(MISSING_MOVIE.format(str(movie), " with its ffmpeg plugin")) from None


def write_movie(frames, path, *, fps=10) -> Path:
    """Write PNG ``frames`` (in order) as a movie: ``.gif`` through Pillow, other suffixes through
    ffmpeg (``.mp4``: H.264). Needs the ``movie`` extra (imageio, imageio-ffmpeg)."""
    check_movie_support(path)
    import imageio.v2 as imageio
    from PIL import Image

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    images = [np.asarray(Image.open(p).convert("RGB")) for p in frames]
    if not images:
        raise ValueError("no frames to write into a movie")
    if path.suffix.lower() == ".gif":
        imageio.mimsave(path, images, duration=1000.0 / fps, loop=0)
        return path
    h, w = images[0].shape[:2]
    if h % 2 or w % 2:  # H.264 in yuv420p needs even sizes: repeat the last row/column
        images = [np.pad(im, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge") for im in images]
    with imageio.get_writer(path, fps=fps, macro_block_size=1) as writer:
        for im in images:
            writer.append_data(im)
    return path
