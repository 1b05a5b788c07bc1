"""A warning when a muscle's wrinkles are finer than the mesh can show (u below an edge)."""

import warnings

import numpy as np
import pytest
from meshes import grid

import wrinkle_vis as wv
from wrinkle_vis.core.sampling import (
    UndersampledWrinklesWarning,
    undersampled_muscles,
    warn_undersampled,
)


def _face(n_wrinkles):
    skin = grid(21, 21, 80.0, bump=5.0)  # edges 4 mm (and 5.7 mm diagonals)
    lin = wv.LinearMuscle("lin", (-25, 0, -3), (5, 0, 1), radius=40, max_angle_deg=30,
                          lambda_w=0.5, n_wrinkles=n_wrinkles)
    return wv.FaceModel(skin, None, [lin])


@pytest.mark.parametrize(("n_wrinkles", "warned"), [(1, False), (2, False), (3, True),
                                                    (50, True)])
def test_a_half_period_below_the_median_edge_warns(n_wrinkles, warned):
    face = _face(n_wrinkles)  # u = 0.5 * 40 / (2 n_w) = 10 / n_w
    edge = float(np.median(face.skin.rest_edge_lengths))
    assert 4.0 < edge < 5.0
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        found = warn_undersampled(face.skin, face.muscles)
    assert [w.category for w in caught] == ([UndersampledWrinklesWarning] if warned else [])
    assert [f.muscle for f in found] == (["lin"] if warned else [])
    if warned:
        text = str(caught[0].message)
        assert f"muscle 'lin': wrinkle half period u = {10 / n_wrinkles:.3g}" in text
        assert f"median edge length {edge:.3g}" in text and "refine the skin" in text
        assert "lower n_w to 2" in text  # u = 5 >= edge at n_w = 2


def test_the_way_out_is_computed():
    face = _face(50)
    (item,) = undersampled_muscles(face.skin, face.muscles)
    assert item.u == pytest.approx(0.2) and item.max_n_wrinkles == 2
    # about n (edge / u)^2 triangles bring the median edge down to u
    assert item.n_triangles >= face.skin.n_triangles * (item.edge_length / item.u) ** 2


def test_the_warning_is_an_error_where_warnings_are(recwarn):
    face = _face(50)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UndersampledWrinklesWarning)
        with pytest.raises(UndersampledWrinklesWarning, match="'lin'"):
            warn_undersampled(face.skin, face.muscles)


def test_the_sessions_note_names_the_frames_aliased_muscles(wv_face):
    from wrinkle_vis.app.session import Session

    session = Session(wv_face)
    session.set_expression("frown")
    note = session.undersampled_note()  # the session's own frame
    assert note.startswith("muscles 'corrugator_L', 'corrugator_R': wrinkle half period")
    session.set_expression("surprise")
    assert session.undersampled_note() is None
    session.set_expression("frown")
    session.set_refine(True)  # refinement resolves them
    assert session.undersampled_note() is None
