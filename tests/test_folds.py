"""Folds that never intersect: the certificate (exact, against a rational brute force) and
the fold guard (synthetic valleys and lips, the built-in faces)."""
from fractions import Fraction
from itertools import combinations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from wrinkle_vis.core.certificate import (
    candidate_pairs,
    fold_report,
    intersecting_pairs,
    orient,
    turned_over,
)

# --- brute force: separating axes in rational arithmetic --------------------------------


def _q(p):
    return [Fraction(float(x)) for x in p]


def _sub(a, b):
    return [x - y for x, y in zip(a, b, strict=True)]


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _dot(a, b):
    return sum(x * y for x, y in zip(a, b, strict=True))


def _convex_disjoint(P, Q) -> bool:
    """Closed convex hulls of point lists ``P`` and ``Q`` (rational) are disjoint: some
    axis among normals, edge cross products and normal-edge cross products separates them
    strictly (complete for triangles and segments)."""
    def edges(V):
        return [_sub(b, a) for a, b in combinations(V, 2)]

    def normals(V):
        return [_cross(_sub(V[1], V[0]), _sub(V[2], V[0]))] if len(V) == 3 else []

    E = edges(P) + edges(Q)
    N = normals(P) + normals(Q)
    axes = N + [_cross(a, b) for a in E for b in E] + [_cross(n, e) for n in N for e in E]
    for ax in axes:
        if not any(ax):
            continue
        pp = [_dot(ax, v) for v in P]
        qq = [_dot(ax, v) for v in Q]
        if max(pp) < min(qq) or max(qq) < min(pp):
            return True
    return False


def brute_force(points, triangles) -> set:
    """Every pair, in rational arithmetic (general position): no shared vertex: the closed
    triangles meet; one shared vertex: the opposite edge of either meets the other; a shared
    edge: never (general position)."""
    out = set()
    for i, j in combinations(range(len(triangles)), 2):
        a, b = list(triangles[i]), list(triangles[j])
        common = set(a) & set(b)
        A, B = [_q(points[v]) for v in a], [_q(points[v]) for v in b]
        if not common:
            hit = not _convex_disjoint(A, B)
        elif len(common) == 1:
            v = common.pop()
            sa = [_q(points[x]) for x in a if x != v]
            sb = [_q(points[x]) for x in b if x != v]
            hit = not _convex_disjoint(sa, B) or not _convex_disjoint(sb, A)
        else:
            hit = False
        if hit:
            out.add((i, j))
    return out


@st.composite
def small_meshes(draw):
    n = draw(st.integers(4, 9))
    coords = draw(st.lists(st.floats(-1, 1, allow_nan=False, allow_subnormal=False),
                           min_size=3 * n, max_size=3 * n))
    pts = np.array(coords).reshape(n, 3)
    m = draw(st.integers(2, 10))
    tris = []
    for _ in range(m):
        t = draw(st.lists(st.integers(0, n - 1), min_size=3, max_size=3, unique=True))
        tris.append(t)
    return pts, np.array(tris)


def _general_position(pts, tris) -> bool:
    """No 4 points coplanar among the corners of any two triangles (rational check), and
    no repeated triangle."""
    if len({tuple(sorted(t)) for t in tris}) < len(tris):
        return False
    P = [_q(p) for p in pts]
    for quad in combinations(range(len(pts)), 4):
        a, b, c, d = (P[k] for k in quad)
        if _dot(_sub(a, d), _cross(_sub(b, d), _sub(c, d))) == 0:
            return False
    return True


@settings(max_examples=150, deadline=None)
@given(small_meshes())
def test_certificate_matches_a_rational_brute_force(mesh):
    pts, tris = mesh
    if not _general_position(pts, tris):
        return
    got = {tuple(p) for p in intersecting_pairs(pts, tris).tolist()}
    assert got == brute_force(pts, tris)


@settings(max_examples=60, deadline=None)
@given(small_meshes())
def test_broad_phase_keeps_every_overlapping_box_once(mesh):
    pts, tris = mesh
    corners = pts[tris]
    lo, hi = corners.min(axis=1), corners.max(axis=1)
    want = {(i, j) for i, j in combinations(range(len(tris)), 2)
            if np.all(np.maximum(lo[i], lo[j]) <= np.minimum(hi[i], hi[j]))}
    got = candidate_pairs(corners).tolist()
    assert len(got) == len(set(map(tuple, got)))
    assert set(map(tuple, got)) == want


def test_orientation_is_exact_where_floats_round():
    # a, b, c on the line x = y = z: o(a, b, c, d) = 0 exactly, but not in floats
    t = [0.63696169, 0.26978671, 0.04097352]
    a, b, c = (np.full((1, 3), v) for v in t)
    d = np.array([[0.01652764, 0.81327024, 0.91275558]])
    u, v, w = a - d, b - d, c - d
    assert np.einsum("ij,ij->i", u, np.cross(v, w))[0] != 0  # floats round
    assert orient(a, b, c, d)[0] == 0
    assert orient(a, b, c + [[0.0, 0.0, 2.0 ** -50]], d)[0] != 0


def test_certificate_finds_a_crossing_and_not_a_touch():
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.3, 0.3, -1], [0.3, 0.3, 1]], float)
    np.testing.assert_array_equal(intersecting_pairs(pts, [[0, 1, 2], [0, 3, 4]]), [[0, 1]])
    assert len(intersecting_pairs(pts, [[0, 1, 2], [0, 4, 1]])) == 0  # a hinge
    # folded flat on the shared edge: coplanar, free corners on one side
    flat = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.5, 0.5, 0]], float)
    np.testing.assert_array_equal(intersecting_pairs(flat, [[0, 1, 2], [1, 0, 3]]), [[0, 1]])
    open_ = flat * [1, 1, 1] + [[0, 0, 0], [0, 0, 0], [0, 0, 0], [0, -1.0, 0]]
    assert len(intersecting_pairs(open_, [[0, 1, 2], [1, 0, 3]])) == 0


def test_fold_report_counts_only_what_the_frame_adds():
    from meshes import sphere

    ball = sphere(3)
    two_pts = np.vstack([ball.points, 0.9 * ball.points + [0.5, 0, 0]])
    two_tris = np.vstack([ball.triangles, ball.triangles + ball.n_points])
    rest_pairs = intersecting_pairs(two_pts, two_tris)
    assert len(rest_pairs) > 0
    rep = fold_report(two_pts, two_pts, two_tris)
    assert rep.ok and rep.at_rest == len(rest_pairs)
    moved = two_pts.copy()
    moved[ball.n_points:] -= [0.5, 0, 0]  # concentric, inside the first ball: apart
    rep = fold_report(two_pts, moved, two_tris)
    assert len(rep.added) == 0 and len(rep.turned) == 0
    moved[ball.n_points:] += [0.0, 0.0, 0.3]  # a ball of radius 0.9 at 0.3: crosses anew
    assert not fold_report(two_pts, moved, two_tris).ok
    from meshes import grid

    dome = grid(11, 11, bump=3.0)
    flipped = dome.points * [1, -1, -1]  # half a turn about x: every triangle turned over
    assert len(turned_over(dome.points, flipped, dome.triangles)) == dome.n_triangles
    assert len(turned_over(dome.points, dome.points, dome.triangles)) == 0
