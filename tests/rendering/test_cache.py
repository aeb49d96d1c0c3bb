"""Tests pv_ambient/rendering/cache.py: the scene cache's named keys, what a build computes once, what
is shared between renderers and what survives a change of colour (σt-only entries)."""
import pytest

from pv_ambient.rendering.cache import SCENE_INDEPENDENT, SIGMA_ONLY, SceneCache


def _filled():
    c = SceneCache()
    for key in (("majorant", 8), ("light_grid", 1.0), ("tau", "light A", 1.0), ("ball", 0.3),
                ("table", 0.0, "preview"), ("diffusion", "light A", 1.0, 0.0, False, 0, False)):
        c[key] = key[0]
    return c


def test_get_builds_once_and_keys_name_their_stage():
    c = SceneCache()
    calls = []
    assert c.get(("tau", "light A"), lambda: calls.append(1) or "τ") == "τ"
    assert c.get(("tau", "light A"), lambda: calls.append(1) or "other") == "τ"  # cached: not built again
    assert calls == [1] and ("tau", "light A") in c and len(c) == 1
    c = _filled()
    assert c.kinds() == {"majorant", "light_grid", "tau", "ball", "table", "diffusion"}
    assert c.keys("tau") == [("tau", "light A", 1.0)] and len(c.keys()) == 6
    assert c.items("ball") == [(("ball", 0.3), "ball")]
    assert repr(c) == "SceneCache(6 entries: ball, diffusion, light_grid, majorant, table, tau)"
    assert repr(SceneCache()) == "SceneCache(0 entries: empty)"


@pytest.mark.parametrize("key", ["tau", (), (3, "tau"), ["tau", 1]])
def test_a_key_is_a_tuple_starting_with_the_stage_name(key):
    with pytest.raises(TypeError, match=r"a scene-cache key is a tuple starting with the stage's name, got "):
        SceneCache()[key] = 1


def test_with_sigma_only_keeps_the_entries_of_sigma_and_geometry_alone():
    c = _filled()
    sigma = c.with_sigma_only()
    assert SIGMA_ONLY == {"majorant", "cast_majorant", "light_grid", "sigma_l", "tau"}
    assert sigma.kinds() == {"majorant", "light_grid", "tau"} and len(sigma) == 3
    assert len(c) == 6  # the original keeps everything
    sigma[("ball", 0.5)] = "new"
    assert ("ball", 0.5) not in c  # a new cache, not a view


def test_share_copies_the_scene_independent_entries_by_reference_and_clear_forgets():
    c, other = SceneCache(), _filled()
    table = object()
    other[("table", 0.6, "balanced")] = table
    c.share(other)
    assert SCENE_INDEPENDENT == {"table"} and c.kinds() == {"table"} and len(c) == 2
    assert c[("table", 0.6, "balanced")] is table
    c.share(other, kinds=("tau",))
    assert c.kinds() == {"table", "tau"}
    c.clear("table")
    assert c.kinds() == {"tau"}
    c.clear()
    assert len(c) == 0 and list(c) == []
