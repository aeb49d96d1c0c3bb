"""Tests progress bars and Ctrl-C end to end: named bars per stage on stderr (off under pytest unless
asked), and an interrupt between tiles, batches or table rows that closes every bar and leaves the
renderer's caches whole."""
import numpy as np
import pytest

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


def test_progress_bars_appear_on_stderr(capfd, tmp_path, monkeypatch):
    from pv_ambient.stages.preintegration import get_table

    monkeypatch.setenv("PV_AMBIENT_CACHE", str(tmp_path))
    get_table(0.41, (0.5, 0.6), quality="preview", cache=False, progress_bar=True)
    err = capfd.readouterr().err
    assert "preintegrating g=0.41" in err and "17/17" in err
    grid = datasets.cloud(n=12)
    pa.render(grid, window_size=(12, 8), model="path_traced", samples_per_pixel=4, progress_bar=True,
              lights=[pa.PointLight((2, 2, 2), 1.0)])
    err = capfd.readouterr().err
    assert "path_traced" in err and "4/4" in err and "spp" in err
    pa.render(grid, window_size=(12, 8), progress_bar=True)
    err = capfd.readouterr().err
    assert "emission_absorption" in err and "8/8" in err and "tile" in err  # 8 rows: 8 tiles
    pa.render(grid, window_size=(12, 8))
    assert capfd.readouterr().err == ""  # no bar unless asked


def _interrupt_after(monkeypatch, n):
    """Make tqdm's ``update`` raise KeyboardInterrupt at its ``n``-th call; record closes."""
    from tqdm.auto import tqdm

    seen = {"updates": 0, "closed": 0, "bars": []}
    update, close = tqdm.update, tqdm.close

    def fake_update(self, k=1):
        seen["bars"].append(self)  # kept alive: a close must come from the code, not from __del__
        seen["updates"] += 1
        if seen["updates"] >= n:
            raise KeyboardInterrupt
        return update(self, k)

    def spy_close(self):
        seen["closed"] += any(b is self for b in seen["bars"])  # this test's bar (not an earlier one's __del__)
        return close(self)

    monkeypatch.setattr(tqdm, "update", fake_update)
    monkeypatch.setattr(tqdm, "close", spy_close)
    return seen


def test_ctrl_c_between_tiles_and_batches_propagates_and_the_renderer_survives(monkeypatch, tmp_path):
    grid = datasets.cloud(n=12)
    r = pa.Renderer(grid, lights=[pa.PointLight((2, 2, 2), 2.0)], transfer_function={"albedo": 0.8})
    ref_ea = r.render(window_size=(12, 8))
    ref_pt = r.render(window_size=(12, 8), model="path_traced", samples_per_pixel=4)
    for model, extra in (("emission_absorption", {}), ("single_scattering", {}),
                         ("path_traced", {"samples_per_pixel": 48})):  # 3 batches of 16
        with monkeypatch.context() as m:
            seen = _interrupt_after(m, 2)
            with pytest.raises(KeyboardInterrupt):
                r.render(window_size=(12, 8), model=model, progress_bar=True, **extra)
            # every bar that ran was closed (since 0.3.0 a lit model has one per stage: light volumes, ray cast)
            assert seen["closed"] == len({id(b) for b in seen["bars"]}) >= 1, f"{model}: a bar was not closed"
    # the renderer's caches were not left half-written: the same pictures again
    np.testing.assert_array_equal(r.render(window_size=(12, 8)).radiance, ref_ea.radiance)
    np.testing.assert_array_equal(r.render(window_size=(12, 8), model="path_traced", samples_per_pixel=4).radiance,
                                  ref_pt.radiance)
    # a table interrupted while it is being computed is not cached
    from pv_ambient.stages.preintegration import get_table

    monkeypatch.setenv("PV_AMBIENT_CACHE", str(tmp_path))
    with monkeypatch.context() as m:
        seen = _interrupt_after(m, 3)
        with pytest.raises(KeyboardInterrupt):
            get_table(0.43, (0.5, 0.6), quality="preview", progress_bar=True)
        assert seen["closed"] == 1
    assert list(tmp_path.iterdir()) == []
    assert get_table(0.43, (0.5, 0.6), quality="preview").D.shape[1] == 17
