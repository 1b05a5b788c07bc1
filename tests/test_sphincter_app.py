"""The sphincter in the app with no change to the app (issue 16): its parameter panel from
the declared parameters, its edits checked and undone, its glyph in the muscles view.
"""

import numpy as np
import pytest

from wrinkle_vis.app.session import Session
from wrinkle_vis.plotting import glyph_factory

pytestmark = pytest.mark.usefixtures("no_leaked_plotters")

NAME = "orbicularis_oculi_L"


@pytest.fixture
def window(make_window, wv_face):
    session = Session(wv_face)
    session.set_expression("squint")
    w = make_window(session)
    w.select_muscle(NAME)
    return w


def test_the_panel_shows_the_sphincters_numbers(window):
    m = window.session.face.muscle(NAME)
    assert list(window.param_widgets) == [
        "depth", "sector_deg", "sector_center_deg", "attenuation_start_deg", "fall_start",
        "lambda_w", "n_wrinkles", "k0", "alpha", "strength"]
    for name, box in window.param_widgets.items():
        assert box.value() == pytest.approx(m.resolved(name), abs=1e-2), name


def test_edits_are_checked_and_undone(window):
    before = window.session.face.muscle(NAME)
    w_before = window.session.state().W.copy()
    assert window.set_parameter("sector_deg", 30.0)
    after = window.session.face.muscle(NAME)
    assert after.sector_deg == 30.0 and after.u < before.u  # a narrower fan, same n_w
    assert not np.array_equal(window.session.state().W, w_before)
    assert not window.set_parameter("attenuation_start_deg", 40.0)  # past Theta = 30
    assert "φ_c (deg) = 40 is invalid; allowed: [0, 30]" in window.param_error.text()
    window.undo_stack.undo()
    assert window.session.face.muscle(NAME) == before


def test_the_muscles_view_draws_the_ring_of_fibres(window):
    m = window.session.face.muscle(NAME)
    drawn = window.muscle_view.actors[f"muscle:{NAME}"].mapper.dataset
    assert glyph_factory(type(m)).__name__ == "sphincter_glyph"
    rho = m.region(drawn.points).lam
    assert abs(np.median(rho) - 0.5 * (1 + m.lambda_w)) < 0.02
