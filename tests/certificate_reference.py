"""The certificate as it was before stop 36 (every pair of overlapping boxes through the
exact narrow phase), kept verbatim as the reference the faster one must equal pair for pair.
Only the tests import it.
"""
from __future__ import annotations

from fractions import Fraction

import numpy as np

_EPS = 2.0 ** -53
_ERR3 = (7.0 + 56.0 * _EPS) * _EPS


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
    u, v, w = a - d, b - d, c - d
    det = np.einsum("ij,ij->i", u, _cross(v, w))
    bound = _ERR3 * np.einsum("ij,ij->i", np.abs(u), _abs_cross(v, w))
    sign = np.sign(det).astype(np.int8)
    unsure = np.flatnonzero((np.abs(det) <= bound) & (bound > 0))
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
    for k in np.flatnonzero((np.abs(det) <= bound) & (bound > 0)):
        sign[k] = _exact_orient2(a[k], b[k], c[k])
    return sign


def _drop_axis(tc: np.ndarray) -> np.ndarray:
    """``(k, 2)`` int: the coordinates kept when projecting the plane of triangles
    ``(k, 3, 3)`` onto the coordinate plane its normal is least parallel to.
    """
    n = _cross(tc[:, 1] - tc[:, 0], tc[:, 2] - tc[:, 0])
    axis = np.abs(n).argmax(axis=1)
    return np.array([[1, 2], [0, 2], [0, 1]])[axis]


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


def _boxes(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return corners.min(axis=1), corners.max(axis=1)


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


def _segment_meets(p, q, tri_idx, corners, normal, perm):
    """``(k,) bool`` twice: the closed segments ``p q`` ``(k, 3)`` meet the closed triangles
    ``corners[tri_idx]`` (general position), and the configuration is degenerate (segment in
    the triangle's plane, or the line through an edge's line); then ``(k,)`` int8 twice: the
    sides of ``p`` and ``q`` against the triangle's plane.
    """
    t0 = corners[tri_idx, 0]
    n, pm = normal[tri_idx], perm[tri_idx]
    sp = _side(p, t0, n, pm, corners, tri_idx)
    sq = _side(q, t0, n, pm, corners, tri_idx)
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
    bound = _ERR3 * np.einsum("ij,ij->i", np.abs(u), pm)
    sign = np.sign(det).astype(np.int8)
    unsure = np.flatnonzero((np.abs(det) <= bound) & (bound > 0))
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


def intersecting_pairs(points, triangles, *, with_degenerate: bool = False):
    """``(k, 2)`` int, ``i < j``: the pairs of ``triangles`` ``(m, 3)`` on ``points``
    ``(n, 3)`` that intersect other than through their shared vertices or edge (see the
    module notes; exact).

    With ``with_degenerate``, also returns a ``(k,)`` bool marking the pairs reported only
    because their configuration is degenerate (contact, decided conservatively).
    """
    pts = np.ascontiguousarray(points, dtype=float)
    tri = np.asarray(triangles, dtype=np.intp)
    corners = pts[tri]
    pairs = candidate_pairs(corners)
    e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    normal, perm = _cross(e1, e2), _abs_cross(e1, e2)
    ta, tb = tri[pairs[:, 0]], tri[pairs[:, 1]]
    eq = ta[:, :, None] == tb[:, None, :]  # (k, 3, 3): corner i of a is corner j of b
    keep = ~(_separated(pts, ta, pairs[:, 1], eq.any(axis=2), corners, normal, perm)
             | _separated(pts, tb, pairs[:, 0], eq.any(axis=1), corners, normal, perm))
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
    out = pairs[hit]
    return (out, degen[hit]) if with_degenerate else out


def _separated(pts, tv, other, is_shared, corners, normal, perm) -> np.ndarray:
    """``(k,) bool``: the corners of triangles ``tv`` ``(k, 3)`` that are not shared lie
    strictly on one side of the plane of triangles ``other`` ``(k,)``, certainly (float
    signs beyond the error bound; an uncertain sign keeps the pair for the exact test).
    """
    t0 = corners[other, 0]
    n, pm = normal[other], perm[other]
    pos = np.ones(len(tv), bool)
    neg = np.ones(len(tv), bool)
    for i in range(3):
        u = pts[tv[:, i]] - t0
        det = np.einsum("ij,ij->i", u, n)
        bound = _ERR3 * np.einsum("ij,ij->i", np.abs(u), pm)
        free = ~is_shared[:, i]
        pos &= ~free | (det > bound)
        neg &= ~free | (det < -bound)
    return pos | neg


def _disjoint(pts, pairs, ta, tb, eq, corners, normal, perm):
    hit = np.zeros(len(pairs), bool)
    degen = np.zeros(len(pairs), bool)
    for other, tv in ((1, ta), (0, tb)):
        for i, j in ((0, 1), (1, 2), (2, 0)):
            h, d, _, _ = _segment_meets(pts[tv[:, i]], pts[tv[:, j]], pairs[:, other],
                                        corners, normal, perm)
            hit |= h
            degen |= d
    return hit, degen


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
