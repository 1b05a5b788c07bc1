"""The certificate's exact predicates on subnormal inputs (docs/model.md, "The fans"; the
false positive hypothesis found at stop 39: a book jittered by 5e-324 crossed itself).

Products of subnormal differences underflow: they round to a multiple of 2^-1074, not to
a relative error, so Shewchuk's static bound (relative) does not cover them, and a
nonzero determinant read as zero with a zero bound was taken as certain.
"""
from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from wrinkle_vis.core.certificate import (
    _exact_orient,
    _exact_orient2,
    _side,
    intersecting_pairs,
    orient,
    orient2,
)

T = 5e-324  # the smallest subnormal, 2^-1074


def test_orient_sees_a_determinant_of_underflowing_products():
    """o = (0, 0, 1) . ((t, 0, 0) x (0, t, 0)) = t^2 > 0, whose product rounds to 0."""
    a, b, c, d = (np.array([p], float) for p in ([0, 0, 1], [T, 0, 0], [0, T, 0], [0, 0, 0]))
    assert orient(a, b, c, d).tolist() == [1]
    assert orient(a, c, b, d).tolist() == [-1]


def test_orient2_sees_a_determinant_of_underflowing_products():
    a, b, c = (np.array([p], float) for p in ([T, 0], [0, 3 * T], [0, 0]))
    assert orient2(a, b, c).tolist() == [1]
    assert orient2(b, a, c).tolist() == [-1]


def test_a_plane_side_of_underflowing_products_is_exact():
    """A point over the plane of a triangle whose normal (products of subnormals) rounds
    to zero: the side is +1, not 0."""
    corners = np.array([[[0, 0, 0], [2 * T, 0, 0], [0, 2 * T, 0]]], float)
    normal = np.zeros((1, 3))  # (2t, 0, 0) x (0, 2t, 0) = (0, 0, 4t^2): rounds to 0
    p = np.array([[0.0, 0.0, 1.0]])
    side = _side(p, corners[:, 0], normal, np.abs(normal), corners, np.array([0]))
    assert side.tolist() == [1]


coordinate = st.one_of(st.integers(-3, 3).map(lambda k: k * T),
                       st.sampled_from([0.0, 1.0, -1.0, 0.5, 2.0 ** -1022, 1e-300, 1e-160]))
point = st.tuples(coordinate, coordinate, coordinate)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(point, point, point, point), min_size=1, max_size=8))
def test_orient_equals_rational_arithmetic_on_tiny_and_subnormal_points(rows):
    a, b, c, d = (np.array([r[i] for r in rows], float) for i in range(4))
    want = [_exact_orient(*r) for r in rows]
    assert orient(a, b, c, d).tolist() == want


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(point, point, point), min_size=1, max_size=8))
def test_orient2_equals_rational_arithmetic_on_tiny_and_subnormal_points(rows):
    a, b, c = (np.array([r[i][:2] for r in rows], float) for i in range(3))
    want = [_exact_orient2(*(p[:2] for p in r)) for r in rows]
    assert orient2(a, b, c).tolist() == want


def lattice_sheet(n: int = 6) -> tuple[np.ndarray, np.ndarray]:
    """``(n*n, 3)`` points and triangles of a flat unit grid, bent up along its middle."""
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    z = np.maximum(i - n // 2, 0).astype(float)
    pts = np.stack([i.ravel(), j.ravel(), z.ravel()], axis=1).astype(float)
    v = (i * n + j)[:-1, :-1].ravel()
    tri = np.concatenate([np.stack([v, v + n, v + n + 1], 1), np.stack([v, v + n + 1, v + 1], 1)])
    return pts, tri


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**16), scale=st.sampled_from([1.0, 2.0 ** -540, 2.0 ** -1000]))
def test_a_subnormal_jitter_adds_no_crossing_to_a_sheet(seed, scale):
    """A bent sheet crosses nowhere; jittered by the smallest subnormals, and scaled down
    so that its own products underflow, it still crosses nowhere (every pair of it is
    apart by much more than the jitter)."""
    pts, tri = lattice_sheet()
    assert len(intersecting_pairs(pts, tri)) == 0
    rng = np.random.default_rng(seed)
    p = pts * scale + rng.integers(-2, 3, pts.shape) * T
    assert len(intersecting_pairs(p, tri)) == 0
