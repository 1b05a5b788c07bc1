"""The head's lips: the rest skin's lip sheets separated in the derivation
(datasets/lips.py), and what the built-in head's expressions add to the rest crossings."""

import numpy as np
import pytest

from wrinkle_vis.core.certificate import fold_report, intersecting_pairs
from wrinkle_vis.datasets.lips import facing_pairs, folded_pairs, separate_crossings


def _grid(n: int, z, flip: bool) -> tuple[np.ndarray, np.ndarray]:
    """A sheet over [0, 10]^2 at height ``z(x)``, ``n`` by ``n`` quads, normal +z (-z when
    ``flip``)."""
    u = np.linspace(0.0, 10.0, n + 1)
    x, y = np.meshgrid(u, u, indexing="ij")
    pts = np.column_stack([x.ravel(), y.ravel(), z(x.ravel())])
    i = np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]
    i = i.ravel()
    tri = np.vstack([np.column_stack([i, i + n + 1, i + 1]),
                     np.column_stack([i + 1, i + n + 1, i + n + 2])])
    return pts, (tri[:, ::-1] if flip else tri)


def _two_lips(tilt: float = 0.06):
    """A lower lip (normal up) and an upper lip (normal down) that dips through it for
    x < 5: they cross along x = 5."""
    lower, t1 = _grid(10, lambda x: 0.0 * x, flip=False)
    upper, t2 = _grid(10, lambda x: tilt * (x - 5.0) + 0.013, flip=True)
    return np.vstack([lower, upper]), np.vstack([t1, t2 + len(lower)])


def test_separate_crossings_moves_two_crossing_lips_apart_by_the_gap():
    pts, tri = _two_lips()
    assert len(intersecting_pairs(pts, tri)) > 0
    out = separate_crossings(pts, tri, np.ones(len(pts), bool), gap=0.5, float32=False)
    assert len(intersecting_pairs(out, tri)) == 0
    n = len(pts) // 2
    lower, upper = out[:n], out[n:]
    # the lower lip went down, the upper up, where they crossed; nothing moved sideways much
    assert lower[:, 2].min() < -0.1 and upper[:, 2].max() >= pts[n:, 2].max() - 1e-9
    assert np.abs(out[:, :2] - pts[:, :2]).max() < 0.1 * np.abs(out - pts).max()  # along normals
    # the sheets now stand apart where the upper one dipped under
    under = pts[n:, 0] < 4.0
    gap = upper[under, 2] - np.interp(upper[under, 0], lower[:: 11, 0], lower[:: 11, 2])
    assert gap.min() > 0.2  # (the pairs that crossed: 0.5 along the normal)
    # far from the crossing (x >= 8), the sheets are as they were
    far = pts[:, 0] >= 8.0
    np.testing.assert_array_equal(out[far], pts[far])


def test_separate_crossings_leaves_what_is_outside_the_region():
    pts, tri = _two_lips()
    region = pts[:, 1] < -1.0  # nowhere
    np.testing.assert_array_equal(separate_crossings(pts, tri, region, float32=False), pts)


def test_folded_pairs_finds_a_sheet_folded_back_around_a_vertex():
    # a fan of two triangles around vertex 0 folded flat onto each other (a mouth corner)
    pts = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0.1], [0, 1, 0.1]])
    tri = np.array([[0, 1, 2], [0, 4, 3]])
    assert folded_pairs(pts, tri, np.ones(5, bool)).tolist() == [[0, 1]]
    flat = np.array([[0, 1, 2], [0, 3, 4]])  # the same, facing the same way: not folded
    assert len(folded_pairs(pts, flat, np.ones(5, bool))) == 0


@pytest.fixture(scope="module")
def head(wv_head):
    return wv_head.with_skin_model(wv_head.skin_model)  # the session's caches (conftest)


def _mouth(head) -> np.ndarray:
    marks = head.landmarks
    return 0.5 * (np.asarray(marks["mouth_corner_L"]) + np.asarray(marks["mouth_corner_R"]))


def test_the_heads_lips_do_not_cross_at_rest(head):
    pairs = intersecting_pairs(head.skin.points, head.skin.triangles)
    centres = head.skin.points[head.skin.triangles[pairs.ravel()]].mean(axis=1)
    near_mouth = np.linalg.norm(centres - _mouth(head), axis=1) < 40.0
    assert not near_mouth.any()  # stop 35's head: 127 pairs at the lips
    assert len(pairs) == 0  # nor the eyelids and the ear since stop 37 (datasets/eyelids.py)


def test_facing_pairs_and_hold_open_a_narrow_slit():
    # two flat lips facing each other 0.3 apart, not crossing: held 0.8 apart when asked
    lower, t1 = _grid(6, lambda x: 0.0 * x, flip=False)
    upper, t2 = _grid(6, lambda x: 0.0 * x + 0.3, flip=True)
    pts, tri = np.vstack([lower, upper]), np.vstack([t1, t2 + len(lower)])
    everywhere = np.ones(len(pts), bool)
    slit = facing_pairs(pts, tri, everywhere, 0.5)
    assert len(slit) > 0 and np.all((slit[:, 0] < len(t1)) != (slit[:, 1] < len(t1)))
    assert len(facing_pairs(pts, tri, everywhere, 0.2)) == 0  # farther apart than that
    same = np.vstack([t1, t2[:, ::-1] + len(lower)])  # both facing up: not lips
    assert len(facing_pairs(pts, same, everywhere, 0.5)) == 0
    assert separate_crossings(pts, tri, everywhere, float32=False) is not pts
    np.testing.assert_array_equal(separate_crossings(pts, tri, everywhere, float32=False), pts)
    out = separate_crossings(pts, tri, everywhere, gap=0.8, hold=slit, float32=False)
    n = len(lower)
    assert (out[n:, 2] - out[:n, 2]).min() > 0.95 * 0.8 - 1e-9


@pytest.mark.slow
@pytest.mark.parametrize("name", ("smile", "pucker"))
def test_the_heads_refined_smile_and_pucker_add_no_crossing(head, name):
    # main's head: 995 and 1,269 added pairs on 712 and 1,157 at rest (the refined slit)
    s = head.evaluate(name, 1.0, refine=True)
    rest = intersecting_pairs(s.rest_points, s.triangles)
    assert len(rest) == 0  # the refined lips (and eyelids) cross nowhere
    assert fold_report(s.rest_points, s.points, s.triangles, rest).ok
