"""Tests progress bars and Ctrl-C end to end: named bars per stage on stderr (off under pytest unless
asked), and an interrupt between tiles, batches or table rows that closes every bar and leaves the
renderer's caches whole."""
import pv_ambient as pa
from pv_ambient import datasets


def test_progress_bars_are_named_per_stage_and_off_by_default_in_tests(capsys):
    """Why: the only bar covered the final ray cast (unnamed), long stages were silent, the
    diffusion solve showed an unlabelled count."""
    import re

    grid = datasets.cloud(n=12)
    pa.render(grid, window_size=(16, 12), model="single_scattering")
    assert capsys.readouterr().err == ""  # progress_bar=None: never under pytest
    pa.render(grid, window_size=(16, 12), model="single_scattering", progress_bar=True)
    err = capsys.readouterr().err
    assert "light volumes (2 lights)" in err and "ray cast (single_scattering)" in err
    pa.render(grid, window_size=(16, 12), model="diffusion", progress_bar=True)
    assert re.search(r"diffusion solve: 100%.*[0-9]+ iterations, residual [0-9.e+-]+", capsys.readouterr().err)
