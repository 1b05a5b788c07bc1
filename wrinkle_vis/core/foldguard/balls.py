"""The wrinkles' balls: medial radii empty of the skin, rest and deformed; certified skips."""
from __future__ import annotations

import math
from itertools import chain

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from ..mesh import _closest_on_triangles as _mesh_closest
from ._base import (  # noqa: F401
    FoldGuard,
    _closest_on_triangles,
    _cross,
    _in_box,
    _near_edges,
    _sq,
    _terms_edges,
    _vertex_normals,
)


def medial_radii(points: np.ndarray, normals: np.ndarray, samples: np.ndarray | None = None,
                 r_max: float | np.ndarray | None = None, iterations: int = 40,
                 tree: cKDTree | None = None) -> np.ndarray:
    r"""``(n, 2)``: radii :math:`(r_+, r_-)` of the largest balls empty of ``samples`` that
    touch ``points`` ``(n, 3)`` on the side of unit ``normals`` ``(n, 3)`` and against it.

    The shrinking-ball search: start with radius ``r_max`` (the samples' bounding-box
    diagonal), centre :math:`c = x \pm r n`; while the sample :math:`q` nearest
    to :math:`c` is closer than :math:`r` (and is not :math:`x`), shrink to the ball through
    :math:`x` and :math:`q` tangent at :math:`x`,
    :math:`r = |q - x|^2 / (2 |n \cdot (q - x)|)`. ``samples`` ``(s, 3)`` default to
    ``points``. ``r_max`` may be ``(n,)``: the balls tangent at a point on one side nest,
    so the result is then :math:`\min(r_\pm, r_{\max})` (all a clamp needs to know, found
    in fewer, nearer steps); ``(n, 2)``, one per side, 0 where that side is not wanted.
    ``tree``: a ``cKDTree`` of ``samples``, when one is at hand.
    """
    pts = np.asarray(points, dtype=float)
    nrm = np.asarray(normals, dtype=float)
    smp = pts if samples is None else np.asarray(samples, dtype=float)
    if tree is None:
        tree = cKDTree(smp, balanced_tree=False)  # built each frame for the deformed skin
    if r_max is None:
        r_max = float(np.linalg.norm(smp.max(axis=0) - smp.min(axis=0)))
    if not len(pts):
        return np.zeros((0, 2))
    out = np.empty((len(pts), 2))
    for col, side in enumerate((1.0, -1.0)):
        r_side = np.asarray(r_max, dtype=float)
        r_side = r_side[:, col] if r_side.ndim == 2 else r_side
        r = np.array(np.broadcast_to(r_side, (len(pts),)))
        active = np.flatnonzero(r > 0)
        for _ in range(iterations):
            if not len(active):
                break
            x, n = pts[active], nrm[active]
            c = x + side * r[active, None] * n
            dist, idx = tree.query(c)
            q = smp[idx]
            d = q - x
            dd = np.einsum("ij,ij->i", d, d)
            h = side * np.einsum("ij,ij->i", d, n)
            shrink = (dist < r[active] * (1.0 - 1e-9)) & (dd > 0) & (h > 0)
            new = np.where(shrink, dd / (2.0 * np.where(h > 0, h, 1.0)), r[active])
            r[active] = np.minimum(r[active], new)
            active = active[shrink]
        out[:, col] = r
    return out


def _side_squares(points: np.ndarray, tri: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""``(m,)`` thrice: the squared sides :math:`a^2 = |v_1 - v_2|^2`, :math:`b^2 = |v_2 -
    v_0|^2`, :math:`c^2 = |v_0 - v_1|^2` of the triangles ``tri`` ``(m, 3)`` on ``points``
    ``(n, 3)``, from one take of each corner's rows (:func:`_enclosing_sq` and
    :func:`_sides_longest` read the same numbers).
    """
    a, b, c = (np.take(points, np.ascontiguousarray(tri[:, j]), axis=0) for j in range(3))
    d = b - c  # (contiguous rows, takes: about half the time of fancy indexing)
    a2 = np.einsum("ij,ij->i", d, d)
    d = c - a
    b2 = np.einsum("ij,ij->i", d, d)
    d = a - b
    return a2, b2, np.einsum("ij,ij->i", d, d)


def _enclosing_sq(points: np.ndarray, tri: np.ndarray,
                  squares: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
                  ) -> np.ndarray:
    r"""``(m,)``: an upper bound of :math:`\rho_t^2`, the squared radius of the smallest disc
    holding the triangles ``tri`` ``(m, 3)`` on ``points`` ``(n, 3)``: half the longest edge
    where the triangle is right or obtuse (:math:`c^2 \ge a^2 + b^2`), else its circumradius
    :math:`a^2 b^2 c^2 / (16 A^2)`; never above :math:`\ell^2 / 3` (Jung), and raised by
    :math:`10^{-9}` of itself against rounding. ``squares``: :func:`_side_squares` of these
    triangles, when at hand (``(m,)`` thrice).
    """
    a2, b2, c2 = _side_squares(points, tri) if squares is None else squares
    top = np.maximum(np.maximum(a2, b2), c2)  # the longest edge's square, and the rest:
    rest = a2 + b2 + c2 - top  # the other two's sum (obtuse or right: top >= rest)
    area16 = 2.0 * (a2 * b2 + b2 * c2 + c2 * a2) - (a2 * a2 + b2 * b2 + c2 * c2)
    acute = (top < rest) & (area16 > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        circ = np.where(acute, a2 * b2 * c2 / np.where(acute, area16, 1.0), 0.0)
    rho = np.where(acute, np.minimum(circ, top / 3.0), 0.25 * top)
    return rho * (1.0 + 1e-9)


def _lift(points: np.ndarray, tri: np.ndarray,
          squares: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> dict:
    r"""The triangles' reach, lifted to 4-D ``cKDTree`` s, for :func:`_suspects`: each vertex
    :math:`v` of ``points`` ``(n, 3)`` carries :math:`\rho_v^2 = \max_{t \ni v} \rho_t^2`
    over its triangles of ``tri`` ``(m, 3)`` (:func:`_enclosing_sq`). The vertices are taken
    in classes of :math:`\rho_v^2` (by factors of 16, at most 6), each class with the
    largest :math:`T` of its :math:`\rho_v^2` and its own tree of the vertices lifted to
    :math:`(v, \sqrt{T - \rho_v^2})`: a centre :math:`c` lifted to :math:`(c, 0)` is
    :math:`\sqrt{|v - c|^2 - \rho_v^2 + T}` from :math:`v`, so one nearest-point query, or one
    ball query of radius :math:`\sqrt{r^2 + T}`, per class finds the vertices with
    :math:`|v - c|^2 - \rho_v^2 \le r^2` exactly. (One tree for a skin whose triangles
    differ much in size, a refined one, is slow to query: its fine vertices' lifts are all
    near :math:`\sqrt T`.) ``squares``: :func:`_side_squares` of ``tri``, when at hand.
    """
    rho_t = _enclosing_sq(points, tri, squares) if len(tri) else np.zeros(0)
    rho = np.zeros(len(points))
    np.maximum.at(rho, tri.ravel(), np.repeat(rho_t, 3))
    top = float(rho.max()) if len(rho) else 0.0
    if top > 0:
        with np.errstate(divide="ignore"):
            level = np.floor(np.log(top / np.maximum(rho, top * 1e-300)) / math.log(16.0))
        level = np.clip(level, 0, 5).astype(np.intp)
    else:
        level = np.zeros(len(rho), np.intp)
    classes, T = [], np.zeros(len(points))
    for k in np.unique(level):
        ids = np.flatnonzero(level == k)
        Tk = float(rho[ids].max())
        T[ids] = Tk
        lifted = np.column_stack([points[ids], np.sqrt(np.maximum(Tk - rho[ids], 0.0))])
        classes.append((cKDTree(lifted, leafsize=32, balanced_tree=False), ids, Tk))
    return {"classes": classes, "T": T, "rho_t": rho_t, "rho": rho, "tri": tri,
            "n": len(points)}


def _skin_lift(face) -> dict:
    """:func:`_lift` of ``face``'s own rest skin, kept with its rest frame."""
    rest = face._rest
    got = getattr(rest, "fold_lift", None)
    if got is None:
        got = rest.fold_lift = _lift(np.asarray(face.skin.points, dtype=float),
                                     np.asarray(face.skin.triangles, dtype=np.intp))
    return got


def _cleared(lift: dict, centres: np.ndarray, radii: np.ndarray, own: np.ndarray
             ) -> np.ndarray:
    r"""``(k,)`` bool: the balls ``centres`` ``(k, 3)``, ``radii`` ``(k,)`` that no triangle
    not incident to vertex ``own`` ``(k,)`` can meet, and no vertex but ``own``, by one
    2-nearest query per class of :func:`_lift`: a triangle :math:`t` with a point :math:`q =
    \sum_i \lambda_i v_i` at :math:`|q - c| \le r` has :math:`\sum_i \lambda_i |v_i - c|^2 =
    |q - c|^2 + \sum_i \lambda_i |v_i - q|^2 \le r^2 + \rho_t^2` (the weighted spread of
    its corners about their mean :math:`q` is at most their spread about the centre of the
    smallest disc holding them), so a corner :math:`v \ne` ``own`` has :math:`|v - c|^2 -
    \rho_v^2 \le r^2`. Where, in every class, the nearest lifted vertex other than ``own``
    is farther than :math:`\sqrt{(r^2 + T)(1 + 10^{-9})}`, no such corner exists. (The
    searches decide it from :func:`_lifted_near`'s query, which also finds the candidates.)
    """
    out = np.ones(len(centres), bool)
    if not len(centres):
        return out
    c4 = np.column_stack([centres, np.zeros(len(centres))])
    # the largest class first (most balls fail there); each later one asks only for the
    # balls still cleared
    for tree, ids, Tk in sorted(lift["classes"], key=lambda c: -len(c[1])):
        left = np.flatnonzero(out)
        if not len(left):
            break
        k = min(2, len(ids))  # (a neighbour beyond every ball's bound is not needed)
        bound = math.sqrt((float(radii[left].max()) ** 2 + Tk) * (1.0 + 1e-9)) * (1.0 + 1e-6)
        d, i = tree.query(c4[left], k=k, distance_upper_bound=bound)
        d, i = d.reshape(len(left), k), i.reshape(len(left), k)
        first = np.where(i[:, 0] < len(ids), ids[np.minimum(i[:, 0], len(ids) - 1)], -1)
        other = np.where(first == own[left], d[:, -1] if k == 2 else np.inf, d[:, 0])
        out[left] = other * other > (radii[left] ** 2 + Tk) * (1.0 + 1e-9)
    return out


_SUSPECTS_K = 6  # the nearest lifted vertices a ball's candidates are first looked for in


def _suspects(lift: dict, centres: np.ndarray, radii: np.ndarray, own: np.ndarray,
              points: np.ndarray, tri: np.ndarray, clear: bool = True
              ) -> tuple[np.ndarray, np.ndarray]:
    r"""``(p,)`` twice: the pairs (ball, triangle) of balls ``centres`` ``(k, 3)``,
    ``radii`` ``(k,)`` tangent at vertices ``own`` ``(k,)`` and triangles ``tri`` ``(m, 3)``
    on ``points`` ``(n, 3)`` not incident to ``own`` that may meet (every pair that does,
    once): a triangle meeting the ball has a corner :math:`v` with :math:`|v - c|^2 \le r^2
    + \rho_t^2 \le r^2 + \rho_v^2` (:func:`_cleared`). With ``clear``, the balls
    :func:`_cleared` clears are skipped; the others' vertices with :math:`|v - c|^2 -
    \rho_v^2 \le r^2` are found by :func:`_lifted_near` (the same queries clear the balls),
    then each of their triangles is kept if a corner has :math:`|v - c|^2
    \le (r^2 + \rho_t^2)(1 + 10^{-9})`, once: through the first of its corners with
    :math:`|v - c|^2 - \rho_v^2 \le r^2 + 1.5 \cdot 10^{-9} (r^2 + T_v)` (the class's query,
    at :math:`2 \cdot 10^{-9}`, finds it; a triangle kept has one, as :math:`\rho_t \le
    \rho_v \le T_v`).
    """
    none = np.zeros(0, np.intp), np.zeros(0, np.intp)
    if not len(centres) or not len(tri):
        return none
    _, ball, vert = _lifted_near(lift, centres, radii, own, clear)
    keep = vert != own[ball]  # (every triangle of the own vertex is incident to it)
    ball, vert = ball[keep], vert[keep]
    if not len(ball):
        return none
    return _first_found(lift, centres, radii, own, points, *_expand(lift, ball, vert))


def _lifted_near(lift: dict, centres: np.ndarray, radii: np.ndarray, own: np.ndarray,
                 clear: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""``(k,)`` bool: the balls ``centres`` ``(k, 3)``, ``radii`` ``(k,)`` tangent at
    vertices ``own`` ``(k,)`` that :func:`_cleared` clears (none without ``clear``); and
    ``(q,)`` twice: the pairs (ball, vertex) of the other balls and every lifted vertex
    (:func:`_lift`) within :math:`\sqrt{(r^2 + T)(1 + 2 \cdot 10^{-9})}` of the lifted
    centre, each once. One :data:`_SUSPECTS_K`-nearest query per class serves both:
    :func:`_cleared`'s two nearest are its first two columns (its test's bound,
    :math:`\sqrt{(r^2 + T)(1 + 10^{-9})}`, lies inside the query's: a vertex beyond the
    query's bound clears either way); a ball whose :math:`K`-th nearest is within its bound
    asks a ball query for the rest (after every class, only where not cleared). A class of
    fewer vertices than :math:`1/`:data:`_REVERSE_RATIO` of the balls is asked by its
    vertices instead (:func:`_reverse_pairs`), the same pairs and the same clearing from
    each pair's lifted distance.
    """
    c4 = np.column_stack([centres, np.zeros(len(centres))])
    cleared = np.ones(len(centres), bool) if clear else np.zeros(len(centres), bool)
    balls, verts, fulls = [], [], []
    by_ball: dict = {}  # (the balls' own lifted tree, built for the first small class)
    for tree, ids, Tk in lift["classes"]:
        r2T = radii * radii + Tk
        if len(ids) * _REVERSE_RATIO < len(centres):  # few vertices: their queries
            row, vert, d2 = _reverse_pairs(by_ball, centres, radii, tree, ids, Tk, lift)
            if clear:
                bad = (vert != own.take(row)) & (d2 <= r2T.take(row) * (1.0 + 1e-9))
                cleared[row[bad]] = False
            keep = d2 <= r2T.take(row) * (1.0 + 2e-9)
            balls.append(row[keep])
            verts.append(vert[keep])
            continue
        bound = np.sqrt(r2T * (1.0 + 2e-9))
        k = min(_SUSPECTS_K, len(ids))  # k nearest first (arrays); a full row: a ball query
        d, i = _query_by_bound(tree, c4, bound, k)
        if clear:  # (_cleared's test, on its two nearest)
            first = np.where(i[:, 0] < len(ids), ids[np.minimum(i[:, 0], len(ids) - 1)], -1)
            other = np.where(first == own, d[:, 1] if k >= 2 else np.inf, d[:, 0])
            cleared &= other * other > r2T * (1.0 + 1e-9)
        inside = d <= bound[:, None]
        full = np.flatnonzero(inside[:, -1]) if k == _SUSPECTS_K else np.zeros(0, np.intp)
        inside[full] = False
        rows, cols = np.nonzero(inside)
        verts.append(ids[i[rows, cols]])
        balls.append(rows)
        fulls.append((tree, ids, full, bound[full]))
    for tree, ids, full, bound in fulls:
        keep = ~cleared[full]
        if keep.any():
            near = tree.query_ball_point(c4[full[keep]], bound[keep])
            counts = np.fromiter(map(len, near), np.intp, len(near))
            verts.append(ids[np.fromiter(chain.from_iterable(near), np.intp,
                                         int(counts.sum()))])
            balls.append(np.repeat(full[keep], counts))
    ball, vert = np.concatenate(balls), np.concatenate(verts)
    if clear:
        keep = ~cleared[ball]
        ball, vert = ball[keep], vert[keep]
    return cleared, ball, vert


_REVERSE_RATIO = 2  # a class of fewer lifted vertices than 1/2 the balls: queried by them


def _reverse_pairs(by_ball: dict, centres: np.ndarray, radii: np.ndarray, tree: cKDTree,
                   ids: np.ndarray, Tk: float, lift: dict
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""``(q,)`` thrice: the pairs (ball, vertex) of :func:`_lifted_near`'s class ``tree``,
    ``ids`` ``(s,)``, ``Tk`` and the balls ``centres`` ``(k, 3)``, ``radii`` ``(k,)``, and
    each pair's lifted :math:`d^2 = |v - c|^2 + T - \rho_v^2`, found by the class's
    vertices in a tree of the balls (kept in ``by_ball``): each ball lifted to :math:`(c,
    \sqrt{R^2 - r^2})`, :math:`R` the largest radius, each vertex to :math:`(v, 0)`, is
    :math:`\sqrt{|v - c|^2 + R^2 - r^2}` from it, so a ball query of radius
    :math:`\sqrt{R^2 + \rho_v^2 + 3 \cdot 10^{-9} (R^2 + T)}` finds every ball with
    :math:`|v - c|^2 - \rho_v^2 \le r^2 + 2 \cdot 10^{-9} (r^2 + T)`, the class query's
    (``docs/model.md``, "Small classes, queried by their vertices"). Every pair within
    the ball query (a few beyond the forward bound; the caller keeps those within it).
    """
    if "tree" not in by_ball:
        r2 = radii * radii
        R2 = float(r2.max())
        by_ball["R2"] = R2
        by_ball["tree"] = cKDTree(np.column_stack([centres, np.sqrt(np.maximum(R2 - r2, 0.0))]),
                                  leafsize=32, balanced_tree=False)
    R2 = by_ball["R2"]
    rho = lift["rho"].take(ids)
    v4 = np.column_stack([tree.data[:, :3], np.zeros(len(ids))])
    near = by_ball["tree"].query_ball_point(v4, np.sqrt(R2 + rho + 3e-9 * (R2 + Tk)),
                                            return_sorted=False)
    counts = np.fromiter(map(len, near), np.intp, len(near))
    row = np.fromiter(chain.from_iterable(near), np.intp, int(counts.sum()))
    at = np.repeat(np.arange(len(ids)), counts)
    d = np.take(tree.data[:, :3], at, axis=0)
    d -= np.take(centres, row, axis=0)
    return row, ids.take(at), np.einsum("ij,ij->i", d, d) + (Tk - rho.take(at))


_BOUND_STEP = 1.25  # the ratio of the query bounds a group of balls shares (_query_by_bound)
_BOUND_GROUPS = 4  # at most so many groups (the last: every bound below 1.25^-3 of the top)
_GROUPED_FROM = 2048  # fewer balls than this: one query


def _query_by_bound(tree: cKDTree, c4: np.ndarray, bound: np.ndarray, k: int
                    ) -> tuple[np.ndarray, np.ndarray]:
    r"""``(b, k)`` twice: the ``k`` nearest points of ``tree`` to ``c4`` ``(b, 4)`` (their
    distances and rows, ``inf`` and ``tree.n`` where none) within at least ``bound``
    ``(b,)`` each, a query per group of balls whose bounds lie within a factor
    :data:`_BOUND_STEP` of each other (at most :data:`_BOUND_GROUPS`, the last holding every
    bound below :math:`1.25^{-3}` of the largest; one query for fewer than
    :data:`_GROUPED_FROM` balls), each at its group's largest bound (one query at the
    largest bound of all lets a few large balls widen every ball's search). A neighbour
    within a ball's own bound is found either way, at the same rank and distance (the
    tree's distance to a point does not depend on the bound); beyond it, the callers read
    nothing but that it is beyond.
    """
    top = float(bound.max()) if len(bound) else 0.0
    if len(bound) < _GROUPED_FROM or top <= 0:  # (a query's own cost: not worth a split)
        groups = np.zeros(1, np.intp)
    else:
        with np.errstate(divide="ignore"):
            g = np.floor(np.log(top / np.maximum(bound, top * 1e-300)) / math.log(_BOUND_STEP))
        g = np.clip(g, 0, _BOUND_GROUPS - 1).astype(np.intp)
        groups = np.unique(g)
    if len(groups) < 2:
        d, i = tree.query(c4, k=k, distance_upper_bound=top)
        return d.reshape(len(c4), k), i.reshape(len(c4), k)
    d, i = np.empty((len(c4), k)), np.empty((len(c4), k), np.intp)
    for grp in groups:
        sel = np.flatnonzero(g == grp)
        dg, ig = tree.query(c4[sel], k=k, distance_upper_bound=float(bound[sel].max()))
        d[sel], i[sel] = dg.reshape(len(sel), k), ig.reshape(len(sel), k)
    return d, i


def _first_found(lift: dict, centres: np.ndarray, radii: np.ndarray, own: np.ndarray,
                 points: np.ndarray, ball: np.ndarray, t: np.ndarray, vert: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    r"""The pairs of :func:`_suspects` kept from its found pairs ``ball``, ``t`` and
    ``vert`` ``(q,)`` (a ball, a triangle of the vertex found for it, that vertex): the
    triangles not incident to the ball's own vertex with a corner at :math:`|v - c|^2 \le
    (r^2 + \rho_t^2)(1 + 10^{-9})`, each through the first of its corners with
    :math:`|v - c|^2 - \rho_v^2 \le r^2 + 1.5 \cdot 10^{-9} (r^2 + T_v)` (the first
    corner where none has it). Column by column: the corners' three rows apart, the
    cheapest test first (reductions over rows of 3 are slow).
    """
    cols = lift.get("columns")
    if cols is None:  # the corners' columns, contiguous (a take from each is faster)
        cols = lift["columns"] = tuple(np.ascontiguousarray(lift["tri"][:, j]) for j in range(3))
    o = own.take(ball)  # (takes throughout: several times faster than fancy indexing)
    cs = [cj.take(t) for cj in cols]
    keep = np.flatnonzero((cs[0] != o) & (cs[1] != o) & (cs[2] != o))  # not own's
    ball, t, vert = ball.take(keep), t.take(keep), vert.take(keep)
    cs = [cj.take(keep) for cj in cs]
    c, dd = np.take(centres, ball, axis=0), []
    for cj in cs:
        d = np.take(points, cj, axis=0)
        d -= c
        dd.append(np.einsum("ij,ij->i", d, d))
    r2 = radii.take(ball) ** 2
    near = np.minimum(np.minimum(dd[0], dd[1]), dd[2]) <= (r2 + lift["rho_t"].take(t)) \
        * (1.0 + 1e-9)
    rho, T = lift["rho"], lift["T"]
    found = [dd[j] - rho.take(cs[j]) <= r2 + 1.5e-9 * (r2 + T.take(cs[j])) for j in range(3)]
    first = np.where(found[0] | ~(found[1] | found[2]), cs[0], np.where(found[1], cs[1], cs[2]))
    keep = near & (first == vert)
    return ball[keep], t[keep]


def _expand(lift: dict, ball: np.ndarray, verts: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(p,)`` thrice: each pair of ``ball`` and ``verts`` ``(q,)`` repeated for every
    triangle of that vertex (ball, triangle, vertex), from :func:`_lift`'s incidence.
    """
    t, deg = _star_rows(lift, verts)
    return np.repeat(ball, deg), t, np.repeat(verts, deg)


def _star_rows(lift: dict, verts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(p,)``: the triangles of each vertex of ``verts`` ``(q,)`` in turn (each vertex's
    in ascending order), and ``(q,)``: how many each has, from :func:`_lift`'s incidence.
    """
    if "ptr" not in lift:  # the vertex-triangle incidence, built on first need: the
        tri = lift["tri"]  # triangles' rows of corners, a CSR matrix as they stand, turned
        m = len(tri)  # to CSC (a counting sort: each vertex's triangles in ascending order)
        inc = sp.csr_matrix((np.ones(3 * m, np.int8), tri.ravel(), np.arange(0, 3 * m + 1, 3)),
                            shape=(m, lift["n"])).tocsc()
        inc.sum_duplicates()  # (a triangle with a repeated corner: once, as COO to CSR)
        lift["by_vertex"] = inc.indices.astype(np.intp, copy=False)
        lift["ptr"] = inc.indptr.astype(np.intp, copy=False)
    ptr = lift["ptr"]
    first = ptr.take(verts)
    deg = ptr.take(verts + 1) - first
    total = int(deg.sum())
    starts = np.repeat(first - np.concatenate([[0], np.cumsum(deg)[:-1]]), deg)
    return lift["by_vertex"].take(starts + np.arange(total)), deg


def _near_found(lift: dict, centres: np.ndarray, radii: np.ndarray, own: np.ndarray,
                points: np.ndarray, ball: np.ndarray, vert: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    r"""``(p,)`` twice: the pairs (ball, triangle) of the balls ``centres`` ``(k, 3)``,
    ``radii`` ``(k,)`` tangent at vertices ``own`` ``(k,)`` kept from the found pairs
    (ball, vertex) ``ball``, ``vert`` ``(q,)`` of :func:`_lifted_near`: each triangle
    :math:`t` of a found vertex :math:`v`, not incident to ``own``, with :math:`|v - c|^2
    \le (r^2 + \rho_t^2)(1 + 10^{-9})`, once per such corner (a triangle may come twice
    or thrice: the shrinking ball's minimum does not mind). The same triangles as
    :func:`_first_found` keeps: one of its corners passes that test where any does, and
    that corner is found (``docs/model.md``, "The found pairs, undeduplicated"); the test
    reads :math:`|v - c|^2` once per found pair, not thrice per triangle.
    """
    d = np.take(points, vert, axis=0)  # (takes throughout: faster than fancy indexing)
    d -= np.take(centres, ball, axis=0)
    r2 = radii.take(ball) ** 2
    t, deg = _star_rows(lift, vert)
    dv, r2 = np.repeat(np.einsum("ij,ij->i", d, d), deg), np.repeat(r2, deg)
    keep = np.flatnonzero(dv <= (r2 + lift["rho_t"].take(t)) * (1.0 + 1e-9))
    t, o = t.take(keep), np.repeat(own.take(ball), deg).take(keep)
    cols = lift.get("columns")
    if cols is None:  # the corners' columns, contiguous (a take from each is faster)
        cols = lift["columns"] = tuple(np.ascontiguousarray(lift["tri"][:, j]) for j in range(3))
    mine = (cols[0].take(t) == o) | (cols[1].take(t) == o) | (cols[2].take(t) == o)
    keep = keep[~mine]
    return np.repeat(ball, deg).take(keep), t[~mine]


def triangle_radii(ids: np.ndarray, normals: np.ndarray, radii: np.ndarray,
                   points: np.ndarray, triangles: np.ndarray, iterations: int = 60,
                   lift: dict | None = None, clear: bool = True,
                   found: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    r"""``(k, 2)``: the radii ``radii`` ``(k, 2)`` (:math:`r_\pm` of balls empty of the
    vertices, :func:`medial_radii`, touching vertices ``ids`` ``(k,)`` of the skin
    ``points`` ``(n, 3)``, ``triangles`` ``(m, 3)``, at unit ``normals`` ``(k, 3)``) lowered
    to balls empty of the *triangles* not incident to the vertex (0: that side not wanted).

    A ball of radius :math:`r` tangent at :math:`x` can hold part of a triangle whose
    corners all lie outside it (a ball smaller than the triangle, or two sheets pressed
    together): the shrinking-ball search is run again on the triangles, with :math:`q` the
    point of a triangle nearest the centre: while one lies inside, shrink to the ball through
    :math:`x` and :math:`q`, :math:`r = |q - x|^2 / (2 |n \cdot (q - x)|)`. The balls tangent
    at :math:`x` on a side nest, so every step stays at or above the largest empty ball and
    a triangle that meets a smaller ball meets the first one: the candidates are found once,
    the triangles with a corner within :math:`\sqrt{r^2 + \rho_t^2}` of the first centre
    (:func:`_suspects`, :math:`\rho_t \le \ell / \sqrt 3` the radius of the smallest disc
    holding the triangle; ``lift``: :func:`_lift` of ``points`` and ``triangles``, when one
    is at hand). With ``clear``, a ball whose nearest vertex but its own is farther than
    :math:`\sqrt{r^2 + \max \rho_v^2}` in the lifted metric is cleared by one nearest-point
    query first (:func:`_cleared`: most balls well below the medial radius; not those of a
    finished vertex search, which end on a vertex). ``found``: the pairs (row of ``ids``,
    vertex) :func:`_lifted_near` found for these very balls (one wanted side a row), when
    they are at hand (the candidates are then taken from them). A search that does not
    settle within ``iterations`` steps falls back to half the distance from :math:`x` to its
    nearest candidate (a ball tangent at :math:`x` lies within its diameter of :math:`x`),
    so the result is never above the largest empty ball's radius.
    """
    ids = np.asarray(ids, dtype=np.intp)
    out = np.array(radii, dtype=float, copy=True)
    if not len(ids) or not len(triangles):
        return out
    tri = np.asarray(triangles, dtype=np.intp)
    rows, cols = np.nonzero(out > 0)  # every wanted ball, both sides in one search
    if not len(rows):
        return out
    r = out[rows, cols]
    sign = np.where(cols == 0, 1.0, -1.0)
    x, n = points[ids[rows]], normals[rows] * sign[:, None]  # n: towards the ball
    if lift is None:
        lift = _lift(points, tri)
    if found is None:
        ball, t = _suspects(lift, x + r[:, None] * n, r, ids[rows], points, tri, clear)
    else:  # the balls are the rows (one side each): the found vertices' triangles
        ball, t = _near_found(lift, x + r[:, None] * n, r, ids[rows], points, *found)
    if not len(ball):
        return out
    ends = lift.get("columns") if lift["tri"] is tri else None
    if ends is None:
        ends = tuple(np.ascontiguousarray(tri[:, j]) for j in range(3))
    corners = tuple(np.take(points, e.take(t), axis=0) for e in ends)  # contiguous rows
    out[rows, cols] = _shrink_on_triangles(r, ball, np.take(x, ball, axis=0),
                                           np.take(n, ball, axis=0), corners, iterations)
    return out


def _shrink_on_triangles(r: np.ndarray, ball: np.ndarray, xb: np.ndarray, nb: np.ndarray,
                         corners: tuple[np.ndarray, np.ndarray, np.ndarray], iterations: int
                         ) -> np.ndarray:
    r"""``(k,)``: the shrinking-ball search of :func:`triangle_radii` on the balls' radii
    ``r`` ``(k,)`` (lowered in place) over their candidate pairs: the ball ``ball`` ``(p,)``
    tangent at ``xb`` ``(p, 3)`` along ``nb`` ``(p, 3)`` (towards the ball) and the
    triangle of ``corners``, its three corners ``(p, 3)`` each (contiguous rows: the
    tests below run several times faster on them than on strided views).
    """
    a, b, c = corners
    live = ~_apart(xb + r[ball, None] * nb, r[ball], a, b, c)
    for _ in range(iterations):
        k = np.flatnonzero(live)
        if not len(k):
            break
        centre = xb[k] + r[ball[k], None] * nb[k]
        q = _closest_on_triangles(centre, a[k], b[k], c[k])
        dq = q - centre
        dd = np.einsum("ij,ij->i", dq, dq)
        rk = r[ball[k]]
        # a triangle outside this ball is outside every smaller one (they nest): only the
        # triangles that reach inside are tried again, and only where their ball shrank
        live[:] = False
        live[k[dd < rk * rk]] = True
        inside = dd < (rk * (1.0 - 1e-9)) ** 2
        k, q = k[inside], q[inside]
        if not len(k):
            break
        d = q - xb[k]
        dd = np.einsum("ij,ij->i", d, d)
        h = np.einsum("ij,ij->i", d, nb[k])
        new = np.where(h > 0, dd / (2.0 * np.where(h > 0, h, 1.0)), 0.0)
        np.minimum.at(r, ball[k], new)
        shrunk = np.zeros(len(r), bool)
        shrunk[ball[k]] = True
        live &= shrunk[ball]  # a shrunk ball: its triangles that reached in
    else:
        k = np.flatnonzero(live)  # not settled: half the distance to the candidates
        q = _closest_on_triangles(xb[k], a[k], b[k], c[k])
        np.minimum.at(r, ball[k], 0.5 * np.linalg.norm(q - xb[k], axis=1))
    return r


def _apart(centres: np.ndarray, radii: np.ndarray, a: np.ndarray, b: np.ndarray,
           c: np.ndarray) -> np.ndarray:
    r"""``(p,)`` bool: the pairs of balls ``centres`` ``(p, 3)``, ``radii`` ``(p,)`` and
    triangles ``a``, ``b``, ``c`` ``(p, 3)`` that cannot meet, by two tests cheaper than the
    nearest point (:func:`_closest_on_triangles`): the triangle's plane, normal :math:`N`,
    is farther than :math:`r` from the centre, :math:`((o - a) \cdot N)^2 > r'^2 |N|^2`; or
    along :math:`u = g - o`, the direction from the centre to the corners' mean :math:`g`,
    every corner lies beyond :math:`r'`, :math:`\min_i u \cdot (v_i - o) > r' |u|` (every
    point :math:`q = \sum_i \lambda_i v_i` of the triangle then has :math:`|q - o| \ge
    \hat u \cdot (q - o) = \sum_i \lambda_i \hat u \cdot (v_i - o) > r'`; it holds
    wherever the corners' ball about :math:`g`, radius :math:`R = \max_i |v_i - g|`, is
    farther than :math:`r'`, as :math:`\hat u \cdot (v_i - o) \ge |g - o| - R`, and on
    most pairs a ring apart besides, ``docs/model.md``, "Refined frames' balls, cheaper");
    with :math:`r' = r(1 + 10^{-6}) + \tau` and :math:`\tau = 10^{-12}(1 + \max |v|)`
    against rounding (far above that of the nearest point's distance, so a pair found
    apart is never one the search's rounding puts inside).
    """
    if not len(a):
        return np.zeros(0, bool)
    tau = 1e-12 * (1.0 + max(float(np.abs(a).max()), float(np.abs(b).max()),
                             float(np.abs(c).max()), float(np.abs(centres).max())))
    lim = radii * (1.0 + 1e-6) + tau
    N = _cross(b - a, c - a)
    h = np.einsum("ij,ij->i", centres - a, N)
    out = h * h > lim * lim * np.einsum("ij,ij->i", N, N)
    u = a + b
    u += c
    u /= 3.0
    u -= centres  # g - o
    low = np.minimum(np.minimum(np.einsum("ij,ij->i", u, a - centres),
                                np.einsum("ij,ij->i", u, b - centres)),
                     np.einsum("ij,ij->i", u, c - centres))
    return out | (low > lim * np.sqrt(_sq(u)))


def _triangle_seps(points: np.ndarray, tri: np.ndarray, near: np.ndarray,
                   lift: dict | None = None, rows: np.ndarray | None = None
                   ) -> tuple[np.ndarray, float]:
    r"""``(n,)`` and a float: each vertex's distance :math:`s_x` to the nearest other vertex
    or triangle not incident to it, given ``near`` ``(n,)``, the distance to the nearest
    other vertex, and the longest edge :math:`L` of ``tri`` ``(m, 3)`` on ``points``
    ``(n, 3)``. Only the triangles that come within ``near`` of :math:`x` can lower it: the
    candidates of the ball of radius ``near`` about :math:`x` (:func:`_suspects`, ``lift``:
    :func:`_lift`). ``rows``: the vertices searched (default all; ``near`` at the others).
    """
    L = _sides_longest(points, tri)
    if lift is None:
        lift = _lift(points, tri)
    sep = np.array(near, dtype=float, copy=True)
    rows = np.arange(len(points)) if rows is None else np.asarray(rows, dtype=np.intp)
    step = 4000
    for lo in range(0, len(rows), step):
        ids = rows[lo:lo + step]
        ok = np.isfinite(sep[ids])
        ids = ids[ok]
        owner, t = _suspects(lift, points[ids], sep[ids], ids, points, tri, clear=False)
        x = points[ids[owner]]
        q = _closest_on_triangles(x, points[tri[t, 0]], points[tri[t, 1]], points[tri[t, 2]])
        np.minimum.at(sep, ids[owner], np.linalg.norm(q - x, axis=1))
    return sep, L


def _deformed_radii(deformed: np.ndarray, tri: np.ndarray, W: np.ndarray, radii: np.ndarray,
                    terms: dict, guard: FoldGuard, step: np.ndarray | None = None
                    ) -> np.ndarray:
    r"""``(n, 2)``: ``radii`` ``(n, 2)``, lowered at the vertices where ``W`` ``(n,)`` is not 0
    to :math:`\eta_d / \eta` times the medial radii of the skin ``deformed`` ``(n, 3)``
    (balls empty of its vertices and of its triangles not incident to the vertex,
    :func:`triangle_radii`) along its area-weighted normals (``eta_deformed``: the clamp then keeps
    :math:`|W| < \eta_d\, r^{\text{def}}_\pm`). The search starts at the radius where
    the clamp's knee would just reach :math:`|W|`, so it stops at once wherever the clamp
    would not act. ``step`` ``(n, 3)``: :math:`W n`, when the frame's normals are those of
    ``deformed`` (else they are computed).

    Only the vertices whose ball did shrink are lowered (``radii`` itself, not a copy, when
    none did): where the search kept its start :math:`R`, :math:`\eta_d R` sits just above
    :math:`|W| / \kappa` and the clamp would not act on that bound, so whatever the rest
    radii say decides there (the same clamped :math:`W`, bit for bit).
    """
    low = _deformed_lows(deformed, tri, W, terms, guard, step)
    if low is None:
        return radii
    rows, values = low
    out = np.array(radii, dtype=float, copy=True)
    out[rows] = np.minimum(out[rows], values)
    return out


def _deformed_lows(deformed: np.ndarray, tri: np.ndarray, W: np.ndarray, terms: dict,
                   guard: FoldGuard, step: np.ndarray | None = None,
                   empty: np.ndarray | None = None, clear: np.ndarray | None = None
                   ) -> tuple[np.ndarray, np.ndarray] | None:
    r"""The search of :func:`_deformed_radii`: the vertices whose ball shrank ``(k,)`` and
    :math:`\eta_d / \eta` times their deformed radii ``(k, 2)`` (``inf`` on the side
    :math:`W` does not push to), or None where no ball shrank.

    ``empty`` ``(n,)`` bool: balls certified empty (:func:`_empty_balls`), not searched;
    ``clear``: balls certified empty of triangles (:func:`_gaps_clear`), searched for
    vertices alone (a radius at most the start, whose ball no triangle enters). The
    samples, triangles, lifts and tree are those of searching every wrinkled vertex (the
    box of all), so each searched ball's result is the same bit for bit.
    """
    ratio = guard.eta_deformed / guard.eta
    ids = np.flatnonzero(W)
    if not len(ids):
        return None
    start = np.abs(W[ids]) / (guard.knee * guard.eta_deformed) * (1.0 + 1e-6)
    reach = 2.0 * float(start.max())  # a ball of radius R tangent at x lies within 2 R of x
    lo, hi = deformed[ids].min(axis=0) - reach, deformed[ids].max(axis=0) + reach
    if empty is not None:
        keep = ~empty[ids]
        if not keep.any():
            return None
        ids, start = ids[keep], start[keep]
    x = deformed[ids]
    if step is None:
        n = _vertex_normals(deformed, tri, ids, terms)
    else:
        n = step[ids] / W[ids, None]
        n /= np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
    side = np.where(W[ids, None] >= 0, [[1.0, 0.0]], [[0.0, 1.0]])  # the side W pushes to
    # a triangle meeting a ball has its corners within the ball's reach plus its edges
    sides: dict = {}  # (a skin's first frame: every triangle's squared sides, for _lift)
    L = _longest_edge(deformed, tri, terms, sides)
    samples, local, t_loc, kept = _local_rows(deformed, tri, lo - L, hi + L)
    if "squares" in sides:
        sides["squares"] = tuple(q.take(kept) for q in sides["squares"])
    # the balls to search (_to_search): the vertices' search where a vertex lies inside
    # (medial_radii), then the triangles' (a ball empty of vertices may hold a triangle)
    c = x + np.where(W[ids] >= 0, 1.0, -1.0)[:, None] * start[:, None] * n
    free = np.zeros(len(ids), bool) if clear is None else clear[ids]
    todo, lift, near = _to_search(samples, t_loc, c, start, local[ids], free,
                                  sides.get("squares"))
    if not len(todo):
        return None
    ids, x, n, c, start, side = ids[todo], x[todo], n[todo], c[todo], start[todo], side[todo]
    free = free[todo]
    r = side * start[:, None]
    hit, tree = _vertex_hits(samples, c, start, local[ids], free, near)
    if len(hit):
        r[hit] = medial_radii(x[hit], n[hit], samples=samples, r_max=r[hit], tree=tree)
    if lift is not None:  # the triangles' search, where not certified clear
        _triangles_search(r, hit, free, near, local[ids], n, samples, t_loc, lift)
    r = np.where(side > 0, r, np.inf)
    low = np.flatnonzero(r.min(axis=1) < start)  # the balls that shrank
    if not len(low):
        return None
    return ids[low], ratio * r[low]


def _triangles_search(r: np.ndarray, hit: np.ndarray, free: np.ndarray,
                      near: tuple[np.ndarray, np.ndarray], own: np.ndarray, n: np.ndarray,
                      samples: np.ndarray, t_loc: np.ndarray, lift: dict) -> None:
    r"""The triangles' search of :func:`_deformed_lows` on its balls' radii ``r`` ``(k, 2)``
    (one wanted side a row, lowered in place) at the local vertices ``own`` ``(k,)`` along
    ``n`` ``(k, 3)`` (:func:`triangle_radii` on ``samples``, ``t_loc``, ``lift``), those not
    ``free`` ``(k,)``: the balls at their start (not in ``hit``, the vertices' search's)
    from the pairs ``near`` :func:`_to_search` found for them at that radius, the others
    (shrunk by a vertex) by a search of their own.
    """
    at_start = ~free
    at_start[hit] = False
    plain = np.flatnonzero(at_start)
    pick = at_start[near[0]] & (near[1] != own[near[0]])  # (own's triangles: all its own)
    found = ((np.cumsum(at_start) - 1)[near[0][pick]], near[1][pick])  # rows of plain
    r[plain] = triangle_radii(own[plain], n[plain], r[plain], samples, t_loc, lift=lift,
                              clear=False, found=found)
    o = hit[~free[hit]]
    r[o] = triangle_radii(own[o], n[o], r[o], samples, t_loc, lift=lift, clear=False)


def _to_search(samples: np.ndarray, t_loc: np.ndarray, c: np.ndarray, start: np.ndarray,
               own: np.ndarray, free: np.ndarray,
               squares: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
               ) -> tuple[np.ndarray, dict | None, tuple[np.ndarray, np.ndarray]]:
    r"""The balls of :func:`_deformed_lows` to search ``(k,)`` (ascending), the lifted
    classes of the local skin ``samples`` ``(s, 3)``, ``t_loc`` ``(t, 3)`` (None where not
    needed) and the pairs (ball, vertex) ``(q,)`` twice of :func:`_lifted_near`, the balls
    as rows of the result: those certified ``free`` ``(b,)`` of triangles (the vertices'
    search alone), and of the others, centres ``c`` ``(b, 3)``, radii ``start`` ``(b,)``
    at the local vertices ``own`` ``(b,)``, those :func:`_cleared` does not clear (one
    nearest-point query of the lifted vertices clears a ball no vertex and no triangle not
    incident to its vertex can enter; the same queries find the others' candidates).
    ``squares``: :func:`_side_squares` of ``t_loc``, when at hand.
    """
    if free.all():
        none = np.zeros(0, np.intp)
        return np.flatnonzero(free), None, (none, none)
    lift = _lift(samples, t_loc, squares)
    rest = np.flatnonzero(~free)
    cleared, ball, vert = _lifted_near(lift, c[rest], start[rest], own[rest])
    ask = free.copy()
    ask[rest[~cleared]] = True
    row = np.cumsum(ask) - 1  # each ball's row among those asked
    return np.flatnonzero(ask), lift, (row[rest[ball]], vert)


def _vertex_hits(samples: np.ndarray, c: np.ndarray, start: np.ndarray, own: np.ndarray,
                 free: np.ndarray, near: tuple[np.ndarray, np.ndarray]
                 ) -> tuple[np.ndarray, cKDTree | None]:
    r"""``(h,)``: the balls of :func:`_deformed_lows`, centres ``c`` ``(k, 3)``, radii
    ``start`` ``(k,)`` at the vertices ``own`` ``(k,)`` of ``samples`` ``(s, 3)``, that hold
    a vertex, nearest at :math:`d < R(1 - 10^{-9})` (``cKDTree``, as
    :func:`medial_radii`'s), and that tree (None where not built). The tree asks only the
    balls ``free`` ``(k,)`` and those with a vertex :math:`v \ne` ``own`` of their pairs
    ``near`` (:func:`_to_search`) at :math:`|v - c|^2 \le R^2`: the lifted query found
    every vertex with :math:`|v - c|^2 - \rho_v^2 \le R^2`, so any other ball's nearest is
    its own vertex, at :math:`R` (the tangent point).
    """
    ball, vert = near
    d = samples[vert] - c[ball]
    inside = (np.einsum("ij,ij->i", d, d) <= start[ball] ** 2) & (vert != own[ball])
    ask = free.copy()
    ask[ball[inside]] = True
    ask = np.flatnonzero(ask)
    if not len(ask):
        return ask, None
    tree = cKDTree(samples, balanced_tree=False)
    dist, _ = tree.query(c[ask], distance_upper_bound=float(start[ask].max()))
    return ask[dist < start[ask] * (1.0 - 1e-9)], tree


def _local_skin(points: np.ndarray, tri: np.ndarray, lo: np.ndarray, hi: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The skin ``points`` ``(n, 3)``, ``tri`` ``(m, 3)`` in the box ``lo``-``hi``: its
    vertices ``(s, 3)`` (:func:`_in_box`), each vertex's row among them ``(n,)`` (-1
    outside) and the triangles with every corner inside, on those rows ``(t, 3)``.
    """
    return _local_rows(points, tri, lo, hi)[:3]


def _local_rows(points: np.ndarray, tri: np.ndarray, lo: np.ndarray, hi: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_local_skin`, and the rows of ``tri`` it keeps ``(t,)``."""
    box = _in_box(points, lo, hi)
    local = np.full(len(points), -1, dtype=np.intp)
    local[box] = np.arange(len(box))
    t_loc = np.take(local, tri)  # (takes, not fancy indexing, and three compares and two
    keep = np.flatnonzero((t_loc[:, 0] >= 0) & (t_loc[:, 1] >= 0) & (t_loc[:, 2] >= 0))
    return np.take(points, box, axis=0), local, np.take(t_loc, keep, axis=0), keep  # ands)


_GAP_CUTS = (0.25, 0.5, 0.75, 1.0)  # of the rest gaps' reach, 3 median edges
_GAP_CORNERS = 160  # the corners a vertex keeps over its gaps' reach (more: no certificate)
_GAP_NEAR = 32  # the near triangles a vertex keeps, least rest bound first (_gaps_apart)


def _gaps_clear(rest: np.ndarray, deformed: np.ndarray, W: np.ndarray, tri: np.ndarray,
                terms: dict, guard: FoldGuard, skip: np.ndarray | None = None
                ) -> np.ndarray | None:
    r"""``(n,)`` bool: the wrinkled vertices whose deformed ball (:func:`_deformed_lows`,
    radius :math:`\rho = |W| / (\kappa\eta_d)(1 + 10^{-6})` tangent at :math:`x'`) no
    triangle not incident to :math:`x` can enter, from the rest skin ``rest`` ``(n, 3)``,
    ``tri`` ``(m, 3)`` and the frame's move :math:`u = x' - x` (``deformed``): with
    :func:`_rest_gaps`' :math:`H_{x,l}` and corners, :math:`\delta_{x,l} = \max |u_w - u_x|`
    over those corners, :math:`U = \max_v |u_v|` and :math:`\sigma = 2\rho(1 + 10^{-6}) +
    \tau`, some cut :math:`c_l` with :math:`c_l - U - |u_x| \ge \sigma` and
    :math:`H_{x,l} - \delta_{x,l} \ge \sigma` (``docs/model.md``, "The rest gaps"). None on
    a skin's first frame (a refined frame's skin is new every frame: its gaps would cost
    more than the search they spare). ``skip`` ``(n,)`` bool: balls certified empty
    already (:func:`_empty_balls`: never searched), left False and not looked at.
    """
    b = _gap_bounds(rest, deformed, W, tri, terms, guard, skip)
    return None if b is None else _gap_cleared(b, len(W))


def _gap_cleared(b: dict, n: int) -> np.ndarray:
    r"""``(n,)`` bool: :func:`_gaps_clear` from its numbers ``b`` (:func:`_gap_bounds`):
    :math:`H_{x,l} - \delta_{x,l} \ge \sigma` where :math:`\delta_{x,l}` is known.
    """
    ids, known = b["ids"], np.flatnonzero(np.isfinite(b["delta"]))
    out = np.zeros(n, bool)
    out[ids[known]] = b["gaps"]["H"][ids[known], b["level"][known]] - b["delta"][known] \
        >= b["sigma"][known]
    return out


def _gap_bounds(rest: np.ndarray, deformed: np.ndarray, W: np.ndarray, tri: np.ndarray,
                terms: dict, guard: FoldGuard, skip: np.ndarray | None = None
                ) -> dict | None:
    r""":func:`_gaps_clear`'s numbers at the wrinkled vertices ``ids`` ``(k,)`` not in
    ``skip``: the least cut ``level`` ``(k,)`` with :math:`c_l - U - |u_x| \ge \sigma`,
    ``delta`` :math:`\delta_{x,l}` there (``inf`` where no cut is far enough or a cut has
    more corners than kept), ``sigma`` ``(k,)``, ``tau`` and the rest ``gaps``; None on a
    skin's first frame, on a refined frame's skin (``terms["refined"]``) or with no vertex
    to look at. A refined skin is met again only while its split set stays (a timeline's
    plateau), and its gaps cost seconds (the paper face's refined peak surprise: 4 s) for
    balls that distances clear few of (``docs/model.md``, "No certificate per hierarchy
    row").
    """
    terms["gap_frames"] = seen = terms.get("gap_frames", 0) + 1
    ids = np.flatnonzero(W if skip is None else (W != 0) & ~skip)
    if seen < 2 or not len(ids) or terms.get("refined", False):
        return None
    gaps = _rest_gaps(rest, tri, ids, terms)
    u = deformed - rest
    uu = np.einsum("ij,ij->i", u, u)  # |u|^2 of every vertex: U, and |u_x| (tau holds the
    U = float(np.sqrt(uu.max()))  # rounding of either way of summing them)
    tau = 1e-12 * (1.0 + gaps["size"] + U)
    sigma = 2.0 * np.abs(W[ids]) / (guard.knee * guard.eta_deformed) * (1.0 + 1e-6) \
        * (1.0 + 1e-6) + tau
    span = gaps["cut"][None, :] - U - np.sqrt(np.take(uu, ids))[:, None]  # (k, c)
    ok_far = span >= sigma[:, None]
    level = np.argmax(ok_far, axis=1)  # the least cut far enough
    count = gaps["count"][ids, level]
    rows = np.flatnonzero(ok_far.any(axis=1) & (count >= 0))
    delta = np.full(len(ids), np.inf)
    delta[rows] = _gap_moves(u, gaps, ids[rows], count[rows])
    return {"ids": ids, "level": level, "delta": delta, "sigma": sigma, "tau": tau,
            "gaps": gaps}


def _gaps_skip(rest: np.ndarray, deformed: np.ndarray, W: np.ndarray, tri: np.ndarray,
               terms: dict, guard: FoldGuard, empty: np.ndarray | None,
               step: np.ndarray | None) -> tuple[np.ndarray | None, np.ndarray | None]:
    r"""The balls :func:`_deformed_lows` need not search ``(n,)`` bool and those it searches
    for vertices alone (:func:`_gaps_clear`), or ``empty`` and None on a skin's first
    frame: ``empty`` (:func:`_empty_balls`), the balls the gaps clear at a vertex with no
    lone neighbour (:func:`_gaps_empty`), and of the others at such a vertex those whose
    near triangles :func:`_gaps_apart` keeps out of the ball exactly. ``step``: the
    frame's :math:`W n` (:func:`_deformed_lows`).
    """
    b = _gap_bounds(rest, deformed, W, tri, terms, guard, empty)
    if b is None:
        return empty, None
    ids, clear = b["ids"], _gap_cleared(b, len(W))
    skip = _gaps_empty(empty, clear, tri, terms)
    rows = np.flatnonzero(~clear[ids] & ~_lone_neighbours(tri, len(W), terms)[ids]
                          & np.isfinite(b["delta"]))
    if len(rows):
        skip[ids[rows]] |= _gaps_apart(deformed, W, tri, terms, guard, b, rows, step)
    return skip, clear


def _gaps_apart(deformed: np.ndarray, W: np.ndarray, tri: np.ndarray, terms: dict,
                guard: FoldGuard, b: dict, rows: np.ndarray, step: np.ndarray | None
                ) -> np.ndarray:
    r"""``(k,)`` bool: of the balls at :func:`_gap_bounds` ``b``'s vertices ``rows``
    ``(k,)``, those no near triangle enters: each triangle not incident to :math:`x`
    within the cut :math:`c_l` with :math:`h_t - \delta_{x,l} < \sigma` (:math:`h_t` its
    rest bound :math:`\max_k \min_i h_{ki}`, kept for the :data:`_GAP_NEAR` least per
    vertex: none certified where more could be) has :math:`\min_i u \cdot (v'_i - c)
    \ge \rho(1 + 10^{-6}) + \tau` along the unit :math:`u` from the centre :math:`c`
    (computed as :func:`_deformed_lows` does) to the triangle's nearest point
    (``docs/model.md``, "The rest gaps, exactly").
    """
    gaps, ids = b["gaps"], b["ids"][rows]
    need = b["sigma"][rows] + b["delta"][rows]  # h_t below it: tested exactly
    ok = gaps["near_top"][ids] >= need
    cand = (gaps["near_h"][ids] < need[:, None]) & (gaps["near_lvl"][ids]
                                                    <= b["level"][rows, None]) & ok[:, None]
    r, slot = np.nonzero(cand)
    if not len(r):
        return ok
    w = W[ids]
    if step is None:
        n = _vertex_normals(deformed, tri, ids, terms)
    else:
        n = step[ids] / w[:, None]
        n /= np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
    start = np.abs(w) / (guard.knee * guard.eta_deformed) * (1.0 + 1e-6)
    c = (deformed[ids] + np.where(w >= 0, 1.0, -1.0)[:, None] * start[:, None] * n)[r]
    corners = np.take(deformed, tri[gaps["near_t"][ids[r], slot]], axis=0)  # (p, 3, 3)
    h = _heights(corners, c, start[r] * (1.0 + 1e-6) + b["tau"])
    ok[r[~(h >= start[r] * (1.0 + 1e-6) + b["tau"])]] = False
    return ok


def _heights(corners: np.ndarray, c: np.ndarray, need: np.ndarray) -> np.ndarray:
    r"""``(p,)``: lower bounds :math:`\min_i u \cdot (v_i - c)` of the distance from the
    points ``c`` ``(p, 3)`` to the triangles ``corners`` ``(p, 3, 3)``, for unit :math:`u`
    (any gives one: :math:`|q - c| \ge u \cdot (q - c)` for every point :math:`q` of the
    triangle): the best of the plane's normal (towards the triangle) and the direction to
    the corners' mean, and where neither reaches ``need`` ``(p,)``, the direction to the
    triangle's nearest point (:func:`_closest_on_triangles`, where the bound is the
    distance). 0 where a direction is undefined (a point on the triangle).
    """
    a = corners - c[:, None]  # v_i - c
    h = np.zeros(len(c))
    N = _cross(a[:, 1] - a[:, 0], a[:, 2] - a[:, 0])
    N *= np.where(np.einsum("ij,ij->i", N, a[:, 0]) >= 0, 1.0, -1.0)[:, None]
    for u in (N, a.mean(axis=1)):
        h = np.maximum(h, _least_height(u, a))
    hard = np.flatnonzero(~(h >= need))
    if len(hard):
        u = _mesh_closest(c[hard], corners[hard]) - c[hard]
        h[hard] = np.maximum(h[hard], _least_height(u, a[hard]))
    return h


def _least_height(u: np.ndarray, a: np.ndarray) -> np.ndarray:
    r"""``(p,)``: :math:`\min_i \hat u \cdot a_i` for the directions ``u`` ``(p, 3)``
    (normalized here; 0 where ``u`` is 0 or not finite) and ``a`` ``(p, 3, 3)``.
    """
    un = np.sqrt(np.einsum("ij,ij->i", u, u))
    good = (un > 0) & np.isfinite(un)
    u = u / np.where(good, un, 1.0)[:, None]
    h = np.minimum(np.minimum(np.einsum("ij,ij->i", u, a[:, 0]),
                              np.einsum("ij,ij->i", u, a[:, 1])),
                   np.einsum("ij,ij->i", u, a[:, 2]))
    return np.where(good, h, 0.0)


def _gaps_empty(empty: np.ndarray | None, clear: np.ndarray, tri: np.ndarray,
                terms: dict) -> np.ndarray:
    r"""``(n,)`` bool: the balls :func:`_deformed_lows` need not search, ``empty``
    (:func:`_empty_balls`) and those of ``clear`` (:func:`_gaps_clear`) at a vertex
    :math:`x` with no *lone neighbour* (:func:`_lone_neighbours`; ``empty`` may be None).

    Every vertex :math:`w \ne x` but a lone neighbour of :math:`x` is a corner of a
    triangle not incident to :math:`x`, which :func:`_gaps_clear` keeps more than
    :math:`2\rho` from :math:`x'`: no deformed vertex but :math:`x'` is in the ball, so the
    vertices' search keeps its start too (``docs/model.md``, "The rest gaps, vertices").
    """
    out = clear & ~_lone_neighbours(tri, len(clear), terms)
    return out if empty is None else out | empty


def _lone_neighbours(tri: np.ndarray, n: int, terms: dict) -> np.ndarray:
    r"""``(n,)`` bool, kept in ``terms``: the vertices :math:`x` of the skin ``tri``
    ``(m, 3)`` on ``n`` vertices with a lone neighbour, another vertex :math:`w` every one
    of whose triangles has :math:`x` as a corner (every vertex where some vertex is in no
    triangle). Per directed corner pair :math:`(w, v)` of a triangle, the count of such
    pairs is at least :math:`w`'s triangle count where :math:`v` is in all of them (each of
    :math:`w`'s corners counts one at least), so marking where it is reached marks every
    such :math:`x` (and, on triangles with a repeated corner, perhaps more).
    """
    got = terms.get("lone_neighbours")
    if got is None:
        deg = np.bincount(tri.ravel(), minlength=n)
        got = np.ones(n, bool)
        if not (deg == 0).any():
            a, b, c = (tri[:, k].astype(np.int64) for k in range(3))
            key = np.concatenate([a * n + b, a * n + c, b * n + a, b * n + c, c * n + a,
                                  c * n + b])
            key, count = np.unique(key, return_counts=True)
            got[:] = False
            got[key[count >= deg[key // n]] % n] = True
        terms["lone_neighbours"] = got
    return got


def _gap_moves(u: np.ndarray, gaps: dict, own: np.ndarray, count: np.ndarray) -> np.ndarray:
    r"""``(k,)``: :math:`\delta_x = \max_w |u_w - u_x|` over the first ``count`` ``(k,)`` of
    :func:`_rest_gaps`' corners of each vertex ``own`` ``(k,)``, for the move ``u``
    ``(n, 3)`` (0 where there are none); the corners taken coordinate by coordinate from
    the move's columns (a take of rows of 3 is several times slower). Only an upper bound
    matters (:func:`_gaps_clear`'s margin :math:`\tau` holds its rounding).
    """
    width = int(count.max()) if len(count) else 0
    if not width:
        return np.zeros(len(own))
    at = np.where(np.arange(width)[None, :] < count[:, None], gaps["corners"][own, :width],
                  own[:, None])  # (k, width): beyond a vertex's count, itself
    ut = np.ascontiguousarray(u.T)
    uo = np.take(ut, own, axis=1)
    sq = np.zeros(at.shape)
    for k in range(3):
        d = np.take(ut[k], at)
        d -= uo[k][:, None]
        d *= d
        sq += d
    return np.sqrt(sq.max(axis=1))


def _rest_gaps(rest: np.ndarray, tri: np.ndarray, ids: np.ndarray, terms: dict) -> dict:
    r"""Per vertex of the rest skin ``rest`` ``(n, 3)``, ``tri`` ``(m, 3)``, found for the
    vertices ``ids`` ``(k,)`` that have none yet and kept in ``terms``: over its triangles
    not incident to it within each cut :math:`c_l` (:data:`_GAP_CUTS` of :math:`D`, 3 median
    edges; :func:`_near_edges`), ``H`` ``(n, c)``: :math:`\min_t \max_k \min_i h_{ki}`
    (the best of four directions' least corner height, at most the distance to the
    triangle's points), ``corners`` ``(n, K)`` (int32) their distinct corners nearest cut
    first and ``count`` ``(n, c)`` how many lie within each cut (-1: more than
    :data:`_GAP_CORNERS`; -2: not found yet); ``cut`` ``(c,)``; ``size``, the rest skin's
    largest coordinate; and the near triangles of :func:`_fill_near` (``near_t``,
    ``near_h``, ``near_lvl`` ``(n, J)``, ``near_top`` ``(n,)``).
    """
    gaps = terms.get("gaps")
    if gaps is None:
        e = rest[tri] - rest[np.roll(tri, 1, axis=1)]
        D = 3.0 * float(np.median(np.sqrt(np.einsum("ijk,ijk->ij", e, e))))
        n, c = len(rest), len(_GAP_CUTS)
        gaps = terms["gaps"] = {"cut": np.array(_GAP_CUTS) * D, "D": D,
                                "size": float(np.abs(rest).max()),
                                "H": np.full((n, c), -np.inf),
                                "corners": np.zeros((n, _GAP_CORNERS), np.int32),
                                "count": np.full((n, c), -2, np.intp),
                                "near_t": np.zeros((n, _GAP_NEAR), np.int32),
                                "near_h": np.full((n, _GAP_NEAR), np.inf),
                                "near_lvl": np.zeros((n, _GAP_NEAR), np.int8),
                                "near_top": np.full(n, -np.inf)}
    todo = ids[gaps["count"][ids, 0] == -2]
    if len(todo):
        _fill_gaps(gaps, rest, tri, todo)
    return gaps


def _fill_gaps(gaps: dict, rest: np.ndarray, tri: np.ndarray, todo: np.ndarray) -> None:
    """:func:`_rest_gaps`' entries of the vertices ``todo`` ``(k,)``, in place."""
    d, h, _, D, owner, t = _near_edges(rest, tri, todo, gaps["D"])
    cut = gaps["cut"]
    c = len(cut)
    level = np.minimum(np.searchsorted(cut, d, side="left"), c - 1)
    H = np.full((len(todo), c), np.inf)
    hp = h.min(axis=2).max(axis=1)  # each pair's bound
    np.minimum.at(H, (owner, level), hp)
    gaps["H"][todo] = np.minimum.accumulate(H, axis=1)
    _fill_near(gaps, todo, owner, t, hp, level)
    # each vertex's distinct corners, at the least cut they appear within
    v = tri[t].ravel()
    key = np.repeat(owner, 3) * np.int64(len(rest)) + v
    lvl = np.repeat(level, 3)
    order = np.lexsort((lvl, key))
    key, lvl = key[order], lvl[order]
    first = np.concatenate([[True], key[1:] != key[:-1]]) if len(key) else np.zeros(0, bool)
    key, lvl = key[first], lvl[first]
    own, v = key // len(rest), key % len(rest)
    order = np.lexsort((lvl, own))
    own, v, lvl = own[order], v[order], lvl[order]
    per = np.zeros((len(todo), c), np.intp)
    np.add.at(per, (own, lvl), 1)
    count = np.cumsum(per, axis=1)
    start = np.concatenate([[0], np.cumsum(count[:, -1])[:-1]]) if len(todo) else per[:, 0]
    slot = np.arange(len(own)) - np.repeat(start, count[:, -1])
    fits = slot < _GAP_CORNERS
    gaps["corners"][todo[own[fits]], slot[fits]] = v[fits]
    gaps["count"][todo] = np.where(count <= _GAP_CORNERS, count, -1)


def _fill_near(gaps: dict, todo: np.ndarray, owner: np.ndarray, t: np.ndarray,
               hp: np.ndarray, level: np.ndarray) -> None:
    """:func:`_rest_gaps`' near triangles of the vertices ``todo`` ``(k,)``, in place, from
    the pairs (row ``owner``, triangle ``t``, bound ``hp``, cut ``level``) ``(p,)``: each
    vertex's :data:`_GAP_NEAR` least ``hp`` in ascending order and ``near_top``, the next
    one's bound (``inf`` where none is left out).
    """
    order = np.lexsort((hp, owner))
    o = owner[order]
    count = np.bincount(o, minlength=len(todo))
    slot = np.arange(len(o)) - np.repeat(np.cumsum(count) - count, count)
    keep = slot < _GAP_NEAR
    at = (todo[o[keep]], slot[keep])
    gaps["near_t"][at] = t[order][keep]
    gaps["near_h"][at] = hp[order][keep]
    gaps["near_lvl"][at] = level[order][keep]
    top = np.full(len(todo), np.inf)
    top[o[slot == _GAP_NEAR]] = hp[order][slot == _GAP_NEAR]
    gaps["near_top"][todo] = top


def _longest_edge(points: np.ndarray, tri: np.ndarray, terms: dict,
                  keep: dict | None = None) -> float:
    """The longest edge of the skin ``points`` ``(n, 3)``, ``tri`` ``(m, 3)``: each
    triangle's three sides on a skin's first frame (:func:`_sides_longest`; a refined
    frame's skin is new every frame); from its second (the terms of a skin that is guarded
    again: an unrefined face's), its unique edges (:func:`_terms_edges`), half as many, the
    same lengths (a side's length does not depend on its direction), their ends kept in
    ``terms`` as two contiguous arrays. ``keep``: a dict that gets the squared sides
    where they were found (a skin's first frame, :func:`_sides_longest`).
    """
    ends, unique = terms.get("edge_ends", (None, False))
    if not unique:
        if "edge_ends" not in terms and "edges" not in terms:  # a skin's first frame
            terms["edge_ends"] = (None, False)
            return _sides_longest(points, tri, keep)
        edges = _terms_edges(terms)[0]
        ends = (np.ascontiguousarray(edges[:, 0], dtype=np.intp),
                np.ascontiguousarray(edges[:, 1], dtype=np.intp))
        terms["edge_ends"] = (ends, True)
    if not len(ends[0]):
        return 0.0
    e = np.take(points, ends[0], axis=0)  # (a take: several times faster than points[ends])
    e -= np.take(points, ends[1], axis=0)
    return float(np.sqrt(np.einsum("ij,ij->i", e, e).max()))


def _sides_longest(points: np.ndarray, tri: np.ndarray, keep: dict | None = None) -> float:
    r"""The longest side of the triangles ``tri`` ``(m, 3)`` on ``points`` ``(n, 3)``:
    :math:`\max_t \max(|v_0 - v_1|, |v_1 - v_2|, |v_2 - v_0|)`, from one take of each
    corner's rows (:func:`_side_squares`: half the takes of the sides' ends, the same
    differences bit for bit, signs aside). ``keep``: a dict that gets the squared sides as
    ``"squares"`` (:func:`_lift` reads them again).
    """
    if not len(tri):
        return 0.0
    squares = _side_squares(points, tri)
    if keep is not None:
        keep["squares"] = squares
    return math.sqrt(max(0.0, *(float(q.max()) for q in squares)))


def _needed(W: np.ndarray, guard: FoldGuard) -> np.ndarray:
    r"""``(k, 2)``: the radius up to which the clamp needs :math:`r_\pm` at each vertex of
    ``W`` ``(k,)`` (a frame's, or its nonzero part): just above :math:`|W| / (\kappa \eta)`
    on the side ``W`` pushes to (a radius beyond it leaves the clamp the identity), 0
    elsewhere.
    """
    W = np.asarray(W, dtype=float)
    start = np.abs(W) / (guard.knee * guard.eta) * (1.0 + 1e-6)
    return np.where(W[:, None] >= 0, [[1.0, 0.0]], [[0.0, 1.0]]) * start[:, None]


def _rest_radii(face, need: np.ndarray, ids: np.ndarray | None = None) -> np.ndarray:
    """``(n, 2)``: rest radii of ``face``'s own skin known at least up to ``need``
    (``(n, 2)``, or ``(k, 2)`` at the vertices ``ids`` ``(k,)``, 0 at the others): the true
    radius where it is below what was ever needed, else a value at or above ``need`` (below
    which the true radius does not lie). What is found is kept with the rest frame; a
    vertex is searched again only when a frame needs more of it. Only the rows ``ids`` are
    looked at (a frame's wrinkled vertices: the cost goes with them, not with the skin).
    """
    rest = face._rest
    known = getattr(rest, "fold_radii", None)
    if known is None:
        known = rest.fold_radii = np.zeros((face.skin.n_points, 2))
        rest.fold_radii_exact = np.zeros((face.skin.n_points, 2), bool)
    if ids is None:
        ids = np.arange(len(known))
    todo = (need > known[ids]) & ~rest.fold_radii_exact[ids]
    sub = np.flatnonzero(todo.any(axis=1))
    if len(sub):
        rows, todo, need = ids[sub], todo[sub], need[sub]
        r_max = np.where(todo, need, 0.0)
        r = medial_radii(face.skin.points[rows], rest.normals[rows],
                         samples=face.skin.points, r_max=r_max, tree=face.skin.kdtree)
        r = triangle_radii(rows, rest.normals[rows], r, face.skin.points, face.skin.triangles,
                           lift=_skin_lift(face))
        known[rows] = np.where(todo, r, known[rows])
        rest.fold_radii_exact[rows] |= todo & (r < r_max)
    return known



def fold_radii(face, skin_face=None, W: np.ndarray | None = None,
               guard: FoldGuard = FoldGuard()) -> np.ndarray:
    r"""``(n, 2)``: :math:`(r_\pm)` on the rest skin of ``skin_face`` (default ``face``) as
    the clamp of a frame's ``W`` ``(n,)`` on that skin needs them (default: every radius in
    full).

    The clamp is the identity wherever :math:`|W| \le \kappa \eta r`, so a radius is
    searched only up to just above :math:`|W| / (\kappa \eta)` (the shrinking-ball search
    from there gives :math:`\min(r, \cdot)`: the balls tangent at a point on one side
    nest): the true radius where the clamp acts, a radius it cannot tell from the true one
    elsewhere, at the cost of a small ball per wrinkled vertex instead of one as large as
    the skin per vertex (minutes at a million triangles). What is found is kept with the
    face's rest frame. A refined skin takes, at each vertex, the smallest radii of the
    three nearest vertices of ``face``'s own skin (its vertices lie on the smooth surface
    through them); those are searched as far as their refined vertices need.
    """
    own = skin_face is None or skin_face is face or skin_face.skin is face.skin
    n = face.skin.n_points if own else skin_face.skin.n_points
    if W is None:
        size = np.linalg.norm(np.ptp(face.skin.points, axis=0))
        ids = np.arange(n)
        need = np.full((n, 2), 2.0 * size)
    else:  # a vertex with no W needs nothing
        W = np.asarray(W, dtype=float)
        ids = np.flatnonzero(W)
        need = _needed(W[ids], guard)
    if own:
        view = _rest_radii(face, need, ids).view()  # the cache, read-only: no copy a frame
        view.setflags(write=False)
        return view
    idx = _nearest_skin_vertices(face, skin_face)  # kept per hierarchy row
    base = np.zeros((2, face.skin.n_points))  # by side: numpy's fast 1-D ufunc.at
    for k in range(3):
        col = idx[ids, k]
        np.maximum.at(base[0], col, need[:, 0])
        np.maximum.at(base[1], col, need[:, 1])
    near = np.flatnonzero((base[0] > 0) | (base[1] > 0))  # what wrinkled fine vertices need
    known = _rest_radii(face, base[:, near].T, near)
    return np.minimum(np.minimum(known[idx[:, 0]], known[idx[:, 1]]), known[idx[:, 2]])


def _nearest_skin_vertices(face, skin_face) -> np.ndarray:
    r"""``(n, 3)``: the three vertices of ``face``'s skin nearest to each vertex of the
    refined ``skin_face``'s (the rows :func:`fold_radii` takes a refined vertex's radii
    from), kept with the refined face's rest frame as ``fold_radii_nearest``.

    A refined face's vertices are rows of its subdivision hierarchy (its rest frame's
    ``refined_from``: the hierarchy and the rows, set by ``FaceModel._refined_face``),
    and each frame of an animation splits its own set, so its refined face is new: the
    nearest vertices are kept per hierarchy row (with ``face``'s rest frame, grown with
    the hierarchy) and a frame queries only the rows no frame asked for before. A query
    point's nearest vertices do not depend on the other points queried with it, so the
    rows are those of querying the refined skin itself, bit for bit.
    """
    fine = skin_face._rest
    n = skin_face.skin.n_points
    idx = getattr(fine, "fold_radii_nearest", None)
    if idx is not None and len(idx) == n:
        return idx
    src = getattr(fine, "refined_from", None)
    if src is None:
        _, idx = face.skin.kdtree.query(skin_face.skin.points, k=3)
    else:
        hier, rows = src
        memo = getattr(face._rest, "fold_nearest_rows", None)
        if memo is None or memo[0] is not hier:
            memo = (hier, np.full((0, 3), -1, np.intp))
        known = memo[1]
        if len(known) < hier.n_points:
            known = np.concatenate([known, np.full((hier.n_points - len(known), 3), -1,
                                                   np.intp)])
        todo = rows[known[rows, 0] < 0]
        if len(todo):
            _, known[todo] = face.skin.kdtree.query(np.take(hier.rest, todo, axis=0), k=3)
        face._rest.fold_nearest_rows = (hier, known)
        idx = known[rows]
    fine.fold_radii_nearest = idx  # as fold_radii keeps them
    return idx
