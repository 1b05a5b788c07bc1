"""The pull guard's faster helpers (stop 39) give what the code they replace gave, bit for bit:
the skin's edges (one sort of keys), the vertex normals (sums without an incidence matrix),
the wrinkle step's rest normals (taken alone) and a refined frame's clamp limits."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

import wrinkle_vis as wv
from wrinkle_vis.core import foldguard
from wrinkle_vis.core.foldguard import (
    FoldGuard,
    _skin_edges,
    _triangles_of,
    _vertex_normals,
    pull_terms,
)


def _random_mesh(rng: np.random.Generator, n: int, m: int, offset: int = 0):
    """``n + offset`` points and ``m`` triangles on the last ``n`` of them, a few of them
    degenerate (a corner twice) and a few repeated."""
    tri = rng.integers(offset, offset + n, size=(m, 3))
    k = m // 10
    tri[:k, 1] = tri[:k, 0]  # degenerate: a corner twice
    tri[k: 2 * k] = tri[:k]  # repeated
    tri[2 * k: 3 * k, 2] = tri[2 * k: 3 * k, 1]
    points = rng.normal(size=(offset + n, 3))
    return points, tri


def _edges_reference(tri: np.ndarray) -> np.ndarray:
    """The edges as ``pull_terms`` found them before stop 39 (``np.unique`` of sorted rows)."""
    if not len(tri):
        return np.zeros((0, 2), np.intp)
    return np.unique(np.sort(np.vstack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]),
                             axis=1), axis=0)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31), n=st.integers(3, 60), m=st.integers(0, 80),
       wide=st.booleans())
def test_the_skins_edges_are_the_unique_sorted_edges(seed, n, m, wide):
    # wide: vertex ids past 46,341, where n**2 no longer fits the 32-bit keys
    rng = np.random.default_rng(seed)
    offset = 50_000 if wide else 0
    _, tri = _random_mesh(rng, n, m, offset)
    got = _skin_edges(np.ascontiguousarray(tri.T), offset + n)
    want = _edges_reference(tri)
    assert got.dtype == np.intp and got.shape == (len(want), 2)
    assert np.array_equal(got, want)


def test_an_edge_key_at_the_32_bit_limit_is_exact():
    n = 46_340  # n**2 < 2**31: the last 32-bit skin
    tri = np.array([[n - 1, n - 2, 0], [n - 3, n - 1, n - 2]])
    for size in (n, n + 1):
        assert np.array_equal(_skin_edges(np.ascontiguousarray(tri.T), size),
                              _edges_reference(tri))


def _normals_reference(points, tri, ids):
    """The vertex normals as ``_vertex_normals`` found them before stop 39: the rows ``ids``
    of the vertex-triangle incidence matrix times the triangles' normals."""
    m = len(tri)
    inc = sp.csr_matrix((np.ones(3 * m), (tri.ravel(), np.repeat(np.arange(m), 3))),
                        shape=(len(points), m))
    sub = inc[ids]
    use = np.unique(sub.indices)
    c = points[tri[use]]
    fn = np.zeros((m, 3))
    fn[use] = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
    n = sub @ fn
    return n / np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31), n=st.integers(3, 40), m=st.integers(1, 120),
       k=st.integers(0, 40), shuffled=st.booleans())
def test_vertex_normals_are_the_incidence_products_bit_for_bit(seed, n, m, k, shuffled):
    rng = np.random.default_rng(seed)
    points, tri = _random_mesh(rng, n, m)
    ids = rng.permutation(n)[: min(k, n)]
    if not shuffled:
        ids = np.sort(ids)
    got = _vertex_normals(points, tri, ids, {})
    want = _normals_reference(points, tri, ids)
    assert got.shape == want.shape == (len(ids), 3)
    assert np.array_equal(got, want)  # the same sums, in the same order


def test_vertex_normals_on_the_paper_faces_refined_skin_bit_for_bit():
    face = wv.datasets.load_face()
    s = face.evaluate("pucker", 1.0, refine=True, skin="geometric", fold_guard=False)
    tri = np.asarray(s.triangles, dtype=np.intp)
    ids = np.flatnonzero(s.W)
    got = _vertex_normals(s.deformed_points, tri, ids, {})
    assert np.array_equal(got, _normals_reference(s.deformed_points, tri, ids))


@pytest.mark.parametrize("rows_first", [False, True])
def test_the_wrinkle_steps_rest_normals_are_the_full_terms_bit_for_bit(rows_first):
    # a step from a skin of its own takes N alone (its A1, A2 replaced by the start's);
    # rows_first: every triangle's rows found first (the subset is taken from them), else
    # the subset's computed alone
    face = wv.datasets.load_face()
    surf = face.skin
    rng = np.random.default_rng(3)
    moving = np.zeros(surf.n_points, bool)
    moving[rng.choice(surf.n_points, 40, replace=False)] = True
    full, alone = (pull_terms(surf.points, surf.triangles) for _ in range(2))
    if rows_first:
        foldguard._terms_rows(full)
        foldguard._terms_rows(alone)
    want = _triangles_of(full, moving)
    got = _triangles_of(alone, moving, normals_only=True)
    assert got[3] is None and got[4] is None
    for a, b in zip(got[:3], want[:3], strict=True):
        assert np.array_equal(a, b)
        assert (a.flags.c_contiguous, a.flags.f_contiguous) == \
            (b.flags.c_contiguous, b.flags.f_contiguous)  # (einsum sums follow the layout)
    again = _triangles_of(alone, moving, normals_only=True)  # kept: the same arrays
    assert again[2] is got[2]
    assert _triangles_of(alone, moving)[3] is not None  # not mistaken for the full entry


def _limit_reference(face, s, guard):
    """The clamp's limits on a refined frame as found before stop 39 (a gather of every
    vertex's three nearest skin vertices and a min over them)."""
    r = face._rest.fold_bounds["radii"]
    base = (1.0 - 1e-5) * guard.knee * guard.eta * r.min(axis=1)
    return base[foldguard._nearest_skin_vertices(face, s.face)].min(axis=1)


@pytest.mark.parametrize("skin", ["geometric", "physical"])
def test_a_refined_frames_clamp_limits_are_the_least_of_its_nearest_vertices(skin):
    # kept per hierarchy row with the face's rest frame: each frame of a ramp (its own
    # split set, its own refined face), then a guard of other parameters (its own
    # limits), then a fresh face's frame, all as found anew
    face = wv.datasets.load_face()
    guards = (FoldGuard(), FoldGuard(), FoldGuard(eta=0.3, knee=0.6))
    for level, guard in zip((0.4, 1.0, 0.7), guards, strict=True):
        s = face.evaluate("pucker", level, refine=True, skin=skin, fold_guard=False)
        foldguard._clamp_only(face, s, guard)
        key, limit = s.face._rest.fold_clamp_limit
        assert key == (guard.eta, guard.knee)
        assert np.array_equal(limit, _limit_reference(face, s, guard))
        assert face._rest.fold_clamp_rows[1] == key
    fresh = wv.datasets.load_face()
    s = fresh.evaluate("pucker", 0.7, refine=True, skin=skin, fold_guard=False)
    foldguard._clamp_only(fresh, s, guards[-1])
    assert np.array_equal(s.face._rest.fold_clamp_limit[1], limit)


def test_a_refined_frames_clamp_limits_follow_a_new_hierarchy():
    # the rows are kept for one hierarchy: another (a face whose engine was built anew)
    # finds its own, never the rows of the first
    face = wv.datasets.load_face()
    s = face.evaluate("pucker", 1.0, refine=True, skin="geometric", fold_guard=False)
    foldguard._clamp_only(face, s, FoldGuard())
    hier, key, rows = face._rest.fold_clamp_rows
    face._rest.fold_clamp_rows = (object(), key, np.zeros_like(rows))  # a stale hierarchy
    s.face._rest.fold_clamp_limit = None
    foldguard._clamp_only(face, s, FoldGuard())
    assert face._rest.fold_clamp_rows[0] is hier
    assert np.array_equal(s.face._rest.fold_clamp_limit[1],
                          _limit_reference(face, s, FoldGuard()))


def _lowest_reference(b, c, top):
    """``_lowest_sigma`` before stop 39 (every entry's vertex, masked by np.where)."""
    low = 1.0 + b * top + c * top * top
    vertex = np.where(c > 0, -b / np.where(c > 0, 2.0 * c, 1.0), 0.0)
    inside = (vertex > 0) & (vertex < top)
    return np.where(inside, np.minimum(low, 1.0 - b * b / np.where(c > 0, 4.0 * c, 1.0)),
                    low)


_COEFFICIENT = st.one_of(st.floats(-5, 5), st.sampled_from([0.0, -0.0, 1e-300, -1e-300,
                                                              1e300, np.inf, np.nan]))


@settings(max_examples=50, deadline=None)
@given(bc=st.lists(st.tuples(_COEFFICIENT, _COEFFICIENT), min_size=0, max_size=40),
       top=st.sampled_from([2.0, 1.25, 1.0]))
def test_the_least_signed_area_is_the_masked_formulas_bit_for_bit(bc, top):
    b = np.array([x for x, _ in bc], dtype=float)
    c = np.array([y for _, y in bc], dtype=float)
    with np.errstate(all="ignore"):
        got, want = foldguard._lowest_sigma(b, c, top), _lowest_reference(b, c, top)
    assert np.array_equal(got, want, equal_nan=True)
    assert np.array_equal(np.signbit(got), np.signbit(want))


def _old_cross_rows(u, v):
    return np.stack([u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                     u[0] * v[1] - u[1] * v[0]])


def _old_cross(u, v):
    return np.stack([u[:, 1] * v[:, 2] - u[:, 2] * v[:, 1],
                     u[:, 2] * v[:, 0] - u[:, 0] * v[:, 2],
                     u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]], axis=1)


def _row_terms_reference(points, corners):
    """``_row_terms`` before stop 39 (stacked cross products)."""
    pts = np.ascontiguousarray(np.asarray(points, dtype=float).T)
    r0 = np.take(pts, corners[0], axis=1)
    e1 = np.take(pts, corners[1], axis=1) - r0
    e2 = np.take(pts, corners[2], axis=1) - r0
    N = _old_cross_rows(e1, e2)
    rows = np.ascontiguousarray(N.T)
    nn = np.where(np.einsum("ij,ij->i", rows, rows) > 0, np.einsum("ij,ij->i", rows, rows),
                  np.inf)
    A1 = _old_cross_rows(N, e1) / nn
    A2 = _old_cross_rows(e2, N) / nn
    return N / nn, A1, A2


def _start_terms_reference(Nt, start, corners):
    """``_start_terms`` before stop 39 (row-wise cross products on (k, 3) rows)."""
    r0 = np.take(start, corners[0], axis=0)
    e1 = np.take(start, corners[1], axis=0) - r0
    e2 = np.take(start, corners[2], axis=0) - r0
    N = Nt.T
    return (np.einsum("ij,ij->i", N, _old_cross(e1, e2)), _old_cross(N, e1).T,
            _old_cross(e2, N).T)


def _layout(a):
    return a.shape, a.flags.c_contiguous, a.flags.f_contiguous


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31), n=st.integers(3, 30), m=st.integers(1, 60),
       fortran=st.booleans())
def test_the_row_and_start_terms_are_the_stacked_products_bit_for_bit(seed, n, m, fortran):
    # fortran: rest normals taken as a subset's are (column-major), else as every
    # triangle's (row-major); the step's einsum and sums follow the layout
    rng = np.random.default_rng(seed)
    points, tri = _random_mesh(rng, n, m)
    corners = np.ascontiguousarray(tri.T)
    got, want = foldguard._row_terms(points, corners), _row_terms_reference(points, corners)
    for a, b in zip(got, want, strict=True):
        assert np.array_equal(a, b) and _layout(a) == _layout(b)
    assert np.array_equal(foldguard._row_terms(points, corners, True)[0], want[0])
    for a, b in zip(foldguard._row_terms(points, corners, order="F"), want, strict=True):
        assert np.array_equal(a, b) and _layout(a) == _layout(np.asfortranarray(b))
    Nt = np.asfortranarray(got[0]) if fortran else got[0]
    start = points + rng.normal(scale=0.3, size=points.shape)
    got = foldguard._start_terms(Nt, start, corners)
    want = _start_terms_reference(Nt, start, corners)
    for a, b in zip(got, want, strict=True):
        assert np.array_equal(a, b) and _layout(a) == _layout(b)
