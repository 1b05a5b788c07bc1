r"""An exact certificate that a triangulated skin does not pass through itself.

Two triangles *intersect* when their closed point sets share a point that is not a vertex or
an edge they share in the mesh. The test is exact: every decision is the sign of an
orientation determinant

.. math::

    o(a, b, c, d) = (a - d) \cdot \big((b - d) \times (c - d)\big),

computed in floating point and accepted when it exceeds Shewchuk's static error bound
:math:`(7 + 56\epsilon)\,\epsilon` times its permanent (:math:`\epsilon = 2^{-53}`) plus a
floor for products that underflow (:func:`_floor`: a subnormal result errs by up to
:math:`2^{-1075}`, which no relative bound covers); the few signs it cannot certify are
recomputed in rational arithmetic (:class:`fractions.Fraction` holds every double exactly),
but for determinants each of whose products has a factor that is exactly zero
(:func:`_zero_terms`), so a sign is never wrong.

* Broad phase, in two parts (:func:`intersecting_pairs` runs these steps once each, on
  coordinate columns of the triangles' corners gathered once).

  1. Triangles that share a vertex: the star of each vertex is tested once
     (:func:`_clear_stars`, per triangle corner, one :func:`numpy.bincount` of windings and
     doubts): where, seen along the sum of its face normals, its triangles are sectors that
     all turn the same way, close into cycles (every edge run once each way: a sparse
     matrix of directed edges, :func:`_irregular_vertices`) and wind around the vertex once,
     two of them meet only in the vertex or the edge they share, and no pair of that star
     needs a test; the pairs of the other stars go to the narrow phase
     (:func:`_star_pairs`).
  2. Triangles that share no vertex (:func:`_apart_pairs`): their axis-aligned boxes are
     binned on a uniform grid of cubes 1.25 times the median box (:func:`_grid_cells`); the
     (cell, triangle) entries are made per cell offset on int32 keys and merged by one
     stable sort (:func:`_cell_entries`).
  3. A pair is produced once, in the lower corner of the two boxes' common cells (a 3-bit
     mask per entry), entry ``i`` with entry ``i + d`` of the same cell for ``d = 1, 2,
     ...`` (:func:`_home_pairs`, each entry carrying how many follow it in its cell), and
     filtered as it is made, in pieces small enough for the cache: the boxes overlap (one
     axis at a time), then the triangles share no vertex. Where the cubes had to be
     widened (boxes of very different sizes, as on a scan: many boxes per cube), the
     entries of a cube are ordered by their boxes' lower x bound and entry ``i`` stops at
     the first ``i + d`` that starts beyond its upper x bound (a sweep along x: the pairs
     made overlap along x).

  On a skin nearly every star passes, so the narrow phase sees about a tenth of the pairs
  of overlapping boxes. The steps are deterministic and the pairs are sorted
  lexicographically at the end, so the result depends on the mesh only.
* Plane filter for pairs that share no vertex (:func:`_apart_narrow_phase`): the sides of
  each triangle's corners against the other's plane are computed once in floating point
  with their error bounds; a pair is separated when all three are certainly on one side;
  otherwise the same sides (the uncertain ones recomputed exactly) are the end sides of the
  six segment tests below.
* Narrow phase, for triangles in general position: two triangles with no common vertex
  intersect iff an edge of one meets the other (closed segment against closed triangle: the
  endpoints are not strictly on one side of its plane and the line through them passes on
  the same side of the three edges, :math:`o(p, q, a, b)`, :math:`o(p, q, b, c)`,
  :math:`o(p, q, c, a)` of one sign or zero). Two triangles with one common vertex
  :math:`v` intersect elsewhere iff the edge of one opposite :math:`v` meets the other (their
  planes cross in a line through :math:`v`; the shorter of the two pieces of it ends on the
  opposite edge of its triangle). Two triangles with a common edge intersect elsewhere only
  when folded flat onto each other: coplanar with their free corners on the same side of the
  edge.
* Coplanar configurations are decided exactly as well: a segment lying in the other
  triangle's plane is tested against it in 2D (projected on the coordinate plane its normal
  is least parallel to, 2D orientations with their own static bound and rational fallback);
  an edge through the shared vertex lying in the other's plane enters the other iff its ray
  lies in the other's closed cone at that vertex. Only pairs involving a triangle with no
  area are reported as *contact*, conservatively. A certificate of no intersection is
  therefore never wrong.

:func:`fold_report` compares a frame with its rest skin: the pairs that intersect in the frame
and not at rest (a scan may cross itself at rest), and the triangles turned over (their normal
against the rest skin's).
"""
from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
from scipy import sparse

__all__ = ["FoldReport", "fold_report", "intersecting_pairs", "turned_over"]

_EPS = 2.0 ** -53
_ERR3 = (7.0 + 56.0 * _EPS) * _EPS
_TINY = 2.0 ** -1069  # 32 times the largest error of a product that underflows (2^-1075)
_SMALL = 2.0 ** -300  # a length below it may come from products that underflow


def _floor(au: list[np.ndarray]) -> np.ndarray:
    r"""``(k,)``: the error a determinant :math:`\sum_i u_i\,n_i` can carry beyond its
    static bound when products underflow, from :math:`|u_i|` ``(k,)`` three times:
    :math:`2^{-1069}\,(1 + \sum_i |u_i|)`.

    A product whose result is subnormal is rounded to a multiple of :math:`2^{-1074}`: its
    error is at most :math:`\eta = 2^{-1075}` in absolute value, not :math:`\epsilon`
    times it (a sum or difference is exact there). :math:`n_i` (a cross product's entry:
    two products) then errs by at most :math:`2\eta` beyond its relative error, and
    :math:`u_i n_i` by :math:`|u_i|\,2\eta + \eta`; the three together by
    :math:`2\eta \sum_i |u_i| + 3\eta` (times :math:`1 + O(\epsilon)`), well within
    the floor. Without it, products of subnormal coordinates' differences round to zero
    and a nonzero determinant reads as zero with a zero bound, taken as certain.
    """
    return _TINY * (1.0 + au[0] + au[1] + au[2])


def _zero_terms(u: np.ndarray, e1: np.ndarray, e2: np.ndarray) -> np.ndarray:
    r"""``(k,) bool``: every term :math:`u_i\,(e_1 \times e_2)_i` is zero because a factor
    of each of its products is (rows ``(k, 3)``, computed differences: a difference of
    doubles is zero exactly when they are equal), so :math:`u \cdot (e_1 \times e_2) = 0`
    exactly.
    """
    z, y, x = u == 0, e1 == 0, e2 == 0
    out = np.ones(len(u), bool)
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        out &= z[:, i] | ((y[:, j] | x[:, k]) & (y[:, k] | x[:, j]))
    return out


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``(k, 3)``: row-wise cross product (faster than :func:`numpy.cross` on short rows)."""
    return np.stack([u[:, 1] * v[:, 2] - u[:, 2] * v[:, 1],
                     u[:, 2] * v[:, 0] - u[:, 0] * v[:, 2],
                     u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]], axis=1)


def _abs_cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``(k, 3)``: the permanent's cross product, :math:`|u_y v_z| + |u_z v_y|`, ..."""
    au, av = np.abs(u), np.abs(v)
    return np.stack([au[:, 1] * av[:, 2] + au[:, 2] * av[:, 1],
                     au[:, 2] * av[:, 0] + au[:, 0] * av[:, 2],
                     au[:, 0] * av[:, 1] + au[:, 1] * av[:, 0]], axis=1)


def _exact_orient(a, b, c, d) -> int:
    """Sign of :math:`o(a, b, c, d)` in rational arithmetic (``a`` ... ``d``: 3 floats)."""
    a, b, c, d = ([Fraction(float(x)) for x in p] for p in (a, b, c, d))
    u = [a[i] - d[i] for i in range(3)]
    v = [b[i] - d[i] for i in range(3)]
    w = [c[i] - d[i] for i in range(3)]
    det = (u[0] * (v[1] * w[2] - v[2] * w[1]) + u[1] * (v[2] * w[0] - v[0] * w[2])
           + u[2] * (v[0] * w[1] - v[1] * w[0]))
    return (det > 0) - (det < 0)


def orient(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray) -> np.ndarray:
    r"""``(k,)`` int8: the exact sign of :math:`o(a, b, c, d)` for rows ``(k, 3)``: positive
    when ``a`` lies on the side of plane ``(d, b, c)`` that ``(b - d) \times (c - d)``
    points to.
    """
    (u0, u1, u2), (v0, v1, v2), (w0, w1, w2) = (a - d).T, (b - d).T, (c - d).T
    x0, x1, x2 = v1 * w2, v2 * w0, v0 * w1
    y0, y1, y2 = v2 * w1, v0 * w2, v1 * w0
    det = u0 * (x0 - y0) + u1 * (x1 - y1) + u2 * (x2 - y2)
    au = [np.abs(u0), np.abs(u1), np.abs(u2)]
    bound = _ERR3 * (au[0] * (np.abs(x0) + np.abs(y0)) + au[1] * (np.abs(x1)
                     + np.abs(y1)) + au[2] * (np.abs(x2) + np.abs(y2)))
    sign = np.sign(det).astype(np.int8)
    unsure = np.flatnonzero(np.abs(det) <= bound + _floor(au))
    if len(unsure):
        unsure = unsure[~_zero_terms(a[unsure] - d[unsure], b[unsure] - d[unsure],
                                     c[unsure] - d[unsure])]
    for k in unsure:
        sign[k] = _exact_orient(a[k], b[k], c[k], d[k])
    return sign


_ERR2 = (3.0 + 16.0 * _EPS) * _EPS


def _exact_orient2(a, b, c) -> int:
    a, b, c = ([Fraction(float(x)) for x in p] for p in (a, b, c))
    det = (a[0] - c[0]) * (b[1] - c[1]) - (a[1] - c[1]) * (b[0] - c[0])
    return (det > 0) - (det < 0)


def orient2(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """``(k,)`` int8: the exact sign of the 2D orientation of rows ``(k, 2)``: positive when
    ``a, b, c`` turn counter-clockwise.
    """
    left = (a[:, 0] - c[:, 0]) * (b[:, 1] - c[:, 1])
    right = (a[:, 1] - c[:, 1]) * (b[:, 0] - c[:, 0])
    det = left - right
    bound = _ERR2 * (np.abs(left) + np.abs(right))
    sign = np.sign(det).astype(np.int8)
    unsure = np.flatnonzero(np.abs(det) <= bound + _TINY)  # two products: 2 eta beyond
    if len(unsure):
        u, v = a[unsure] - c[unsure], b[unsure] - c[unsure]
        unsure = unsure[~(((u[:, 0] == 0) | (v[:, 1] == 0)) & ((u[:, 1] == 0) | (v[:, 0] == 0)))]
    for k in unsure:
        sign[k] = _exact_orient2(a[k], b[k], c[k])
    return sign


def _drop_axis(tc: np.ndarray) -> np.ndarray:
    """``(k, 2)`` int: the coordinates kept when projecting the plane of triangles
    ``(k, 3, 3)`` onto the coordinate plane its normal is least parallel to.
    """
    n = np.abs(_cross(tc[:, 1] - tc[:, 0], tc[:, 2] - tc[:, 0]))
    axis = n.argmax(axis=1)
    for k in np.flatnonzero(n.max(axis=1) < _SMALL):  # products may underflow: exact
        axis[k] = _exact_normal_axis(tc[k])
    return np.array([[1, 2], [0, 2], [0, 1]])[axis]


def _exact_normal_axis(tc: np.ndarray) -> int:
    """The axis of the largest entry of the normal of triangle ``tc`` ``(3, 3)`` (exact)."""
    a, b, c = ([Fraction(float(x)) for x in p] for p in tc)
    u, v = [b[i] - a[i] for i in range(3)], [c[i] - a[i] for i in range(3)]
    n = [abs(u[(i + 1) % 3] * v[(i + 2) % 3] - u[(i + 2) % 3] * v[(i + 1) % 3])
         for i in range(3)]
    return max(range(3), key=lambda i: n[i])


def _flat(x: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """``(k, 2)``: points ``(k, 3)`` with only the coordinates ``keep`` ``(k, 2)``."""
    return np.take_along_axis(x, keep, axis=1)


def _segments_meet2(p, q, u, v) -> np.ndarray:
    """``(k,) bool``: closed 2D segments ``p q`` and ``u v`` share a point (exact)."""
    d1, d2 = orient2(u, v, p), orient2(u, v, q)
    d3, d4 = orient2(p, q, u), orient2(p, q, v)
    cross = (d1 * d2 <= 0) & (d3 * d4 <= 0)
    collinear = (d1 == 0) & (d2 == 0)
    lo1, hi1 = np.minimum(p, q), np.maximum(p, q)
    lo2, hi2 = np.minimum(u, v), np.maximum(u, v)
    overlap = (np.maximum(lo1, lo2) <= np.minimum(hi1, hi2)).all(axis=1)
    return np.where(collinear, overlap, cross)


def _inside2(p, a, b, c, s) -> np.ndarray:
    """``(k,) bool``: 2D point ``p`` in the closed triangle ``a b c`` of orientation ``s``."""
    return ((orient2(a, b, p) * s >= 0) & (orient2(b, c, p) * s >= 0)
            & (orient2(c, a, p) * s >= 0))


def _coplanar_segment_meets(p, q, tc) -> tuple[np.ndarray, np.ndarray]:
    """``(k,) bool`` twice: segments ``p q`` ``(k, 3)`` lying in the planes of triangles
    ``tc`` ``(k, 3, 3)`` meet them (closed, exact), and the triangle has no area.
    """
    keep = _drop_axis(tc)
    a, b, c = (_flat(tc[:, i], keep) for i in range(3))
    p2, q2 = _flat(p, keep), _flat(q, keep)
    s = orient2(a, b, c)
    hit = _inside2(p2, a, b, c, s) | _inside2(q2, a, b, c, s)
    for u, v in ((a, b), (b, c), (c, a)):
        hit |= _segments_meet2(p2, q2, u, v)
    return hit & (s != 0), s == 0


def _ray_in_cone(v, p, b1, b2, tc) -> np.ndarray:
    """``(k,) bool``: the ray from ``v`` through ``p`` lies in the closed cone of ``v b1 b2``
    (all ``(k, 3)``, coplanar; ``tc`` the triangles ``(k, 3, 3)`` whose plane they share).
    """
    keep = _drop_axis(tc)
    v2, p2, c1, c2 = (_flat(x, keep) for x in (v, p, b1, b2))
    s = orient2(v2, c1, c2)
    return (orient2(v2, c1, p2) * s >= 0) & (orient2(v2, p2, c2) * s >= 0) & (s != 0)


def candidate_pairs(corners: np.ndarray) -> np.ndarray:
    """``(k, 2)`` int, ``i < j``: the triangles ``(m, 3, 3)`` whose closed bounding boxes
    overlap, each pair once (uniform grid on the boxes, cell about twice the median box).
    """
    m = len(corners)
    if m < 2:
        return np.zeros((0, 2), np.intp)
    lo, hi = _boxes(corners)
    size = float(np.median((hi - lo).max(axis=1))) * 2.0
    span = float((hi.max(axis=0) - lo.min(axis=0)).max())
    if not np.isfinite(size) or size <= 0.0:
        size = span if span > 0 else 1.0
    origin = lo.min(axis=0)
    c0 = np.floor((lo - origin) / size).astype(np.int64)
    c1 = np.floor((hi - origin) / size).astype(np.int64)
    n = c1 - c0 + 1
    count = n.prod(axis=1)
    tri = np.repeat(np.arange(m), count)
    # local cell offsets of each entry inside its triangle's cell range
    start = np.repeat(np.cumsum(count) - count, count)
    k = np.arange(len(tri)) - start
    nt = n[tri]
    ix = c0[tri, 0] + k % nt[:, 0]
    iy = c0[tri, 1] + (k // nt[:, 0]) % nt[:, 1]
    iz = c0[tri, 2] + k // (nt[:, 0] * nt[:, 1])
    dims = c1.max(axis=0) + 1
    cell = (iz * dims[1] + iy) * dims[0] + ix
    order = np.argsort(cell, kind="stable")
    cell, tri = cell[order], tri[order]
    bounds = np.flatnonzero(np.diff(cell)) + 1
    group_end = np.repeat(np.append(bounds, len(cell)),
                          np.diff(np.concatenate([[0], bounds, [len(cell)]])))
    out = []
    idx = np.arange(len(cell))
    d = 1
    while len(idx):
        idx = idx[idx + d < group_end[idx]]
        if not len(idx):
            break
        a, b = tri[idx], tri[idx + d]
        olo = np.maximum(lo[a], lo[b])
        ok = (olo <= np.minimum(hi[a], hi[b])).all(axis=1)
        home = np.floor((olo - origin) / size).astype(np.int64)
        hc = (home[:, 2] * dims[1] + home[:, 1]) * dims[0] + home[:, 0]
        ok &= hc == cell[idx]
        out.append(np.stack([np.minimum(a[ok], b[ok]), np.maximum(a[ok], b[ok])], axis=1))
        d += 1
    return np.concatenate(out) if out else np.zeros((0, 2), np.intp)


def _segment_meets(p, q, tri_idx, corners, normal, perm, sides=None):
    """``(k,) bool`` twice: the closed segments ``p q`` ``(k, 3)`` meet the closed triangles
    ``corners[tri_idx]`` (general position), and the configuration is degenerate (segment in
    the triangle's plane, or the line through an edge's line); then ``(k,)`` int8 twice: the
    sides of ``p`` and ``q`` against the triangle's plane (or ``sides``, when known).
    """
    if sides is None:
        t0 = corners[tri_idx, 0]
        n, pm = normal[tri_idx], perm[tri_idx]
        sides = _side(p, t0, n, pm, corners, tri_idx), _side(q, t0, n, pm, corners, tri_idx)
    sp, sq = sides
    reach = (sp * sq) <= 0
    in_plane = (sp == 0) & (sq == 0)
    hit = reach & ~in_plane
    degenerate = np.zeros(len(p), bool)
    flat_rows = np.flatnonzero(in_plane)
    if len(flat_rows):
        h, d = _coplanar_segment_meets(p[flat_rows], q[flat_rows],
                                       corners[tri_idx[flat_rows]])
        degenerate[flat_rows] = d
        hit_flat = h
    cand = np.flatnonzero(hit)
    if len(cand):
        tc = corners[tri_idx[cand]]
        pc, qc = p[cand], q[cand]
        s1 = orient(pc, qc, tc[:, 0], tc[:, 1])
        s2 = orient(pc, qc, tc[:, 1], tc[:, 2])
        s3 = orient(pc, qc, tc[:, 2], tc[:, 0])
        inside = (((s1 >= 0) & (s2 >= 0) & (s3 >= 0)) | ((s1 <= 0) & (s2 <= 0) & (s3 <= 0)))
        flat = (s1 == 0) & (s2 == 0) & (s3 == 0)
        hit[cand] = inside & ~flat
        degenerate[cand] |= flat
    if len(flat_rows):
        hit[flat_rows] = hit_flat
    return hit, degenerate, sp, sq


def _side(p, t0, n, pm, corners, tri_idx) -> np.ndarray:
    r"""``(k,)`` int8: exact side of points ``p`` against the triangles' planes, with
    precomputed :math:`n = (b - a) \times (c - a)` and its permanent.
    """
    u = p - t0
    det = np.einsum("ij,ij->i", u, n)
    au = np.abs(u)
    bound = _ERR3 * np.einsum("ij,ij->i", au, pm)
    sign = np.sign(det).astype(np.int8)
    unsure = np.flatnonzero(np.abs(det) <= bound + _floor(list(au.T)))
    if len(unsure):
        tcs = corners[tri_idx[unsure]]
        unsure = unsure[~_zero_terms(u[unsure], tcs[:, 1] - tcs[:, 0], tcs[:, 2] - tcs[:, 0])]
    for k in unsure:
        tc = corners[tri_idx[k]]
        sign[k] = _exact_orient(p[k], tc[1], tc[2], tc[0])
    return sign


def _folded_flat(pts, u, v, a, b) -> bool:
    """Coplanar ``a`` and ``b`` on the same side of edge ``u v`` (exact)."""
    P = [[Fraction(float(x)) for x in pts[i]] for i in (u, v, a, b)]
    e = [P[1][i] - P[0][i] for i in range(3)]
    fa = [P[2][i] - P[0][i] for i in range(3)]
    fb = [P[3][i] - P[0][i] for i in range(3)]

    def cross(x, y):
        return [x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0]]

    ca, cb = cross(e, fa), cross(e, fb)
    return sum(x * y for x, y in zip(ca, cb, strict=True)) > 0


# --- broad phase: stars that cannot cross, and the pairs that share no corner ------------

_STAR_MARGIN = 1e-10


def _gather(cols: tuple[np.ndarray, ...], idx: np.ndarray) -> list[np.ndarray]:
    return [c[idx] for c in cols]


def _sub(u: list[np.ndarray], v: list[np.ndarray]) -> list[np.ndarray]:
    return [p - q for p, q in zip(u, v, strict=True)]


def _dot(u: list[np.ndarray], v: list[np.ndarray]) -> np.ndarray:
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


def _cross_cols(u: list[np.ndarray], v: list[np.ndarray]) -> list[np.ndarray]:
    return [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]


def _irregular_vertices(tri: np.ndarray, n_points: int) -> np.ndarray:
    """``(n,) bool``: vertices on an edge that is not shared by exactly two triangles
    running it in opposite directions (boundary, non-manifold or misoriented edges), or on
    a triangle with a repeated corner.

    The directed edges are counted in a sparse matrix :math:`D` (:math:`D_{ab}`: the
    triangles running ``a`` to ``b``); an edge is regular iff :math:`D_{ab} = D_{ba} = 1`.
    """
    a = tri.ravel()
    b = tri[:, [1, 2, 0]].ravel()
    count = sparse.csr_matrix((np.ones(len(a), np.int32), (a, b)), shape=(n_points, n_points))
    count.sum_duplicates()
    out = np.zeros(n_points, bool)
    entries = count.tocoo()
    twice = entries.data != 1
    unmatched = (count - count.T).tocoo()
    unmatched.eliminate_zeros()
    for rows in (entries.row[twice], entries.col[twice], unmatched.row, unmatched.col,
                 a[a == b]):
        out[rows] = True
    return out


def _corner_columns(pts: np.ndarray, tri: np.ndarray) -> list[list[np.ndarray]]:
    """``[k][c]`` ``(m,)``: coordinate ``c`` of corner ``k`` of triangles ``(m, 3)``."""
    axes = [np.ascontiguousarray(pts[:, c]) for c in range(3)]
    return [[x.take(tri[:, k]) for x in axes] for k in range(3)]


def _normals(x: list[list[np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    r"""``(m, 3)`` twice: :math:`n = (b - a) \times (c - a)` of triangles ``(a, b, c)`` given
    by their corner columns ``x`` (:func:`_corner_columns`), and its permanent (the same
    products' absolute values added), as :func:`_cross` and :func:`_abs_cross` give them.
    """
    e1 = [x[1][c] - x[0][c] for c in range(3)]
    e2 = [x[2][c] - x[0][c] for c in range(3)]
    normal, perm = np.empty((len(e1[0]), 3)), np.empty((len(e1[0]), 3))
    for c in range(3):
        i, j = (c + 1) % 3, (c + 2) % 3
        p, q = e1[i] * e2[j], e1[j] * e2[i]
        np.subtract(p, q, out=normal[:, c])
        np.add(np.abs(p, out=p), np.abs(q, out=q), out=perm[:, c])
    return normal, perm


def _unless_small(length: np.ndarray) -> np.ndarray:
    """``(k,)``: ``length`` ``(k,)``, infinite where it is below ``_SMALL``."""
    return np.where(length < _SMALL, np.inf, length)


_AHEAD = np.array([[0.5257311, 0.6881910, 0.5000000], [-0.8090170, 0.2628656, 0.5257311]])


def _clear_stars(pts: np.ndarray, tri: np.ndarray, normal: np.ndarray, perm: np.ndarray,
                 x: list[list[np.ndarray]] | None = None) -> np.ndarray:
    r"""``(n,) bool``: vertices ``v`` whose star cannot intersect itself: two triangles
    that share ``v`` meet only in ``v`` or in the edge they share.

    Seen along :math:`N = \sum_t n_t` (the star's face normals), every triangle
    :math:`t = (v, a, b)` of the star must turn counter-clockwise, certainly
    (:math:`n_t \cdot N > 0`), so that it is a sector of angle below :math:`\pi` seen
    from ``v`` and its projection is one to one. Every edge at ``v`` must be shared by two
    triangles running it in opposite directions, so that the sectors close into cycles,
    and the sectors must wind around ``v`` once: exactly one holds a direction ``d`` not
    along ``N``, certainly, in its angle (:math:`(a - v) \cdot g > 0 > (b - v) \cdot g`
    with :math:`g = d \times N`; each cycle winds at least once). Then the sectors'
    interiors are disjoint and their boundary rays distinct but for the shared edges: two
    triangles of the star project onto sets that meet only in ``v`` or along the edge
    they share, and, each projection being one to one, meet only there.

    A sign is taken as certain when the product exceeds :math:`10^{-10}` times the
    product of the lengths (of :math:`N` and the permanent of :math:`n_t`, or of the
    edge and :math:`g`), far above its rounding (a few :math:`\epsilon` of that, the
    rounding of the differences and of :math:`n_t` included); any doubt leaves the vertex
    to the exact pairwise test. That holds where no length involved (of :math:`N`,
    :math:`g`, the edges and the permanent of :math:`n_t`) is below :math:`2^{-300}`: a
    product that underflows errs by :math:`2^{-1075}` at most, so the errors beyond the
    relative ones are a few :math:`2^{-1075}` times the lengths and the degree, far below
    :math:`10^{-10}` times the products of two lengths of at least :math:`2^{-300}`, and
    the lengths themselves (square roots of sums of squares of at least :math:`2^{-600}`)
    are accurate. A star with a shorter one is a doubt.
    """
    n_points = len(pts)
    v = tri.ravel()
    nv = [np.bincount(v, np.repeat(normal[:, k], 3), n_points) for k in range(3)]
    ln = np.sqrt(_dot(nv, nv))
    d = _AHEAD[(np.abs(_AHEAD[0] @ nv) > 0.8 * ln).astype(np.intp)]
    g = _cross_cols([d[:, 0], d[:, 1], d[:, 2]], nv)
    lg = np.sqrt(_dot(g, g))
    lperm = np.sqrt(np.einsum("ij,ij->i", perm, perm))
    nt = [np.ascontiguousarray(normal[:, k]) for k in range(3)]
    # per triangle, edge k runs from corner k to corner k + 1: a - v at corner k is edge k,
    # and b - v is minus edge k + 2
    corner = [np.ascontiguousarray(tri[:, k]) for k in range(3)]
    x = _corner_columns(pts, tri) if x is None else x
    edge = [_sub(x[(k + 1) % 3], x[k]) for k in range(3)]
    # a length below _SMALL: products may underflow and the margins not hold; an infinite
    # threshold makes every test it enters a doubt
    ledge = [_unless_small(np.sqrt(_dot(e, e))) for e in edge]
    lperm = _STAR_MARGIN * _unless_small(lperm)
    ln, lg = _unless_small(ln), _unless_small(lg)
    weight = np.empty((len(tri), 3))
    for k in range(3):
        vk = corner[k]
        ok = _dot(nt, _gather(tuple(nv), vk)) > lperm * ln[vk]
        gv = _gather(tuple(g), vk)
        out = _dot(edge[k], gv)  # (a - v) . g
        into = -_dot(edge[(k + 2) % 3], gv)  # (b - v) . g
        margin = _STAR_MARGIN * lg[vk]
        ok &= (np.abs(out) > margin * ledge[k]) & (np.abs(into) > margin * ledge[(k + 2) % 3])
        # winding + 2 doubts: the star passes where its sum is 1
        weight[:, k] = ((out > 0) & (into < 0)) + 2.0 * ~ok
    return (np.bincount(v, weight.ravel(), n_points) == 1) & ~_irregular_vertices(tri, n_points)


def _within_groups(key: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(p,)`` int twice: positions ``i < j`` of every pair of equal entries of the
    sorted ``key`` ``(e,)``.
    """
    if len(key) < 2:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    start = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    end = np.repeat(np.r_[start[1:], len(key)], np.diff(np.r_[start, len(key)]))
    count = end - np.arange(len(key)) - 1
    first = np.repeat(np.arange(len(key)), count)
    offset = np.arange(len(first)) - np.repeat(np.cumsum(count) - count, count)
    return first, first + 1 + offset


def _star_pairs(tri: np.ndarray, unclear: np.ndarray) -> np.ndarray:
    """``(k, 2)`` int, ``i < j``: the pairs of triangles ``(m, 3)`` that share a vertex
    and whose shared vertices are all ``unclear`` ``(n,) bool``.
    """
    t = np.repeat(np.arange(len(tri)), 3)
    v = tri.ravel()
    sel = np.flatnonzero(unclear[v])
    order = np.argsort(v[sel], kind="stable")
    t, v = t[sel][order], v[sel][order]
    i, j = _within_groups(v)
    a, b = t[i], t[j]
    ta = tri[a]
    shared = (ta[:, :, None] == tri[b][:, None, :]).any(axis=2)
    shared_clear = (shared & ~unclear[ta]).any(axis=1)
    # a pair sharing two unclear vertices is found at both: keep it at the smaller
    found_before = (shared & (ta < v[i][:, None])).any(axis=1)
    keep = ~shared_clear & ~found_before
    return np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1)[keep]


def _boxes(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(m, 3)`` twice: the lower and upper corners of triangles ``(m, 3, 3)``' boxes."""
    c0, c1, c2 = corners[:, 0], corners[:, 1], corners[:, 2]
    return np.minimum(np.minimum(c0, c1), c2), np.maximum(np.maximum(c0, c1), c2)


def _cell_entries(c0: np.ndarray, n: np.ndarray, dims: np.ndarray,
                  rank: np.ndarray | None = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(e,)`` three times, sorted by cell: every (cell, triangle) of boxes covering the
    cells ``c0`` to ``c0 + n - 1`` ``(m, 3)`` int on a grid ``dims`` ``(3,)`` (a cell's
    key: :math:`(z d_y + y) d_x + x`), and a 3-bit mask of the axes along which the cell
    is the box's first. With ``rank`` ``(m,)`` (distinct, below ``m``), the entries of a
    cell are in the order of their triangles' ranks.
    """
    key0 = (c0[:, 2] * dims[1] + c0[:, 1]) * dims[0] + c0[:, 0]
    reach = n.max(axis=0)
    if int(reach.prod()) > 27:  # a few boxes span many cells: one entry per cell at once
        count = n.prod(axis=1)
        t = np.repeat(np.arange(len(n)), count)
        k = np.arange(len(t)) - np.repeat(np.cumsum(count) - count, count)
        nt = n[t]
        d = np.stack([k % nt[:, 0], (k // nt[:, 0]) % nt[:, 1], k // (nt[:, 0] * nt[:, 1])],
                     axis=1)
        cell = key0[t] + (d[:, 2] * dims[1] + d[:, 1]) * dims[0] + d[:, 0]
        first = (d == 0).astype(np.uint8) @ np.array([1, 2, 4], np.uint8)
    else:  # one run of entries sorted by cell per offset, merged by the stable sort
        if rank is not None:  # runs sorted by cell, then rank
            order = np.argsort(key0.astype(np.int64) * len(n) + rank)
        else:
            if int(dims.prod()) < 2**31:  # int32 keys sort faster
                key0 = key0.astype(np.int32)
            order = np.argsort(key0)
        key0 = key0.take(order)
        spans = [[n[:, k].take(order) > o for o in range(int(reach[k]))] for k in range(3)]
        cells, tris, firsts = [], [], []
        for dz in range(int(reach[2])):
            for dy in range(int(reach[1])):
                inside_yz = spans[1][dy] & spans[2][dz]
                for dx in range(int(reach[0])):
                    sel = np.flatnonzero(inside_yz & spans[0][dx] if dx else inside_yz)
                    cells.append(key0.take(sel) + ((dz * dims[1] + dy) * dims[0] + dx))
                    tris.append(order.take(sel))
                    firsts.append(np.full(len(sel), (dx == 0) | (dy == 0) << 1
                                          | (dz == 0) << 2, np.uint8))
        cell, t, first = np.concatenate(cells), np.concatenate(tris), np.concatenate(firsts)
    if rank is not None:
        order = np.argsort(cell.astype(np.int64) * len(n) + rank.take(t), kind="stable")
    else:
        if int(dims.prod()) < 2**31:
            cell = cell.astype(np.int32, copy=False)
        order = np.argsort(cell, kind="stable")
    return cell.take(order), t.take(order), first.take(order)


_CHUNK = 1 << 15  # pairs filtered at once, so that their temporaries stay in cache


def _home_pairs(cell: np.ndarray, t: np.ndarray, first: np.ndarray,
                sweep: tuple[np.ndarray, np.ndarray] | None = None
                ) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """``(p,)`` int twice, in pieces of at most ``_CHUNK``: the pairs of entries ``t`` in
    the same cell of the sorted ``cell`` ``(e,)`` whose masks ``first`` together hold every
    axis (the pair's home cell), entry ``i`` with entry ``i + d`` for ``d = 1, 2, ...``.

    With ``sweep``, the entries' lower and upper x bounds ``(e,)`` twice, nondecreasing
    lower bounds within each cell: only the pairs whose x ranges overlap, and entry ``i``
    stops at the first ``i + d`` that starts beyond its upper bound (the later ones do too).
    """
    end = np.r_[np.flatnonzero(cell[1:] != cell[:-1]) + 1, len(cell)]
    rem = np.repeat(end, np.diff(np.r_[0, end])) - np.arange(len(cell))  # entries from i on
    idx = np.flatnonzero(rem > 1)  # intp: numpy converts other indices before gathering
    rem, fi = rem.take(idx), first.take(idx)
    top = sweep[1].take(idx) if sweep is not None else None
    d = 1
    while len(idx):
        if sweep is not None and top is not None:
            go = np.flatnonzero(sweep[0].take(idx + d) <= top)
            idx, rem, fi, top = idx.take(go), rem.take(go), fi.take(go), top.take(go)
        home = idx.take(np.flatnonzero((fi | first.take(idx + d)) == 7))
        for s in range(0, len(home), _CHUNK):
            piece = home[s:s + _CHUNK]
            yield t.take(piece), t.take(piece + d)
        d += 1
        more = np.flatnonzero(rem > d)
        idx, rem, fi = idx.take(more), rem.take(more), fi.take(more)
        if top is not None:
            top = top.take(more)


_CELL = 1.25  # the grid cube over the median box's longest side


def _grid_cells(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """``(3, m)`` int twice: the first and last cells of boxes ``lo``, ``hi`` ``(3, m)``
    on a grid of cubes ``_CELL`` times the median box's longest side, larger where that would
    put a box in more than 6 cells on average, and at most 1024 cubes along an axis; and
    whether the cubes were made larger (boxes of very different sizes: many per cube).
    """
    origin = lo.min(axis=1)[:, None]
    span = float((hi.max(axis=1) - origin[:, 0]).max())
    side = np.maximum(np.maximum(hi[0] - lo[0], hi[1] - lo[1]), hi[2] - lo[2])
    size = max(_CELL * float(np.partition(side, len(side) // 2)[len(side) // 2]), span / 1024.0)
    if not np.isfinite(size) or size <= 0.0:
        size = span if span > 0 else 1.0
    widened = False
    while True:
        c0 = ((lo - origin) * (1.0 / size)).astype(np.int64)
        c1 = ((hi - origin) * (1.0 / size)).astype(np.int64)
        if ((c1[0] - c0[0] + 1) * (c1[1] - c0[1] + 1) * (c1[2] - c0[2] + 1)).sum() \
                <= 6 * len(side) or size >= span:
            return c0, c1, widened
        size *= 4.0 / 3.0
        widened = True


def _apart_pairs(tri: np.ndarray, pts: np.ndarray, x: list[list[np.ndarray]] | None = None
                 ) -> np.ndarray:
    """``(k, 2)`` int, ``i < j``: the pairs of triangles ``(m, 3)`` on ``pts`` ``(n, 3)``
    that share no vertex and whose closed bounding boxes overlap.

    The boxes are binned on a uniform grid (:func:`_grid_cells`); a pair is kept in the
    one cell it shares that is the lower corner of the two boxes' common range of cells:
    there, along every axis, the cell is the first of one of the two boxes (a 3-bit mask
    per entry).
    """
    cols = [np.ascontiguousarray(tri[:, k], dtype=np.intp) for k in range(3)]
    x = _corner_columns(pts, tri) if x is None else x
    lo, hi = np.empty((3, len(tri))), np.empty((3, len(tri)))
    for k in range(3):
        a, b, c = x[0][k], x[1][k], x[2][k]
        np.minimum(np.minimum(a, b, out=lo[k]), c, out=lo[k])
        np.maximum(np.maximum(a, b, out=hi[k]), c, out=hi[k])
    c0, c1, widened = _grid_cells(lo, hi)
    rank: np.ndarray | None = None
    sweep: tuple[np.ndarray, np.ndarray] | None = None
    axes: tuple[int, ...] = (0, 1, 2)
    if widened:  # many boxes per cube: sweep along x inside each cube
        rank = np.empty(len(tri), np.int64)
        rank[np.argsort(lo[0])] = np.arange(len(tri))
    cell, t, first = _cell_entries(c0.T, (c1 - c0 + 1).T, c1.max(axis=1) + 1, rank)
    if widened:
        sweep, axes = (lo[0].take(t), hi[0].take(t)), (1, 2)
    small = [c.astype(np.int32) for c in cols] if len(pts) < 2**31 else cols
    out_a, out_b = [np.zeros(0, np.intp)], [np.zeros(0, np.intp)]
    for a, b in _home_pairs(cell, t, first, sweep):
        for k in axes:  # the boxes overlap, one axis at a time
            lk, hk = lo[k], hi[k]
            meet = lk.take(a) <= hk.take(b)
            meet &= lk.take(b) <= hk.take(a)
            keep = np.flatnonzero(meet)
            a, b = a.take(keep), b.take(keep)
        ta, tb = [c.take(a) for c in small], [c.take(b) for c in small]
        common = (ta[0] == tb[0]) | (ta[0] == tb[1]) | (ta[0] == tb[2])
        for p in ta[1:]:
            common |= (p == tb[0]) | (p == tb[1]) | (p == tb[2])
        apart = np.flatnonzero(~common)
        out_a.append(a.take(apart))
        out_b.append(b.take(apart))
    a, b = np.concatenate(out_a), np.concatenate(out_b)
    return np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1)


def intersecting_pairs(points, triangles, *, with_degenerate: bool = False):
    """``(k, 2)`` int, ``i < j``, in lexicographic order: the pairs of ``triangles``
    ``(m, 3)`` on ``points`` ``(n, 3)`` that intersect other than through their shared
    vertices or edge (see the module notes; exact).

    With ``with_degenerate``, also returns a ``(k,)`` bool marking the pairs reported only
    because their configuration is degenerate (contact, decided conservatively).
    """
    pts = np.ascontiguousarray(points, dtype=float)
    tri = np.asarray(triangles, dtype=np.intp).reshape(-1, 3)
    x = _corner_columns(pts, tri)
    corners = np.stack([np.stack(x[k], axis=1) for k in range(3)], axis=1)  # pts[tri]
    normal, perm = _normals(x)
    if len(tri) < 2:
        pairs, degen = np.zeros((0, 2), np.intp), np.zeros(0, bool)
    else:
        unclear = ~_clear_stars(pts, tri, normal, perm, x)
        star, apart = _star_pairs(tri, unclear), _apart_pairs(tri, pts, x)
        h1, d1 = _narrow_phase(pts, tri, corners, normal, perm, star)
        h2, d2 = _apart_narrow_phase(pts, tri, corners, normal, perm, apart, x)
        pairs, degen = np.concatenate([star[h1], apart[h2]]), np.concatenate([d1[h1], d2[h2]])
    order = np.lexsort((pairs[:, 1], pairs[:, 0]))
    return (pairs[order], degen[order]) if with_degenerate else pairs[order]


def _narrow_phase(pts, tri, corners, normal, perm, pairs) -> tuple[np.ndarray, np.ndarray]:
    """``(k,) bool`` twice: which candidate ``pairs`` ``(k, 2)`` intersect (exact), and
    which of them only as a degenerate contact.
    """
    ta, tb = tri[pairs[:, 0]], tri[pairs[:, 1]]
    eq = eq_all = ta[:, :, None] == tb[:, None, :]  # (k, 3, 3): corner i of a is j of b
    keep = np.flatnonzero(~_separated(pts, ta, pairs[:, 1], eq.any(axis=2), corners, normal,
                                      perm))
    keep = keep[~_separated(pts, tb[keep], pairs[keep, 0], eq[keep].any(axis=1), corners,
                            normal, perm)]
    pairs, ta, tb, eq = pairs[keep], ta[keep], tb[keep], eq[keep]
    shared = eq.sum(axis=(1, 2))
    hit = np.zeros(len(pairs), bool)
    degen = np.zeros(len(pairs), bool)
    for k, test in ((0, _disjoint), (1, _one_shared)):
        sel = np.flatnonzero(shared == k)
        if len(sel):
            h, d = test(pts, pairs[sel], ta[sel], tb[sel], eq[sel], corners, normal, perm)
            hit[sel], degen[sel] = h | d, d & ~h
    two = np.flatnonzero(shared == 2)
    if len(two):
        hit[two] = _two_shared(pts, pairs[two], ta[two], tb[two], eq[two], corners, normal,
                               perm)
    full_hit, full_degen = np.zeros(len(eq_all), bool), np.zeros(len(eq_all), bool)
    full_hit[keep], full_degen[keep] = hit, degen & hit
    return full_hit, full_degen


def _apart_narrow_phase(pts, tri, corners, normal, perm, pairs,
                        x: list[list[np.ndarray]] | None = None
                        ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_narrow_phase` for ``pairs`` ``(k, 2)`` of triangles that share no vertex
    (``x``: the corner columns of :func:`_corner_columns`, when known).

    The sides of each triangle's corners against the other's plane are computed once: they
    separate the pair when all three are certainly on one side, and otherwise they are the
    edges' end sides of the segment tests (uncertain ones recomputed exactly).
    """
    x = _corner_columns(pts, tri) if x is None else x
    planes = [np.ascontiguousarray(c) for c in (*normal.T, *perm.T)]
    a, b = pairs[:, 0], pairs[:, 1]
    sep, det_a, bound_a = _apart_separated(x, planes, a, b)
    keep = np.flatnonzero(~sep)
    sep, det_b, bound_b = _apart_separated(x, planes, b.take(keep), a.take(keep))
    keep, det_a, bound_a = keep[~sep], det_a[:, keep[~sep]], bound_a[:, keep[~sep]]
    det_b, bound_b = det_b[:, ~sep], bound_b[:, ~sep]
    hit, degen = np.zeros(len(pairs), bool), np.zeros(len(pairs), bool)
    if len(keep):
        kp = pairs[keep]
        ka, kb = tri[kp[:, 0]], tri[kp[:, 1]]
        side_a = _certain_sides(pts, ka, kp[:, 1], corners, det_a, bound_a)
        side_b = _certain_sides(pts, kb, kp[:, 0], corners, det_b, bound_b)
        h, d = _disjoint(pts, kp, ka, kb, None, corners, normal, perm, (side_a, side_b))
        hit[keep], degen[keep] = h | d, d & ~h
    return hit, degen


def _certain_sides(pts, tv, other, corners, det, bound) -> np.ndarray:
    """``(3, k)`` int8: the exact sides of the corners of triangles ``tv`` ``(k, 3)``
    against the planes of triangles ``other`` ``(k,)``, from their float determinants
    ``det`` and error bounds ``bound`` ``(3, k)`` (rational where the bound does not
    certify the sign).
    """
    sign = np.sign(det).astype(np.int8)
    ii, kk = np.nonzero(np.abs(det) <= bound)
    if len(ii):
        tcs = corners[other[kk]]
        keep = ~_zero_terms(pts[tv[kk, ii]] - tcs[:, 0], tcs[:, 1] - tcs[:, 0],
                            tcs[:, 2] - tcs[:, 0])
        ii, kk = ii[keep], kk[keep]
    for i, k in zip(ii, kk, strict=True):
        tc = corners[other[k]]
        sign[i, k] = _exact_orient(pts[tv[k, i]], tc[1], tc[2], tc[0])
    return sign


def _apart_separated(x: list[list[np.ndarray]], planes: list[np.ndarray], tv: np.ndarray,
                     other: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_separated` for triangles ``tv`` ``(k,)`` against triangles ``other``
    ``(k,)`` that share no corner with them, on the corner columns ``x`` and the columns of
    the normals and their permanents ``planes``; also the corners' float determinants and
    their error bounds ``(3, k)``.
    """
    t0 = [c.take(other) for c in x[0]]
    n = [c.take(other) for c in planes[:3]]
    pm = [c.take(other) for c in planes[3:]]
    dets, bounds = np.empty((3, len(other))), np.empty((3, len(other)))
    for i in range(3):
        u = [c.take(tv) - t for c, t in zip(x[i], t0, strict=True)]
        dets[i] = u[0] * n[0] + u[1] * n[1] + u[2] * n[2]
        au = [np.abs(c) for c in u]
        bounds[i] = _ERR3 * (au[0] * pm[0] + au[1] * pm[1] + au[2] * pm[2]) + _floor(au)
    sure = np.asarray((dets > bounds).all(axis=0) | (dets < -bounds).all(axis=0))
    return sure, dets, bounds


def _separated(pts, tv, other, is_shared, corners, normal, perm) -> np.ndarray:
    """``(k,) bool``: the corners of triangles ``tv`` ``(k, 3)`` that are not shared lie
    strictly on one side of the plane of triangles ``other`` ``(k,)``, certainly (float
    signs beyond the error bound; an uncertain sign keeps the pair for the exact test).
    """
    t0 = [np.ascontiguousarray(corners[other, 0, c]) for c in range(3)]
    n = [normal[other, c] for c in range(3)]
    pm = [perm[other, c] for c in range(3)]
    pos = np.ones(len(tv), bool)
    neg = np.ones(len(tv), bool)
    for i in range(3):
        p = pts[tv[:, i]]
        u = [p[:, c] - t0[c] for c in range(3)]
        det = u[0] * n[0] + u[1] * n[1] + u[2] * n[2]
        au = [np.abs(c) for c in u]
        bound = _ERR3 * (au[0] * pm[0] + au[1] * pm[1] + au[2] * pm[2]) + _floor(au)
        free = ~is_shared[:, i]
        pos &= ~free | (det > bound)
        neg &= ~free | (det < -bound)
    return pos | neg


def _disjoint(pts, pairs, ta, tb, eq, corners, normal, perm, sides=None):
    """The six edges of two triangles with no common vertex against the other triangle,
    in one call (``sides``: the exact sides ``(3, k)`` twice of the corners of ``ta`` and
    ``tb`` against the other's plane, when known).
    """
    p = np.concatenate([pts[tv[:, i]] for tv in (ta, tb) for i in range(3)])
    q = np.concatenate([pts[tv[:, j]] for tv in (ta, tb) for j in (1, 2, 0)])
    against = np.concatenate([np.tile(pairs[:, 1], 3), np.tile(pairs[:, 0], 3)])
    ends = None
    if sides is not None:
        ends = (np.concatenate([sides[0].ravel(), sides[1].ravel()]),
                np.concatenate([sides[0][[1, 2, 0]].ravel(), sides[1][[1, 2, 0]].ravel()]))
    h, d, _, _ = _segment_meets(p, q, against, corners, normal, perm, ends)
    return h.reshape(6, -1).any(axis=0), d.reshape(6, -1).any(axis=0)


def _one_shared(pts, pairs, ta, tb, eq, corners, normal, perm):
    ia = eq.any(axis=2).argmax(axis=1)  # the shared corner's slot in a
    ib = eq.any(axis=1).argmax(axis=1)
    rows = np.arange(len(pairs))
    hit = np.zeros(len(pairs), bool)
    degen = np.zeros(len(pairs), bool)
    for tv, slot, other, ot, oslot in ((ta, ia, 1, tb, ib), (tb, ib, 0, ta, ia)):
        p = pts[tv[rows, (slot + 1) % 3]]
        q = pts[tv[rows, (slot + 2) % 3]]
        h, d, sp, sq = _segment_meets(p, q, pairs[:, other], corners, normal, perm)
        hit |= h
        degen |= d
        # an edge v p in the other's plane: it enters the other iff its ray lies in the
        # other's cone at v (exact); both edges in the plane: the triangles are coplanar
        for x, side in ((p, sp), (q, sq)):
            rows_in = np.flatnonzero(side == 0)
            if len(rows_in):
                k = rows_in
                v = pts[ot[k, oslot[k]]]
                b1 = pts[ot[k, (oslot[k] + 1) % 3]]
                b2 = pts[ot[k, (oslot[k] + 2) % 3]]
                hit[k] |= _ray_in_cone(v, x[k], b1, b2, corners[pairs[k, other]])
    return hit, degen & ~hit


def _two_shared(pts, pairs, ta, tb, eq, corners, normal, perm):
    ia_free = (~eq.any(axis=2)).argmax(axis=1)
    ib_free = (~eq.any(axis=1)).argmax(axis=1)
    rows = np.arange(len(pairs))
    a = ta[rows, ia_free]
    b = tb[rows, ib_free]
    side = _side(pts[b], corners[pairs[:, 0], 0], normal[pairs[:, 0]], perm[pairs[:, 0]],
                 corners, pairs[:, 0])
    hit = np.zeros(len(pairs), bool)
    for k in np.flatnonzero(side == 0):
        u, v = (x for x in ta[k] if x != a[k])
        hit[k] = _folded_flat(pts, u, v, a[k], b[k])
    return hit


def turned_over(rest_points, points, triangles, *, min_cos: float = 0.0) -> np.ndarray:
    """``(t,)`` int: the triangles whose normal in ``points`` makes an angle with their
    normal in ``rest_points`` whose cosine is at most ``min_cos`` (0: turned over or
    collapsed to no area).
    """
    tri = np.asarray(triangles, dtype=np.intp)
    r, p = np.asarray(rest_points, float)[tri], np.asarray(points, float)[tri]
    nr = _cross(r[:, 1] - r[:, 0], r[:, 2] - r[:, 0])
    npt = _cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    dot = np.einsum("ij,ij->i", nr, npt)
    size = np.linalg.norm(nr, axis=1) * np.linalg.norm(npt, axis=1)
    return np.flatnonzero(dot <= min_cos * size)


@dataclass(frozen=True)
class FoldReport:
    """What a frame adds to the crossings of its rest skin.

    Attributes
    ----------
    added : (k, 2) int
        Intersecting triangle pairs of the frame that do not intersect at rest.
    degenerate : (k,) bool
        Of ``added``, the pairs reported as contact because their configuration is
        degenerate.
    turned : (t,) int
        Triangles turned over against the rest skin.
    at_rest : int
        Intersecting pairs of the rest skin (not counted against the frame).
    """

    added: np.ndarray
    degenerate: np.ndarray
    turned: np.ndarray
    at_rest: int

    @property
    def ok(self) -> bool:
        """No added crossing and no triangle turned over."""
        return len(self.added) == 0 and len(self.turned) == 0

    def __str__(self) -> str:
        return (f"{len(self.added)} crossing pairs added ({int(self.degenerate.sum())} "
                f"degenerate contacts), {len(self.turned)} triangles turned over, "
                f"{self.at_rest} pairs crossing at rest")


def _pair_keys(pairs: np.ndarray, m: int) -> np.ndarray:
    return pairs[:, 0].astype(np.int64) * m + pairs[:, 1]


def fold_report(rest_points, points, triangles, rest_pairs=None) -> FoldReport:
    """The certificate of one frame: its crossings not there at rest, and its turned-over
    triangles.

    Only the triangles the frame moved, and those whose boxes reach the box around them,
    are tested: a pair of triangles that did not move crosses in the frame exactly when it
    crosses at rest, so it is never *added* (the result is the same as testing every pair).

    Parameters
    ----------
    rest_points, points : (n, 3) float
        The rest skin and the frame's skin, on the same ``triangles`` ``(m, 3)``.
    rest_pairs : (r, 2) int, optional
        :func:`intersecting_pairs` of the rest skin, when already known (it depends on the
        rest skin only).
    """
    tri = np.asarray(triangles, dtype=np.intp)
    rest = np.asarray(rest_points, dtype=float)
    pts = np.asarray(points, dtype=float)
    if rest_pairs is None:
        rest_pairs = intersecting_pairs(rest, tri)
    pairs, degen = _moved_pairs(pts, np.any(pts != rest, axis=1), tri)
    new = ~np.isin(_pair_keys(pairs, len(tri)), _pair_keys(np.asarray(rest_pairs), len(tri)))
    return FoldReport(pairs[new], degen[new], turned_over(rest, pts, tri), len(rest_pairs))


def _moved_pairs(pts: np.ndarray, moved: np.ndarray, tri: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """``(k, 2)`` int and ``(k,)`` bool: the intersecting pairs (and which are degenerate)
    of ``tri`` ``(m, 3)`` on ``pts`` ``(n, 3)`` with at least one triangle that has a
    corner in ``moved`` ``(n,) bool``.
    """
    moved_t = moved[tri].any(axis=1)
    if not moved_t.any():
        return np.zeros((0, 2), np.intp), np.zeros(0, bool)
    corners = pts[tri]
    lo, hi = corners.min(axis=1), corners.max(axis=1)
    box_lo, box_hi = lo[moved_t].min(axis=0), hi[moved_t].max(axis=0)
    near = np.flatnonzero(np.all((hi >= box_lo) & (lo <= box_hi), axis=1))
    pairs, degen = intersecting_pairs(pts, tri[near], with_degenerate=True)
    pairs = near[pairs]
    keep = moved_t[pairs].any(axis=1)
    return pairs[keep], degen[keep]
