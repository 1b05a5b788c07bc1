"""Degenerate or inconsistent landmarks are refused in one line naming them (issue 33, M10)."""

import json

import numpy as np
import pytest

import wrinkle_vis as wv
from wrinkle_vis.datasets import builtin_landmarks
from wrinkle_vis.datasets.lee_perry_smith import LAYOUT

#: The Lee Perry-Smith head's landmarks (mm): a real scan's, fitted within 0.15.
SCAN = {k: tuple(v) for k, v in json.loads(LAYOUT.read_text())["landmarks"].items()}


def fit_landmarks(source: dict, target: dict):
    from wrinkle_vis.datasets.scans import fit_landmarks as fit

    return fit(source, target)


def _swapped(a: str, b: str) -> dict:
    out = dict(SCAN)
    out[a], out[b] = SCAN[b], SCAN[a]
    return out


def _mirrored() -> dict:
    swap = {"L": "R", "R": "L"}
    return {(k[:-1] + swap[k[-1]] if k[-2:] in ("_L", "_R") else k): v
            for k, v in SCAN.items()}


def test_real_landmarks_fit():
    rot, scale, _ = fit_landmarks(builtin_landmarks(), SCAN)
    assert np.linalg.det(rot) == pytest.approx(1.0) and 0.8 < scale < 1.3


@pytest.mark.parametrize(("marks", "message"), [
    ({k: (0.1, 0.2, 0.3) for k in SCAN}, "are all at one point"),
    ({k: (0.0, 0.01 * i, 0.0) for i, k in enumerate(SCAN)}, "lie on one line"),
    ({k: (0.01 * i, 0.02 * i, -0.005 * i) for i, k in enumerate(SCAN)}, "lie on one line"),
    (_mirrored(), "mirror image of the face's: _L and _R are swapped"),
    ({k: (-x, y, z) for k, (x, y, z) in SCAN.items()}, "mirror image"),
    (_swapped("nasion", "chin"), "the landmarks nasion (1.7"),
    (_swapped("eye_outer_L", "mouth_corner_L"), "the landmarks mouth_corner_L (1.3"),
])
def test_degenerate_landmarks_are_one_line_naming_them(marks, message):
    with pytest.raises(ValueError) as info:
        fit_landmarks(builtin_landmarks(), marks)
    text = str(info.value)
    assert message in text and "\n" not in text


def test_swapped_landmarks_name_only_the_swapped_ones():
    with pytest.raises(ValueError) as info:
        fit_landmarks(builtin_landmarks(), _swapped("eye_outer_L", "mouth_corner_L"))
    named = str(info.value).split(" lie far")[0]
    assert "eye_outer_L" in named and "mouth_corner_L" in named and "nasion" not in named


def test_a_scan_with_collinear_landmarks_is_refused_before_the_skull(wv_face, monkeypatch):
    """The finding: accepted after 144 s and 1 GB; now refused before any skull work."""
    import wrinkle_vis.datasets.skull as skull_module

    def no_skull(*args):
        raise AssertionError("the level-set skull's field was sampled")

    monkeypatch.setattr(skull_module, "sample_narrow_band", no_skull)
    marks = {k: (0.0, 10.0 * i, 0.0) for i, k in enumerate(SCAN)}
    with pytest.raises(ValueError, match="lie on one line"):
        wv.datasets.load_face(skin=wv_face.skin, landmarks=marks, unit="mm")
