import json
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import wrinkle_vis as wv
from wrinkle_vis.datasets import BUILTIN_LAYOUT, builtin_layout

coord = st.floats(-100, 100, allow_nan=False)
point = st.tuples(coord, coord, coord)


@st.composite
def linear_muscles(draw, name):
    a = np.array(draw(point))
    direction = np.array(draw(st.tuples(coord, coord, coord)))
    if np.linalg.norm(direction) < 1e-3:
        direction = np.array([1.0, 0, 0])
    length = draw(st.floats(1, 50))
    i = a + length * direction / np.linalg.norm(direction)
    return wv.LinearMuscle(name, a, i, radius=length * draw(st.floats(1.05, 3)),
                           max_angle_deg=draw(st.floats(1, 90)),
                           lambda_w=draw(st.floats(0, 0.95)), n_wrinkles=draw(st.integers(1, 9)),
                           k0=draw(st.floats(0, 5)), alpha=draw(st.floats(-1, 10)))


@st.composite
def sheet_muscles(draw, name):
    x0, y0, w = draw(coord), draw(coord), draw(st.floats(1, 40))
    length = draw(st.floats(1, 60))
    return wv.SheetMuscle(name, ((x0, y0, 0), (x0 + w, y0, 0)),
                          ((x0, y0 + length, 1), (x0 + w, y0 + length, 1)),
                          lambda_w=draw(st.floats(0, 0.95)), n_wrinkles=draw(st.integers(1, 9)),
                          k0=draw(st.floats(0, 5)), depth=draw(st.none() | st.floats(1, 30)))


@st.composite
def layouts(draw):
    n = draw(st.integers(0, 4))
    muscles = [draw(st.one_of(linear_muscles(f"m{i}"), sheet_muscles(f"m{i}"))) for i in range(n)]
    names = [m.name for m in muscles]
    expressions = {}
    for k in range(draw(st.integers(0, 3))):
        acts = {m: draw(st.floats(0, 1)) for m in names if draw(st.booleans())}
        expressions[f"e{k}"] = wv.Expression(f"e{k}", acts, onset_s=draw(st.floats(0, 3)))
    landmarks = {f"l{k}": draw(point) for k in range(draw(st.integers(0, 3)))}
    names = st.text(st.characters(blacklist_categories=("Cc", "Cf", "Cs")), max_size=12)
    return wv.Layout(name=draw(names), muscles=muscles, expressions=expressions,
                     skin=draw(st.none() | st.just("skin.obj")), landmarks=landmarks)


@given(layout=layouts())
@settings(max_examples=40, suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_layout_round_trips_through_a_file(layout, tmp_path):
    path = tmp_path / "layout.json"
    wv.save_layout(layout, path)
    again = wv.load_layout(path)
    assert again == layout
    assert again.muscles == layout.muscles


def test_builtin_layout_file_matches_the_code():
    shipped = wv.load_layout(BUILTIN_LAYOUT)
    code = builtin_layout()
    assert [m.name for m in shipped.muscles] == [m.name for m in code.muscles]
    for a, b in zip(shipped.muscles, code.muscles, strict=True):
        for p in a.point_parameters:
            np.testing.assert_allclose(getattr(a, p), getattr(b, p), atol=1e-9)
    assert shipped.expressions == code.expressions
    assert set(shipped.landmarks) == set(code.landmarks)


def test_save_is_atomic_when_the_write_fails(tmp_path, monkeypatch):
    path = tmp_path / "layout.json"
    good = wv.Layout(name="good")
    wv.save_layout(good, path)
    before = path.read_text()

    def crash(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", crash)
    with pytest.raises(OSError, match="disk full"):
        wv.save_layout(wv.Layout(name="new"), path)
    assert path.read_text() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["layout.json"]  # no temp left


def _write(tmp_path, data):
    path = tmp_path / "bad.json"
    path.write_text(data if isinstance(data, str) else json.dumps(data))
    return path


GOOD = {"format": "wrinkle-vis-layout", "version": 1, "name": "x",
        "muscles": [{"type": "linear", "name": "m", "attachment": [0, 0, 0],
                     "insertion": [10, 0, 0], "radius": 20.0, "max_angle_deg": 30.0}],
        "expressions": {"e": {"activations": {"m": 0.5}}}}


def _bad(**changes):
    data = json.loads(json.dumps(GOOD))
    for path, value in changes.items():
        target = data
        keys = path.split("/")
        for k in keys[:-1]:
            target = target[int(k)] if isinstance(target, list) else target[k]
        target[keys[-1]] = value
    return data


@pytest.mark.parametrize(
    ("data", "json_path", "expected"),
    [
        ("{not json", "line 1 column 2", "valid JSON"),
        ([1, 2], "$", "a JSON object"),
        (_bad(format="other"), "$.format", "'wrinkle-vis-layout'"),
        (_bad(version=2), "$.version", "1 (this wrinkle-vis reads version 1)"),
        (_bad(colour="red"), "$.colour", "one of"),
        (_bad(muscles={"a": 1}), "$.muscles", "a list of muscles"),
        (_bad(**{"muscles/0/type": "spiral"}), "$.muscles[0].type", "installed types"),
        (_bad(**{"muscles/0/radius": -3}), "$.muscles[0].radius",
         "radius (R, the maximal radius of influence) in (0, inf)"),  # the type's metadata
        (_bad(**{"muscles/0/insertion": [0, 0, 0]}), "$.muscles[0].insertion",
         "insertion (the end in the skin, within the radius of the attachment): [x, y, z] on "
         "the skin"),
        (_bad(**{"muscles/0/fall_start": -1}), "$.muscles[0].fall_start",
         "fall_start (R_s, Waters' fall start, where the displacement peaks) in (0, inf) or "
         "null (derived)"),
        (_bad(**{"muscles/0/colour": 1}), "$.muscles[0]", "valid muscle parameters"),
        (_bad(**{"expressions/e/activations": {"nope": 1}}), "$.expressions.e.activations.nope",
         "the name of a muscle"),
        (_bad(**{"expressions/e/activations": {"m": 3}}), "$.expressions.e.activations.m",
         "a number in [0, 1]"),
        (_bad(skin=5), "$.skin", "a mesh path or null"),
        (_bad(landmarks={"nose_tip": [0, "a", 1]}), "$.landmarks.nose_tip", "[x, y, z]"),
    ],
)
def test_malformed_layouts_name_file_path_expected_and_found(tmp_path, data, json_path, expected):
    path = _write(tmp_path, data)
    with pytest.raises(wv.LayoutError) as info:
        wv.load_layout(path)
    err = info.value
    assert err.source == str(path) and err.path == json_path
    assert expected in err.expected
    assert str(path) in str(err) and json_path in str(err) and "found" in str(err)


def test_unknown_muscle_type_names_the_installed_types(tmp_path):
    path = _write(tmp_path, _bad(**{"muscles/0/type": "spiral"}))
    with pytest.raises(wv.LayoutError, match="linear.*ring.*sheet"):
        wv.load_layout(path)


def test_missing_layout_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="no layout file at"):
        wv.load_layout(tmp_path / "nope.json")


def test_good_layout_loads(tmp_path):
    lay = wv.load_layout(_write(tmp_path, GOOD))
    assert lay.muscles[0].radius == 20.0 and lay.expressions["e"].activations == {"m": 0.5}
