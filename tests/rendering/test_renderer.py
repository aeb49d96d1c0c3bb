"""Tests pv_ambient/rendering/renderer.py: the Renderer and render() — ``auto`` decided in one place,
the docstrings that list every model and option, lights set and placed, steps of the presets."""
import pv_ambient as pa


def test_render_docstrings_list_every_model_and_option():
    """Why: ``help(pa.render)`` listed neither models nor options; ``Renderer.render`` omitted diffusion."""
    from pv_ambient.rendering.presets import ALL_MODELS, MODEL_OPTIONS

    for doc in (pa.render.__doc__, pa.Renderer.render.__doc__):
        for name in ALL_MODELS:
            assert f'"{name}"' in doc, name
        for option in sorted(MODEL_OPTIONS | {"radius", "ambient_radiance", "phase", "light_resolution"}):
            assert option in doc, option
        assert "DESIGN" not in doc
