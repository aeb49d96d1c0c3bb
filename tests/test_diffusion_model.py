"""The ``diffusion`` render model (DESIGN §4b): exact single scattering plus the multiply-scattered
light of the diffusion solve; its limits and caching."""

import numpy as np
import pytest

from pv_ambient.lights import PointLight
from test_ambient import LIGHTS, physical_grid, rel, render, renderer


def test_albedo_zero_is_single_scattering():
    r = renderer(physical_grid(albedo=0.0, emission=(0.5, 0.3, 0.1)))
    assert rel(render(r, "diffusion"), render(r, "single_scattering")) == 0.0


def test_no_lights_is_black():
    out = render(renderer(physical_grid(), lights=()), "diffusion")
    assert np.all(out == 0)


def test_multiple_scattering_is_second_order_in_albedo():
    ratios = []
    for a in (0.2, 0.05, 0.01):
        r = renderer(physical_grid(sigma=4.0, albedo=a, noise=False))
        ss = render(r, "single_scattering")
        d = render(r, "diffusion")
        assert np.all(d >= ss - 1e-9)
        ratios.append((d - ss).sum() / ss.sum())  # multiply- over single-scattered: O(albedo)
    # single scattering is O(a), the diffusion part O(a²): the ratio falls ~4× and ~5× here
    assert ratios[0] > 3.0 * ratios[1] > 0 and ratios[1] > 4.0 * ratios[2] > 0


def test_relight_resolves_only_the_moved_light():
    r = renderer(physical_grid())
    render(r, "diffusion")
    keys = {k for k in r._cache if k[0] == "diffusion"}
    assert len(keys) == 2  # one solve per light
    moved = PointLight((-0.3, -1.6, 0.9), intensity=(3.0, 2.5, 2.0))
    r.set_lights([moved, LIGHTS[1]])
    render(r, "diffusion")
    new = {k for k in r._cache if k[0] == "diffusion"} - keys
    assert len(new) == 1 and moved in next(iter(new))
