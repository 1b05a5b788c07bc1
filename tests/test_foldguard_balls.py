"""The balls' search on refined frames: its cheap pair test against the exact nearest point."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from wrinkle_vis.core.foldguard import _apart, _closest_on_triangles


def _pairs_near_contact(seed: int, k: int = 4000):
    """Random triangles (some slivers, some far from the origin) and balls whose radius is
    the distance from their centre to the triangle times a factor near 1 (both sides of
    contact, down to a relative 1e-7), the centre anywhere around the triangle."""
    rng = np.random.default_rng(seed)
    shift = rng.choice([0.0, 50.0]) * rng.normal(size=3)
    a, b, c = (rng.normal(size=(k, 3)) + shift for _ in range(3))
    sliver = rng.random(k) < 0.2
    c[sliver] = a[sliver] + rng.uniform(0, 1, (sliver.sum(), 1)) * (b - a)[sliver] \
        + 1e-6 * rng.normal(size=(sliver.sum(), 3))
    w = rng.dirichlet([1.0, 1.0, 1.0], k)
    q = w[:, :1] * a + w[:, 1:2] * b + w[:, 2:] * c
    centres = q + rng.uniform(0.01, 3.0, (k, 1)) * rng.normal(size=(k, 3))
    dist = np.linalg.norm(_closest_on_triangles(centres, a, b, c) - centres, axis=1)
    factor = 1.0 + rng.choice([-1.0, 1.0], k) * 10.0 ** rng.uniform(-7, 0, k)
    return centres, dist * np.abs(factor), a, b, c


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_a_pair_found_apart_is_one_the_nearest_point_puts_outside(seed):
    """``_apart`` never drops a (ball, triangle) pair whose nearest point lies inside the
    ball (the search's own test, ``|q - c|^2 < r^2``), on balls within a relative 1e-7 of
    touching their triangle, and it does drop most of the pairs far apart (a test that
    calls nothing apart would pass the first check)."""
    centres, r, a, b, c = _pairs_near_contact(seed)
    apart = _apart(centres, r, a, b, c)
    q = _closest_on_triangles(centres, a, b, c)
    dd = np.einsum("ij,ij->i", q - centres, q - centres)
    meet = dd < r * r
    assert not (apart & meet).any()
    far = dd > (2.0 * r) ** 2
    assert apart[far].mean() > 0.5


def _two_sheets(seed: int):
    """A bumpy fine sheet (edges about 1, jittered) under a coarse one (edges about 5) a
    random gap above, with three random slivers: triangles of sizes 16 to 100 times apart (so
    :func:`_lift` makes several classes) and balls that reach the coarse sheet."""
    rng = np.random.default_rng(seed)

    def sheet(n, width, z, flip):
        x, y = np.meshgrid(np.linspace(-width / 2, width / 2, n), np.linspace(-10, 10, n))
        pts = np.c_[x.ravel(), y.ravel(), z(x, y).ravel()]
        idx = np.arange(n * n).reshape(n, n)
        a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), \
            idx[1:, :-1].ravel()
        tri = np.r_[np.c_[a, b, c], np.c_[a, c, d]]
        return pts, tri[:, ::-1] if flip else tri

    fine, tri = sheet(21, 20.0, lambda x, y: 0.6 * np.sin(0.5 * x + seed) * np.cos(0.4 * y),
                      False)
    fine[:, :2] += rng.uniform(-0.2, 0.2, (len(fine), 2))
    coarse, ctri = sheet(5, 15.0, lambda x, y: 0.4 * np.cos(0.3 * x - seed), True)
    coarse[:, 0] += 8.0
    coarse[:, 2] += rng.uniform(0.3, 2.5) + rng.uniform(-0.3, 0.3, len(coarse))
    sliver = rng.uniform(-6, 6, (9, 3)) * [1, 1, 0.3] + [4.0, 0, 1.0]
    pts = np.vstack([fine, coarse, sliver])
    k, s0 = len(fine), len(fine) + len(coarse)
    tri = np.vstack([tri, ctri + k, s0 + np.arange(9).reshape(3, 3)])
    return pts, tri, k


def _balls(seed: int, pts, k, count=400):
    """Balls tangent at random fine vertices, up or down, radii 0.05 to 3."""
    rng = np.random.default_rng(seed + 1)
    own = rng.integers(0, k, count)
    n = np.tile([0.0, 0.0, 1.0], (count, 1)) * rng.choice([-1.0, 1.0], (count, 1))
    r = rng.uniform(0.05, 3.0, count)
    return own, n, r, pts[own] + r[:, None] * n


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_one_lifted_query_clears_as_cleared_and_finds_every_lifted_vertex(seed):
    """``_lifted_near`` (the k-nearest query that both clears and finds) against
    ``_cleared`` and against every lifted vertex by brute force: the same balls cleared,
    and for the others exactly the vertices with ``|v - c|^2 - rho_v^2 + T <= (r^2 + T)
    (1 + 2e-9)`` in their class, each once (balls with more than K such vertices
    included: the ball query's path)."""
    from wrinkle_vis.core.foldguard import _SUSPECTS_K, _cleared, _lift, _lifted_near

    pts, tri, k = _two_sheets(seed)
    own, _, r, c = _balls(seed, pts, k)
    lift = _lift(pts, tri)
    assert len(lift["classes"]) >= 2
    cleared, ball, vert = _lifted_near(lift, c, r, own)
    np.testing.assert_array_equal(cleared, _cleared(lift, c, r, own))
    assert cleared.any() and not cleared.all()  # both kinds of ball (seed 7209: 5 %)
    lifted = np.sum((pts[None, :, :] - c[:, None, :]) ** 2, axis=2) - lift["rho"][None, :] \
        + lift["T"][None, :]
    want = lifted <= (r[:, None] ** 2 + lift["T"][None, :]) * (1.0 + 2e-9)
    want[cleared] = False
    got = np.zeros_like(want)
    got[ball, vert] = True
    assert len(set(zip(ball.tolist(), vert.tolist(), strict=True))) == len(ball)  # once
    np.testing.assert_array_equal(got, want)
    assert want.sum(axis=1).max() > _SUSPECTS_K  # some ball took the ball query
    _, b2, _ = _lifted_near(lift, c, r, own, clear=False)  # not cleared: every ball's
    assert set(b2.tolist()) >= set(np.flatnonzero(want.any(axis=1)).tolist())


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_the_vertex_search_asks_only_balls_that_may_hold_a_vertex(seed):
    """``_vertex_hits`` (the tree asked only for balls certified free of triangles and those
    whose lifted pairs reach inside) finds the very balls a nearest-vertex query of every
    ball finds (``d < R (1 - 1e-9)``), and asks fewer than all."""
    from scipy.spatial import cKDTree

    from wrinkle_vis.core.foldguard import _to_search, _vertex_hits

    pts, tri, k = _two_sheets(seed)
    own, _, r, c = _balls(seed, pts, k)
    free = np.random.default_rng(seed).random(len(own)) < 0.2
    todo, lift, near = _to_search(pts, tri, c, r, own, free)
    hit, tree = _vertex_hits(pts, c[todo], r[todo], own[todo], free[todo], near)
    dist, _ = cKDTree(pts).query(c[todo])
    want = np.flatnonzero(dist < r[todo] * (1.0 - 1e-9))
    np.testing.assert_array_equal(hit, want)
    assert len(want) > 0 and len(todo) > len(want)
    assert tree is not None


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_triangle_radii_from_found_pairs_are_those_of_its_own_search(seed):
    """``triangle_radii`` given the pairs ``_lifted_near`` found for its balls returns, bit
    for bit, what its own search (``_suspects``) returns, on balls that shrink and balls
    that do not."""
    from wrinkle_vis.core.foldguard import _lift, _lifted_near, triangle_radii

    pts, tri, k = _two_sheets(seed)
    own, n, r, c = _balls(seed, pts, k)
    radii = np.where(n[:, 2:] > 0, [[1.0, 0.0]], [[0.0, 1.0]]) * r[:, None]
    up = np.tile([0.0, 0.0, 1.0], (len(own), 1))
    lift = _lift(pts, tri)
    _, ball, vert = _lifted_near(lift, c, r, own, clear=False)
    mine = triangle_radii(own, up, radii, pts, tri, lift=lift, clear=False, found=(ball, vert))
    theirs = triangle_radii(own, up, radii, pts, tri, lift=lift, clear=False)
    np.testing.assert_array_equal(mine, theirs)
    assert (theirs.sum(axis=1) < r).mean() > 0.05  # some balls did shrink
