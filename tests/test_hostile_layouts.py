"""Hostile layouts, landmarks and parameters get one-line errors naming where (issue 33:
M1, M2, M5, M9, L2, L3, L7).
"""

import json
import warnings

import numpy as np
import pytest

import wrinkle_vis as wv
from wrinkle_vis.core.expressions import Expression
from wrinkle_vis.core.layout import LayoutError, load_layout
from wrinkle_vis.datasets import BUILTIN_LAYOUT, read_landmarks

BIG = 10**400  # beyond 1.8e308: float() of it overflows
KW = {"radius": 10.0, "max_angle_deg": 30.0}


def _layout() -> dict:
    return json.loads(BUILTIN_LAYOUT.read_text())


def _muscle(data: dict, name: str) -> tuple[int, dict]:
    return next((i, m) for i, m in enumerate(data["muscles"]) if m["name"] == name)


def _write(tmp_path, data, name="l.json") -> str:
    path = tmp_path / name
    path.write_text(json.dumps(data))
    return path


def _one_line_error(path, where: str) -> str:
    with pytest.raises(LayoutError) as info:
        load_layout(path)
    message = str(info.value)
    assert "\n" not in message and str(path) in message and where in message, message
    return message


HUGE = [("corrugator_L", "k0", BIG), ("corrugator_L", "k0", -BIG), ("corrugator_L", "alpha", BIG),
        ("corrugator_L", "n_wrinkles", BIG), ("corrugator_L", "radius", BIG),
        ("frontalis_major_L", "width", BIG), ("orbicularis_oculi_L", "sector_deg", BIG),
        ("orbicularis_oculi_L", "end_b", [BIG, 0, 0]),
        ("corrugator_L", "attachment", [0, BIG, 0]), ("corrugator_L", "strength", BIG)]


@pytest.mark.parametrize(("muscle", "key", "value"), HUGE,
                         ids=[f"{m}.{k}{'-' if '-' in str(v)[:3] else ''}" for m, k, v in HUGE])
def test_integers_beyond_float_range_in_muscles_are_one_line_errors(tmp_path, muscle, key,
                                                                   value):
    data = _layout()
    i, m = _muscle(data, muscle)
    m[key] = value
    _one_line_error(_write(tmp_path, data), f"$.muscles[{i}].{key}")


@pytest.mark.parametrize("key", ["onset_s", "hold_s", "release_s"])
def test_integers_beyond_float_range_in_expressions_are_one_line_errors(tmp_path, key):
    data = _layout()
    data["expressions"]["frown"][key] = BIG
    _one_line_error(_write(tmp_path, data), "$.expressions.frown")


def test_landmarks_beyond_float_range_are_one_line_errors(tmp_path):
    data = _layout()
    data["landmarks"]["nasion"] = [0, BIG, 0]
    _one_line_error(_write(tmp_path, data), "$.landmarks.nasion")
    path = _write(tmp_path, {"nasion": [0, BIG, 0]}, "marks.json")
    with pytest.raises(ValueError, match="landmark 'nasion': expected .* finite"):
        read_landmarks(path)


def test_an_integer_of_over_4300_digits_names_its_line_and_column(tmp_path):
    text = json.dumps(_layout(), indent=1).replace('"k0": 6.0', '"k0": ' + "7" * 5000, 1)
    assert "7" * 5000 in text
    path = tmp_path / "l.json"
    path.write_text(text)
    line = text[:text.index("7" * 5000)].count("\n") + 1
    message = _one_line_error(path, f"line {line} column ")
    assert "at most 4300 digits" in message and "5000 digits" in message
    assert "set_int_max_str_digits" not in message
    (tmp_path / "m.json").write_text('{"nasion": [' + "1" * 5000 + ", 0, 0]}")
    with pytest.raises(ValueError, match="line 1 column 13: expected a number of at most"):
        read_landmarks(tmp_path / "m.json")


def test_durations_adding_to_infinity_are_refused():
    """1e308 each is finite, their sum is not: frame counts then crashed (int(inf))."""
    with pytest.raises(ValueError, match=r"onset_s = 1e\+308 must be in \[0, 3.2e\+07\]"):
        Expression("x", {}, onset_s=1e308, hold_s=1e308, release_s=1e308)
    assert Expression("x", {}, hold_s=3.2e7).duration_s == 3.2e7 + 2


def test_durations_adding_to_infinity_in_the_cli_are_one_line(tmp_path, capsys):
    from wrinkle_vis.cli import main

    data = _layout()
    data["expressions"]["frown"].update(onset_s=1e308, hold_s=1e308, release_s=1e308)
    path = _write(tmp_path, data)
    assert main(["export", "--sequence", "--layout", str(path), "-e", "frown", "--fps", "1",
                 "-o", str(tmp_path / "r.pvd")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "$.expressions.frown" in err and "Traceback" not in err


@pytest.mark.parametrize("name", ["corr\nugator", "corr\x1b[31mugator", "corr\x00ugator",
                                  "corr\u200bugator", "corr\x7fugator"])
def test_control_characters_in_muscle_names_are_refused(tmp_path, name):
    data = _layout()
    i, m = _muscle(data, "corrugator_R")
    m["name"] = name
    message = _one_line_error(_write(tmp_path, data), f"$.muscles[{i}].name")
    assert "control character U+" in message
    assert not any(ch in message for ch in "\x1b\x00\u200b\x7f")  # shown escaped


def test_control_characters_in_expression_names_are_refused(tmp_path):
    data = _layout()
    data["expressions"]["bad\x1b[2J"] = data["expressions"].pop("frown")
    _one_line_error(_write(tmp_path, data), "expected a name without control characters")


def test_control_characters_in_the_layouts_name_are_refused(tmp_path):
    """``summary`` printed the face's name raw: escape sequences reached the terminal."""
    data = _layout()
    data["name"] = "evil\x1b[31mred"
    message = _one_line_error(_write(tmp_path, data), "$.name: expected a string without "
                                                      "control characters")
    assert "\x1b" not in message


def test_unicode_muscle_names_are_accepted(tmp_path):
    data = _layout()
    _, m = _muscle(data, "corrugator_R")
    m["name"] = "procérus_鼻根筋"
    for item in data["expressions"].values():
        acts = item["activations"]
        if "corrugator_R" in acts:
            acts["procérus_鼻根筋"] = acts.pop("corrugator_R")
    for item in data.get("mapping", {}).values():  # the AU mapping names muscles too
        if "corrugator_R" in item["muscles"]:
            item["muscles"]["procérus_鼻根筋"] = item["muscles"].pop("corrugator_R")
    assert "procérus_鼻根筋" in [m.name for m in load_layout(_write(tmp_path, data)).muscles]


def test_a_key_twice_in_an_object_is_refused_with_its_json_path(tmp_path):
    text = json.dumps(_layout(), indent=1)
    path = tmp_path / "l.json"
    path.write_text(text.replace('"name": "corrugator_L",',
                                 '"name": "corrugator_L", "k0": 9.0,', 1))
    i, _ = _muscle(_layout(), "corrugator_L")
    _one_line_error(path, f"$.muscles[{i}].k0: expected each key once")
    path.write_text(text.replace('"format"', '"name": "x", "format"', 1))
    _one_line_error(path, "$.name: expected each key once")


def test_a_utf8_byte_order_mark_is_accepted(tmp_path):
    path = tmp_path / "l.json"
    path.write_bytes(b"\xef\xbb\xbf" + json.dumps(_layout()).encode())
    assert load_layout(path) == load_layout(BUILTIN_LAYOUT)
    marks = tmp_path / "m.json"
    marks.write_bytes(b"\xef\xbb\xbf" + json.dumps(_layout()["landmarks"]).encode())
    assert read_landmarks(marks) == {k: tuple(v) for k, v in _layout()["landmarks"].items()}


def test_landmarks_nested_100000_deep_are_one_line(tmp_path, capsys):
    from wrinkle_vis.cli import main

    path = tmp_path / "m.json"
    path.write_text("[" * 100_000)
    with pytest.raises(ValueError, match="nested at most"):
        read_landmarks(path)
    assert main(["summary", "--skin", str(tmp_path / "m.json"), "--landmarks",
                 str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_refine_levels_must_be_a_whole_number(wv_face):
    for bad in (2.7, "2", True, -1):
        with pytest.raises(ValueError, match="refine_levels = .* must be a whole number"):
            wv_face.evaluate("surprise", refine=True, refine_levels=bad)


def test_an_attachment_at_1e200_is_refused_without_a_warning():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(wv.MuscleParameterError, match=r"attachment = .* coordinates "
                                                          r"within \+-1e\+12") as info:
            wv.LinearMuscle("m", (1e200, 0.0, 0.0), (0.0, 0.0, 1.0), **KW)
    assert info.value.param == "attachment"
    wv.LinearMuscle("m", (1e9, 0.0, 0.0), (1e9, 0.0, 1.0), **KW)  # far, finite: fine


def test_bools_and_huge_counts_are_refused():
    with pytest.raises(wv.MuscleParameterError, match="k0 = True"):
        wv.LinearMuscle("m", (0, 0, 0), (0, 0, 1), **KW, k0=True)
    with pytest.raises(wv.MuscleParameterError, match="n_wrinkles = an integer of about 401"):
        wv.LinearMuscle("m", (0, 0, 0), (0, 0, 1), **KW, n_wrinkles=BIG)
    np.testing.assert_equal(wv.LinearMuscle("m", (0, 0, 0), (0, 0, 1), **KW,
                                            n_wrinkles=10**9).n_wrinkles, 10**9)


def test_an_unknown_type_says_what_was_expected(tmp_path):
    data = _layout()
    data["muscles"][0]["type"] = "evil"
    message = _one_line_error(_write(tmp_path, data), "$.muscles[0].type: expected a muscle "
                                                      "type that is installed (installed "
                                                      "types: linear, ")
    assert message.endswith('found "evil"') and "expected unknown" not in message


@pytest.mark.parametrize(("param", "value"), [("max_angle_deg", 1e-320), ("radius", 1e-300),
                                              ("max_angle_deg", 1e-10)])
def test_values_next_to_an_open_zero_are_refused(param, value):
    """Found by the fuzz test: 1e-320 degrees passed (0, 180] and overflowed a division."""
    with pytest.raises(wv.MuscleParameterError, match=f"{param} = .*at least 1e-09"):
        wv.LinearMuscle("m", (0, 0, 0), (0, 0, 1), **{**KW, param: value})
