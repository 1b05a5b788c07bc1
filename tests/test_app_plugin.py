"""The ring plug-in gets its parameter panel and glyph with no change to the app (issue 16):
the panel reads the type's declared parameters, the muscles view its declared glyph.
"""

from __future__ import annotations

import numpy as np
import pytest

import wrinkle_vis as wv
from wrinkle_vis.app.session import Session, editable
from wrinkle_vis.plotting import glyph_factory

pytestmark = pytest.mark.usefixtures("no_leaked_plotters")


@pytest.fixture
def ring_window(make_window, wv_face):
    ring_type = wv.get_muscle_type("ring")
    ring = ring_type.create("orbicularis_ring", (35.0, 0.0, 100.0), wv_face.skin, wv_face.skull)
    session = Session(wv_face.with_muscle(ring))
    session.set_activation("orbicularis_ring", 1.0)
    window = make_window(session)
    window.select_muscle("orbicularis_ring")
    return window


def test_the_panel_shows_every_number_the_plugin_declares(ring_window):
    w = ring_window
    ring = w.session.face.muscle("orbicularis_ring")
    want = [p.name for p in type(ring).parameters() if p.is_number]
    assert want == ["radius", "depth", "lambda_w", "n_wrinkles", "k0", "alpha", "strength"]
    assert list(w.param_widgets) == want == [p.name for p in editable(ring)]
    labels = [w.param_form.itemAt(i, w.param_form.ItemRole.LabelRole).widget().text()
              for i in range(len(want))]
    assert labels == ["radius", "depth", "λ_w", "n_w", "k₀", "α", "K"]  # the panel shows symbols
    for name, box in w.param_widgets.items():
        assert box.value() == pytest.approx(getattr(ring, name), abs=1e-3)
    assert w.param_widgets["radius"].singleStep() == 1.0
    assert "half thickness along the axis" in w.param_widgets["depth"].toolTip()
    assert "(mm)" in w.param_widgets["depth"].toolTip()


def test_the_plugins_parameters_are_edited_checked_and_undone(ring_window):
    w = ring_window
    assert w.set_parameter("radius", 18.0)
    assert w.session.face.muscle("orbicularis_ring").radius == 18.0
    assert w.set_parameter("n_wrinkles", 3)
    assert w.session.face.muscle("orbicularis_ring").n_wrinkles == 3
    assert not w.set_parameter("depth", -1.0)  # its declared range (0, inf)
    assert "depth = -1 is invalid; allowed: (0, inf)" in w.param_error.text()
    assert w.param_widgets["depth"].value() == 10.0  # put back
    assert not w.set_parameter("strength", 12.0)  # the plug-in's own check, below radius / 2
    assert "K = 12" in w.param_error.text()  # called by the panel's label
    w.undo_stack.undo()
    w.undo_stack.undo()
    assert w.session.face.muscle("orbicularis_ring").radius == 15.0
    assert w.param_widgets["radius"].value() == 15.0


def test_the_muscles_view_draws_the_plugins_glyph(ring_window):
    w = ring_window
    ring = w.session.face.muscle("orbicularis_ring")
    actor = w.muscle_view.actors["muscle:orbicularis_ring"]
    drawn = actor.mapper.dataset
    want = glyph_factory(type(ring))(ring)
    assert glyph_factory(type(ring)).__name__ == "ring_glyph"
    np.testing.assert_allclose(drawn.points, want.points)
    # a torus round the centre in the ring's plane, not a sphere
    axis = np.asarray(ring.axis) / np.linalg.norm(ring.axis)
    v = drawn.points - np.asarray(ring.center)
    radial = np.linalg.norm(v - (v @ axis)[:, None] * axis, axis=1)
    assert radial.min() > 15.0 * (1 - 1 / 12) - 0.05
    assert np.all(drawn.point_data["activation"] == 1.0)
