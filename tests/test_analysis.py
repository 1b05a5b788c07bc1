"""Sections, crests and furrows, furrow runs, folds, flips and the normals' anisotropy,
against analytic answers on synthetic grids and cylinders."""

import numpy as np
import pytest

from wrinkle_vis import TriangleSurface
from wrinkle_vis.core.analysis import (
    crests,
    dihedral_change,
    edge_triangles,
    furrow_runs,
    furrows,
    normal_change_anisotropy,
    section,
    shading_crease,
    signed_dihedral,
    turned_over,
)

HALF = 20.0  # the grids span [-HALF, HALF]^2


def grid(h=0.5, jitter=0.0, seed=0):
    """A flat square in z = 0 of spacing ``h``, interior vertices moved by up to
    ``jitter * h`` in x and y, every square split along the same diagonal."""
    n = int(round(2 * HALF / h)) + 1
    x, y = np.meshgrid(np.linspace(-HALF, HALF, n), np.linspace(-HALF, HALF, n))
    pts = np.c_[x.ravel(), y.ravel(), np.zeros(n * n)]
    if jitter:
        inner = (np.abs(pts[:, 0]) < HALF) & (np.abs(pts[:, 1]) < HALF)
        rng = np.random.default_rng(seed)
        pts[inner, :2] += rng.uniform(-jitter * h, jitter * h, (int(inner.sum()), 2))
    idx = np.arange(n * n).reshape(n, n)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    return TriangleSurface(pts, np.r_[np.c_[a, b, c], np.c_[a, c, d]])


def cylinder(radius=10.0, n_around=64, n_along=11, height=20.0):
    """An open cylinder about the z axis, outward oriented."""
    th = np.linspace(0, 2 * np.pi, n_around, endpoint=False)
    z = np.linspace(0, height, n_along)
    T, Z = np.meshgrid(th, z)
    pts = np.c_[radius * np.cos(T.ravel()), radius * np.sin(T.ravel()), Z.ravel()]
    idx = np.arange(n_around * n_along).reshape(n_along, n_around)
    nxt = np.roll(idx, -1, axis=1)
    a, b = idx[:-1].ravel(), nxt[:-1].ravel()
    c, d = nxt[1:].ravel(), idx[1:].ravel()
    return TriangleSurface(pts, np.r_[np.c_[a, b, c], np.c_[a, c, d]])


def with_heights(surface, z):
    p = surface.points.copy()
    p[:, 2] = z
    return p


def rotation(seed):
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


# ---------------------------------------------------------------------- section
@pytest.mark.parametrize("jitter", [0.0, 0.3])
@pytest.mark.parametrize("c", [1.3, 2.0, -7.75])  # 2.0 and -7.75 lie on grid lines
def test_section_of_a_plane_grid_is_the_segment_with_exact_linear_values(c, jitter):
    g = grid(jitter=jitter)
    p = g.points
    field = np.c_[2 * p[:, 0] + 3 * p[:, 1] - 1, -p[:, 1]]
    (line,) = section(g, field, (c, 5.0, 0.0), (2.0, 0.0, 0.0))
    assert not line.closed
    assert line.length == pytest.approx(2 * HALF, abs=1e-9)
    np.testing.assert_allclose(line.points[:, 0], c, atol=1e-12)
    np.testing.assert_allclose(line.points[[0, -1], 1], [-HALF, HALF], atol=1e-12)
    assert np.all(np.diff(line.s) > 0) and np.all(np.diff(line.points[:, 1]) > 0)  # by y
    np.testing.assert_allclose(line.s, line.points[:, 1] + HALF, atol=1e-9)
    q = line.points
    np.testing.assert_allclose(line.values, np.c_[2 * q[:, 0] + 3 * q[:, 1] - 1, -q[:, 1]],
                               atol=1e-12)
    np.testing.assert_allclose(line.sample(g, p[:, 1]), q[:, 1], atol=1e-12)


def test_section_along_a_grid_line_sits_on_its_vertices():
    g = grid()
    (line,) = section(g, None, (2.0, 0.0, 0.0), (1.0, 0.0, 0.0))
    assert len(line) == 81 and line.values is None  # one point per vertex of the column
    np.testing.assert_allclose(line.points[:, 1], np.linspace(-HALF, HALF, 81), atol=1e-12)


def test_oblique_section_length_and_order_axis():
    g = grid()
    (line,) = section(g, None, (0, 0, 0), (1.0, 1.0, 0.0), order_axis=0)
    assert line.length == pytest.approx(2 * HALF * np.sqrt(2), rel=1e-12)
    np.testing.assert_allclose(np.sum(line.points[:, :2], axis=1), 0.0, atol=1e-12)
    assert line.points[0, 0] == pytest.approx(-HALF) and line.points[-1, 0] == pytest.approx(HALF)
    (back,) = section(g, None, (0, 0, 0), (1.0, 1.0, 0.0), order_axis=(-1.0, 1.0, 0.0))
    np.testing.assert_allclose(back.points, line.points[::-1], atol=1e-12)


def test_section_misses_a_surface_wholly_on_one_side():
    assert section(grid(), None, (0, 0, 1.0), (0, 0, 1.0)) == []


def test_section_of_a_cylinder_is_a_closed_counter_clockwise_polygon():
    cyl = cylinder(radius=10.0, n_around=64)
    (loop,) = section(cyl, cyl.points[:, 2], (0, 0, 7.3), (0, 0, 1.0))
    assert loop.closed
    np.testing.assert_array_equal(loop.points[0], loop.points[-1])
    # it crosses the 64 vertical edges on the circle and the 64 diagonals on the chords
    # between them: the perimeter of the inscribed 64-gon
    assert len(loop) == 129
    assert loop.length == pytest.approx(2 * 64 * 10 * np.sin(np.pi / 64), rel=1e-12)
    np.testing.assert_allclose(loop.values, 7.3, atol=1e-12)
    q = loop.points[:-1]
    area_z = 0.5 * np.sum(q[:, 0] * np.roll(q[:, 1], -1) - np.roll(q[:, 0], -1) * q[:, 1])
    assert area_z > 0  # counter-clockwise about +z
    (flipped,) = section(cyl, None, (0, 0, 7.3), (0, 0, -1.0))
    np.testing.assert_allclose(flipped.points[1], loop.points[-2], atol=1e-12)


def test_section_mask_keeps_the_runs_inside():
    cyl = cylinder()
    (half_loop,) = section(cyl, None, (0, 0, 7.3), (0, 0, 1.0), cyl.points[:, 0] > 0)
    assert not half_loop.closed
    assert np.all(half_loop.points[:, 0] > 0)
    assert half_loop.length == pytest.approx(np.pi * 10, rel=0.05)

    g = grid()
    lines = section(g, g.points[:, 1], (1.3, 0, 0), (1, 0, 0), np.abs(g.points[:, 1]) > 5)
    assert len(lines) == 2
    lo, hi = lines
    assert lo.points[0, 1] == pytest.approx(-HALF) and hi.points[-1, 1] == pytest.approx(HALF)
    assert -6 < lo.points[-1, 1] < -5 < 5 < hi.points[0, 1] < 6
    assert lo.s[0] == 0.0 == hi.s[0]


def test_section_on_other_points_equals_section_of_the_moved_surface():
    g = grid(jitter=0.2)
    moved = g.points @ rotation(1).T + (3.0, -2.0, 1.0)
    a = section(g, g.points[:, 0], (3, -2, 1), (0.2, 1.0, 0.3), points=moved)
    b = section(g.with_points(moved), g.points[:, 0], (3, -2, 1), (0.2, 1.0, 0.3))
    assert len(a) == len(b) == 1
    np.testing.assert_allclose(a[0].points, b[0].points)
    np.testing.assert_allclose(a[0].values, b[0].values)


# ---------------------------------------------------------------------- crests and furrows
@pytest.mark.parametrize("h", [0.25, 0.5])
def test_crests_and_furrows_of_a_cosine(h):
    P = 8.0
    g = grid(h=h)
    (line,) = section(g, np.cos(2 * np.pi * g.points[:, 1] / P), (1.3, 0, 0), (1, 0, 0))
    y = lambda e: line.points[e.index, 1]  # noqa: E731
    c = crests(line.s, line.values, 0.05)
    f = furrows(line.s, line.values, 0.05)
    np.testing.assert_allclose(y(c), [-16, -8, 0, 8, 16], atol=1e-9)  # the ends are no
    np.testing.assert_allclose(y(f), [-12, -4, 4, 12], atol=1e-9)  # extrema
    np.testing.assert_allclose(f.s, y(f) + HALF, atol=1e-9)
    np.testing.assert_allclose(f.value, -1.0, atol=1e-12)
    np.testing.assert_allclose(f.depth, 2.0, atol=1e-12)
    np.testing.assert_allclose(c.prominence, 2.0, atol=1e-12)
    exact = np.degrees(np.arctan(2 * np.pi / P))  # 38.1 degrees
    # the steepest chord of the sampled cosine is a little less steep
    np.testing.assert_allclose(f.side_slope_deg, exact, atol=4 * h)
    assert np.all(f.side_slope_deg <= exact)
    np.testing.assert_allclose(c.side_slope_deg, f.side_slope_deg[0], atol=1e-9)


def test_prominence_ignores_ripples():
    s = np.linspace(0, 40, 4001)
    W = np.cos(2 * np.pi * s / 8) + 0.02 * np.sin(2 * np.pi * s / 0.5)
    f = furrows(s, W, 0.1)
    np.testing.assert_allclose(f.s, [4, 12, 20, 28, 36], atol=0.15)
    np.testing.assert_allclose(crests(s, W, 0.1).s, [8, 16, 24, 32], atol=0.15)
    assert len(furrows(s, W, 0.0)) > 10
    assert len(furrows(s, W, 2.5)) == 0 and furrows(s, W, 2.5).depth.shape == (0,)


def test_furrow_depth_is_the_lower_crest_and_side_slope_the_steeper_wall():
    # crest 1 at s=0, bottom 0 at s=1 (wall slope -1), crest 0.5 at s=3 (slope 0.25)
    s = np.linspace(-1, 5, 601)
    W = np.interp(s, [-1, 0, 1, 3, 5], [0, 1, 0, 0.5, 0])
    (f,) = [furrows(s, W, 0.1)]
    assert len(f) == 1
    assert f.s[0] == pytest.approx(1.0) and f.depth[0] == pytest.approx(0.5)
    assert f.side_slope_deg[0] == pytest.approx(45.0)
    c = crests(s, W, 0.1)
    np.testing.assert_allclose(c.s, [0, 3])
    # each crest's walls reach down to the furrow bottom or to its prominence base
    np.testing.assert_allclose(c.side_slope_deg, [45.0, np.degrees(np.arctan(0.25))])


def test_a_lone_furrow_has_its_prominence_bases_for_walls():
    s = np.linspace(-1, 1, 2001)
    f = furrows(s, s**2, 0.1)
    assert len(f) == 1 and len(crests(s, s**2, 0.1)) == 0
    assert f.s[0] == pytest.approx(0.0) and f.depth[0] == pytest.approx(1.0)
    assert f.side_slope_deg[0] == pytest.approx(np.degrees(np.arctan(2.0)), abs=0.02)


# ---------------------------------------------------------------------- furrow runs
SECTIONS = np.linspace(-HALF + 1e-6, HALF - 1e-6, 21)  # every 2 mm across the whole grid


def test_straight_furrows_run_the_width_of_the_grid():
    g = grid()
    W = np.cos(2 * np.pi * g.points[:, 1] / 8.0)
    runs = furrow_runs(g, W, SECTIONS, 0, None, 0.05, 3.0)
    assert len(runs) == 4  # y = -12, -4, 4, 12
    for r in runs:
        assert len(r) == 21 and r.length == pytest.approx(2 * HALF, abs=1e-5)
        np.testing.assert_array_equal(r.sections, np.arange(21))
        np.testing.assert_allclose(r.depth, 2.0, atol=1e-9)
    np.testing.assert_allclose(sorted(r.points[0, 1] for r in runs), [-12, -4, 4, 12])
    upper = furrow_runs(g, W, SECTIONS, 0, g.points[:, 1] > 0)
    assert sorted(round(r.points[0, 1]) for r in upper) == [4, 12]


def test_slanted_furrows_still_link():
    g = grid()
    p = g.points
    W = np.cos(2 * np.pi * (p[:, 1] - 0.3 * p[:, 0]) / 8.0)
    runs = furrow_runs(g, W, SECTIONS, 0, None, 0.05, 3.0)
    full = [r for r in runs if len(r) == 21]
    assert len(full) >= 3  # the ones that stay inside the grid
    for r in full:
        assert r.length == pytest.approx(2 * HALF * np.sqrt(1 + 0.3**2), rel=0.01)
        # bottoms sit on crossing points, which are 0.5 apart along a section
        np.testing.assert_allclose(np.diff(r.points[:, 1]), 0.3 * 2.0, atol=0.41)


def test_a_broken_furrow_does_not_link_across_the_break():
    g = grid()
    p = g.points
    P = 12.0  # half a period (6) is more than max_jump + step (5)
    W = np.cos(2 * np.pi * (p[:, 1] - 0.5 * P * (p[:, 0] > 0)) / P)
    xs = np.arange(-19.0, 19.5, 2.0)
    runs = furrow_runs(g, W, xs, 0, None, 0.05, 3.0)
    for r in runs:
        side = np.sign(r.points[:, 0])
        assert np.all(side == side[0])
    longest = [r for r in runs if r.length > 17.9]
    assert len(longest) >= 6 and all(r.length == pytest.approx(18.0) for r in longest)
    # with a looser max_jump they do link
    assert max(r.length for r in furrow_runs(g, W, xs, 0, None, 0.05, 5.0)) > 30


# ---------------------------------------------------------------------- folds and flips
def test_edge_triangles_run_the_edge_forwards_first():
    g = grid(h=2.0)
    et = edge_triangles(g)
    inner = et[:, 0] >= 0
    assert np.count_nonzero(~inner) == 4 * 20  # the boundary
    tri = g.triangles[et[inner, 0]]
    e = g.edges[inner]
    fwd = np.zeros(len(e), bool)
    for k in range(3):
        fwd |= (tri[:, k] == e[:, 0]) & (tri[:, (k + 1) % 3] == e[:, 1])
    assert fwd.all()


def test_dihedral_change_is_zero_for_a_rigid_motion():
    g = grid(h=1.0, jitter=0.2)
    p = g.points
    bumpy = with_heights(g, 3 * np.cos(p[:, 0] / 3) * np.sin(p[:, 1] / 4))
    moved = bumpy @ rotation(2).T + (10.0, -3.0, 5.0)
    d = dihedral_change(g, bumpy, moved)
    boundary = np.isnan(d)
    assert np.count_nonzero(boundary) == 4 * 40
    assert np.nanmax(d) < 1e-9
    assert np.nanmax(np.abs(signed_dihedral(g, bumpy))) > 5  # it is bent
    assert not turned_over(g, bumpy, bumpy + (10.0, -3.0, 5.0)).any()


def fold(points, angle_deg, at=0.0):
    """Turn the half x > at up about the line x = at, z = 0 by ``angle_deg``."""
    q = points.copy()
    a = np.radians(angle_deg)
    right = q[:, 0] > at
    dx = q[right, 0] - at
    q[right, 0] = at + dx * np.cos(a)
    q[right, 2] = dx * np.sin(a)
    return q


@pytest.mark.parametrize("angle", [30.0, -30.0, 120.0])
def test_dihedral_change_of_a_fold(angle):
    g = grid(h=1.0)
    p = g.points
    d = dihedral_change(g, p, fold(p, angle))
    on_line = (p[g.edges, 0] == 0).all(axis=1) & ~np.isnan(d)
    assert np.count_nonzero(on_line) == 40
    np.testing.assert_allclose(d[on_line], abs(angle), atol=1e-9)
    np.testing.assert_allclose(d[~on_line & ~np.isnan(d)], 0.0, atol=1e-9)


def test_dihedral_change_counts_convex_to_concave_fully():
    g = grid(h=1.0)
    p = g.points
    d = dihedral_change(g, fold(p, 20.0), fold(p, -20.0))
    assert np.nanmax(d) == pytest.approx(40.0)


def turned_normals(points, angle_deg):
    """``(n, 3)``: the normal (0, 0, 1), turned by ``angle_deg`` about the y axis on x > 0."""
    a = np.radians(angle_deg)
    n = np.tile([0.0, 0.0, 1.0], (len(points), 1))
    n[points[:, 0] > 0] = (-np.sin(a), 0.0, np.cos(a))
    return n


@pytest.mark.parametrize("angle", [8.0, -30.0, 120.0])
def test_shading_crease_is_the_new_turn_across_the_line(angle):
    g = grid(h=1.0, jitter=0.2)
    p = g.points
    d = shading_crease(g, turned_normals(p, 0.0), turned_normals(p, angle))
    across = (p[g.edges, 0] > 0).sum(axis=1) == 1
    np.testing.assert_allclose(d[across], abs(angle), atol=1e-9)
    np.testing.assert_allclose(d[~across], 0.0, atol=1e-9)


def test_shading_crease_counts_convex_to_concave_twice():
    p = grid(h=1.0).points
    d = shading_crease(grid(h=1.0), turned_normals(p, 20.0), turned_normals(p, -20.0))
    assert d.max() == pytest.approx(40.0)


def test_shading_crease_of_a_rigid_turn_is_at_most_the_turn_times_the_rest_turn():
    g = grid(h=1.0, jitter=0.2)
    p = g.points
    rest = g.vertex_normals(with_heights(g, 3 * np.cos(p[:, 0] / 3) * np.sin(p[:, 1] / 4)))
    for seed in range(3):
        r = rotation(seed)
        turn = np.arccos(np.clip((np.trace(r) - 1) / 2, -1, 1))
        d = shading_crease(g, rest, rest @ r.T)
        rest_turn = np.linalg.norm(rest[g.edges[:, 1]] - rest[g.edges[:, 0]], axis=1)
        assert (np.radians(d) <= turn * rest_turn * (1 + 1e-6) + 1e-12).all()
        assert d.max() > 0.0
    assert shading_crease(g, rest, rest).max() == 0.0


def test_turned_over_flags_exactly_a_reflected_patch():
    g = grid(h=1.0)
    p = g.points
    patch = (p[g.triangles, 0] >= 5.0).all(axis=1)
    reflected = p.copy()
    reflected[:, 0] = np.where(p[:, 0] > 5.0, 10.0 - p[:, 0], p[:, 0])  # folded flat over
    np.testing.assert_array_equal(turned_over(g, p, reflected), patch)
    np.testing.assert_array_equal(turned_over(g, p, fold(p, 120.0, at=5.0)), patch)
    assert not turned_over(g, p, fold(p, 60.0, at=5.0)).any()


# ---------------------------------------------------------------------- anisotropy
P, A = 8.0, 0.5
TOL = {0.0: 0.01, 0.2: 0.06}  # honest bounds: the jittered mesh's normals are noisier


def furrows_along_x(g):
    return with_heights(g, A * np.cos(2 * np.pi * g.points[:, 1] / P))


@pytest.mark.parametrize("jitter", [0.0, 0.2])
def test_anisotropy_of_straight_furrows(jitter):
    g = grid(jitter=jitter)
    p, wrinkled = g.points, furrows_along_x(g)
    tol = TOL[jitter]
    assert normal_change_anisotropy(g, p, wrinkled, (0, 1, 0)) > 1 - tol
    assert normal_change_anisotropy(g, p, wrinkled, (1, 0, 0)) < tol
    # out of the plane components of the fibre do not matter, nor does its length
    assert normal_change_anisotropy(g, p, wrinkled, (0, 3, 7)) == pytest.approx(
        normal_change_anisotropy(g, p, wrinkled, (0, 1, 0)))
    for theta in (30.0, 45.0, 60.0):  # a fibre at theta to y: cos^2 theta
        fibre = (np.sin(np.radians(theta)), np.cos(np.radians(theta)), 0.0)
        assert normal_change_anisotropy(g, p, wrinkled, fibre) == pytest.approx(
            np.cos(np.radians(theta)) ** 2, abs=tol)


@pytest.mark.parametrize("jitter", [0.0, 0.2])
def test_anisotropy_of_a_crossed_pattern_is_one_half(jitter):
    g = grid(jitter=jitter)
    p = g.points
    egg_box = with_heights(g, A * (np.cos(2 * np.pi * p[:, 0] / P) +
                                   np.cos(2 * np.pi * p[:, 1] / P)))
    assert normal_change_anisotropy(g, p, egg_box, (0, 1, 0)) == pytest.approx(
        0.5, abs=TOL[jitter])


def test_anisotropy_per_triangle_fibre_and_mask():
    g = grid()
    p = g.points
    left = p[:, 0] < 0
    # furrows across y on the left half, along y (seams) on the right half
    z = np.where(left, A * np.cos(2 * np.pi * p[:, 1] / P), A * np.cos(2 * np.pi * p[:, 0] / P))
    wrinkled = with_heights(g, z)
    assert normal_change_anisotropy(g, p, wrinkled, (0, 1, 0), p[:, 0] < -2) > 0.99
    assert normal_change_anisotropy(g, p, wrinkled, (0, 1, 0), p[:, 0] > 2) < 0.01
    per_triangle = np.tile([0.0, 1.0, 0.0], (g.n_triangles, 1))
    assert normal_change_anisotropy(g, p, wrinkled, per_triangle) == pytest.approx(
        normal_change_anisotropy(g, p, wrinkled, (0, 1, 0)))
    assert np.isnan(normal_change_anisotropy(g, p, p + (0, 0, 1), (0, 1, 0)))
