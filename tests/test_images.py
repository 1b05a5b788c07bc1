"""Image regression tests of the field maps and layers (pytest-pyvista's verify_image_cache).

Reference images live in tests/image_cache; regenerate one with
``pytest tests/test_images.py --reset_image_cache -k NAME`` and look at it before committing.
"""

import pytest

MUSCLE = "frontalis_major_L"


@pytest.mark.parametrize("field", ["lambda", "gamma", "eps", "At"])
def test_surprise_field_of_frontalis(verify_image_cache, wv_face, wv_plotter, wv_render, field):
    wv_render(wv_plotter, wv_face, "surprise", field, MUSCLE, camera="forehead")
    wv_plotter.show()


@pytest.mark.parametrize("expression", ["surprise", "frown", "fear"])
def test_total_w(verify_image_cache, wv_face, wv_plotter, wv_render, expression):
    wv_render(wv_plotter, wv_face, expression, "W", camera="forehead")
    wv_plotter.show()


@pytest.mark.parametrize("layer", ["skin", "muscles", "skull"])
def test_layer(verify_image_cache, wv_face, wv_plotter, wv_render, layer):
    wv_render(wv_plotter, wv_face, "fear", None, layers=(layer,), camera="three_quarter")
    wv_plotter.show()


@pytest.mark.parametrize("expression", ["surprise", "frown"])
def test_plain_skin_under_a_raking_light(verify_image_cache, wv_face, wv_plotter, expression):
    """What a reader of the paper's Fig. 9 looks at: no colour map, a grazing light."""
    from wrinkle_vis.plotting import add_raking_light, add_skin, set_camera

    state = wv_face.evaluate(expression, refine=True)
    add_skin(wv_plotter, state, field=None)
    add_raking_light(wv_plotter)
    set_camera(wv_plotter, "upper_face", wv_face)
    wv_plotter.show()
