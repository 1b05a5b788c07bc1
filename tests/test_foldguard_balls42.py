"""The deformed balls' search made cheaper on refined frames (stop 42): each change against
the search it replaces (``docs/model.md``, "Refined frames' balls, stop 42")."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st
from test_foldguard_balls import _balls, _two_sheets

from wrinkle_vis.core.foldguard import FoldGuard, _lift, _lifted_near, balls
from wrinkle_vis.core.foldguard.balls import (
    _deformed_lows,
    _enclosing_sq,
    _expand,
    _first_found,
    _local_rows,
    _near_found,
    _shrink_on_triangles,
    _side_squares,
    _sides_longest,
    _star_rows,
)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_a_small_class_asked_by_its_vertices_finds_what_its_balls_queries_find(seed):
    """``_lifted_near`` with its small classes asked by their vertices in a tree of the
    lifted balls (``_reverse_pairs``; the default, and every class so) against the balls'
    own queries of every class and against every lifted vertex by brute force: the same
    balls cleared, and for the others exactly the vertices with ``|v - c|^2 - rho_v^2 + T
    <= (r^2 + T)(1 + 2e-9)``, each once."""
    pts, tri, k = _two_sheets(seed)
    own, _, r, c = _balls(seed, pts, k)
    lift = _lift(pts, tri)
    runs = {}
    for ratio in (balls._REVERSE_RATIO, 0, np.inf):  # default, every class, none reversed
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(balls, "_REVERSE_RATIO", ratio)
            runs[ratio] = _lifted_near(_lift(pts, tri), c, r, own)
    lifted = np.sum((pts[None, :, :] - c[:, None, :]) ** 2, axis=2) - lift["rho"][None, :] \
        + lift["T"][None, :]
    brute = lifted <= (r[:, None] ** 2 + lift["T"][None, :]) * (1.0 + 2e-9)
    want = runs[np.inf][0]
    assert want.any() and not want.all()
    brute[want] = False
    for cleared, ball, vert in runs.values():
        np.testing.assert_array_equal(cleared, want)
        pairs = list(zip(ball.tolist(), vert.tolist(), strict=True))
        assert len(pairs) == len(set(pairs))  # each once
        mine = np.zeros_like(brute)
        mine[ball, vert] = True
        np.testing.assert_array_equal(mine, brute)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_the_found_pairs_kept_by_their_own_corner_are_the_first_found_triangles(seed):
    """``_near_found`` (each triangle of a found vertex whose corner passes the disc test,
    once per such corner) keeps the very (ball, triangle) pairs ``_first_found`` keeps
    (once each, through its first found corner), and every pair whose triangle meets the
    ball (brute force over every triangle not incident to the ball's vertex)."""
    pts, tri, k = _two_sheets(seed)
    own, _, r, c = _balls(seed, pts, k)
    lift = _lift(pts, tri)
    _, ball, vert = _lifted_near(lift, c, r, own, clear=False)
    b1, t1 = _near_found(lift, c, r, own, pts, ball, vert)
    b0, t0 = _first_found(lift, c, r, own, pts, *_expand(lift, ball, vert))
    mine = set(zip(b1.tolist(), t1.tolist(), strict=True))
    theirs = set(zip(b0.tolist(), t0.tolist(), strict=True))
    assert mine == theirs and len(b0) == len(theirs)
    assert len(theirs) < len(b1) <= 3 * len(theirs)  # some come twice, none more than thrice
    from wrinkle_vis.core.foldguard import _closest_on_triangles

    bb, tt = np.nonzero((tri[None, :, :] != own[:, None, None]).all(axis=2))
    q = _closest_on_triangles(c[bb], *(pts[tri[tt, j]] for j in range(3)))
    meet = np.sum((q - c[bb]) ** 2, axis=1) < r[bb] ** 2
    assert meet.sum() > 10
    assert set(zip(bb[meet].tolist(), tt[meet].tolist(), strict=True)) <= mine


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), degenerate=st.integers(0, 5))
def test_the_incidence_turned_from_the_triangles_rows_is_coo_to_csr(seed, degenerate):
    """``_star_rows``' vertex-triangle incidence (the triangles' rows as CSR, turned to
    CSC) is COO to CSR's, bit for bit, triangles with a repeated corner included (once)."""
    pts, tri, _ = _two_sheets(seed)
    rng = np.random.default_rng(seed)
    tri = tri.copy()
    for t in rng.integers(0, len(tri), degenerate):
        tri[t, 1] = tri[t, 0]
    lift = _lift(pts, tri)
    verts = rng.integers(0, len(pts), 300)
    t, deg = _star_rows(lift, verts)
    m = len(tri)
    inc = sp.coo_matrix((np.ones(3 * m, np.int8), (tri.ravel(), np.repeat(np.arange(m), 3))),
                        shape=(len(pts), m)).tocsr()
    np.testing.assert_array_equal(lift["ptr"], inc.indptr)
    np.testing.assert_array_equal(lift["by_vertex"], inc.indices)
    want = [inc.indices[inc.indptr[v]:inc.indptr[v + 1]] for v in verts]
    np.testing.assert_array_equal(deg, [len(w) for w in want])
    np.testing.assert_array_equal(t, np.concatenate(want))


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), scale=st.floats(1e-6, 1e3))
def test_the_squared_sides_of_the_whole_skin_are_the_local_skins_bit_for_bit(seed, scale):
    """The squared sides ``_deformed_lows`` finds once (``_sides_longest`` on the whole
    skin), taken at the local skin's rows, give the local skin's own enclosing discs, and
    the longest side of the sides' ends, bit for bit."""
    pts, tri, _ = _two_sheets(seed)
    rng = np.random.default_rng(seed)
    pts = pts * scale + rng.normal(scale=0.05 * scale, size=pts.shape)
    keep: dict = {}
    longest = _sides_longest(pts, tri, keep)
    e = pts[np.r_[tri[:, 0], tri[:, 1], tri[:, 2]]] - pts[np.r_[tri[:, 1], tri[:, 2], tri[:, 0]]]
    assert longest == float(np.sqrt(np.einsum("ij,ij->i", e, e).max()))
    lo, hi = np.array([-4.0, -6.0, -9.0]) * scale, np.array([7.0, 5.0, 9.0]) * scale
    samples, _, t_loc, rows = _local_rows(pts, tri, lo, hi)
    assert 0 < len(rows) < len(tri)
    squares = tuple(q.take(rows) for q in keep["squares"])
    for got, want in zip(squares, _side_squares(samples, t_loc), strict=True):
        np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(_enclosing_sq(samples, t_loc, squares),
                                  _enclosing_sq(samples, t_loc))


@pytest.mark.parametrize("reverse", [np.inf, 2, 0])  # no class, the small, every class
@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_the_deformed_search_gives_the_exhaustive_searchs_radii(seed, reverse):
    """``_deformed_lows`` on two bumpy sheets under a coarse one (its small classes asked by
    their vertices or by the balls' own queries) lowers exactly the balls the shrinking-ball
    search over every vertex (a ``cKDTree``'s nearest, ``medial_radii``) and then every
    triangle not incident to the ball's vertex (``_shrink_on_triangles``) lowers,
    to the same radii bit for bit; some shrink, some do not."""
    pts, tri, k = _two_sheets(seed)
    own, n, r, _ = _balls(seed, pts, k, 300)
    own, first = np.unique(own, return_index=True)
    n, r = n[first], r[first]
    guard = FoldGuard()
    W = np.zeros(len(pts))
    W[own] = np.where(n[:, 2] > 0, 1.0, -1.0) * r * guard.knee * guard.eta_deformed
    step = W[:, None] * np.tile([0.0, 0.0, 1.0], (len(pts), 1))
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(balls, "_REVERSE_RATIO", reverse)
        got = _deformed_lows(pts, tri, W, {}, guard, step)
    start = np.abs(W[own]) / (guard.knee * guard.eta_deformed) * (1.0 + 1e-6)
    radii = np.where(n[:, 2:] > 0, [[1.0, 0.0]], [[0.0, 1.0]]) * start[:, None]
    want = balls.medial_radii(pts[own], np.tile([0.0, 0.0, 1.0], (len(own), 1)), samples=pts,
                              r_max=radii)
    side = np.where(n[:, 2] > 0, 0, 1)
    b, t = np.nonzero((tri[None, :, :] != own[:, None, None]).all(axis=2))  # every triangle
    every = _shrink_on_triangles(want[np.arange(len(own)), side], b, pts[own[b]], n[b],
                                 tuple(pts[tri[t, j]] for j in range(3)), 60)
    want = np.where(radii > 0, every[:, None], np.inf)
    low = np.flatnonzero(want.min(axis=1) < start)
    assert got is not None and 0 < len(low) < len(own)
    np.testing.assert_array_equal(got[0], own[low])
    ratio = guard.eta_deformed / guard.eta
    np.testing.assert_array_equal(got[1], ratio * want[low])
