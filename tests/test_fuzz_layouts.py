"""Fuzzed layouts: each gives a one-line error or a valid, finite frame (issue 33).

The built-in layout with one value replaced by something hostile (huge and tiny numbers,
integers beyond any float, NaN, infinities, negatives, bools, strings with control
characters, nested lists and objects, null) must either be refused in one line, a
:class:`~wrinkle_vis.core.layout.LayoutError` or another ``ValueError`` naming the problem,
or make a face whose frames are finite everywhere.
"""

import json
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from wrinkle_vis.core.face import FaceModel
from wrinkle_vis.core.layout import load_layout
from wrinkle_vis.datasets import BUILTIN_LAYOUT

LAYOUT = json.loads(BUILTIN_LAYOUT.read_text())


def _leaves(value, path=()):
    """Every path to a value of ``value`` (objects by key, lists by index)."""
    yield path
    if isinstance(value, dict):
        for k, v in value.items():
            yield from _leaves(v, (*path, k))
    elif isinstance(value, list):
        for i, v in enumerate(value):
            yield from _leaves(v, (*path, i))


PATHS = [p for p in _leaves(LAYOUT) if p]

HOSTILE = st.one_of(
    st.sampled_from([10**400, -10**400, 10**20, 2**63, -1, 0, 1, 1e308, -1e308, 1e-320,
                     math.nan, math.inf, -math.inf, True, False, None, "", "many",
                     "a\x1b[31mb", "a\x00b", "é", [], {}, [[[[1.0]]]], {"x": {"y": [1]}},
                     [1e400, 0, 0], [0.0, 0.0], "1e3"]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-10**30, max_value=10**30),
    st.text(max_size=6),
)


def _replaced(path, value) -> dict:
    data = json.loads(json.dumps(LAYOUT))
    holder = data
    for key in path[:-1]:
        holder = holder[key]
    holder[path[-1]] = value
    return data


def _expression(face, path) -> str:
    """An expression that moves the mutated muscle if there is one, else ``frown``."""
    if path[0] == "muscles" and isinstance(path[1], int):
        name = LAYOUT["muscles"][path[1]]["name"]
        for key, ex in face.expressions.items():
            if any(m.startswith(name[:8]) for m in ex.activations):
                return key
    if path[0] == "expressions" and path[1] in face.expressions:
        return path[1]
    return "frown" if "frown" in face.expressions else next(iter(face.expressions))


def _one_line_error_or_finite_frame(skin, folder, path, value) -> None:
    file = folder / "fuzzed.json"
    file.write_text(json.dumps(_replaced(path, value)))
    try:
        layout = load_layout(file)
        face = FaceModel(skin, None, layout.muscles, layout.expressions)
    except ValueError as exc:  # LayoutError, MuscleParameterError, a face-level bound
        message = str(exc)
        assert message and "\n" not in message and "Traceback" not in message
        assert not any(c in message for c in "\x1b\x00"), message  # shown escaped
        return
    if not face.expressions:
        return
    state = face.evaluate(_expression(face, path))  # a RuntimeWarning fails the test too
    for what in (state.points, state.normals, state.W):
        assert np.isfinite(what).all(), f"{path} = {value!r}"


@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(path=st.sampled_from(PATHS), value=HOSTILE)
def test_a_fuzzed_layout_is_a_one_line_error_or_a_finite_frame(wv_face, tmp_path, path,
                                                               value):
    _one_line_error_or_finite_frame(wv_face.skin, tmp_path, path, value)


@pytest.mark.parametrize(("path", "value"), [
    (("muscles", 7, "k0"), 10**400), (("muscles", 7, "k0"), 1e300),
    (("muscles", 15, "end_b"), [1e400, 0, 0]), (("expressions", "frown", "hold_s"), 1e308),
    (("landmarks", "nasion", 0), 10**400), (("muscles", 7, "name"), "a\x1b[2Jb"),
])
def test_the_findings_of_the_fuzz_campaign(wv_face, tmp_path, path, value):
    """Values the campaign's fuzzer found (OverflowError tracebacks, NaN normals)."""
    _one_line_error_or_finite_frame(wv_face.skin, tmp_path, path, value)
