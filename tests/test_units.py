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


def _in_metres(face):
    """``face`` (millimetres) in metres: its meshes, muscle points and lengths / 1000."""
    muscles = []
    for m in face.muscles:
        data = m.to_dict()
        for p in m.parameters():
            if p.unit in ("length", "point") and data.get(p.name) is not None:
                data[p.name] = (np.asarray(data[p.name], float) / 1000.0).tolist()
        muscles.append(type(m).from_dict(data))
    return wv.FaceModel(face.skin.with_points(face.skin.points / 1000.0),
                        face.skull.with_points(face.skull.points / 1000.0), muscles,
                        face.expressions, unit="m")


def test_the_summary_of_a_face_in_metres_prints_its_values(wv_face):
    """Issue 32: every per-muscle range of a face in metres printed as [-0.000, +0.000]."""
    import re

    state = _in_metres(wv_face).evaluate("surprise")
    text = state.summary()
    line = next(x for x in text.splitlines() if x.strip().startswith("frontalis_major_L:"))
    low, high = (float(x) for x in re.search(r"W \[(\S+), (\S+)\]", line).groups())
    w = state.fields["frontalis_major_L"]["W"]
    w = w[np.isfinite(w)]
    assert w.min() < 0 < w.max() and max(-w.min(), w.max()) < 1e-2  # metres: small numbers
    assert low == pytest.approx(w.min(), rel=1e-3) and high == pytest.approx(w.max(), rel=1e-3)
    total = re.search(r"W total \(m\): min (\S+)\s+max (\S+)", text).groups()
    assert [float(x) for x in total] == pytest.approx([state.W.min(), state.W.max()], rel=1e-3)


@pytest.mark.parametrize("scale", [1e-3, 0.3, 0.6, 1.0, 1.9, 2.5, 6.5, 1e3])
def test_the_physical_skin_simulates_a_face_of_no_human_size_at_human_size(wv_face, scale):
    """A face keeps its unit on the physical skin where its landmarks are a human's in it
    (within a factor 2), else it is simulated at the built-in face's size."""
    from types import SimpleNamespace

    from wrinkle_vis.core.units import (
        HUMAN_LANDMARK_RADIUS_M,
        HUMAN_SIZE_FACTOR,
        landmark_radius,
        physical_metres_per_unit,
    )

    assert physical_metres_per_unit(wv_face) == 1e-3  # the built-in face: its millimetres
    assert landmark_radius(wv_face.landmarks) * 1e-3 == pytest.approx(HUMAN_LANDMARK_RADIUS_M,
                                                                      rel=0.01)
    marks = {k: scale * np.asarray(v) for k, v in wv_face.landmarks.items()}
    face = SimpleNamespace(unit="mm", landmarks=marks)
    s = physical_metres_per_unit(face)
    if 1 / HUMAN_SIZE_FACTOR <= scale * landmark_radius(wv_face.landmarks) * 1e-3 \
            / HUMAN_LANDMARK_RADIUS_M <= HUMAN_SIZE_FACTOR:
        assert s == 1e-3
    else:
        assert landmark_radius(marks) * s == pytest.approx(HUMAN_LANDMARK_RADIUS_M, rel=1e-12)
    assert physical_metres_per_unit(SimpleNamespace(unit="cm", landmarks=None)) == 0.01
