"""The sphincter's placement widget: three skin handles, the ellipse and the wrinkling
region drawn in the ellipse's plane, a dragged centre that stays on the skin.
"""

import numpy as np
import pytest
from test_widgets import _display, _select, drag, showing, views  # noqa: F401 (a fixture)

import wrinkle_vis as wv
from wrinkle_vis.app.session import Session
from wrinkle_vis.core.mesh import closest_points
from wrinkle_vis.widgets import handles_for, widget_factory
from wrinkle_vis.widgets.sphincter import SphincterWidget, sphincter_glyph, sphincter_outline


def test_the_type_declares_its_widget_and_three_skin_handles(wv_face):
    m = wv_face.muscle("orbicularis_oculi_L")
    assert widget_factory(type(m)) is SphincterWidget
    assert [(h.param, h.layer) for h in handles_for(m)] == [
        ("center", "skin"), ("end_a", "skin"), ("end_b", "skin")]


@pytest.mark.parametrize("name", ["orbicularis_oculi_L", "orbicularis_oris"])
def test_outline_lies_on_the_ellipse_and_the_band(wv_face, name):
    m = wv_face.muscle(name)
    shapes = sphincter_outline(m)
    r = m.region(shapes["aoi_ellipse"].points)
    np.testing.assert_allclose(r.lam, 1.0, atol=1e-9)
    np.testing.assert_allclose(r["depth"], 0.0, atol=1e-9)  # in the ellipse's plane
    band = m.region(shapes["region_band"].points)
    assert np.all((band.lam > m.lambda_w - 1e-9) & (band.lam < 1 + 1e-9))
    assert np.all(np.abs(band.angle_deg) <= m.sector_deg + 1e-9)
    if m.sector_deg < 180:  # both ellipses and both rays of the sector
        assert np.isclose(band.lam, m.lambda_w).any() and np.isclose(band.lam, 1.0).any()
        assert np.isclose(np.abs(band.angle_deg), m.sector_deg).sum() >= 4
    glyph = m.region(sphincter_glyph(m).points)
    assert np.abs(glyph.lam - 0.5 * (1 + m.lambda_w)).max() < 0.1  # a tube along the band


def test_dragging_the_centre_moves_the_ellipse_on_the_skin(wv_face, views):  # noqa: F811
    name = "orbicularis_oculi_L"
    session = Session(wv_face)
    session.set_expression("squint")
    moves = []

    def on_move(handle, point, finished):
        moves.append((handle, point, finished))
        session.set_face(session.face.with_muscle(wv.core.editing.with_point(
            session.face.muscle(name), handle.param, handle.index, point)))
        views.draw(session.state(), showing(session), session.face)

    views.on_move = on_move
    widget = _select(views, session, name)
    assert {"widget:aoi_ellipse", "widget:region_band", "widget:aoi",
            "widget:region"} <= set(views.muscle_view.actors)
    handle = next(h for h in widget.handles(widget.muscle) if h.param == "center")
    before = session.face.muscle(name)
    start = _display(views.skin_view, widget.position(handle))
    drag(views.skin_view, start, start + (8, 6))
    assert moves and moves[-1][2]
    after = session.face.muscle(name)
    p = np.asarray(after.center)
    assert np.linalg.norm(p - np.asarray(before.center)) > 1.0
    assert np.linalg.norm(closest_points(wv_face.skin, p[None])[0] - p) < 1e-6
    assert after.end_a == before.end_a and after.end_b == before.end_b


@pytest.mark.parametrize("expression", ["squint", "pucker"])
def test_sphincter_total_w(verify_image_cache, wv_face, wv_plotter, expression):
    """W on the refined paper-size face, from the front: squint, the fans of crow's feet at
    the outer corners of the eyes; pucker, the lip lines radiating around the mouth
    (tests/image_cache, looked at).
    """
    from wrinkle_vis.plotting import add_skin, set_camera

    add_skin(wv_plotter, wv_face.evaluate(expression, refine=True), "W")
    set_camera(wv_plotter, "front", wv_face)
    wv_plotter.camera.zoom(1.8)
    wv_plotter.camera.focal_point = (0.0, -25.0, 80.0) if expression == "pucker" else (
        0.0, 0.0, 80.0)
    wv_plotter.show()
