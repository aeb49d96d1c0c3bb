"""Tests pv_ambient/rendering/path_traced.py: the ``path_traced`` model through the renderer — the
target error and its warning, the time budget of ``auto``, denoising that keeps the standard error."""
import warnings

import pytest

import pv_ambient as pa
from pv_ambient import datasets


def test_target_error_not_reached_warns_with_the_error_reached():
    """Why: ``target_error=0.01`` was missed silently (the samples_per_pixel cap came first)."""
    r = pa.Renderer(datasets.cloud(n=12), lights=[pa.PointLight((1.5, 1.5, 1.5), 4.0)])
    with pytest.warns(UserWarning, match=r"target_error=0.001 was not reached: the relative error is [0-9.]+ after "
                                         r"4 samples per pixel"):
        res = r.render(window_size=(12, 10), model="path_traced", samples_per_pixel=4, target_error=1e-3)
    assert res.metadata["relative_error"] > 1e-3
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # reached: no warning
        r.render(window_size=(12, 10), model="path_traced", samples_per_pixel=64, target_error=10.0)
