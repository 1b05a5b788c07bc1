"""The deformed balls' search made cheaper on refined frames (stop 41): each shortcut against
the exact search it stands for (``docs/model.md``, "Refined frames' balls, cheaper")."""

from __future__ import annotations

import numpy as np
from conftest import bumpy_sheets
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from wrinkle_vis.core.foldguard import (
    _apart,
    _closest_on_triangles,
    _cross,
    _enclosing_sq,
    _lift,
    _lifted_near,
    _shrink_on_triangles,
    _sq,
    triangle_radii,
)
from wrinkle_vis.core.foldguard.balls import _GROUPED_FROM, _query_by_bound, _sides_longest


def _skin(seed: int):
    """Two bumpy sheets (unit cells, jittered) a small gap apart, the upper shifted half a
    cell, and a coarse sheet of cells 4 times larger above: points, triangles, the count
    of the lower sheet's vertices (the balls' own vertices)."""
    rng = np.random.default_rng(seed)
    pts, tri = bumpy_sheets(12, rng.uniform(0.4, 0.9), rng.uniform(0.6, 1.6), 0.5)
    pts = pts + rng.uniform(-0.15, 0.15, pts.shape) * [1, 1, 0.3]
    big, btri = bumpy_sheets(4, 0.3, 0.0)
    big = big[:16] * [4.0, 4.0, 1.0] + [-1.0, -1.0, rng.uniform(2.0, 4.0)]
    return np.vstack([pts, big]), np.vstack([tri, btri[:18] + len(pts)]), 144


def _ring_balls(seed: int, pts: np.ndarray, own_count: int, count: int = 300):
    """Balls tangent at random vertices of the lower sheet along +z or -z, two in three
    towards the side its neighbours bend to (a valley's balls meet its ring): own vertices,
    unit normals towards the ball ``(k, 3)`` and radii ``(k,)`` from 0.05 to 4."""
    rng = np.random.default_rng(seed + 7)
    own = rng.integers(0, own_count, count)
    side = rng.choice([-1.0, 1.0], count)
    rows = np.arange(own_count).reshape(12, 12)  # the lower sheet's grid
    i, j = np.divmod(own, 12)
    nbrs = [rows[np.clip(i + di, 0, 11), np.clip(j + dj, 0, 11)]
            for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1))]
    bend = np.mean([pts[v, 2] for v in nbrs], axis=0) - pts[own, 2]
    valley = rng.random(count) < 2 / 3
    side[valley] = np.where(bend[valley] >= 0, 1.0, -1.0)
    n = np.tile([0.0, 0.0, 1.0], (count, 1)) * side[:, None]
    return own, n, rng.uniform(0.05, 4.0, count)


def _sq_rows(d: np.ndarray) -> np.ndarray:
    """``(..., )``: the squared lengths of ``d``'s last axis."""
    return np.einsum("...j,...j->...", d, d)


def _contact(x, n, a, b, c, hi: float = 6.0, steps: int = 45) -> np.ndarray:
    """``(p,)``: the radius at which the ball tangent at ``x`` along ``n`` ``(p, 3)`` first
    meets the triangle ``a``, ``b``, ``c`` ``(p, 3)`` (the balls nest: bisection), ``inf``
    where it does not within ``hi``."""
    lo, up = np.zeros(len(x)), np.full(len(x), hi)
    for _ in range(steps):
        mid = 0.5 * (lo + up)
        centre = x + mid[:, None] * n
        meet = _sq(_closest_on_triangles(centre, a, b, c) - centre) < mid * mid
        up, lo = np.where(meet, mid, up), np.where(meet, lo, mid)
    centre = x + hi * n
    far = ~(_sq(_closest_on_triangles(centre, a, b, c) - centre) < hi * hi)
    return np.where(far, np.inf, up)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_a_pair_apart_along_the_mean_is_one_the_nearest_point_puts_outside(seed):
    """``_apart`` (the plane, then the direction to the corners' mean) on the pairs the
    refined search meets most, a ball tangent at a vertex and a triangle of its rings or of
    the sheets around, at radii within a relative 1e-7 to 0.3 of first contact on either
    side: a pair it finds apart never has its nearest point inside (the search's own
    test), and along the mean it clears most pairs the corners' ball did not."""
    rng = np.random.default_rng(seed)
    pts, tri, k = _skin(seed)
    own, n, _ = _ring_balls(seed, pts, k, 60)
    g = pts[tri].mean(axis=1)
    ball, t = np.nonzero((tri[None, :, :] != own[:, None, None]).all(axis=2)
                         & (_sq_rows(g[None, :, :] - pts[own][:, None, :]) < 16.0))
    x, nb = pts[own[ball]], n[ball]
    a, b, c = (pts[tri[t, j]] for j in range(3))
    rc = _contact(x, nb, a, b, c)
    keep = np.isfinite(rc) & (rc > 1e-3)
    x, nb, a, b, c, rc = x[keep], nb[keep], a[keep], b[keep], c[keep], rc[keep]
    side = rng.choice([-1.0, 1.0], len(rc))
    r = rc * (1.0 + side * 10.0 ** rng.uniform(-7, np.log10(0.3), len(rc)))
    centre = x + r[:, None] * nb
    apart = _apart(centre, r, a, b, c)
    meet = _sq(_closest_on_triangles(centre, a, b, c) - centre) < r * r
    assert meet.any() and not (apart & meet).any()
    g = (a + b + c) / 3.0  # the corners' ball test (29c63b8's second test)
    lim = r * (1.0 + 1e-6)
    R = np.sqrt(np.maximum(np.maximum(_sq(a - g), _sq(b - g)), _sq(c - g)))
    N = _cross(b - a, c - a)
    h = np.einsum("ij,ij->i", centre - a, N)
    before = (h * h > lim * lim * _sq(N)) | (_sq(centre - g) > (lim + R * (1 + 1e-6)) ** 2)
    assert not (before & ~apart).any()  # it clears every pair the old tests cleared
    missed = ~meet & ~before & (r < 0.9 * rc)
    assert missed.sum() > 20 and apart[missed].mean() > 0.5


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_the_refined_search_gives_the_radii_of_a_search_over_every_triangle(seed):
    """``triangle_radii`` (from ``_lifted_near``'s found pairs, the deformed search's path,
    and from its own candidates) against the shrinking-ball search over every triangle not
    incident to the ball's vertex: bit for bit, on balls that shrink through a ring's
    triangle, through the sheet across, and on balls that do not shrink."""
    pts, tri, k = _skin(seed)
    own, n, r = _ring_balls(seed, pts, k, 150)
    radii = np.where(n[:, 2:] > 0, [[1.0, 0.0]], [[0.0, 1.0]]) * r[:, None]
    up = np.tile([0.0, 0.0, 1.0], (len(own), 1))
    lift = _lift(pts, tri)
    _, ball, vert = _lifted_near(lift, pts[own] + r[:, None] * n, r, own, clear=False)
    found = triangle_radii(own, up, radii, pts, tri, lift=lift, clear=False,
                           found=(ball, vert))
    searched = triangle_radii(own, up, radii, pts, tri, lift=_lift(pts, tri), clear=True)
    b, t = np.nonzero((tri[None, :, :] != own[:, None, None]).all(axis=2))
    every = _shrink_on_triangles(r.copy(), b, pts[own[b]], n[b],
                                 tuple(pts[tri[t, j]] for j in range(3)), 60)
    want = np.where(n[:, 2:] > 0, [[1.0, 0.0]], [[0.0, 1.0]]) * every[:, None]
    np.testing.assert_array_equal(found, want)
    np.testing.assert_array_equal(searched, want)
    adj = np.zeros((len(pts), len(pts)), bool)  # the balls that a ring neighbour's
    for i, j in ((0, 1), (1, 2), (2, 0)):  # triangles alone shrink as far
        adj[tri[:, i], tri[:, j]] = adj[tri[:, j], tri[:, i]] = True
    ring = adj[own[b][:, None], tri[t]].any(axis=1)
    alone = _shrink_on_triangles(r.copy(), b[ring], pts[own[b[ring]]], n[b[ring]],
                                 tuple(pts[tri[t[ring], j]] for j in range(3)), 60)
    by_ring = (alone == every) & (every < r)
    assert by_ring.sum() >= 5 and (every < r).sum() > by_ring.sum() and (every == r).sum() >= 5


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), spread=st.floats(1.5, 6.0))
def test_queries_grouped_by_bound_find_what_one_query_at_the_largest_finds(seed, spread):
    """``_query_by_bound`` against one ``k``-nearest query at the largest bound of all:
    within each ball's own bound the same neighbours, at the same ranks and distances bit
    for bit; beyond it, nothing nearer than the bound."""
    rng = np.random.default_rng(seed)
    pts = rng.uniform(0, 10, (1500, 4)) * [1, 1, 1, 0.2]
    tree = cKDTree(pts, leafsize=32, balanced_tree=False)
    b = _GROUPED_FROM + 100  # (fewer: one query, nothing grouped)
    c4 = np.column_stack([rng.uniform(0, 10, (b, 3)), np.zeros(b)])
    bound = rng.uniform(0.5, 0.5 * spread, b)
    for k in (1, 6):
        d, i = _query_by_bound(tree, c4, bound, k)
        dd, ii = tree.query(c4, k=k, distance_upper_bound=float(bound.max()))
        dd, ii = dd.reshape(b, k), ii.reshape(b, k)
        inside = dd <= bound[:, None]
        np.testing.assert_array_equal(d[inside], dd[inside])
        np.testing.assert_array_equal(i[inside], ii[inside])
        assert (d[~inside] > bound[:, None].repeat(k, axis=1)[~inside]).all()
        assert inside.any() and (~inside).any()


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), scale=st.floats(1e-6, 1e3))
def test_the_enclosing_discs_and_longest_side_by_takes_are_the_gathers_bit_for_bit(seed,
                                                                                     scale):
    """``_enclosing_sq`` and ``_sides_longest`` (one take per corner) give what 29c63b8's
    gathers gave, bit for bit."""
    rng = np.random.default_rng(seed)
    pts, tri, _ = _skin(seed)
    pts = pts * scale + rng.normal(scale=0.1 * scale, size=pts.shape)
    a, b, c = pts[tri[:, 0]], pts[tri[:, 1]], pts[tri[:, 2]]
    a2, b2, c2 = (np.einsum("ij,ij->i", u - v, u - v) for u, v in ((b, c), (c, a), (a, b)))
    top = np.maximum(np.maximum(a2, b2), c2)
    rest = a2 + b2 + c2 - top
    area16 = 2.0 * (a2 * b2 + b2 * c2 + c2 * a2) - (a2 * a2 + b2 * b2 + c2 * c2)
    acute = (top < rest) & (area16 > 0)
    circ = np.where(acute, a2 * b2 * c2 / np.where(acute, area16, 1.0), 0.0)
    want = np.where(acute, np.minimum(circ, top / 3.0), 0.25 * top) * (1.0 + 1e-9)
    np.testing.assert_array_equal(_enclosing_sq(pts, tri), want)
    edges = np.vstack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    e = pts[edges[:, 0]] - pts[edges[:, 1]]
    assert _sides_longest(pts, tri) == float(np.sqrt(np.einsum("ij,ij->i", e, e).max()))
