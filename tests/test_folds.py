"""Folds that never intersect: the certificate (exact, against a rational brute force) and
the fold guard (synthetic valleys and lips, the built-in faces)."""
from fractions import Fraction
from itertools import combinations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wrinkle_vis.core.certificate import (
    candidate_pairs,
    fold_report,
    intersecting_pairs,
    orient,
    turned_over,
)
from wrinkle_vis.core.foldguard import (
    FoldGuard,
    guard_frame,
    medial_radii,
    pull_terms,
    skin_scale,
    soft_clamp,
    triangle_radii,
)
from wrinkle_vis.core.mesh import TriangleSurface

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
    """Every pair, in rational arithmetic: no shared vertex: the closed triangles meet (no
    separating axis); one shared vertex: the opposite edge of either meets the other (for
    triangles with area, also when coplanar); a shared edge: the free corners coplanar and
    on the same side of it."""
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
            u, v = sorted(common)
            fa = _q(points[next(x for x in a if x not in common)])
            fb = _q(points[next(x for x in b if x not in common)])
            pu, pv = _q(points[u]), _q(points[v])
            e = _sub(pv, pu)
            ca, cb = _cross(e, _sub(fa, pu)), _cross(e, _sub(fb, pu))
            hit = _dot(_cross(ca, cb), e) == 0 and not any(_cross(ca, cb)) and _dot(ca, cb) > 0
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


@st.composite
def lattice_meshes(draw):
    """Corners on the lattice {0, 1, 2}^3: coplanar and collinear configurations abound."""
    n = draw(st.integers(4, 9))
    pts = np.array(draw(st.lists(st.tuples(*[st.integers(0, 2)] * 3), min_size=n,
                                 max_size=n, unique=True)), float)
    tris = []
    for _ in range(draw(st.integers(2, 10))):
        t = draw(st.lists(st.integers(0, n - 1), min_size=3, max_size=3, unique=True))
        if np.any(np.cross(pts[t[1]] - pts[t[0]], pts[t[2]] - pts[t[0]])):  # has area
            tris.append(t)
    return pts * 0.1, np.array(tris, dtype=int).reshape(-1, 3)


@settings(max_examples=200, deadline=None)
@given(lattice_meshes())
def test_certificate_is_exact_on_degenerate_configurations(mesh):
    pts, tris = mesh
    if len({tuple(sorted(t)) for t in tris.tolist()}) < len(tris):
        return
    got, degenerate = intersecting_pairs(pts, tris, with_degenerate=True)
    assert not degenerate.any()
    assert {tuple(p) for p in got.tolist()} == brute_force(pts, tris)


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


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_grid_sweep_keeps_every_apart_overlapping_pair_once(seed):
    """Boxes of very different sizes widen the grid's cubes, and the pairs come from a sweep
    along x inside each cube: the same pairs as testing every pair."""
    from wrinkle_vis.core.certificate import _apart_pairs, _grid_cells

    rng = np.random.default_rng(seed)
    centres = np.repeat(rng.uniform(0, 1, (6, 3)), 12, axis=0)  # 6 clusters of 12 points
    far = np.array([[0, 0, 0], [1, 1, 1], [1, 0, 0], [0, 1, 1], [0, 1, 0], [1, 0, 1]])
    pts = np.concatenate([centres + rng.normal(0, 0.02, (72, 3)),
                          far + rng.normal(0, 0.01, (6, 3))])  # the cube's far corners
    small = [12 * rng.integers(6) + rng.choice(12, 3, replace=False) for _ in range(60)]
    large = [72 + rng.choice(6, 3, replace=False) for _ in range(4)]  # across the cube
    tris = np.array(small + large)
    corners = pts[tris]
    lo, hi = corners.min(axis=1), corners.max(axis=1)
    assert _grid_cells(lo.T, hi.T)[2]  # the cubes were widened: the sweep runs
    want = {(i, j) for i, j in combinations(range(len(tris)), 2)
            if np.all(np.maximum(lo[i], lo[j]) <= np.minimum(hi[i], hi[j]))
            and not set(tris[i]) & set(tris[j])}
    got = _apart_pairs(tris, pts).tolist()
    assert len(got) == len(set(map(tuple, got)))
    assert set(map(tuple, got)) == want


@settings(max_examples=80, deadline=None)
@given(small_meshes(), st.data())
def test_fold_report_tests_only_the_moved_region_and_finds_the_same(mesh, data):
    pts, tris = mesh
    moved = np.array(data.draw(st.lists(st.booleans(), min_size=len(pts), max_size=len(pts))))
    shift = np.array(data.draw(st.lists(st.floats(-1, 1, allow_nan=False,
                                                  allow_subnormal=False),
                                        min_size=3, max_size=3)))
    frame = pts + moved[:, None] * shift
    rest_pairs = intersecting_pairs(pts, tris)
    every = {tuple(p) for p in intersecting_pairs(frame, tris).tolist()}
    want = every - {tuple(p) for p in rest_pairs.tolist()}
    got = fold_report(pts, frame, tris, rest_pairs)
    assert {tuple(p) for p in got.added.tolist()} == want


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


# --- the fast broad phase against the reference it replaced (stop 36) -------------------


def _sorted_pairs(pairs, degenerate):
    order = np.lexsort((pairs[:, 1], pairs[:, 0]))
    return pairs[order], degenerate[order]


def _assert_as_reference(pts, tris):
    """The certificate equals the reference (every pair of overlapping boxes through the
    exact narrow phase, kept from before stop 36) pair for pair, degenerate flags too, and
    lists its pairs in lexicographic order."""
    from certificate_reference import intersecting_pairs as reference

    got, degenerate = intersecting_pairs(pts, tris, with_degenerate=True)
    want, want_degenerate = _sorted_pairs(*reference(pts, tris, with_degenerate=True))
    np.testing.assert_array_equal(got.reshape(-1, 2), want.reshape(-1, 2))
    np.testing.assert_array_equal(degenerate, want_degenerate)
    return got


@st.composite
def folded_grids(draw, most: int = 6):
    """A grid of ``nx x ny`` vertices on the integer lattice with heights in {-1, 0, 1}
    (coplanar quads, shared edges folded flat, vertices on faces abound), some vertices
    thrown across their neighbours, some triangles turned round or left out (boundaries,
    holes, misoriented edges)."""
    nx, ny = draw(st.integers(2, most)), draw(st.integers(2, most))
    x, y = np.meshgrid(np.arange(nx), np.arange(ny))
    z = np.array(draw(st.lists(st.integers(-1, 1), min_size=nx * ny, max_size=nx * ny)))
    pts = np.c_[x.ravel(), y.ravel(), z].astype(float)
    for k in draw(st.lists(st.integers(0, nx * ny - 1), max_size=3)):
        pts[k] += draw(st.tuples(*[st.integers(-2, 2)] * 3))
    idx = np.arange(nx * ny).reshape(ny, nx)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    tri = np.r_[np.c_[a, b, c], np.c_[a, c, d]]
    turn = np.array(draw(st.lists(st.booleans(), min_size=len(tri), max_size=len(tri))))
    tri[turn & (np.arange(len(tri)) % 5 == 0)] = tri[turn & (np.arange(len(tri)) % 5 == 0)][
        :, ::-1]
    keep = np.array(draw(st.lists(st.booleans(), min_size=len(tri), max_size=len(tri))))
    keep |= np.arange(len(tri)) % 3 != 0
    return pts * draw(st.sampled_from([1.0, 0.1, 1e-3])), tri[keep]


@settings(max_examples=150, deadline=None)
@given(folded_grids())
def test_certificate_equals_the_reference_on_folded_grids(mesh):
    pts, tris = mesh
    _assert_as_reference(pts, tris)


@settings(max_examples=40, deadline=None)
@given(folded_grids(most=4))
def test_certificate_equals_a_rational_brute_force_on_folded_grids(mesh):
    pts, tris = mesh
    corners = pts[tris]
    if not np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]).any(
            axis=1).all():
        return  # the brute force does not call contacts with flat triangles
    got = _assert_as_reference(pts, tris)
    assert {tuple(p) for p in got.tolist()} == brute_force(pts, tris)


def _fan(angles, heights, closed=True, radius=None):
    """A fan of triangles around a vertex at the origin, its rim at ``angles`` and
    ``heights`` (closed: the last rim vertex joins the first)."""
    angles = np.asarray(angles, float)
    r = np.ones_like(angles) if radius is None else np.asarray(radius, float)
    rim = np.c_[r * np.cos(angles), r * np.sin(angles), heights]
    pts = np.vstack([[0.0, 0.0, 0.0], rim])
    k = np.arange(1, len(angles) + 1)
    nxt = np.roll(k, -1) if closed else k[1:]
    tri = np.c_[np.zeros(len(nxt), int), k[:len(nxt)], nxt]
    return pts, tri


def test_the_star_test_clears_only_stars_that_wind_once():
    from wrinkle_vis.core.certificate import _abs_cross, _clear_stars
    from wrinkle_vis.core.certificate import _cross as cross

    def clear(pts, tri):
        c = pts[tri]
        e1, e2 = c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]
        return _clear_stars(pts, tri, cross(e1, e2), _abs_cross(e1, e2))[0]

    once = _fan(np.linspace(0, 2 * np.pi, 7)[:-1], 0.1 * np.sin(np.arange(6)))
    assert clear(*once) and len(_assert_as_reference(*once)) == 0
    # around twice, the heights going up and down: the two sheets cross (intermediate
    # values), and every sector turns the same way, every edge is shared twice
    twice = _fan(np.linspace(0, 4 * np.pi, 11)[:-1], 0.3 * np.cos(np.linspace(0, 2 * np.pi,
                                                                       11)[:-1]))
    assert not clear(*twice)
    got = _assert_as_reference(*twice)
    assert len(got) > 0 and {tuple(p) for p in got.tolist()} == brute_force(*twice)
    # an open fan (a boundary vertex) over more than a turn, its last sector tilted
    # through the plane of the first ones
    # through the plane of the first ones; turned about z, so that the direction the
    # winding is counted along falls both in and out of the overlap
    for turn in np.linspace(0, 2 * np.pi, 8, endpoint=False):
        spiral = _fan(turn + np.linspace(0, 2.4 * np.pi, 9), [0, 0, 0, 0, 0, 0, 0, 0.2, -0.2],
                      closed=False, radius=np.linspace(1.0, 0.6, 9))
        assert not clear(*spiral)
        got = _assert_as_reference(*spiral)
        assert len(got) > 0 and {tuple(p) for p in got.tolist()} == brute_force(*spiral)
    # two cones touching at their apex (two cycles at one vertex): only the apex is shared
    up, tu = _fan(np.linspace(0, 2 * np.pi, 6)[:-1], np.full(5, 1.0))
    down, td = _fan(np.linspace(0, 2 * np.pi, 6)[:-1] + 0.3, np.full(5, -1.0))
    pts = np.vstack([up, down[1:]])
    tri = np.vstack([tu, np.where(td[:, ::-1] == 0, 0, td[:, ::-1] + 5)])
    assert not clear(pts, tri)
    assert len(_assert_as_reference(pts, tri)) == 0 and brute_force(pts, tri) == set()


def test_certificate_equals_the_reference_on_touching_configurations():
    tri = np.array([[0, 1, 2], [3, 4, 5]])
    base = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    for other in ([[0.25, 0.25, 0], [1, 1, 1], [1, -1, 1]],  # a vertex on the other's face
                  [[1, 0, 0.5], [2, 0, 0.5], [1.5, 1, 0.5]],  # apart, one plane above
                  [[0.5, 0.5, 0], [1.5, 0.5, 0], [0.5, 1.5, 0]],  # coplanar, touching
                  [[0.5, 0.5, 0], [0.5, -0.5, 0], [2, 0, 0]],  # coplanar, overlapping
                  [[0.5, 0.5, -1], [0.5, 0.5, 1], [2, 2, 0]]):  # an edge through an edge
        pts = np.vstack([base, other])
        got = _assert_as_reference(pts, tri)
        assert {tuple(p) for p in got.tolist()} == brute_force(pts, tri)


@pytest.mark.parametrize("scene", ["valley", "lips", "spheres"])
def test_certificate_equals_the_reference_on_the_stress_scenes(scene):
    if scene == "spheres":
        from meshes import sphere

        ball = sphere(3)
        pts = np.vstack([ball.points, 0.9 * ball.points + [0.5, 0, 0]])
        tri = np.vstack([ball.triangles, ball.triangles + ball.n_points])
        assert len(_assert_as_reference(pts, tri)) > 0
        return
    skin, W = valley() if scene == "valley" else lips()
    raw = skin.points + W[:, None] * skin.vertex_normals()
    assert len(_assert_as_reference(raw, skin.triangles)) > 0  # the unguarded folds
    _assert_as_reference(skin.points, skin.triangles)


@pytest.mark.slow
def test_certificate_equals_the_reference_on_the_heads_frames(head):
    _assert_as_reference(head.skin.points, head.skin.triangles)
    for expr in ("smile", "pucker"):
        s = head.evaluate(expr, fold_guard=False)
        assert len(_assert_as_reference(s.points, s.triangles)) > 0


# --- the fold guard on synthetic scenes -------------------------------------------------



def _sheet(nx, ny, height, flip=False, width=20.0):
    """A ``width x 20`` sheet ``z = height(x, y)``, facing +z (or -z with ``flip``), its
    heights jittered by 1e-4 (a grid on a translation surface has exactly planar quads: the
    certificate's slow rational path)."""
    x, y = np.meshgrid(np.linspace(-width / 2, width / 2, nx), np.linspace(-10, 10, ny))
    jitter = 1e-4 * np.random.default_rng(nx * ny).standard_normal(x.shape)
    pts = np.c_[x.ravel(), y.ravel(), (height(x, y) + jitter).ravel()]
    idx = np.arange(nx * ny).reshape(ny, nx)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    tri = np.r_[np.c_[a, b, c], np.c_[a, c, d]]
    return pts, (tri[:, ::-1] if flip else tri)


def valley():
    """A narrow valley (walls 8 high, 3 wide at half height) with wrinkles on both walls
    bulging into it (W up to 2, along the outward normal)."""
    pts, tri = _sheet(161, 41, lambda x, y: 8.0 * np.tanh(np.abs(x)) ** 2 + 0.01 * y * y,
                      width=40.0)
    skin = TriangleSurface(pts, tri)
    x, y = pts[:, 0], pts[:, 1]
    W = 2.0 * np.exp(-((np.abs(x) - 1.5) / 0.8) ** 2) * (0.5 + 0.5 * np.cos(np.pi * y / 2.5))
    return skin, W


def lips():
    """Two gently curved sheets 2 apart facing each other, with a band of wrinkled bulges
    (1.4 high) towards each other."""
    a, ta = _sheet(81, 41, lambda x, y: 0.002 * (x * x + y * y), width=40.0)
    b, tb = _sheet(81, 41, lambda x, y: 2.0 - 0.002 * (x * x + y * y), flip=True, width=40.0)
    skin = TriangleSurface(np.vstack([a, b]), np.vstack([ta, tb + len(a)]))
    x, y = skin.points[:, 0], skin.points[:, 1]
    W = 1.4 * np.exp(-x * x / 2.0) * np.maximum(np.cos(np.pi * y / 3.0), 0.0)
    return skin, W


@pytest.mark.parametrize("scene", [valley, lips])
def test_the_guard_keeps_wrinkles_pushed_into_each_other_apart(scene):
    skin, W = scene()
    n = skin.vertex_normals()
    raw = skin.points + W[:, None] * n
    assert len(fold_report(skin.points, raw, skin.triangles).added) > 0  # unguarded: folds
    radii = medial_radii(skin.points, n)
    g = guard_frame(skin.points, skin.points, raw, W, skin.triangles, radii)
    assert fold_report(skin.points, g.points, skin.triangles).ok
    changed = g.W != W
    assert 0 < changed.sum() <= 0.1 * len(W)
    np.testing.assert_array_equal(g.points[~changed], raw[~changed])  # untouched elsewhere



def _sheet_under_a_large_triangle(gap: float):
    """A fan of six triangles (edges 1) at z = 0 under one large triangle at z = ``gap``
    whose corners lie 10 away: every ball tangent at the fan's centre up to radius 20 is
    empty of vertices, but any of radius above ``gap / 2`` holds part of the triangle."""
    angles = np.arange(6) * np.pi / 3.0
    fan = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(6)])
    big = 10.0 * np.column_stack([np.cos(angles[::2] + 0.3), np.sin(angles[::2] + 0.3),
                                  np.zeros(3)]) + [0.0, 0.0, gap]
    pts = np.vstack([[0.0, 0.0, 0.0], fan, big])
    tri = np.array([[0, 1 + k, 1 + (k + 1) % 6] for k in range(6)] + [[9, 8, 7]])
    return pts, tri


def test_a_ball_empty_of_vertices_is_lowered_to_one_empty_of_triangles():
    gap = 0.5
    pts, tri = _sheet_under_a_large_triangle(gap)
    n = np.tile([0.0, 0.0, 1.0], (len(pts), 1))
    r = medial_radii(pts[:1], n[:1], samples=pts)
    assert r[0, 0] > 20.0  # the vertices alone: a ball far larger than the gap
    t = triangle_radii(np.array([0]), n[:1], r, pts, tri)
    np.testing.assert_allclose(t[0, 0], gap / 2.0, rtol=1e-6)  # the ball touching z = gap
    assert t[0, 1] == r[0, 1]  # below: nothing but the fan itself


def test_the_deformed_balls_keep_a_wrinkle_from_passing_through_a_triangle():
    """A wrinkle at the fan's centre, 1.2 times the gap to the triangle above, passes through
    it unguarded; the rest radii say nothing (the caller's, huge), and the deformed skin's
    balls, empty of triangles, hold W below the gap."""
    gap = 0.5
    pts, tri = _sheet_under_a_large_triangle(gap)
    W = np.zeros(len(pts))
    W[0] = 1.2 * gap
    step = np.zeros_like(pts)
    step[0, 2] = W[0]
    raw = pts + step
    assert len(fold_report(pts, raw, tri).added) > 0
    radii = np.full((len(pts), 2), 1e3)
    g = guard_frame(pts, pts, raw, W, tri, radii, pulls=False, deformed_radii=True)
    assert fold_report(pts, g.points, tri).ok
    assert 0.0 < g.W[0] < FoldGuard().eta_deformed * gap / 2.0

def _fine_sheet_under_coarse_triangles(seed: int):
    """A bumpy fine sheet (edges about 1, jittered in the plane, x in [-10, 10]) under a
    bumpy coarse one (edges about 5-7, x in [4, 19]) a random gap above, and two random
    slivers over it: balls at the fine sheet's vertices reach the coarse triangles between
    their corners (and those far from the coarse sheet do not)."""
    rng = np.random.default_rng(seed)
    fine, tri = _sheet(21, 21, lambda x, y: 0.6 * np.sin(0.5 * x + seed) * np.cos(0.4 * y))
    fine[:, :2] += rng.uniform(-0.2, 0.2, (len(fine), 2))
    coarse, ctri = _sheet(4, 4, lambda x, y: 0.5 * np.cos(0.3 * x - seed), flip=True,
                          width=15.0)
    coarse[:, 0] += 11.5
    coarse[:, 2] += rng.uniform(0.3, 2.5) + rng.uniform(-0.3, 0.3, len(coarse))
    sliver = rng.uniform(-6, 6, (6, 3)) * [1, 1, 0.3] + [12.0, 0, 1.0]
    pts = np.vstack([fine, coarse, sliver])
    k, s0 = len(fine), len(fine) + len(coarse)
    tri = np.vstack([tri, ctri + k, [[s0, s0 + 1, s0 + 2], [s0 + 3, s0 + 4, s0 + 5]]])
    return pts, tri, k


def _brute_meets(pts, tri, centres, radii, own):
    """(ball, triangle) pairs of every triangle not incident to ``own`` that comes nearer
    than its ball's radius to the centre, by the closest point of every triangle."""
    from wrinkle_vis.core.foldguard import _closest_on_triangles

    b = np.repeat(np.arange(len(centres)), len(tri))
    t = np.tile(np.arange(len(tri)), len(centres))
    q = _closest_on_triangles(centres[b], pts[tri[t, 0]], pts[tri[t, 1]], pts[tri[t, 2]])
    inside = np.linalg.norm(q - centres[b], axis=1) < radii[b]
    inside &= ~(tri[t] == own[b, None]).any(axis=1)
    return set(zip(b[inside].tolist(), t[inside].tolist(), strict=True))


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_the_cheap_filter_never_clears_a_ball_a_triangle_enters(seed):
    """``_suspects`` (and the 2-nearest clearing ``_cleared`` it starts with) against every
    triangle's closest point: each ball that any triangle not its vertex's own enters keeps
    that triangle among its candidates, once."""
    from wrinkle_vis.core.foldguard import _cleared, _lift, _suspects

    pts, tri, k = _fine_sheet_under_coarse_triangles(seed)
    rng = np.random.default_rng(seed)
    own = rng.integers(0, k, 300)
    n = np.tile([0.0, 0.0, 1.0], (len(own), 1))
    r = rng.uniform(0.05, 3.0, len(own))
    c = pts[own] + r[:, None] * n
    lift = _lift(pts, tri)
    truth = _brute_meets(pts, tri, c, r, own)
    ball, t = _suspects(lift, c, r, own, pts, tri)
    got = list(zip(ball.tolist(), t.tolist(), strict=True))
    assert len(got) == len(set(got))  # each pair once
    assert truth <= set(got)
    met = {b for b, _ in truth}
    cleared = np.flatnonzero(_cleared(lift, c, r, own))
    assert not met & set(cleared.tolist())
    assert 0.1 < len(cleared) / len(own) < 0.9  # both kinds of ball are there
    assert len(truth) > 0


def _brute_triangle_radii(ids, normals, radii, pts, tri, iterations=60):
    """The shrinking ball on every triangle not incident to the vertex (no candidates)."""
    from wrinkle_vis.core.foldguard import _closest_on_triangles

    out = np.array(radii, dtype=float)
    for i, v in enumerate(ids):
        others = tri[~(tri == v).any(axis=1)]
        a, b, c = pts[others[:, 0]], pts[others[:, 1]], pts[others[:, 2]]
        for col, sign in ((0, 1.0), (1, -1.0)):
            r, x, nv = out[i, col], pts[v], sign * normals[i]
            for _ in range(iterations if r > 0 else 0):
                centre = np.broadcast_to(x + r * nv, a.shape)
                q = _closest_on_triangles(centre, a, b, c)
                dq = np.einsum("ij,ij->i", q - centre, q - centre)
                inside = dq < (r * (1.0 - 1e-9)) ** 2
                if not inside.any():
                    break
                d = q[inside] - x
                h = d @ nv
                r = min(r, float(np.min(np.where(h > 0, np.einsum("ij,ij->i", d, d)
                                                 / (2.0 * np.where(h > 0, h, 1.0)), 0.0))))
            out[i, col] = r
    return out


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_triangle_radii_are_the_search_on_every_triangle(seed):
    """The balls emptied of triangles through the filtered candidates are the shrinking-ball
    search on every triangle not incident to the vertex, to rounding (rest radii of the
    fine sheet, both sides, from the vertex search)."""
    pts, tri, k = _fine_sheet_under_coarse_triangles(seed)
    rng = np.random.default_rng(seed)
    ids = np.sort(rng.choice(k, 40, replace=False))
    n = TriangleSurface(pts, tri).vertex_normals()[ids]
    r = medial_radii(pts[ids], n, samples=pts)
    got = triangle_radii(ids, n, r, pts, tri)
    np.testing.assert_allclose(got, _brute_triangle_radii(ids, n, r, pts, tri), rtol=1e-12)
    assert (got < r).any()  # the triangles did lower some


def test_soft_clamp_is_the_identity_below_the_knee_and_c1():
    x = np.linspace(-3, 3, 6001)
    c = soft_clamp(x, np.full_like(x, 1.0), 0.5)
    inside = np.abs(x) <= 0.5
    np.testing.assert_array_equal(c[inside], x[inside])
    assert np.all(np.abs(c) < 1.0) and np.all(np.diff(c) > 0)
    slope = np.diff(c) / np.diff(x)
    assert np.max(np.abs(np.diff(slope))) < 1e-2  # no kink at the knee


def test_medial_radii_of_a_sphere_and_a_slab():
    from meshes import sphere

    ball = sphere(4, radius=3.0)
    radial = ball.points / 3.0
    r = medial_radii(ball.points, radial)
    np.testing.assert_allclose(r[:, 1], 3.0, rtol=1e-9)  # inside: the ball itself
    cap = np.c_[np.full(len(radial), 2.0), np.zeros(len(radial))]  # one side, from 2 down
    np.testing.assert_array_equal(medial_radii(ball.points, radial, r_max=cap), cap)
    cap = np.c_[np.zeros(len(radial)), np.full(len(radial), 5.0)]  # the balls tangent nest
    np.testing.assert_allclose(medial_radii(ball.points, radial, r_max=cap)[:, 1], 3.0,
                               rtol=1e-9)
    assert np.all(r[:, 0] > 9.0)  # outside: empty up to the cap (the box diagonal)
    r = medial_radii(ball.points, ball.vertex_normals())  # normals a little off radial
    assert np.all(r[:, 1] <= 3.0 + 1e-9) and np.all(r[:, 1] > 0.8 * 3.0)
    skin, _ = lips()
    r = medial_radii(skin.points, skin.vertex_normals())
    centre = np.linalg.norm(skin.points[:, :2], axis=1) < 1.0
    np.testing.assert_allclose(r[centre, 0], 1.0, rtol=0.05)  # half the gap


def test_the_pull_guard_keeps_triangles_from_turning_over():
    pts, tri = _sheet(41, 41, lambda x, y: 0.02 * x * x)
    x = pts[:, 0]
    pull = np.zeros_like(pts)
    pull[:, 0] = -6.0 * np.exp(-((x - 2.0) / 1.5) ** 2)  # drags skin over its neighbour
    bent = pts + pull
    assert len(turned_over(pts, bent, tri)) > 0
    f = skin_scale(pts, bent, tri)
    guarded = pts + f[:, None] * pull
    assert fold_report(pts, guarded, tri).ok
    assert 0.1 < f.min() < 1.0
    faint = np.abs(pull[:, 0]) < 1e-3 * np.abs(pull[:, 0]).max()
    assert faint.mean() > 0.25
    np.testing.assert_array_equal(f[faint], 1.0)  # the guard stays where the pull is
    assert np.mean(f < 1.0) <= 0.4  # the pulled band is about a third of the sheet
    e = np.vstack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    size = np.linalg.norm(pull, axis=1)
    shear = np.abs(f[e[:, 0]] - f[e[:, 1]]) * np.maximum(size[e[:, 0]], size[e[:, 1]])
    edge = np.linalg.norm(pts[e[:, 0]] - pts[e[:, 1]], axis=1)
    assert np.max(shear / edge) < 0.75  # the factor varies slowly against the pull
    assert FoldGuard().min_area == 0.2



def test_the_pull_guard_does_not_depend_on_the_order_of_the_edges_given():
    pts, tri = _sheet(41, 41, lambda x, y: 0.02 * x * x)
    pull = np.zeros_like(pts)
    pull[:, 0] = -6.0 * np.exp(-((pts[:, 0] - 2.0) / 1.5) ** 2)
    edges = TriangleSurface(pts, tri).edges
    shuffled = edges[np.random.default_rng(3).permutation(len(edges))]
    f = skin_scale(pts, pts + pull, tri, terms=pull_terms(pts, tri, edges))
    g = skin_scale(pts, pts + pull, tri, terms=pull_terms(pts, tri, shuffled))
    assert f.min() < 0.5  # the guard acts (the Dijkstra limits matter)
    np.testing.assert_array_equal(f, g)

# --- the built-in faces ------------------------------------------------------------------


@pytest.fixture(scope="module")
def procedural():
    import wrinkle_vis as wv

    return wv.datasets.load_face()


@pytest.fixture(scope="module")
def head(wv_head):
    return wv_head.with_skin_model(wv_head.skin_model)  # the session's caches (conftest)


@pytest.mark.parametrize("refine, names, intensities", [
    (False, None, (0.5, 1.0)),
    (True, ("surprise", "frown", "pucker"), (1.0,)),
    pytest.param(True, None, (0.25, 0.5, 1.0), marks=pytest.mark.slow),
])
def test_the_procedural_face_never_folds_and_the_guard_leaves_it_be(procedural, refine, names,
                                                                     intensities):
    for name in names or procedural.expressions:
        for intensity in intensities:
            s = procedural.evaluate(name, intensity, refine=refine)
            assert fold_report(s.rest_points, s.points, s.triangles).ok, (name, intensity)
            raw = procedural.evaluate(name, intensity, refine=refine, fold_guard=False)
            acted = s.fold_guard > 0
            if refine:  # the deformed skin's radii: a little near the pressed lips
                assert acted.mean() <= 0.01, (name, intensity)
            else:  # the paper's figures, bit for bit
                assert not acted.any(), (name, intensity)
            np.testing.assert_array_equal(s.points[~acted], raw.points[~acted])


@pytest.mark.slow
def test_the_guard_keeps_the_head_scans_pulls_from_turning_skin_over(head):
    rest_pairs = intersecting_pairs(head.skin.points, head.skin.triangles)
    worse = 0
    for name in head.expressions:
        for intensity in (0.5, 1.0):
            s = head.evaluate(name, intensity)
            assert len(turned_over(s.rest_points, s.points, s.triangles)) == 0, name
            if intensity == 1.0 and name in ("smile", "duchenne_smile"):
                raw = head.evaluate(name, intensity, fold_guard=False)
                assert len(turned_over(raw.rest_points, raw.points, raw.triangles)) > 0
                guarded = fold_report(s.rest_points, s.points, s.triangles, rest_pairs)
                unguarded = fold_report(raw.rest_points, raw.points, raw.triangles, rest_pairs)
                worse += len(guarded.added) >= len(unguarded.added)
    assert worse == 0


@pytest.mark.slow
def test_refined_head_frames_turn_no_triangle_over(head):
    for name in ("smile", "duchenne_smile", "waters_sadness"):
        raw = head.evaluate(name, 1.0, refine=True, fold_guard=False)
        assert len(turned_over(raw.rest_points, raw.points, raw.triangles)) > 100, name
        s = head.evaluate(name, 1.0, refine=True)
        assert len(turned_over(s.rest_points, s.points, s.triangles)) == 0, name
        assert np.mean(s.fold_guard > 0) < 0.6  # refined vertices crowd the mouth


def test_the_heads_rest_skin_crosses_itself_nowhere(head):
    # main's head: 125 pairs at rest (the eyelids, 122, and an ear, 3), since stop 36's lips
    skin = head.skin
    assert len(intersecting_pairs(skin.points, skin.triangles)) == 0


@pytest.mark.slow
@pytest.mark.parametrize("intensity", (0.25, 0.5, 0.75, 1.0))
def test_no_head_expression_adds_a_crossing_or_turns_a_triangle_unrefined(head, intensity):
    # main's head: the eyelids add up to 48 pairs (squint, the Duchenne smile at 1)
    face = head.with_skin_model("geometric")
    rest = intersecting_pairs(face.skin.points, face.skin.triangles)
    for name in face.expressions:
        s = face.evaluate(name, intensity)
        assert fold_report(s.rest_points, s.points, s.triangles, rest).ok, name


@pytest.mark.slow
def test_the_physical_skin_moves_the_heads_eyelids_without_a_crossing(head):
    # main's head: 14-48 pairs added at the eyelids (squint, the Duchenne smile at 0.25-1)
    face = head.with_skin_model("physical")
    rest = intersecting_pairs(face.skin.points, face.skin.triangles)
    for name in ("squint", "duchenne_smile", "waters_happiness", "waters_anger",
                 "waters_disgust"):
        for intensity in (0.5, 1.0):
            s = face.evaluate(name, intensity)
            assert fold_report(s.rest_points, s.points, s.triangles, rest).ok, name


@pytest.mark.slow
def test_the_heads_refined_mouth_corners_take_the_pulls_without_a_crossing(head):
    # main's head: 3-11 pairs at the right mouth corner, geometric and physical skin
    for model, frames in (("geometric", (("pucker", 0.25), ("waters_sadness", 0.5),
                                         ("waters_fear", 1.0))),
                          ("physical", (("waters_sadness", 0.75), ("waters_fear", 1.0)))):
        face = head.with_skin_model(model)
        for name, intensity in frames:
            s = face.evaluate(name, intensity, refine=True)
            rest = intersecting_pairs(s.rest_points, s.triangles)
            assert fold_report(s.rest_points, s.points, s.triangles, rest).ok, (model, name)


@pytest.mark.slow
@pytest.mark.parametrize("intensity", (0.25, 0.5, 0.75, 1.0))
def test_refined_head_expressions_add_no_crossing(head, intensity):
    # main's head: the eyelids add up to 255 pairs (squint, the Duchenne smile at 1); before
    # the guard's balls were empty of triangles, 4-5 pairs at the left eye's outer corner
    # (squint and the Duchenne smile at 0.75 and 1, Waters' happiness at 1)
    face = head.with_skin_model("geometric")
    for name in face.expressions:
        s = face.evaluate(name, intensity, refine=True)
        rest = intersecting_pairs(s.rest_points, s.triangles)
        r = fold_report(s.rest_points, s.points, s.triangles, rest)
        assert len(r.turned) == 0, name
        assert len(r.added) == 0, name
        assert len(rest) == 0, name  # the smooth surface through the rest skin: clean too


def _scaled_k0(face, factor):
    import dataclasses

    for m in face.muscles:
        face = face.with_muscle(dataclasses.replace(m, k0=m.k0 * factor), replacing=m.name)
    return face


@pytest.mark.slow
def test_stress_k0_five_times_unrefined_stays_clean(procedural):
    face = _scaled_k0(procedural.with_skin_model("geometric"), 5.0)  # k0 scales W alone
    for name in face.expressions:
        for intensity in (0.25, 0.5, 1.0):
            s = face.evaluate(name, intensity)
            assert fold_report(s.rest_points, s.points, s.triangles).ok, (name, intensity)


@pytest.mark.slow
def test_stress_k0_five_times_refined_stays_clean(procedural):
    face = _scaled_k0(procedural.with_skin_model("geometric"), 5.0)  # k0 scales W alone
    for name in ("pucker", "waters_anger"):  # unguarded, these cross and turn over
        raw = face.evaluate(name, 1.0, refine=True, fold_guard=False)
        assert not fold_report(raw.rest_points, raw.points, raw.triangles).ok, name
    for name in face.expressions:
        for intensity in (0.5, 1.0):
            s = face.evaluate(name, intensity, refine=True)
            assert fold_report(s.rest_points, s.points, s.triangles).ok, (name, intensity)


#: Crossing pairs that refined head frames with k0 at 5x its default still add (0 wherever
#: not listed): none since stop 41, when the fans' guard became the default on refined
#: frames (``FoldGuard(fans="refined")``, docs/model.md "The fans"). Stop 38 left 4 + 4 at
#: the left eye's outer corner (``EYE_CORNER``), where the rest skin folds on itself and
#: W's step folded a vertex's own fan over its neighbours, which no ball sees.
#: The guard of balls empty of vertices (stop 37): 5-27 pairs in 17 geometric and 5-10
#: pairs in 17 physical frames of these expressions.
HEAD_STRESS_LEFT: dict = {}

#: The crossing pairs those two frames add with the fans' guard off (``fans=False``).
EYE_CORNER = {("geometric", "duchenne_smile", 1.0): 4, ("geometric", "squint", 1.0): 4}


@pytest.mark.slow
@pytest.mark.parametrize("model", ("geometric", "physical"))
def test_stress_k0_five_times_refined_head_adds_no_crossing(head, model):
    face = _scaled_k0(head.with_skin_model(model), 5.0)
    for name in ("duchenne_smile", "squint", "waters_happiness", "waters_anger",
                 "waters_disgust"):  # those that cross on main's guard
        for intensity in (0.25, 0.5, 0.75, 1.0):
            s = face.evaluate(name, intensity, refine=True)
            rest = intersecting_pairs(s.rest_points, s.triangles)
            r = fold_report(s.rest_points, s.points, s.triangles, rest)
            assert len(r.turned) == 0, (name, intensity)
            assert len(r.added) <= HEAD_STRESS_LEFT.get((model, name, intensity), 0), \
                (name, intensity)


@pytest.mark.slow
def test_stress_k0_five_times_the_default_fans_clear_the_eye_corner(head):
    """The two frames the guard leaves without the fans (``EYE_CORNER``: they cross
    there) add no crossing and turn no triangle with the default guard, whose fans are on
    for refined frames, nor with the fans on everywhere."""
    from wrinkle_vis.core.foldguard import FoldGuard, guarded

    face = _scaled_k0(head.with_skin_model("geometric"), 5.0)
    for (_, name, intensity), left in EYE_CORNER.items():
        raw = face.evaluate(name, intensity, refine=True, fold_guard=False)
        rest = intersecting_pairs(raw.rest_points, raw.triangles)
        without = guarded(face, face.evaluate(name, intensity, refine=True, fold_guard=False),
                          FoldGuard(fans=False))
        assert len(fold_report(without.rest_points, without.points, without.triangles,
                               rest).added) == left
        for s in (face.evaluate(name, intensity, refine=True),
                  guarded(face, face.evaluate(name, intensity, refine=True, fold_guard=False),
                          FoldGuard(fans=True))):
            r = fold_report(s.rest_points, s.points, s.triangles, rest)
            assert len(r.turned) == 0 and len(r.added) == 0, (name, intensity, len(r.added))


def test_cli_fold_guard_flag_reaches_the_exported_fields(tmp_path):
    import pyvista as pv

    from wrinkle_vis.cli import main

    arrays = {}
    for flag in ("on", "off"):
        out = tmp_path / f"smile_{flag}.vtp"
        assert main(["export", "--face", "lee_perry_smith", "-e", "smile", "--fold-guard",
                     flag, "-o", str(out)]) == 0
        arrays[flag] = pv.read(out).point_data
    assert np.any(arrays["on"]["fold_guard"] > 0)
    assert not np.any(arrays["off"]["fold_guard"])
    np.testing.assert_array_equal(arrays["off"]["W"], arrays["off"]["W_raw"])
    np.testing.assert_array_equal(arrays["on"]["W_raw"], arrays["off"]["W"])


def test_the_guard_field_is_described_once_and_read_by_state_and_probe(head):
    from wrinkle_vis.app.session import Session
    from wrinkle_vis.core.face import FIELD_NAMES
    from wrinkle_vis.core.fields import FRAME_FIELDS, check_field, field_spec

    assert "fold_guard" in FRAME_FIELDS and "fold_guard" not in FIELD_NAMES
    spec = field_spec("fold_guard")
    assert spec.total and spec.where == "frame" and spec.limits == (0.0, 1.0)
    assert check_field("fold_guard") is spec  # a total: no muscle needed
    s = head.evaluate("smile")
    np.testing.assert_array_equal(s.field_values("fold_guard"), s.fold_guard)
    m = head.muscle_names[0]
    np.testing.assert_array_equal(s.field_values("fold_guard", m), s.fold_guard)
    assert np.isnan(s.fields[m]["fold_guard"]).all()  # not one muscle's field
    v = int(np.argmax(s.fold_guard))
    assert s.fold_guard[v] > 0
    session = Session(head)
    session.set_expression("smile")
    assert session.probe(v)["total"]["fold_guard"] == s.fold_guard[v]


def test_the_apps_field_box_shows_the_guard_field(window):
    from qtpy import QtCore

    box = window.field_box
    tips = {box.itemText(i): box.itemData(i, QtCore.Qt.ToolTipRole) for i in range(box.count())}
    assert tips["fold_guard"].startswith("g: fold guard")
    box.setCurrentText("fold_guard")
    assert window.session.field == "fold_guard" and window.session.muscle is None
    state = window.session.state()
    np.testing.assert_array_equal(window.session.field_values(state), state.fold_guard)


def test_the_fields_see_the_guarded_pull(head):
    s = head.evaluate("smile")
    raw = head.evaluate("smile", fold_guard=False)
    assert np.any(s.fold_guard > 0)
    again = head._frame(dict(s.activations), s.deformed_points)  # Eq. 9-11 on that skin
    changed = 0
    for m in (k for k, a in s.activations.items() if a > 0):
        for key in ("eps", "A", "W"):
            np.testing.assert_array_equal(s.fields[m][key], again.fields[m][key])
        changed += np.sum(~np.isclose(s.fields[m]["eps"], raw.fields[m]["eps"],
                                      equal_nan=True))
    assert changed > 0
    np.testing.assert_array_equal(s.W_raw, raw.W)


def test_rest_radii_are_searched_as_far_as_a_frame_needs():
    """The rest radii searched up to what a frame needs are the true ones wherever they are
    below it (the balls tangent at a point on one side nest) and at least what is needed
    elsewhere; a later frame that needs more searches again, one that needs less does not.
    """
    import wrinkle_vis as wv
    from wrinkle_vis.core import foldguard

    face = wv.datasets.load_face(n_triangles=1200)
    pts, nrm = face.skin.points, face._rest.normals
    full = triangle_radii(np.arange(len(pts)), nrm, medial_radii(pts, nrm), pts,
                          face.skin.triangles)  # the balls empty of the skin's triangles
    rng = np.random.default_rng(3)
    need = np.c_[rng.uniform(0, 20, len(pts)), rng.uniform(0, 20, len(pts))]
    need[rng.random(len(pts)) < 0.3] = 0.0
    got = foldguard._rest_radii(face, need).copy()
    below = full < need
    assert 0.05 < below[need > 0].mean() < 0.95  # both kinds of vertex are there
    # (each search stops at a ball no triangle enters by more than 1e-9 of its radius:
    # the radius to within 2e-9 (r / s)^2, s the distance to the triangle)
    np.testing.assert_allclose(got[below], full[below], rtol=1e-7)
    assert np.all(got[~below] >= need[~below] * (1 - 1e-12))
    calls = []
    real = foldguard.medial_radii
    foldguard.balls.medial_radii = lambda *a, **k: calls.append(len(a[0])) or real(*a, **k)
    try:
        foldguard._rest_radii(face, 0.5 * need)
        assert calls == []  # known far enough already
        more = foldguard._rest_radii(face, 2.0 * need).copy()
        assert calls and calls[0] < len(pts)  # only the vertices not yet known that far
    finally:
        foldguard.balls.medial_radii = real
    below = full < 2.0 * need
    np.testing.assert_allclose(more[below], full[below], rtol=1e-7)


def test_the_guard_on_needed_radii_gives_the_frame_of_the_true_radii(monkeypatch):
    """A guarded frame on the radii searched as far as its W needs is the one the true radii
    (searched from the whole diagonal, at every vertex) give, to the search's tolerance (a
    ball that a triangle's face stops ends through a point of the face that depends on
    where the search started, by a few ulps here: 1e-14 at one vertex); radii searched less
    far give another frame (the test can fail)."""
    import wrinkle_vis as wv
    from wrinkle_vis.core import foldguard

    true_radii = foldguard.fold_radii

    def frame(how):
        face = _scaled_k0(wv.datasets.load_face(n_triangles=1200), 10.0)
        if how == "true":
            pts, nrm = face.skin.points, face._rest.normals
            full = triangle_radii(np.arange(len(pts)), nrm, medial_radii(pts, nrm), pts,
                                  face.skin.triangles)
            monkeypatch.setattr(foldguard.frame, "fold_radii", lambda *a, **k: full.copy())
        elif how == "short":  # half as far as needed: the clamp sees smaller radii
            monkeypatch.setattr(foldguard.frame, "fold_radii", lambda f, s, W, g: true_radii(
                f, s, 0.25 * np.asarray(W), g))
        s = face.evaluate("pucker", 1.0)
        monkeypatch.undo()
        return s

    needed, true = frame("needed"), frame("true")
    assert np.any(true.fold_guard > 0)  # the clamp acts on this frame
    for key in ("points", "W", "deformed_points", "fold_guard"):
        np.testing.assert_allclose(getattr(needed, key), getattr(true, key), rtol=1e-9,
                                   atol=1e-9, err_msg=key)
    short = frame("short").W
    assert np.abs(short - true.W).max() > 1e-3  # far beyond the tolerance


# --- the guard's cost: rest work once, per-frame checks where the frame acts (guard29) ----


def _pulled_sheet():
    """The pull guard's sheet (a pull dragging skin over its neighbour) and its pull."""
    pts, tri = _sheet(41, 41, lambda x, y: 0.02 * x * x)
    pull = np.zeros_like(pts)
    pull[:, 0] = -6.0 * np.exp(-((pts[:, 0] - 2.0) / 1.5) ** 2)
    return pts, tri, pull


def test_an_idle_frame_builds_no_path_graph_and_searches_no_deformed_ball(procedural,
                                                                         monkeypatch):
    """Where no guard acts (every unrefined frame of the procedural face), the frame pays
    for its checks only: no shortest-path graph (built when a triangle is within reach of
    the pull guard's bound) and no shrinking-ball search on the deformed skin (a single
    nearest-sample query finds no ball with a sample inside)."""
    from wrinkle_vis.core import foldguard

    # the geometric skin's frames: the physical skin moves skin outside the muscles' areas,
    # and two of its frames look for a ball at one vertex
    procedural = procedural.with_skin_model("geometric")
    names = [n for n in procedural.expressions if n != "neutral"]
    before = {n: procedural.evaluate(n) for n in names}  # rest radii and terms: cached
    searched = []
    real = foldguard.medial_radii
    for module in (foldguard.balls, foldguard.certified):  # (the modules that search balls)
        monkeypatch.setattr(module, "medial_radii",
                            lambda *a, **k: searched.append(len(a[0])) or real(*a, **k))

    def no_graph(*a, **k):
        raise AssertionError("an idle frame built the pull guard's graph")

    monkeypatch.setattr(foldguard.pulls, "_edge_graph", no_graph)
    for name in names:
        s = procedural.evaluate(name)
        assert not np.any(s.fold_guard), name
        np.testing.assert_array_equal(s.points, before[name].points)
    assert searched == []


def test_the_pull_guards_rest_structures_are_built_once_and_give_the_same_factors():
    """The pulled triangles' rest terms (per moving set) and the search graph's structure
    (per skin) are kept in the terms: a second frame reuses them, and its factors are bit
    for bit those of fresh terms."""
    pts, tri, pull = _pulled_sheet()
    terms = pull_terms(pts, tri)
    f = skin_scale(pts, pts + pull, tri, terms=terms)
    assert f.min() < 0.5  # the guard acts
    structure, subsets = terms["edge_structure"], dict(terms["subsets"])
    g = skin_scale(pts, pts + 0.9 * pull, tri, terms=terms)  # the same vertices move
    assert terms["edge_structure"] is structure
    assert len(terms["subsets"]) == 1
    assert all(terms["subsets"][k][1] is v[1] for k, v in subsets.items())
    np.testing.assert_array_equal(g, skin_scale(pts, pts + 0.9 * pull, tri))
    np.testing.assert_array_equal(f, skin_scale(pts, pts + pull, tri))


def _limits_from_scratch(graph, s_star, corners, top):
    """The shortest-path bound on a matrix built from scratch (the edges once, undirected,
    a source joined to the bad triangles' corners): what ``_limits`` must give."""
    import scipy.sparse as sp
    from scipy.sparse import csgraph

    n = len(graph["indptr"]) - 2
    least = np.full(n, np.inf)
    np.minimum.at(least, corners.ravel(), np.maximum(np.repeat(s_star, 3), 1e-12))
    src = np.flatnonzero(np.isfinite(least))
    live = np.flatnonzero(np.isfinite(graph["w"]))
    rows = np.r_[graph["a"][live], np.full(len(src), n)]
    cols = np.r_[graph["b"][live], src]
    mat = sp.csr_matrix((np.r_[graph["w"][live], least[src]], (rows, cols)),
                        shape=(n + 1, n + 1))
    return csgraph.dijkstra(mat, directed=False, indices=n, limit=top)[:n]


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_the_search_graph_updated_in_place_matches_one_built_from_scratch(seed):
    """After random factors change the pulls' lengths, the graph's weights updated in
    place (``_reweigh``) equal those of a graph built afresh, and the bound found on it
    equals the one a matrix built from scratch gives, bit for bit."""
    from wrinkle_vis.core import foldguard

    rng = np.random.default_rng(seed)
    pts, tri = _sheet(9, 7, lambda x, y: 0.1 * x * y)
    size = rng.uniform(0, 2, len(pts)) * (rng.random(len(pts)) < 0.6)
    terms = pull_terms(pts, tri)
    cap = foldguard._GRAPH_CACHE_EDGES
    try:  # a skin's structure kept (every edge), or built for the frame (pulled edges only)
        for foldguard.pulls._GRAPH_CACHE_EDGES in (cap, 0):
            _reweigh_and_search(foldguard, rng, pts, tri, size, terms)
    finally:
        foldguard.pulls._GRAPH_CACHE_EDGES = cap


def _reweigh_and_search(foldguard, rng, pts, tri, size, terms):
    graph = foldguard._edge_graph(size, terms, 4.0)
    f = np.ones(len(pts))
    for _ in range(3):
        changed = np.flatnonzero(rng.random(len(pts)) < 0.3)
        f[changed] *= rng.uniform(0.2, 1.0, len(changed))
        foldguard._reweigh(graph, changed, f * size)
        fresh = foldguard._edge_graph(f * size, terms, 4.0)
        np.testing.assert_array_equal(graph["w"], fresh["w"])
        np.testing.assert_array_equal(graph["mat"].data[:-len(pts)],
                                      fresh["mat"].data[:-len(pts)])
        bad = rng.choice(len(tri), size=3, replace=False)
        s_star = rng.uniform(0.1, 1.5, 3)
        got = foldguard._limits(s_star, tri[bad], graph, 2.0)
        np.testing.assert_array_equal(got, _limits_from_scratch(graph, s_star, tri[bad], 2.0))


def test_the_first_root_is_the_masked_one_bit_for_bit():
    """``_first_root`` (both branches evaluated, then picked) against the masked form on
    linear, two-root, no-root and tangent quadratics."""
    from wrinkle_vis.core.foldguard import _first_root

    rng = np.random.default_rng(5)
    k = 4000
    a = rng.uniform(1e-12, 2, k)
    b = rng.normal(0, 3, k)
    c = rng.normal(0, 3, k) * (rng.random(k) < 0.8)  # a fifth linear
    c[:50] = b[:50] ** 2 / (4 * a[:50])  # tangent
    c[50:100] = 1e-13 * b[50:100]  # linear by the tolerance
    out = np.full(k, np.inf)
    lin = np.abs(c) <= 1e-12 * np.maximum(np.abs(b), 1e-300)
    m = lin & (b < 0)
    out[m] = -a[m] / b[m]
    q = ~lin
    disc = b[q] * b[q] - 4.0 * a[q] * c[q]
    ok = disc >= 0
    sq = np.sqrt(np.where(ok, disc, 0.0))
    r1 = (-b[q] - sq) / (2.0 * c[q])
    r2 = (-b[q] + sq) / (2.0 * c[q])
    out[q] = np.where(ok, np.minimum(np.where(r1 > 0, r1, np.inf),
                                     np.where(r2 > 0, r2, np.inf)), np.inf)
    got = _first_root(a, b, c)
    np.testing.assert_array_equal(got, out)
    assert np.isfinite(got).sum() > k // 4 and np.isinf(got).sum() > k // 10


# --- the guard on animation frames (cost29): new activations, a new refined skin a frame ---


def test_a_refined_frames_nearest_skin_vertices_are_kept_per_hierarchy_row():
    """Each refined frame of a ramp has a refined skin of its own; the three nearest skin
    vertices of its vertices (whose rest radii bound its clamp) are those of a fresh query
    of that skin, bit for bit, and a later frame queries only the hierarchy rows no frame
    asked for before (on a face of its own: the first frame's rows, none)."""
    import wrinkle_vis as wv
    from wrinkle_vis.core import foldguard

    face = wv.datasets.load_face().with_skin_model("geometric")
    tree = face.skin.kdtree
    asked = []

    class Counting:  # the skin's kd-tree, counting the points each query asks for
        def query(self, x, k=1, **kw):
            asked.append(len(x))
            return tree.query(x, k=k, **kw)

        def __getattr__(self, name):
            return getattr(tree, name)

    states = [face.evaluate("surprise", i, refine=True, fold_guard=False)
              for i in (0.6, 0.8, 1.0, 0.6)]
    assert len({s.n_points for s in states[:3]}) == 3  # three split sets, three skins
    foldguard._skin_bounds(face)  # the rest skin's bounds: once, before counting
    face.skin.__dict__["kdtree"] = Counting()
    try:
        for k, s in enumerate(states):
            asked.clear()
            foldguard.certify(face, s)  # the clamp's certificate asks for the rows it lacks
            idx = foldguard._nearest_skin_vertices(face, s.face)  # (kept, or the rest found)
            np.testing.assert_array_equal(idx, tree.query(s.face.skin.points, k=3)[1])
            new = sum(asked)  # the rows no frame asked for: all, some, some, none
            assert new == s.n_points if k == 0 else (0 < new < s.n_points if k < 3 else
                                                     new == 0)
    finally:
        face.skin.__dict__["kdtree"] = tree


def test_the_pull_terms_are_found_where_needed_and_equal_those_found_at_once():
    """``pull_terms`` finds the edges and the triangles' rows lazily: a frame no guard
    limits finds no edges, and every triangle's rows only where more than three quarters of
    them are pulled (stop 41: then the pulled ones are taken from them); the factors
    (acting or not) are bit for bit those of terms whose every row and edge was found
    first."""
    from wrinkle_vis.core.foldguard import _terms_edges, _terms_rows

    pts, tri, pull = _pulled_sheet()
    lazy = pull_terms(pts, tri)
    f = skin_scale(pts, pts + 0.01 * pull, tri, terms=lazy)  # nothing limited
    moving = np.linalg.norm(pts + 0.01 * pull - pts, axis=1) > 0  # (as skin_scale sees it)
    pulled = np.mean(np.any(moving[tri], axis=1))
    assert np.all(f == 1.0) and "edges" not in lazy and ("N" in lazy) == (pulled > 0.75)
    few = pull_terms(pts, tri)  # a pull on fewer triangles: their rows alone
    local = np.where((np.abs(pts[:, 0] - 2.0) < 2.0)[:, None], pull, 0.0)
    skin_scale(pts, pts + 0.01 * local, tri, terms=few)
    assert "N" not in few and few["subsets"]
    eager = pull_terms(pts, tri, TriangleSurface(pts, tri).edges)
    _terms_rows(eager)
    for scale in (0.01, 0.5, 1.0):
        np.testing.assert_array_equal(skin_scale(pts, pts + scale * pull, tri, terms=lazy),
                                      skin_scale(pts, pts + scale * pull, tri, terms=eager))
    np.testing.assert_array_equal(_terms_edges(lazy)[0], eager["edges"])
    pull[np.abs(pts[:, 0] - 2.0) > 5.0] = 0.0  # a region of the sheet: a subset's terms
    for scale in (0.5, 1.0):  # a step from a deformed skin (the wrinkles' own), acting
        start = pts + 0.4 * scale * pull
        got = [skin_scale(pts, pts + scale * pull, tri, 0.05, 0.8, terms=t, start=start)
               for t in (pull_terms(pts, tri), eager)]
        assert got[0].min() < 1.0
        np.testing.assert_array_equal(*got)
