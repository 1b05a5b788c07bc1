"""The fans' guard: each vertex's displaced fan kept off its two rings (docs/model.md)."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..certificate import (
    _corner_columns,
    _narrow_phase,
    _normals,
)
from ._base import (  # noqa: F401
    _any_corner,
    _cross,
    _incidence,
    _rows_dot,
)

# ---------------------------------------------------------------- the fans' guard
#
# The wrinkles' step x' -> x' + W n' moves each vertex along its own normal; where the skin
# folds on itself (normals far apart over an edge) a vertex's fan can pass through the
# triangles of its two rings, which no ball (empty of the triangles *not* incident to its
# vertex) sees. :func:`guard_fans` certifies cheaply, per vertex, that its displaced fan
# meets the triangles of its two rings only where it shares a vertex or an edge with them
# (``docs/model.md``, "The fans"), tests the pairs of the few vertices it cannot certify
# exactly, and scales their W back towards the deformed skin until none crosses.

_FAN_MARGIN = 1e-10  # relative margin of the certificate's signs (far above rounding)
_FAN_ROUNDS = 8  # the scale-back's rounds before it sets the W of a crossing pair to 0


def _fan_structure(tri: np.ndarray, n: int, terms: dict) -> dict:
    """The skin's fan structure, cached in ``terms``: ``across`` ``(m, 3)``, the third
    vertex of the triangle across edge ``k`` (corner ``k`` to ``k + 1``) of each triangle
    (-1 on a boundary), and ``open`` ``(n,)`` bool, vertices on an edge that is not shared
    by exactly two triangles running it in opposite directions.
    """
    fans = terms.get("fans")
    if fans is None:
        runs = terms.pop("fan_runs", None)
        runs = _edge_runs(tri, n) if runs is None else runs
        fans = terms["fans"] = {"across": _across(tri, n, runs), "open": _open(n, runs)}
    return fans


def _open(n: int, runs: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
    """``(n,)`` bool: the vertices on an edge that is not run exactly once each way (by
    the triangles whose directed edges :func:`_edge_runs` sorted into ``runs``: a boundary,
    non-manifold or misoriented edge, or one from a vertex to itself), as
    :func:`~wrinkle_vis.core.certificate._irregular_vertices` finds them.
    """
    _, s, new = runs
    starts = np.flatnonzero(new)
    val, count = s[starts], np.diff(np.append(starts, len(s)))
    half = val >> 1
    edge = np.empty(len(half), bool)  # where an undirected edge's runs start
    edge[:1], edge[1:] = True, half[1:] != half[:-1]
    first = np.flatnonzero(edge)
    runs_of = np.diff(np.append(first, len(half)))  # 1 or 2: one direction or both
    once = count == 1
    regular = (runs_of == 2) & once[first] & once[np.minimum(first + 1, len(once) - 1)]
    ends = half[first[~regular]]
    out = np.zeros(n, bool)
    out[ends // n] = True
    out[ends % n] = True
    return out


def _edge_runs(tri: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""The directed edges of ``tri`` ``(m, 3)`` (edge ``k`` of triangle ``t`` at ``3t + k``)
    sorted (stably) by the key :math:`2(n \min(a, b) + \max(a, b)) + [a > b]` of each edge ``a b``:
    the order ``(3m,)``, the sorted keys, and where a run of equal keys starts ``(3m,)``
    bool.
    """
    a, b = tri.ravel(), tri[:, [1, 2, 0]].ravel()
    lo, hi, back = np.minimum(a, b), np.maximum(a, b), a > b
    low = 2 * hi + back  # (< 2n: the key is 2n lo + low)
    key = lo.astype(np.int64) * (2 * n) + low
    if 2 * n <= _RADIX:  # two digits, or three: lo, hi, back
        order = _stable_order(key, (lo, low), 2 * n)
    else:
        order = _stable_order(key, (lo, hi, back), n)
    s = key[order]
    new = np.empty(len(s), bool)
    new[:1], new[1:] = True, s[1:] != s[:-1]
    return order, s, new


_RADIX = 1 << 16  # the keys numpy's stable argsort sorts by radix (uint16), linear


def _stable_order(key: np.ndarray, digits: tuple[np.ndarray, ...], base: int) -> np.ndarray:
    r"""``(k,)``: ``np.argsort(key, kind="stable")`` of the keys ``key`` ``(k,)`` int, whose
    order is that of their ``digits`` (each ``(k,)`` in ``[0, base)``, the most significant
    first) read left to right: where ``base`` fits 16 bits, a stable radix pass per digit
    from the last (a stable sort by the digits from the last is the order by all of them,
    ties in their first order), else the comparison sort itself.
    """
    if base > _RADIX:
        return np.argsort(key, kind="stable")
    order = np.argsort(digits[-1].astype(np.uint16), kind="stable")
    for digit in digits[-2::-1]:
        order = order[np.argsort(digit.astype(np.uint16)[order], kind="stable")]
    return order


def _across(tri: np.ndarray, n: int,
            runs: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """``(m, 3)``: the third vertex of the triangle across edge ``k`` (corner ``k`` to
    ``k + 1``) of each triangle ``tri`` ``(m, 3)`` on ``n`` vertices: of the first triangle
    (in ``tri``'s order) that runs the edge the other way, -1 where none does.

    One stable sort of the directed edges by (undirected edge, direction): an edge's twins
    are the run of the same undirected edge and the other direction, next to its own (an
    edge from a vertex to itself is its own twin). ``runs``: :func:`_edge_runs`, when
    known.
    """
    order, s, new = _edge_runs(tri, n) if runs is None else runs
    starts = np.flatnonzero(new)
    val = s[starts]
    twin = np.full(len(starts), -1, np.intp)
    # runs r (forward: even) and r + 1 (backward) of one undirected edge
    up = np.flatnonzero((val[1:] == val[:-1] + 1) & ((val[:-1] & 1) == 0))
    twin[up], twin[up + 1] = starts[up + 1], starts[up]
    own_twin = ((tri[:, 0] == tri[:, 1]) | (tri[:, 1] == tri[:, 2])
                | (tri[:, 2] == tri[:, 0])).any()
    if own_twin:  # an edge from a vertex to itself: its own twin
        half = val >> 1
        own = ((val & 1) == 0) & (half // n == half % n)
        twin[own] = starts[own]
    third = tri[:, [2, 0, 1]].ravel()[order]  # the corner opposite each edge, sorted
    if len(starts) == len(s) and not own_twin:  # runs of one: the twins are up's pairs
        found = np.full(len(s), -1, np.intp)
        found[up], found[up + 1] = third[up + 1], third[up]
    else:
        at = twin[np.cumsum(new) - 1]
        found = np.where(at >= 0, third[np.maximum(at, 0)], -1)
    across = np.empty(len(s), np.intp)
    across[order] = found
    return across.reshape(-1, 3)


# The fans' rest margins (docs/model.md, "The fans", "A filter on the rest skin"): the
# certificate of each vertex v taken along a fixed direction (v's rest normal) on a
# reference skin r (the rest skin, cached per skin in ``terms``), with how far every edge
# of its two rings may change, relative to its ends, before one of its signs could flip.


def _fan_edges(tri: np.ndarray, n: int, terms: dict) -> dict:
    """The skin's edges ``(e, 2)`` and, per vertex, its incident edges and neighbours in
    one CSR layout (``start`` ``(n + 1,)``, ``edge`` and ``nbr`` ``(2e,)``), cached in
    ``terms``.
    """
    graph = terms.get("fan_edges")
    if graph is None:
        edges = terms.get("edges")
        if edges is None:  # (sorted by first end, then second: one key each, unique)
            runs = _edge_runs(tri, n)  # (kept for the fans' structure, which follows)
            if "fans" not in terms:
                terms["fan_runs"] = runs
            edges = _edges_of_runs(n, runs)
        ends = np.concatenate([edges[:, 0], edges[:, 1]])
        order = np.argsort(ends.astype(np.uint16) if n <= _RADIX else ends, kind="stable")
        start = np.concatenate([[0], np.cumsum(np.bincount(ends, minlength=n))])
        graph = terms["fan_edges"] = {
            "edges": np.asarray(edges, dtype=np.intp), "start": start,
            "edge": np.where(order < len(edges), order, order - len(edges)),
            "nbr": np.concatenate([edges[:, 1], edges[:, 0]])[order]}
    return graph


def _edges_of_runs(n: int, runs: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
    """``(e, 2)``: the undirected edges of the triangles on ``n`` vertices whose directed
    edges :func:`_edge_runs` sorted into ``runs``, ends ascending, sorted by first end,
    then second, each once (the keys' halves, one per undirected edge).
    """
    half = runs[1][runs[2]] >> 1
    key = half[np.r_[True, half[1:] != half[:-1]]]
    return np.stack([key // n, key % n], axis=1)


def _csr_rows(start: np.ndarray, values: np.ndarray, rows: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
    """``rows`` ``(r,)`` of the CSR layout ``start`` ``(n + 1,)``, ``values``: their
    ``indptr`` ``(r + 1,)`` and values, concatenated.
    """
    count = start[rows + 1] - start[rows]
    indptr = np.concatenate([[0], np.cumsum(count)])
    return indptr, values[np.repeat(start[rows] - indptr[:-1], count) + np.arange(indptr[-1])]


def _segment_max(values: np.ndarray, indptr: np.ndarray) -> np.ndarray:
    """``(r,)``: the largest of each segment ``indptr[i]:indptr[i + 1]`` of ``values``, 0
    for an empty one.
    """
    if not len(values):
        return np.zeros(len(indptr) - 1)
    out = np.maximum.reduceat(values, np.minimum(indptr[:-1], len(values) - 1))
    return np.where(indptr[1:] > indptr[:-1], out, 0.0)


def _ring(rows: np.ndarray, graph: dict, n: int) -> np.ndarray:
    """``(k,)`` sorted: ``rows`` ``(r,)`` and their neighbours in ``graph``
    (:func:`_fan_edges`): through the rows' edge lists, or, where the rows are many, one
    pass over every edge (the same set).
    """
    mask = np.zeros(n, bool)
    mask[rows] = True
    edges = graph["edges"]
    if 8 * len(rows) > len(edges):  # most of the skin: one pass over its edges is cheaper
        e0, e1 = edges[:, 0], edges[:, 1]
        a, b = e0[mask[e1]], e1[mask[e0]]
        mask[a] = True
        mask[b] = True
    else:
        mask[_csr_rows(graph["start"], graph["nbr"], rows)[1]] = True
    return np.flatnonzero(mask)


def _margin(a: np.ndarray, s: np.ndarray) -> np.ndarray:
    r"""``(k,)``: the :math:`\rho \ge 0` below which :math:`a > \rho s + \rho^2`
    (:math:`a` ``(k,)`` the sign's value less its rounding margin, :math:`s` the sum of the
    projected lengths of its two edge vectors), :math:`2a / (s + \sqrt{s^2 + 4a})`; 0 where
    :math:`a \le 0`.
    """
    a = np.maximum(a, 0.0)
    return 2.0 * a / np.maximum(s + np.sqrt(s * s + 4.0 * a), 1e-300)


def _projected_length(e: np.ndarray, m: np.ndarray) -> np.ndarray:
    """``(k,)``: the lengths of the rows of ``e`` ``(k, 3)`` projected off the unit ``m``."""
    along = _rows_dot(e, m)
    return np.sqrt(np.maximum(_rows_dot(e, e) - along * along, 0.0))


def _rest_fan_margins(r: np.ndarray, tri: np.ndarray, terms: dict) -> np.ndarray:
    r"""``(n + 2e,)``: the margins :math:`\mu_{vu}` on the reference skin ``r`` ``(n, 3)``
    of each vertex v's fan certificate along v's reference normal :math:`m_v`, for every
    u of v's closed ring: first u = v (``[:n]``), then v's neighbours in
    :func:`_fan_edges`' CSR order (``[n:]``). If no edge at u changes by
    :math:`\rho_u \ge \mu_{vu}` (relative to its ends) for any u, the certificate holds
    (docs/model.md, "The fans"): :math:`\mu_{vu}` bounds the signs at u, u's fan's
    triangles' along :math:`m_v` and the turn of v's link at u. 0 where one fails on ``r``
    itself: u open, u's fan not winding once around u along :math:`m_v`.
    """
    n = len(r)
    graph, fans = _fan_edges(tri, n, terms), _fan_structure(tri, n, terms)
    A = _cross(r[tri[:, 1]] - r[tri[:, 0]], r[tri[:, 2]] - r[tri[:, 0]])
    m = np.stack([np.bincount(tri.ravel(), np.repeat(A[:, k], 3), n) for k in range(3)], 1)
    m = m / np.maximum(np.sqrt(_rows_dot(m, m)), 1e-300)[:, None]
    # the closed ring's (v, u) pairs, then every triangle t of u's fan: (v, u, t)
    count = np.diff(graph["start"])
    pv = np.concatenate([np.arange(n), np.repeat(np.arange(n), count)])
    pu = np.concatenate([np.arange(n), graph["nbr"]])
    indptr, t = _sub_rows(_fan_incidence(tri, n, terms), pu)
    g = np.repeat(np.arange(len(pu)), np.diff(indptr))
    u, mv = pu[g], m[pv[g]]
    k = (tri[t] == u[:, None]).argmax(axis=1)
    e1 = r[tri[t, (k + 1) % 3]] - r[u]
    e2 = r[tri[t, (k + 2) % 3]] - r[u]
    up = _rows_dot(A[t], mv)
    s = _projected_length(e1, mv) + _projected_length(e2, mv)  # the edges at u
    mu = np.full(len(pu), np.inf)
    np.minimum.at(mu, g, _margin(up - _FAN_MARGIN * s * s, s))
    flat = _rows_dot(e1, e2) - _rows_dot(e1, mv) * _rows_dot(e2, mv)
    once = np.bincount(g, np.arctan2(up, flat), len(pu)) < 3.0 * np.pi
    v, margin, u = _link_margins(r, tri, fans, m)
    key = pv[n:].astype(np.int64) * n + pu[n:]
    order = np.argsort(key)
    np.minimum.at(mu, n + order[np.searchsorted(key[order], v.astype(np.int64) * n + u)],
                  margin)
    mu[~once | fans["open"][pu] | ~np.isfinite(mu)] = 0.0
    return mu


def _link_margins(r: np.ndarray, tri: np.ndarray, fans: dict, m: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""``(3m,)`` three times: for every corner (v, u, w) of ``tri`` on ``r``, v, the margin
    of v's link turning left at u along :math:`m_v` (``m`` ``(n, 3)``) and u:
    :math:`m_v \cdot (u - u^-) \times (w - u) > 0`, :math:`u^-` across the edge v-u; 0
    where that edge is a boundary.
    """
    rows = np.arange(3 * len(tri))
    j, k = rows % len(tri), rows // len(tri)
    v, u, w = tri[j, k], tri[j, (k + 1) % 3], tri[j, (k + 2) % 3]
    before = fans["across"][j, k]
    e_in, e_out = r[u] - r[np.maximum(before, 0)], r[w] - r[u]
    mv = m[v]
    s = _projected_length(e_in, mv) + _projected_length(e_out, mv)
    turn = _rows_dot(_cross(e_in, e_out), mv)
    return v, np.where(before >= 0, _margin(turn - _FAN_MARGIN * s * s, s), 0.0), u


def _cleared_by_rest(p: np.ndarray, rest: np.ndarray, tri: np.ndarray, ask: np.ndarray,
                     terms: dict) -> tuple[np.ndarray, np.ndarray]:
    r"""``(k,)`` bool twice: which vertices ``ask`` ``(k,)`` have a fan that is a star on
    ``p`` ``(n, 3)`` (:math:`\rho_v < \mu_{vv}`), and a fan certificate that holds on
    ``p``, by the reference skin ``rest``'s margins alone (cached in ``terms``):
    :math:`\rho_u < \mu_{vu}` (:func:`_rest_fan_margins`) for every u of v's closed
    ring, :math:`\rho_u` the largest change :math:`|\Delta_b - \Delta_a|`
    (:math:`\Delta = p - r`) of an edge at u (the edges within three rings of ``ask``
    only are looked at).
    """
    return _rest_filter(p, _rest_region(rest, tri, ask, terms))


def _rest_region(rest: np.ndarray, tri: np.ndarray, ask: np.ndarray, terms: dict) -> dict:
    r"""What :func:`_rest_filter` needs to clear the vertices ``ask`` ``(k,)`` on any
    frame, gathered once (a moved set's region is kept with it, :func:`_fan_region`):
    ``verts`` ``(q,)`` (the ends of the edges at ``ask``'s closed rings' vertices, the
    ``ring`` ``(r,)``) and their rest points; those edges ``e0``, ``e1`` ``(f,)`` (as
    indices into ``verts``) by ring vertex (``indptr`` ``(r + 1,)``); the margins
    :math:`\mu_{vv}` (``mu_own`` ``(k,)``, ``own``: v's place in the ring) and
    :math:`\mu_{vu}` of each (v, u) (``mu_nbr``, ``nbr``: u's place in the ring, ``row``:
    v's place in ``ask``).
    """
    n = len(rest)
    mu = terms.get("fan_margins")
    if mu is None:
        mu = terms["fan_margins"] = _rest_fan_margins(rest, tri, terms)
    graph = _fan_edges(tri, n, terms)
    ring = _ring(ask, graph, n)
    indptr, ids = _csr_rows(graph["start"], graph["edge"], ring)
    e = graph["edges"][ids]
    inside = np.zeros(n, np.intp)
    inside[e.ravel()] = 1
    verts = np.flatnonzero(inside)
    inside[verts] = np.arange(len(verts))
    local = inside[e]
    at_ptr, at = _csr_rows(graph["start"], np.arange(len(graph["nbr"])), ask)
    return {"verts": verts, "rest": rest[verts], "e0": local[:, 0].copy(),
            "e1": local[:, 1].copy(), "indptr": indptr,
            "own": np.searchsorted(ring, ask), "mu_own": mu[ask],
            "nbr": np.searchsorted(ring, graph["nbr"][at]), "mu_nbr": mu[n + at],
            "row": np.repeat(np.arange(len(ask)), np.diff(at_ptr)), "k": len(ask)}


def _rest_filter(p: np.ndarray, region: dict) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_cleared_by_rest` on the region :func:`_rest_region` gathered: the frame's
    arithmetic only (the same values, so the same decisions).
    """
    D = p[region["verts"]] - region["rest"]
    step = D[region["e1"]] - D[region["e0"]]
    near = _segment_max(np.sqrt(_rows_dot(step, step)), region["indptr"])
    far = near[region["nbr"]] >= region["mu_nbr"]  # a sign at a neighbour in doubt
    star = near[region["own"]] < region["mu_own"]
    return star, star & (np.bincount(region["row"], far, region["k"]) == 0)


_FAN_REGIONS = 8  # the pulled regions whose fan work a skin's terms remember
_FAN_PAIRS = 4  # and, per region, the sets of loose vertices whose pairs it remembers


def _fan_region(changed: np.ndarray, tri: np.ndarray, terms: dict,
                rest: np.ndarray | None) -> tuple[dict, np.ndarray]:
    """A region of the skin around a set ``S`` of vertices holding ``changed`` ``(n,)``
    bool, kept in ``terms`` (the last :data:`_FAN_REGIONS`, the least recently used dropped
    first), and which of its vertices are within two rings of ``changed`` ``(k,)`` bool.

    The region: ``ask`` ``(k,)``, the vertices within two rings of ``S``; ``e0``, ``e1``,
    the edges among them (indices into ``ask``); given a reference skin ``rest``,
    :func:`_rest_region` of ``ask`` and which fail their certificate on it
    (``rest_fails``). A frame whose moved vertices lie in a kept ``S`` (the frames of an
    expression's ramp: W's support shrinks or stays as it grows) finds it; one that
    overlaps the latest ``S`` widens it to the union; any other starts a region of its own.
    """
    flag = rest is not None
    memo = terms.setdefault("fan_regions", [])
    for i in range(len(memo) - 1, -1, -1):
        region = memo[i]
        if region["rest"] == flag and not (changed & ~region["S"]).any():
            memo.append(memo.pop(i))  # the most recent last
            return region, _two_rings(changed[region["ask"]], _region_edges(region, terms))
    S = changed
    if memo and memo[-1]["rest"] == flag and (changed & memo[-1]["S"]).any():
        S = changed | memo.pop()["S"]
    n = len(changed)
    graph = _fan_edges(tri, n, terms)
    ask = _ring(_ring(np.flatnonzero(S), graph, n), graph, n)
    region = {"S": S, "rest": flag, "ask": ask, "pairs": {}}
    if rest is not None:
        region["rest_region"] = _rest_region(rest, tri, ask, terms)
        region["rest_fails"] = ~_rest_sure(rest, tri, terms)[ask]
    memo.append(region)
    while len(memo) > _FAN_REGIONS:
        memo.pop(0)
    if S is changed:  # ask is the two rings of changed itself
        return region, np.ones(len(ask), bool)
    return region, _two_rings(changed[ask], _region_edges(region, terms))


def _region_edges(region: dict, terms: dict) -> dict:
    """The ``region`` (:func:`_fan_region`) with ``e0``, ``e1`` ``(f,)``: the skin's edges
    (:func:`_fan_edges`, cached in ``terms``) with both ends in its ``ask``, as indices
    into ``ask``; found on the region's first use that needs them.
    """
    if "e0" not in region:
        ask, edges = region["ask"], terms["fan_edges"]["edges"]
        inside = np.full(len(region["S"]), -1)
        inside[ask] = np.arange(len(ask))
        e = inside[edges]
        e = e[(e[:, 0] >= 0) & (e[:, 1] >= 0)]
        region["e0"], region["e1"] = e[:, 0].copy(), e[:, 1].copy()
    return region


def _two_rings(mark: np.ndarray, region: dict) -> np.ndarray:
    """``(k,)`` bool: the vertices of the region's ``ask`` within two rings of ``mark``
    ``(k,)`` (a part of the region's ``S``), along the region's edges (every edge at a
    vertex within one ring of ``S`` is among them).
    """
    e0, e1 = region["e0"], region["e1"]
    mark = mark.copy()
    for _ in range(2):
        a, b = e0[mark[e1]], e1[mark[e0]]
        mark[a] = True
        mark[b] = True
    return mark


def _rest_sure(rest: np.ndarray, tri: np.ndarray, terms: dict) -> np.ndarray:
    """``(n,)`` bool, cached in ``terms``: the vertices whose fan certificate fails on the
    reference skin ``rest`` itself (:func:`_rest_fan_margins`: some margin 0), negated.
    """
    fails = terms.get("fan_rest_fails")
    if fails is None:
        fails = terms["fan_rest_fails"] = ~_cleared_by_rest(
            rest, rest, tri, np.arange(len(rest)), terms)[1]
    return ~fails


def _fan_terms(p: np.ndarray, tri: np.ndarray, sub: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Per vertex of the triangles ``sub`` (indices into ``tri`` ``(m, 3)``, every
    triangle of the fans asked about) on ``p`` ``(n, 3)``: ``m`` ``(n, 3)``, the unit sum of
    the fans' area vectors :math:`A_t`; ``c`` ``(n,)``, :math:`\min_t m \cdot A_t / |A_t|`;
    ``star`` ``(n,)`` bool, the fan seen along ``m`` is a star once around its vertex:
    every :math:`m \cdot A_t > 0` (with margin) and the projected angles add up to less
    than :math:`3\pi` (they add up to :math:`2\pi k`, :math:`k` the winding).
    :func:`_fan_columns` on ``p``'s columns.
    """
    m, c, star = _fan_columns(np.ascontiguousarray(p.T), tri, sub)
    return m.T, c, star


def _cdot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(k,)``: the dot products of the columns of ``a`` and ``b`` ``(3, k)`` (summed in
    :func:`_rows_dot`'s order, :math:`(a_0 b_0 + a_1 b_1) + a_2 b_2`: the same values; one
    buffer for the products).
    """
    out = a[0] * b[0]
    tmp = a[1] * b[1]
    out += tmp
    np.multiply(a[2], b[2], out=tmp)
    out += tmp
    return out


def _ccross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(3, k)``: the cross products of the columns of ``a`` and ``b`` ``(3, k)`` (as
    :func:`_cross` computes them, :math:`a_1 b_2 - a_2 b_1` and so on: the same values),
    written into one array.
    """
    out = np.empty(np.broadcast_shapes(a.shape, b.shape), np.result_type(a, b))
    tmp = np.empty_like(out[0])
    for i, j, k in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        np.multiply(a[j], b[k], out=out[i])
        np.multiply(a[k], b[j], out=tmp)
        out[i] -= tmp
    return out


def _fan_columns(pc: np.ndarray, tri: np.ndarray, sub: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_fan_terms` on the points' columns ``pc`` ``(3, n)``, ``m`` as ``(3, n)``:
    one gather of each corner's coordinates (takes along the contiguous rows), the same
    arithmetic, so the same values (:func:`_fan_sums`' first three).
    """
    return _fan_sums(pc, tri[sub])[:3]


def _fan_sums(pc: np.ndarray, t: np.ndarray) -> tuple:
    r""":func:`_fan_columns` of the triangles ``t`` ``(T, 3)`` on the columns ``pc``
    ``(3, n)``: ``m`` ``(3, n)``, ``c`` and ``star`` ``(n,)``; and what the turns of the
    links reuse (the same values as gathered anew): the corners ``x`` (three ``(3, T)``,
    :math:`x_k` at ``t[:, k]``), the sides ``d`` (:math:`x_{k+1} - x_k`) and the normals
    at each corner, ``mv`` (:math:`m` at ``t[:, k]``).
    """
    n = pc.shape[1]
    x = tuple(np.take(pc, t[:, k], axis=1) for k in range(3))
    d = (x[1] - x[0], x[2] - x[1], x[0] - x[2])  # a - o at each corner k, below
    f = (x[2] - x[0], x[0] - x[1], x[1] - x[2])  # b - o
    A = _ccross(d[0], f[0])
    la = np.maximum(np.sqrt(_cdot(A, A)), 1e-300)
    flat_t = t.ravel()
    m = np.stack([np.bincount(flat_t, np.repeat(A[k], 3), n) for k in range(3)])
    m = m / np.maximum(np.sqrt(_cdot(m, m)), 1e-300)
    c = np.full(n, np.inf)
    angle = np.zeros(n)
    mvs = []
    for k in range(3):  # corner k: o = x_k, a = x_{k+1}, b = x_{k+2}
        mv = np.take(m, t[:, k], axis=1)
        mvs.append(mv)
        up = _cdot(A, mv)
        np.minimum.at(c, t[:, k], up / la)
        flat = _cdot(d[k], f[k]) - _cdot(d[k], mv) * _cdot(f[k], mv)
        angle += np.bincount(t[:, k], np.arctan2(up, flat), n)
    star = (c > _FAN_MARGIN) & (angle < 3.0 * np.pi)
    return m, c, star, x, d, mvs


def _link_turns(pc: np.ndarray, t: np.ndarray, before: np.ndarray, sums: tuple
                ) -> tuple[np.ndarray, np.ndarray]:
    r"""``(3T,)`` bool twice, per corner (v, u, w) of the triangles ``t`` ``(T, 3)``
    (``3T``: every triangle's first corners, then its second, then its third; u after v,
    w after u, ``before`` ``(T, 3)`` :math:`u^-` across v-u, -1: none) on the columns
    ``pc`` ``(3, n)``, with :func:`_fan_sums`' ``sums``: v's link turns left at u along
    :math:`m_v`, :math:`m_v \cdot (u - u^-) \times (w - u) > \epsilon |u - u^-| |w - u|`
    (2), and u's fan is a star along :math:`m_v` by its own,
    :math:`c_u > |m_v - m_u| + \epsilon` (3): the same values as the corners' own
    gathers (:math:`w - u` is the side after u, :math:`m_u` the normal at u's corner).
    """
    _, c, _, x, d, mvs = sums
    left, along = [], []
    for k in range(3):
        j = (k + 1) % 3
        e_in = x[j] - np.take(pc, np.maximum(before[:, k], 0), axis=1)
        e_out = d[j]
        turn = _cdot(_ccross(e_in, e_out), mvs[k])
        left.append(turn > _FAN_MARGIN * np.sqrt(_cdot(e_in, e_in) * _cdot(e_out, e_out)))
        dm = mvs[k] - mvs[j]
        along.append(c[t[:, j]] > np.sqrt(_cdot(dm, dm)) + _FAN_MARGIN)
    return np.concatenate(left), np.concatenate(along)


def _certified_fans(p: np.ndarray, tri: np.ndarray, ask: np.ndarray, fans: dict,
                    terms: dict) -> tuple[np.ndarray, np.ndarray]:
    r"""``(k,)`` bool twice, for vertices ``ask`` ``(k,)`` on ``p`` ``(n, 3)``: whose fan is
    a star (its triangles meet only in shared vertices and edges), and whose fan meets
    the triangles of its two rings only in shared vertices and edges, certainly
    (``docs/model.md``, "The fans"): :func:`_fan_certificates`' first two.
    """
    star, sure, _ = _fan_certificates(p, tri, ask, fans, terms)
    return star, sure


def _fan_certificates(p: np.ndarray, tri: np.ndarray, ask: np.ndarray, fans: dict,
                      terms: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""For vertices ``ask`` ``(k,)`` on ``p`` ``(n, 3)``: ``(k,)`` bool, whose fan is a
    star; ``(k,)`` bool, whose certificate holds for every edge v-u at it; ``(h, 2)``,
    the edges (v, u) whose certificate holds at the vertices v of ``ask`` where it does not
    hold for all (``docs/model.md``, "The fans"). Seen along the vertex's :math:`m_v`
    (:func:`_fan_terms`): the vertex and its ring are closed (not ``open``), its fan is a
    star once around it (1); every :math:`u`'s fan is a star once around it (3: along
    :math:`m_u` with :math:`c_u > |m_v - m_u|`, which makes it one along :math:`m_v`, or
    else checked along :math:`m_v`, :func:`_stars_along`); and its link turns left at
    every ring vertex (2: the projected fan :math:`S_v` is convex), or else, for the edge
    v-u, v's fan keeps off the wedge of u's other triangles (2', :func:`_wedges_clear`).
    """
    n = len(p)
    inc = _fan_incidence(tri, n, terms)
    asked = np.zeros(n, bool)
    asked[ask] = True
    ring = _ring(ask, _fan_edges(tri, n, terms), n)
    sub = _triangles_at(ring, tri, inc)  # the triangles at the asked ones' rings
    every = len(sub) == len(tri)  # (all of them: no gather)
    t = tri if every else tri[sub]
    pc = np.ascontiguousarray(p.T)  # (the coordinates' columns: one take each)
    sums = _fan_sums(pc, t)
    mc, c, star = sums[:3]
    m = mc.T
    star &= ~fans["open"]
    across = fans["across"] if every else fans["across"][sub]
    tt = t.T.ravel()
    rows = np.flatnonzero(asked[tt])  # the asked vertices' corners (k, t): edges v-u
    v, u, w = tt[rows], t[:, [1, 2, 0]].T.ravel()[rows], t[:, [2, 0, 1]].T.ravel()[rows]
    before = across.T.ravel()[rows]  # the ring vertex before u (across edge v-u)
    left, along = _link_turns(pc, t, across, sums)
    left, along = left[rows], along[rows]
    good = star[v] & star[u]  # 1 and 3 along m_u (of a closed u)
    check = np.flatnonzero(good & ~along)  # u's star along m_v, checked
    if len(check):
        good[check] = _stars_along(p, tri, inc, v[check], u[check], m)
    ok = asked & star
    ok[v[~(good & left)]] = False  # 1-3: every pair v's certificate stands for is apart
    # 2' per edge v-u where the link turns right somewhere and u is not certified either
    # (an edge with a certified end has its pairs apart: it brings none to the exact test)
    check = np.flatnonzero(good & ~ok[v] & ~ok[u] & asked[u])
    if len(check):
        good[check] = _wedges_clear(p, tri, inc, m, v[check], u[check], w[check],
                                    before[check])
    half = np.flatnonzero(good & ~ok[v] & ~ok[u] & asked[u])
    return star[ask], ok[ask], np.stack([v[half], u[half]], axis=1)


def _triangles_at(rows: np.ndarray, tri: np.ndarray, inc: _FanIncidence) -> np.ndarray:
    """``(k,)`` ascending: the triangles of ``tri`` ``(m, 3)`` with a corner in ``rows``
    ``(r,)`` (distinct): through the rows of the incidence ``inc`` ``(n, m)``, or, where
    the rows are many, one look at every triangle's corners (the same set).
    """
    if 16 * len(rows) > len(tri):
        mark = np.zeros(inc.shape[0], bool)
        mark[rows] = True
        return np.flatnonzero(_any_corner(mark, tri))
    at = np.zeros(len(tri), bool)
    at[_sub_rows(inc, rows)[1]] = True
    return np.flatnonzero(at)


def _wedges_clear(p: np.ndarray, tri: np.ndarray, inc: _FanIncidence, m: np.ndarray,
                  v: np.ndarray, u: np.ndarray, up: np.ndarray, um: np.ndarray
                  ) -> np.ndarray:
    r"""``(r,)`` bool: condition 2' of the fan certificate (``docs/model.md``, "The fans")
    for each edge v-u (``v``, ``u`` ``(r,)``, v's link running ``um`` :math:`u^-`, u,
    ``up`` :math:`u^+`; -1: none) on ``p`` ``(n, 3)``, seen along :math:`m_v` (``m``
    ``(n, 3)``). With :math:`a = u^+ - u`, :math:`b = u^- - u`,
    :math:`f_a(x) = m_v \cdot a \times (x - u)` and
    :math:`f_b(x) = m_v \cdot (x - u) \times b`, every triangle of v's fan not holding u
    has all its corners x in :math:`H_a = \{f_a > 0\}` (:math:`u^+` itself exempt) and all
    in :math:`H_b = \{f_b > 0\}` (:math:`u^-` exempt), or, where the link turns right at u
    (:math:`m_v \cdot a \times b < 0`), all in one of the two; each sign with the relative
    margin ``_FAN_MARGIN``. With 1 and 3 (the caller's), no triangle of v's fan then meets
    a triangle of u's that shares no vertex with it.
    """
    indptr, t = _sub_rows(inc, v)  # every triangle of v's fan, per edge
    row = np.repeat(np.arange(len(v)), np.diff(indptr))
    pc, mc = np.ascontiguousarray(p.T), np.ascontiguousarray(m.T)  # (columns: the same
    o = np.take(pc, u, axis=1)  # values as on the rows, one take each)
    mv, a = np.take(mc, v, axis=1), np.take(pc, up, axis=1) - o
    b = np.take(pc, np.maximum(um, 0), axis=1) - o
    la, lb = np.sqrt(_cdot(a, a)), np.sqrt(_cdot(b, b))
    right = (_cdot(_ccross(a, b), mv) < -_FAN_MARGIN * la * lb)[row]
    # each edge's terms on its fan's rows: one gather of them all (the same values)
    per = np.take(np.concatenate([mv, o, a, b, la[None], lb[None]]), row, axis=1)
    mv, o, a, b, la, lb = per[0:3], per[3:6], per[6:9], per[9:12], per[12], per[13]
    ur, upr, umr = np.take(np.stack([u, up, um]), row, axis=1)
    corners = tri[t]
    A = B = (corners != ur[:, None]).all(axis=1)  # (rows holding u: nothing to check)
    skip = ~A
    for j in range(3):
        x = np.take(pc, corners[:, j], axis=1) - o
        lx = np.sqrt(_cdot(x, x))
        A = A & ((corners[:, j] == upr)
                 | (_cdot(_ccross(a, x), mv) > _FAN_MARGIN * la * lx))
        B = B & ((corners[:, j] == umr)
                 | (_cdot(_ccross(x, b), mv) > _FAN_MARGIN * lb * lx))
    fine = skip | (A & B) | (right & (A | B))
    return (np.bincount(row, ~fine, len(v)) == 0) & (um >= 0)


def _stars_along(p: np.ndarray, tri: np.ndarray, inc: _FanIncidence, v: np.ndarray,
                 u: np.ndarray, m: np.ndarray) -> np.ndarray:
    r"""``(k,)`` bool: the fan of each ``u`` ``(k,)`` on ``p`` is a star once around it
    seen along :math:`m_v` (``v`` ``(k,)``, ``m`` ``(n, 3)``): every
    :math:`m_v \cdot A_t > 0` with margin, the projected angles adding up to below
    :math:`3\pi`.
    """
    indptr, indices = _sub_rows(inc, u)
    row = np.repeat(np.arange(len(u)), np.diff(indptr))
    t = tri[indices]
    o = p[u[row]]
    k = (t == u[row, None]).argmax(axis=1)  # u's corner: the other two follow it
    a = p[t[np.arange(len(t)), (k + 1) % 3]] - o
    b = p[t[np.arange(len(t)), (k + 2) % 3]] - o
    mv = m[v[row]]
    A = np.cross(a, b)
    up = np.einsum("ij,ij->i", A, mv)
    flat = np.einsum("ij,ij->i", a, b) - (np.einsum("ij,ij->i", a, mv)
                                         * np.einsum("ij,ij->i", b, mv))
    pos = up > _FAN_MARGIN * np.linalg.norm(A, axis=1)
    good = np.bincount(row, ~pos, len(u)) == 0
    return good & (np.bincount(row, np.arctan2(up, flat), len(u)) < 3.0 * np.pi)


class _FanIncidence(NamedTuple):
    """The vertex-triangle incidence of a skin's triangles in CSR form: ``indptr``
    ``(n + 1,)``, ``indices`` (each vertex's triangles, ascending, each once) and ``shape``
    ``(n, m)``: what :func:`_incidence`'s matrix holds, without building one.
    """

    indptr: np.ndarray
    indices: np.ndarray
    shape: tuple[int, int]


def _fan_incidence(tri: np.ndarray, n: int, terms: dict) -> _FanIncidence:
    """``(n, m)``: :func:`_incidence` of ``tri`` as a :class:`_FanIncidence`, cached in
    ``terms``: one stable sort of the corners by vertex (radix where ``n`` fits 16
    bits): corner ``3t + k`` in order, so each vertex's triangles ascending; where a
    triangle repeats a corner (its entries summed into one by the matrix), the matrix's.
    """
    inc = terms.get("fan_incidence")
    if inc is None:
        flat = tri.ravel()
        if ((tri[:, 0] == tri[:, 1]) | (tri[:, 1] == tri[:, 2])
                | (tri[:, 2] == tri[:, 0])).any():
            mat = _incidence(tri, n)
            indptr, indices = mat.indptr, mat.indices
        else:
            order = np.argsort(flat.astype(np.uint16) if n <= _RADIX else flat, kind="stable")
            indptr = np.zeros(n + 1, np.intp)
            np.cumsum(np.bincount(flat, minlength=n), out=indptr[1:])
            indices = order // 3
        inc = terms["fan_incidence"] = _FanIncidence(indptr, indices, (n, len(tri)))
    return inc


def _sub_rows(inc: _FanIncidence, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``rows`` ``(r,)`` of the CSR matrix ``inc`` as its ``indptr`` ``(r + 1,)`` and
    ``indices`` (what ``inc[rows]`` holds, without building it).
    """
    start, count = inc.indptr[rows], np.diff(inc.indptr)[rows]
    indptr = np.concatenate([[0], np.cumsum(count)])
    at = np.repeat(start - indptr[:-1], count) + np.arange(indptr[-1])
    return indptr, inc.indices[at]


def _row_products(a: tuple, b: tuple) -> tuple[np.ndarray, np.ndarray]:
    """``(k,)`` int twice: every (column of row ``r`` of ``a``, column of row ``r`` of
    ``b``), for every row ``r`` of the two (``indptr``, ``indices``) of :func:`_sub_rows`
    (same number of rows).
    """
    rows = np.repeat(np.arange(len(a[0]) - 1), np.diff(a[0]))
    count = np.diff(b[0])[rows]
    start = np.repeat(b[0][rows] - np.cumsum(count) + count, count)
    return np.repeat(a[1], count), b[1][start + np.arange(count.sum())]


def _fan_pairs(tri: np.ndarray, inc: _FanIncidence, loose: np.ndarray, edges: np.ndarray
               ) -> np.ndarray:
    """``(k, 2)`` int, ``i < j``, unique: the pairs of triangles ``tri`` ``(m, 3)`` that no
    certificate covers: two of the fan of a vertex in ``loose`` ``(a,)`` (not a star), and
    one of each end's fan of ``edges`` ``(e, 2)`` (neither end certified) that share no
    vertex.
    """
    fans = _sub_rows(inc, loose)
    a1, b1 = _row_products(fans, fans)
    a2, b2 = _row_products(_sub_rows(inc, edges[:, 0]), _sub_rows(inc, edges[:, 1]))
    apart = ~(tri[a2][:, :, None] == tri[b2][:, None, :]).any(axis=(1, 2))
    a = np.concatenate([a1, a2[apart]])
    b = np.concatenate([b1, b2[apart]])
    keep = a != b
    a, b = a[keep], b[keep]
    key = np.unique(np.minimum(a, b).astype(np.int64) * len(tri) + np.maximum(a, b))
    return np.stack([key // len(tri), key % len(tri)], axis=1).astype(np.intp)


def _pairs_cross(p: np.ndarray, tri: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """``(k,)`` bool: which ``pairs`` ``(k, 2)`` of triangles ``tri`` ``(m, 3)`` on ``p``
    ``(n, 3)`` intersect other than in their shared vertices or edge, a contact included
    (the certificate's exact narrow phase, :mod:`wrinkle_vis.core.certificate`).
    """
    if not len(pairs):
        return np.zeros(0, bool)
    ids, local = np.unique(pairs, return_inverse=True)
    sub = tri[ids]
    x = _corner_columns(p, sub)
    corners = np.stack([np.stack(x[k], axis=1) for k in range(3)], axis=1)
    normal, perm = _normals(x)
    hit, _ = _narrow_phase(p, sub, corners, normal, perm, local.reshape(-1, 2))
    return hit


_PLANE_MARGIN = 1e-10  # relative margin of the planes' sides (far above rounding)


def _apart_by_planes(p: np.ndarray, tri: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    r"""``(k,)`` bool: the ``pairs`` ``(k, 2)`` of triangles ``tri`` on ``p`` ``(n, 3)``
    that certainly meet only in what they share: the corners of one that the other does
    not share (at least one) lie strictly on one side of the other's plane,
    :math:`|h| > \epsilon` with one sign for all, :math:`h = N \cdot (x - a)`,
    :math:`N = (b - a) \times (c - a)` for the other = (a, b, c), :math:`\epsilon` =
    ``_PLANE_MARGIN`` :math:`|b - a| |c - a| |x - a|` (``docs/model.md``, "The fans", "A
    plane first"); the exact test would find them apart.
    """
    if not len(pairs):
        return np.zeros(0, bool)
    k = len(pairs)
    t = tri[np.concatenate([pairs[:, 0], pairs[:, 1]])]  # each triangle's plane against
    s = tri[np.concatenate([pairs[:, 1], pairs[:, 0]])]  # the other's corners, both ways
    a = p[t[:, 0]]
    e1, e2 = p[t[:, 1]] - a, p[t[:, 2]] - a
    N = _cross(e1, e2)
    scale = _PLANE_MARGIN * _PLANE_MARGIN * _rows_dot(e1, e1) * _rows_dot(e2, e2)
    free = (s[:, :, None] != t[:, None, :]).all(axis=2)  # (2k, 3): not a corner of t
    x = p[s] - a[:, None, :]
    h = np.einsum("ij,ikj->ik", N, x)
    sure = h * h > scale[:, None] * np.einsum("ikj,ikj->ik", x, x)  # |h| > eps
    pos = (~free | (sure & (h > 0))).all(axis=1)
    neg = (~free | (sure & (h < 0))).all(axis=1)
    one = (pos | neg) & free.any(axis=1)
    return one[:k] | one[k:]


def guard_fans(deformed: np.ndarray, points: np.ndarray, W: np.ndarray,
               triangles: np.ndarray, terms: dict | None = None,
               rest: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    r"""The wrinkles' step ``deformed`` :math:`x'` to ``points`` :math:`x' + W n'`
    (``(n, 3)``, ``W`` ``(n,)``) with no vertex's fan passing through the triangles of its
    two rings (``docs/model.md``, "The fans"): returns the points and :math:`W`, scaled
    by :math:`h_v \in [0, 1]` (:math:`x' + h_v (x - x')`), ``points`` and ``W``
    themselves (bit for bit) where nothing would cross.

    Each vertex within two rings of a moved one is cleared by the reference skin
    ``rest``'s cached margins where its two rings' edges changed less than its margin
    (:func:`_cleared_by_rest`, a few operations per edge), else certified by
    :func:`_certified_fans` (a few products per fan corner); the pairs no certificate
    covers are tested exactly (:func:`_loose_pairs`, :func:`_pairs_cross`); the
    :math:`W` of the corners of each pair that crosses, and is apart on ``deformed``, is
    scaled back to just below where it crosses (:func:`_scale_back`; the least factor
    where pairs share a corner; after ``_FAN_ROUNDS`` rounds, to 0), and the vertices
    around those are certified and tested again, until no pair crosses. A pair apart on
    ``deformed`` is apart once its corners' :math:`W` is 0, so this ends. ``terms``: a
    cache (:func:`pull_terms`' dict, of ``rest`` when it is given); a skin's first frame,
    every frame of a refined skin (``terms["refined"]``) and a call without ``rest`` use
    no margins and work on the triangles within three rings of the moved vertices only
    (:func:`_triangles_within`; the same pairs, so the same frame).
    """
    tri = np.asarray(triangles, dtype=np.intp)
    terms = {} if terms is None else terms
    d, p0 = np.asarray(deformed, dtype=float), np.asarray(points, dtype=float)
    moved = p0 != d
    moved = moved[:, 0] | moved[:, 1] | moved[:, 2]
    if not moved.any():
        return points, W
    if rest is not None and (terms.get("refined") or not terms.get("fans_seen")):
        # a skin's first frame is guarded without the rest filter: its margins cost a
        # pass over the whole skin (three times the frame's exact checks on a refined
        # frame's skin, new on each frame); a skin seen again pays for them once, but
        # a refined one (one per split set, each seen a few times) never
        terms["fans_seen"] = True
        rest = None
    if rest is None:  # no cached structures: those of the triangles near the moved ones
        near = _triangles_within(moved, tri, 3)
        if not near.any():  # (moved vertices in no triangle: no pair moved)
            return points, W
        if not near.all():
            kept = _near_terms(near, terms) if terms.get("refined") else {}
            p, h = _scaled_fans(d, p0, moved, tri[near], kept, None)
            return (points, W) if p is p0 else (p, np.asarray(W, dtype=float) * h)
    p, h = _scaled_fans(d, p0, moved, tri, terms, rest)
    terms.pop("fan_runs", None)  # (the edges' sort, if the fans' structure did not take it)
    return (points, W) if p is p0 else (p, np.asarray(W, dtype=float) * h)


def _near_terms(near: np.ndarray, terms: dict) -> dict:
    """The cache of the triangles ``near`` ``(m,)`` bool of a refined skin (``terms``):
    kept in ``terms`` for the last such set, found again by a frame with the same set (the
    skin seen again with the same moved vertices: the app's Play going round), else new.
    """
    kept = terms.get("fan_near")
    if kept is None or not np.array_equal(kept[0], near):
        kept = terms["fan_near"] = (near, {})
    return kept[1]


def _triangles_within(mark: np.ndarray, tri: np.ndarray, rings: int) -> np.ndarray:
    """``(m,)`` bool: the triangles ``tri`` ``(m, 3)`` with a corner within ``rings``
    rings of the vertices ``mark`` ``(n,)`` bool: every triangle at such a vertex.
    """
    mark = mark.copy()
    c0, c1, c2 = np.ascontiguousarray(tri.T)  # (the corners' columns: gathers from
    for _ in range(rings):  # contiguous indices, twice as fast as the rows' strides)
        hit = mark[c0] | mark[c1] | mark[c2]
        mark[c0[hit]] = True
        mark[c1[hit]] = True
        mark[c2[hit]] = True
    return mark[c0] | mark[c1] | mark[c2]


def _scaled_fans(d: np.ndarray, p0: np.ndarray, moved: np.ndarray, tri: np.ndarray,
                 terms: dict, rest: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`guard_fans`' rounds on ``tri`` ``(m, 3)`` (every triangle within three
    rings of ``moved`` ``(n,)`` bool at least): the points ``(n, 3)`` (``p0`` itself where
    nothing crosses) and the factors :math:`h` ``(n,)``.
    """
    h = np.ones(len(d))
    p, rounds, changed = p0, 0, moved
    while True:
        pairs = _loose_pairs(p, tri, changed, terms, rest)
        pairs = pairs[~_apart_by_planes(p, tri, pairs)]  # (the exact test's verdict)
        hit = pairs[_pairs_cross(p, tri, pairs)]
        hit = hit[~_pairs_cross(d, tri, hit)]  # a pair the pulls crossed is not W's
        if not len(hit):
            break
        rounds += 1
        factor = np.ones(len(d))
        np.minimum.at(factor, tri[hit].reshape(len(hit), 6),
                      _scale_back(d, p, tri, hit)[:, None] if rounds < _FAN_ROUNDS else 0.0)
        changed = (factor < 1.0) & moved
        h[changed] *= factor[changed]
        if p is p0:
            p = p0.copy()
        p[changed] = d[changed] + h[changed, None] * (p0[changed] - d[changed])
    return p, h


def _loose_pairs(p: np.ndarray, tri: np.ndarray, changed: np.ndarray, terms: dict,
                 rest: np.ndarray | None = None) -> np.ndarray:
    """``(k, 2)``: the pairs of triangles (:func:`_fan_pairs`) around the vertices within
    two rings of ``changed`` ``(n,)`` bool on ``p`` ``(n, 3)`` that neither the reference
    skin ``rest``'s margins (:func:`_cleared_by_rest`) nor :func:`_certified_fans` clear,
    left to the exact test. The region's index work is kept per moved set
    (:func:`_fan_region`), the pairs per set of vertices left.
    """
    n = len(p)
    region, asked = _fan_region(changed, tri, terms, rest)
    if rest is not None:
        star, sure = _rest_filter(p, region["rest_region"])
        left = asked & ~sure
        if not left.any():
            return np.zeros((0, 2), np.intp)
        ask, star, sure = region["ask"][left], star[left], sure[left]
        # a star whose certificate fails on the rest skin itself (its link turns right
        # there) is not certified again: its edges' pairs go to the exact test
        check = ~(star & region["rest_fails"][left])
    else:
        ask = region["ask"][asked]
        star, sure = np.zeros(len(ask), bool), np.zeros(len(ask), bool)
        check = np.ones(len(ask), bool)
    half = np.zeros((0, 2), np.intp)
    if check.any():
        star[check], sure[check], half = _fan_certificates(
            p, tri, ask[check], _fan_structure(tri, n, terms), terms)
    return _pairs_of(tri, n, terms, region, ask[~sure], ask[~star], half)


def _pairs_of(tri: np.ndarray, n: int, terms: dict, region: dict, loose: np.ndarray,
              open_fans: np.ndarray, half: np.ndarray | None = None) -> np.ndarray:
    """:func:`_fan_pairs` of the vertices ``loose`` ``(a,)`` (sorted; certificate not
    holding for every edge) and ``open_fans`` (their fans not stars): the edges with both
    ends loose, found through the skin's edge lists, less those certified at either end
    (``half`` ``(h, 2)``: (v, u), :func:`_fan_certificates`), the pairs kept in the
    ``region`` (:func:`_fan_region`) for the last :data:`_FAN_PAIRS` such sets.
    """
    half = np.zeros((0, 2), np.intp) if half is None else half
    key = (loose.tobytes(), open_fans.tobytes(), half.tobytes())
    memo = region["pairs"]
    pairs = memo.pop(key, None)
    if pairs is None:
        graph = _fan_edges(tri, n, terms)
        mark = np.zeros(n, bool)
        mark[loose] = True
        indptr, nbr = _csr_rows(graph["start"], graph["nbr"], loose)
        src = np.repeat(loose, np.diff(indptr))
        both = mark[nbr] & (src < nbr)
        e = np.stack([src[both], nbr[both]], axis=1)
        if len(half) and len(e):  # an edge certified at one end: its pairs are apart
            done = np.minimum(half[:, 0], half[:, 1]).astype(np.int64) * n \
                + np.maximum(half[:, 0], half[:, 1])
            e = e[~np.isin(e[:, 0].astype(np.int64) * n + e[:, 1], done)]
        pairs = _fan_pairs(tri, _fan_incidence(tri, n, terms), open_fans, e)
    memo[key] = pairs
    while len(memo) > _FAN_PAIRS:
        memo.pop(next(iter(memo)))
    return pairs


def _scale_back(d: np.ndarray, p: np.ndarray, tri: np.ndarray, hit: np.ndarray
                ) -> np.ndarray:
    r"""``(k,)`` in ``[0, 1)``: for each pair ``hit`` ``(k, 2)`` of triangles ``tri`` that
    crosses on ``p`` and not on ``d`` (``(n, 3)``), a factor :math:`\lambda` at which it
    is apart on :math:`d + \lambda (p - d)` (its own corners scaled, the others'
    ignored), within :math:`2^{-8}` of where it first crosses (bisection from
    :math:`\lambda = 0`, apart, and 1, crossing).
    """
    k = len(hit)
    key = np.repeat(np.arange(k, dtype=np.int64), 6) * len(p) + tri[hit].reshape(-1)
    ids, local = np.unique(key, return_inverse=True)
    rows, verts = ids // len(p), ids % len(p)
    lo, hi = np.zeros(k), np.ones(k)
    pairs = np.arange(2 * k).reshape(k, 2)
    for _ in range(8):
        mid = 0.5 * (lo + hi)
        pts = d[verts] + mid[rows, None] * (p[verts] - d[verts])
        cross = _pairs_cross(pts, local.reshape(2 * k, 3), pairs)
        lo, hi = np.where(cross, lo, mid), np.where(cross, mid, hi)
    return lo
