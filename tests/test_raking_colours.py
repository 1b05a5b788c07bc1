"""The raking light keeps a colour map's colours (issue 32): colour-mapped skin under it
neither darkens to grey on the far side nor washes out, while plain skin keeps the full
grazing relief.
"""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv
from matplotlib.colors import rgb_to_hsv

from wrinkle_vis.plotting import add_raking_light, add_skin, remove_raking_light, set_camera

SIZE = (360, 360)


def lab_chroma(rgb: np.ndarray) -> np.ndarray:
    """CIELAB chroma :math:`\\sqrt{a^2 + b^2}` of sRGB colours ``(..., 3)`` in [0, 1]
    (D65): how colourful, not how bright; grey is 0.
    """
    c = np.where(rgb > 0.04045, ((rgb + 0.055) / 1.055) ** 2.4, rgb / 12.92)
    m = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722],
                  [0.0193, 0.1192, 0.9505]])
    xyz = c @ m.T / np.array([0.95047, 1.0, 1.08883])
    f = np.where(xyz > 216 / 24389, np.cbrt(xyz), (24389 / 27 * xyz + 16) / 116)
    return np.hypot(500 * (f[..., 0] - f[..., 1]), 200 * (f[..., 1] - f[..., 2]))


def render(state, field, muscle, camera, light: str, light_first: bool = True) -> np.ndarray:
    """The skin coloured by ``field``, lit by ``light`` (``"raking"``, ``"kit"`` or
    ``"none"``: the colour map's own colours), as ``(h, w, 3)`` floats.
    """
    p = pv.Plotter(off_screen=True, window_size=SIZE)
    p.set_background("black")
    try:
        if light == "raking" and light_first:  # as the app: light, then the skin
            add_raking_light(p)
        extra = {"lighting": False} if light == "none" else {}
        add_skin(p, state, field, muscle, scalar_bar=False, normals=state.normals, **extra)
        if light == "raking" and not light_first:  # as the notebook: skin, then light
            add_raking_light(p)
        set_camera(p, camera, state.face)
        return p.screenshot(return_img=True)[..., :3] / 255.0
    finally:
        p.close()


@pytest.fixture(scope="module")
def surprise():
    from wrinkle_vis.datasets import load_face

    return load_face().evaluate("surprise")


@pytest.mark.parametrize(("field", "muscle", "camera", "light_first"), [
    ("W", None, "front", True), ("W", None, "three_quarter", False),
    ("lambda", "frontalis_inner_L", "front", True)])
def test_a_colour_map_keeps_its_colours_under_the_raking_light(surprise, field, muscle,
                                                               camera, light_first):
    """Over the coloured pixels, the rendered colours' chroma against the colour map's own
    (unlit) stays high everywhere, the far side included (10th percentile), and their HSV
    saturation stays the colour map's. Before the fix the grazing key light left the far
    tenth at about half the colour map's chroma (0.42-0.54 here).
    """
    ref = render(surprise, field, muscle, camera, "none")
    lit = render(surprise, field, muscle, camera, "raking", light_first)
    coloured = rgb_to_hsv(ref)[..., 1] > 0.3
    assert coloured.sum() > 500
    ratio = lab_chroma(lit[coloured]) / lab_chroma(ref[coloured])
    assert np.percentile(ratio, 10) > 0.7, np.percentile(ratio, [2, 10, 50])
    assert np.median(ratio) > 0.8
    saturation = rgb_to_hsv(lit[coloured])[:, 1], rgb_to_hsv(ref[coloured])[:, 1]
    assert abs(np.median(saturation[0]) - np.median(saturation[1])) < 0.05
    assert lit[coloured].max(axis=-1).mean() < 0.98  # not washed out to white
    # the relief still shows in the colours: the lit/unlit brightness varies
    brightness = lit[coloured].max(axis=-1) / np.maximum(ref[coloured].max(axis=-1), 1e-6)
    assert np.std(brightness) > 0.03


def test_plain_skin_keeps_the_full_raking_relief_and_the_light_comes_off(surprise):
    p = pv.Plotter(off_screen=True, window_size=SIZE)
    try:
        add_raking_light(p)
        plain = add_skin(p, surprise, None)
        assert (plain.prop.ambient, plain.prop.diffuse) == (0.0, 1.0)
        coloured = add_skin(p, surprise, "W", name="coloured")
        assert coloured.prop.ambient > 0.3 and coloured.prop.diffuse < 1.0
        remove_raking_light(p)  # the light kit and the plain material again
        assert (coloured.prop.ambient, coloured.prop.diffuse) == (0.0, 1.0)
        assert len(p.renderer.lights) > 2  # the light kit's
    finally:
        p.close()
