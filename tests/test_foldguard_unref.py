"""The fold guard on unrefined frames (stop 40): a ball the rest gaps clear at a vertex with
no lone neighbour is skipped whole (``docs/model.md``, "The rest gaps, vertices"), sound
against the exact search; the faster helpers give what the code they replace gave."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import bumpy_sheets, smooth_move
from hypothesis import given, settings
from hypothesis import strategies as st

import wrinkle_vis as wv
from wrinkle_vis.core import foldguard
from wrinkle_vis.core.foldguard import (
    FoldGuard,
    _deformed_lows,
    _gap_moves,
    _gaps_clear,
    _gaps_empty,
    _local_skin,
    _lone_neighbours,
    _longest_edge,
    pull_terms,
)
from wrinkle_vis.core.mesh import _closest_on_triangles


def _same_lows(a, b) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])


def _with_fins(points: np.ndarray, tri: np.ndarray, at: np.ndarray, lift: np.ndarray):
    """``points``, ``tri`` with a fin at each vertex ``at`` ``(k,)``: a new vertex at
    ``at + lift`` ``(k, 3)`` in a single triangle with ``at`` and a neighbour of it (the new
    vertex is ``at``'s lone neighbour: its only triangle holds ``at``)."""
    if not len(at):
        return points, tri
    nb = np.array([tri[np.flatnonzero((tri == a).any(axis=1))[0]] for a in at])
    other = np.where(nb[:, 0] != at, nb[:, 0], nb[:, 1])
    w = len(points) + np.arange(len(at))
    fins = np.stack([at, w, other], axis=1)
    return np.vstack([points, points[at] + lift]), np.vstack([tri, fins])


def _lone_reference(tri: np.ndarray, n: int) -> np.ndarray:
    """The vertices x with another vertex w every one of whose triangles holds x, by sets."""
    out = np.zeros(n, bool)
    for w in range(n):
        own = [set(t) for t in tri if w in t]
        if not own:
            return np.ones(n, bool)
        for x in set.intersection(*own) - {w}:
            out[x] = True
    return out


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31), n=st.integers(3, 25), m=st.integers(1, 40),
       degenerate=st.booleans())
def test_the_lone_neighbours_are_those_of_the_sets(seed, n, m, degenerate):
    """Every vertex with a lone neighbour is marked (on triangles with a repeated corner
    perhaps more: never fewer); on proper triangles exactly those."""
    rng = np.random.default_rng(seed)
    tri = np.array([rng.choice(n, 3, replace=False) for _ in range(m)])
    if degenerate:
        tri[: m // 3, 1] = tri[: m // 3, 0]
    got = _lone_neighbours(tri, n, {})
    want = _lone_reference(tri, n)
    assert not (want & ~got).any()
    if not degenerate:
        assert np.array_equal(got, want)


def test_a_fins_vertex_inside_a_ball_the_gaps_clear_keeps_the_ball_searched():
    """A flat sheet with a fin at x: its lone vertex w (in one triangle, with x) sits in
    x's ball, which no triangle not incident to x enters (the gaps clear it). The vertices'
    search shrinks the ball on w, so it must be searched: skipping it on the gaps alone
    would keep W."""
    rest, tri = bumpy_sheets(9, 0.0, 50.0, 0.0)
    x = 4 * 9 + 4
    rest, tri = _with_fins(rest, tri, np.array([x]), np.array([[0.05, 0.0, 0.4]]))
    guard = FoldGuard()
    W = np.zeros(len(rest))
    W[x] = 0.3 * guard.knee * guard.eta_deformed  # the ball's radius: 0.3
    terms = pull_terms(rest, tri)
    assert _gaps_clear(rest, rest, W, tri, terms, guard) is None  # a skin's first frame
    clear = _gaps_clear(rest, rest, W, tri, terms, guard)
    assert clear[x]  # no triangle not incident to x comes within 0.6 of it
    exact = _deformed_lows(rest, tri, W, terms, guard)
    assert exact is not None and list(exact[0]) == [x]  # the fin's vertex shrinks it
    empty = _gaps_empty(None, clear, tri, terms)
    assert not empty[x]
    assert _same_lows(_deformed_lows(rest, tri, W, terms, guard, empty=empty, clear=clear),
                      exact)


@settings(max_examples=40, deadline=None)
@given(bump=st.floats(0.0, 1.0), gap=st.floats(0.2, 1.5), shift=st.sampled_from([0.0, 0.5]),
       amp=st.floats(0.0, 1.0), k=st.floats(0.3, 2.0), w=st.floats(0.02, 0.5),
       fins=st.integers(0, 6), seed=st.integers(0, 2**16), stepped=st.booleans(),
       near=st.sampled_from([1, 3, foldguard._GAP_NEAR]))
def test_a_ball_the_gaps_skip_is_one_the_exact_search_keeps(bump, gap, shift, amp, k, w,
                                                            fins, seed, stepped, near):
    """Two bumpy sheets (with a few fins: lone vertices) moved by a random smooth field: no
    ball ``_gaps_skip`` skips (cleared by the gaps, or its near triangles kept out exactly
    by ``_gaps_apart``) is lowered by the exact search (vertices and triangles), and the
    search skipping them returns the exact one's result bit for bit; ``_gaps_clear``
    told to skip balls certified already clears the others as before. ``stepped``: the
    normals from the frame's step W n (else the deformed skin's own); ``near``: the near
    triangles kept per vertex (few: those left out decide)."""
    own = foldguard.balls._GAP_NEAR
    foldguard.balls._GAP_NEAR = near  # (read by the balls' module)
    try:
        _check_the_gaps_skip(bump, gap, shift, amp, k, w, fins, seed, stepped)
    finally:
        foldguard.balls._GAP_NEAR = own


def _check_the_gaps_skip(bump, gap, shift, amp, k, w, fins, seed, stepped):
    rng = np.random.default_rng(seed)
    rest, tri = bumpy_sheets(10, bump, gap, shift)
    at = 100 + rng.choice(100, fins, replace=False)  # on the upper sheet, up: often inside
    lift = rng.uniform(-0.1, 0.1, (fins, 3)) + [0, 0, 0.25]  # the ball W > 0 pushes there
    rest, tri = _with_fins(rest, tri, at, lift)
    deformed, W = smooth_move(rng, rest, amp, k, w)
    W[at] = np.abs(W[at])
    guard = FoldGuard()
    terms = pull_terms(rest, tri)
    _gaps_clear(rest, deformed, W, tri, terms, guard)
    step = None
    if stepped:
        ids = np.flatnonzero(W)
        step = np.zeros_like(rest)
        step[ids] = W[ids, None] * foldguard._vertex_normals(deformed, tri, ids, terms)
    empty, clear = foldguard._gaps_skip(rest, deformed, W, tri, terms, guard, None, step)
    assert np.array_equal(clear, _gaps_clear(rest, deformed, W, tri, terms, guard))
    exact = _deformed_lows(deformed, tri, W, terms, guard, step)
    if exact is not None:
        assert not empty[exact[0]].any()
    skip = rng.uniform(size=len(W)) < 0.5  # balls certified already: left out, the rest
    part = _gaps_clear(rest, deformed, W, tri, terms, guard, skip)  # the same
    assert np.array_equal(np.zeros(len(W), bool) if part is None else part, clear & ~skip)
    assert _same_lows(_deformed_lows(deformed, tri, W, terms, guard, step, empty, clear),
                      exact)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31), scale=st.floats(1e-9, 10.0), unique=st.booleans())
def test_the_longest_edge_and_local_skin_are_the_gathers_bit_for_bit(seed, scale, unique):
    """``_longest_edge`` and ``_local_skin`` by takes give what fancy indexing gave."""
    rng = np.random.default_rng(seed)
    rest, tri = bumpy_sheets(8, 0.5, 0.7, 0.3)
    pts = rest + rng.normal(scale=scale, size=rest.shape)
    terms = pull_terms(rest, tri)
    if unique:
        _longest_edge(pts, tri, terms)  # (from a second frame: the unique edges)
    ends = terms.get("edge_ends", (None,))[0] if unique else None
    edges = np.stack(ends, 1) if ends is not None else np.vstack(
        [tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    e = pts[edges[:, 0]] - pts[edges[:, 1]]
    assert _longest_edge(pts, tri, terms) == float(np.sqrt(np.einsum("ij,ij->i", e, e).max()))
    lo = pts.min(axis=0) + rng.uniform(0, 0.5, 3) * np.ptp(pts, axis=0)
    hi = lo + rng.uniform(0, 0.7, 3) * np.ptp(pts, axis=0)
    samples, local, t_loc = _local_skin(pts, tri, lo, hi)
    box = foldguard._in_box(pts, lo, hi)
    want = np.full(len(pts), -1, np.intp)
    want[box] = np.arange(len(box))
    t_want = want[tri]
    t_want = t_want[t_want.min(axis=1) >= 0]
    assert np.array_equal(samples, pts[box]) and np.array_equal(local, want)
    assert np.array_equal(t_loc, t_want) and t_loc.dtype == t_want.dtype
    assert t_loc.flags.c_contiguous and samples.flags.c_contiguous


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31), scale=st.floats(1e-6, 10.0))
def test_the_gaps_corner_moves_bound_the_largest_move(seed, scale):
    """``_gap_moves``: the largest |u_w - u_x| over each vertex's first corners, within
    rounding of the rows' norms (an upper bound is all the certificate needs)."""
    rng = np.random.default_rng(seed)
    rest, tri = bumpy_sheets(8, 0.5, 0.7, 0.0)
    terms = pull_terms(rest, tri)
    ids = np.arange(len(rest))
    gaps = foldguard._rest_gaps(rest, tri, ids, terms)
    u = rng.normal(scale=scale, size=rest.shape)
    count = gaps["count"][ids, rng.integers(0, len(gaps["cut"]), len(ids))]
    own, count = ids[count >= 0], count[count >= 0]
    got = _gap_moves(u, gaps, own, count)
    for x, c, g in zip(own, count, got, strict=True):
        d = np.linalg.norm(u[gaps["corners"][x, :c]] - u[x], axis=1) if c else np.zeros(1)
        assert abs(g - max(d.max(), 0.0)) <= 1e-12 * (1.0 + d.max())


@pytest.fixture(scope="module")
def twins():
    return {name: (wv.datasets.load_face(*arg), wv.datasets.load_face(*arg))
            for name, arg in (("procedural", ()), ("head", ("lee_perry_smith",)))}


@pytest.mark.parametrize("name,skin,expressions", [
    ("procedural", "geometric", ("surprise", "pucker", "waters_anger", "smile")),
    ("procedural", "physical", ("frown", "surprise")),
    ("head", "geometric", ("smile", "pucker"))])
def test_unrefined_frames_with_the_gaps_skip_are_those_without_it(twins, name, skin,
                                                                  expressions):
    """Frames of animation ramps guarded with the skips and (a twin face) without them
    (c0ffd06's: the certified empty balls alone skipped, every wrinkled ball's gaps looked
    at): bit for bit the same, and the skips did skip balls, some by the exact test."""
    fast, slow = (f.with_skin_model(skin) for f in twins[name])
    own, own_apart, skipped, apart = foldguard._gaps_skip, foldguard._gaps_apart, [], []

    def counted(rest, d2, W, tri, terms, guard, empty, step):
        out, clear = own(rest, d2, W, tri, terms, guard, empty, step)
        if clear is not None:
            skipped.append(int(np.count_nonzero(out & (True if empty is None else ~empty))))
        return out, clear

    def counted_apart(*args):
        ok = own_apart(*args)
        apart.append(int(ok.sum()))
        return ok

    def without(rest, d2, W, tri, terms, guard, empty, step):
        return empty, _gaps_clear(rest, d2, W, tri, terms, guard)

    for expression in expressions:
        for intensity in (0.0, 0.3, 0.6, 0.8, 1.0):
            foldguard.frame._gaps_skip, foldguard.balls._gaps_apart = counted, counted_apart
            try:
                a = fast.evaluate(expression, intensity, fold_guard=True)
            finally:
                foldguard.frame._gaps_skip, foldguard.balls._gaps_apart = own, own_apart
            foldguard.frame._gaps_skip = without
            try:
                b = slow.evaluate(expression, intensity, fold_guard=True)
            finally:
                foldguard.frame._gaps_skip = own
            for k in ("points", "W", "deformed_points", "fold_guard", "W_raw"):
                assert np.array_equal(getattr(a, k), getattr(b, k)), f"{expression} {k}"
    assert sum(skipped) > 0
    if name == "procedural" and skin == "geometric":
        assert sum(apart) > 0


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31), scale=st.floats(1e-6, 10.0))
def test_the_hot_triangles_terms_by_takes_are_the_gathers_bit_for_bit(seed, scale):
    """``_cold_pass`` takes its hot triangles' rows (column-major gathers before): the
    quadratic's b and c are the same bit for bit."""
    rng = np.random.default_rng(seed)
    rest, tri = bumpy_sheets(8, 0.5, 0.7, 0.3)
    terms = pull_terms(rest, tri)
    N, A1, A2 = foldguard._terms_rows(terms)
    pull_t = np.ascontiguousarray(rng.normal(scale=scale, size=rest.shape).T)
    hot = np.flatnonzero(rng.uniform(size=len(tri)) < rng.uniform())
    old = foldguard._quadratic(pull_t, terms["corners"][:, hot], N[:, hot], A1[:, hot],
                               A2[:, hot])
    new = foldguard._quadratic(pull_t, *(np.take(a, hot, axis=1)
                                         for a in (terms["corners"], N, A1, A2)))
    assert all(np.array_equal(a, b) for a, b in zip(old, new, strict=True))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31), flat=st.booleans(), scale=st.floats(1e-3, 1e3))
def test_the_heights_bound_the_distance_to_the_triangle_from_below(seed, flat, scale):
    """``_heights``: at most the distance from each point to its triangle (the nearest
    point's, checked also on a fine sampling of the triangle), and equal to it where the
    nearest point's direction is taken (``need`` above every distance); ``flat``: some
    triangles with (nearly) collinear corners."""
    rng = np.random.default_rng(seed)
    corners = rng.normal(scale=scale, size=(200, 3, 3))
    if flat:
        corners[::3, 2] = corners[::3, 0] + rng.uniform(-2, 3, (67, 1)) * (
            corners[::3, 1] - corners[::3, 0])
    c = rng.normal(scale=scale, size=(200, 3))
    got = foldguard._heights(corners, c, np.zeros(200))
    lam = rng.dirichlet(np.ones(3), size=400)
    pts = np.einsum("sk,pkj->psj", lam, corners)  # (200, 400, 3) points of each triangle
    sampled = np.linalg.norm(pts - c[:, None], axis=2).min(axis=1)
    nearest = np.linalg.norm(_closest_on_triangles(c, corners) - c, axis=1)
    slack = 1e-9 * scale
    assert np.all(got <= np.minimum(sampled, nearest) + slack)
    full = foldguard._heights(corners, c, np.full(200, np.inf))
    assert np.all(full <= np.minimum(sampled, nearest) + slack)
    assert np.allclose(full, nearest, rtol=1e-9, atol=slack)


def test_a_refined_skin_met_again_builds_no_rest_gaps(wv_face):
    """A timeline's plateau (the app's Play): the peak of surprise's timeline refines to the
    same split set frame after frame, so one refined skin is guarded again and again. Its
    rest gaps cost seconds a time (4 s on the paper face, a hitch in the playback) and are
    never built; the frames are those of the search, as on a skin met once."""
    face = wv_face.with_skin_model("geometric")
    timeline = face.expressions["surprise"]
    states = [face.evaluate(timeline.at(t, 1.0), refine=True) for t in (1.0, 1.1)]
    assert states[0].face is states[1].face  # one refined skin, guarded twice
    terms = states[1].face._rest.pull_terms
    assert terms["refined"] and terms["gap_frames"] >= 2
    assert "gaps" not in terms
