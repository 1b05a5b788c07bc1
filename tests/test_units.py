"""A face knows its unit: from its layout, set, or guessed from its size with a warning."""

import numpy as np
import pytest

import wrinkle_vis as wv
from wrinkle_vis.core.units import UnitWarning, check_unit, face_unit, guess_unit


@pytest.mark.parametrize("height, unit", [(0.42, "m"), (0.25, "m"), (24.0, "cm"),
                                          (42.0, "cm"), (230.0, "mm"), (420.0, "mm"),
                                          (1e5, None), (0.001, None), (float("nan"), None)])
def test_guess_unit(height, unit):
    assert guess_unit(height) == unit


def test_check_unit():
    assert check_unit("cm") == "cm"
    with pytest.raises(ValueError, match="unknown length unit .furlong.; use one of m, cm, mm"):
        check_unit("furlong")


def test_a_face_carries_its_unit_through_edits(wv_face):
    face = wv.FaceModel(wv_face.skin, wv_face.skull, wv_face.muscles, wv_face.expressions,
                        unit="cm")
    assert face.unit == "cm" and face_unit(face) == "cm"
    assert face.without_muscle(face.muscle_names[0]).unit == "cm"
    state = face.evaluate("surprise")
    assert face_unit(state) == "cm" and "W total (cm)" in state.summary()
    assert face.evaluate("surprise", refine=True).face.unit == "cm"
    assert wv_face.unit == "mm"  # the procedural face says so
    with pytest.raises(ValueError, match="unknown length unit"):
        wv.FaceModel(wv_face.skin, unit="parsec")


@pytest.mark.slow
def test_a_scan_in_metres_is_labelled_metres(wv_face):
    skin = wv_face.skin.with_points(wv_face.skin.points / 1000.0)
    with pytest.warns(UnitWarning, match="reads as m:"):
        face = wv.datasets.load_face(skin=skin)
    assert face.unit == "m"
    marks = {k: np.asarray(v) / 1000.0 for k, v in wv_face.landmarks.items()}
    placed = wv.datasets.load_face(skin=skin, landmarks=marks, unit="m")
    assert placed.unit == "m" and len(placed.muscles) == len(wv_face.muscles)
    assert "W total (m)" in placed.evaluate("surprise").summary()
