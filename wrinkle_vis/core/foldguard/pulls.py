"""The pulls' guard: triangles kept from turning over (``docs/model.md``, the pulls)."""
from __future__ import annotations

import heapq
from collections.abc import Callable
from typing import Any, Literal

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from ._base import (  # noqa: F401
    _terms_edges,
    soft_clamp,
)


def _row_terms(points: np.ndarray, corners: np.ndarray, normals_only: bool = False,
               order: Literal["C", "F"] = "C") -> tuple[np.ndarray, ...]:
    r"""``(3, k)`` thrice: :math:`N / |N|^2`, :math:`A_1 = N \times e_1 / |N|^2` and
    :math:`A_2 = e_2 \times N / |N|^2` of the triangles ``corners`` ``(3, k)`` on ``points``
    ``(n, 3)`` (0 for a triangle with no area); with ``normals_only`` :math:`N / |N|^2`
    alone (a 1-tuple). Computed as rows, component by component (the products of
    :func:`numpy.cross`, in its order; :math:`|N|^2` by ``einsum`` on rows), into arrays
    of the memory ``order`` ``"C"`` or ``"F"`` (the same values).
    """
    e1, e2 = _edge_rows(points, corners)
    t = np.empty(corners.shape[1])  # the products' scratch
    N = _cross_rows(e1, e2, np.empty((3, len(t)), order=order), t)
    rows = np.ascontiguousarray(N.T)  # |N|^2 by einsum on rows, its summation order
    nn = np.einsum("ij,ij->i", rows, rows)
    del rows
    nn = np.where(nn > 0, nn, np.inf)
    if normals_only:
        N /= nn
        return (N,)
    A1 = _cross_rows(N, e1, np.empty((3, len(t)), order=order), t)
    A1 /= nn
    del e1
    A2 = _cross_rows(e2, N, np.empty((3, len(t)), order=order), t)
    A2 /= nn
    N /= nn
    return N, A1, A2


def _edge_rows(points: np.ndarray, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(3, k)`` twice: the edges :math:`e_1 = v_1 - v_0`, :math:`e_2 = v_2 - v_0` of the
    triangles ``corners`` ``(3, k)`` on ``points`` ``(n, 3)``, as rows x, y, z.
    """
    pts = np.ascontiguousarray(np.asarray(points, dtype=float).T)
    r0 = np.take(pts, corners[0], axis=1)
    e1 = np.take(pts, corners[1], axis=1)
    e1 -= r0
    e2 = np.take(pts, corners[2], axis=1)
    e2 -= r0
    return e1, e2


def _cross_rows(u: np.ndarray, v: np.ndarray, out: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``out`` ``(3, k)`` (any layout): the cross products of the columns of ``u`` and
    ``v`` ``(3, k)``, each component :math:`u_i v_j - u_j v_i` (:func:`numpy.cross`'s
    products, in its order) written in place; ``t`` ``(k,)``: scratch.
    """
    for row, (i, j) in enumerate(((1, 2), (2, 0), (0, 1))):
        np.multiply(u[i], v[j], out=out[row])
        np.multiply(u[j], v[i], out=t)
        out[row] -= t
    return out


def _start_terms(Nt: np.ndarray, start: np.ndarray, corners: np.ndarray
                 ) -> tuple[np.ndarray, ...]:
    r"""``(k,)`` then ``(3, k)`` twice: :math:`\sigma_t(0) = N_t \cdot (e_1 \times e_2)`,
    :math:`A_1 = N_t \times e_1`, :math:`A_2 = e_2 \times N_t` for the rest normals
    :math:`N_t = N / |N|^2` ``(3, k)`` and the edges :math:`e_1, e_2` of the triangles
    ``corners`` ``(3, k)`` on the skin ``start`` ``(n, 3)`` a step begins from.
    """
    e1, e2 = _edge_rows(start, corners)
    k = corners.shape[1]
    t = np.empty(k)
    cross = np.empty((k, 3))  # laid out as before (the einsum's sums follow the layout):
    _cross_rows(e1, e2, cross.T, t)  # rows of (k, 3), and A1, A2 the transposes of such
    A1 = _cross_rows(Nt, e1, np.empty((3, k), order="F"), t)
    A2 = _cross_rows(e2, Nt, np.empty((3, k), order="F"), t)
    return np.einsum("ij,ij->i", Nt.T, cross), A1, A2


def pull_terms(rest: np.ndarray, triangles: np.ndarray,
               edges: np.ndarray | Callable[[], np.ndarray] | None = None) -> dict:
    r"""What :func:`skin_scale` needs of the rest skin ``(n, 3)``, ``(m, 3)``, computed once:
    the corners as rows ``(3, m)``, :math:`N / |N|^2` and the rows
    :math:`A_1 = N \times e_1 / |N|^2`, :math:`A_2 = e_2 \times N / |N|^2` (so that
    :math:`b = \delta_2 \cdot A_1 + \delta_1 \cdot A_2`), each ``(3, m)``; the skin's edges
    ``(e, 2)`` (each sorted, and sorted by first end, then second: the order of a sparse
    matrix's rows) and their rest lengths ``(e,)``. ``edges``: the skin's unique edges sorted
    (``TriangleSurface.edges``), when at hand, or a function giving them.

    The edges and their lengths are needed only where a pull is limited (the search of
    :func:`skin_scale`), so unless given as an array they are found the first time they
    are (:func:`_terms_edges`): a frame no guard acts on, on a skin of its own (a refined
    frame's), never pays for them. The rows :math:`N`, :math:`A_1`, :math:`A_2` likewise
    (:func:`_terms_rows`): a frame asks for those of its pulled triangles only
    (:func:`_triangles_of`), each triangle's computed alone, the same bit for bit.
    """
    rest = np.asarray(rest, dtype=float)
    tri = np.asarray(triangles, dtype=np.intp)
    corners = np.ascontiguousarray(tri.T)
    terms = {"corners": corners, "rest": rest, "edges_of": edges}
    if edges is not None and not callable(edges):
        _terms_edges(terms)
    return terms


def _terms_rows(terms: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(3, m)`` thrice: :math:`N / |N|^2`, :math:`A_1`, :math:`A_2` of every triangle of
    :func:`pull_terms` ``terms``, computed on first use and kept in ``terms``.
    """
    if "N" not in terms:
        terms["N"], terms["A1"], terms["A2"] = _row_terms(terms["rest"], terms["corners"])
    return terms["N"], terms["A1"], terms["A2"]


def _quadratic(pull_t: np.ndarray, corners: np.ndarray, N: np.ndarray, A1: np.ndarray,
               A2: np.ndarray, f: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    r"""``(k,)`` twice: :math:`b` and :math:`c` of :math:`\sigma_t(s) = 1 + b s + c s^2` for
    the pull ``(3, n)``, times the factors ``f`` ``(n,)`` when given, on the triangles
    ``corners`` ``(3, k)`` (their :func:`_row_terms`).
    """
    def at(c: np.ndarray) -> np.ndarray:  # f: the products of (pull_t * f)[:, c]
        p = np.take(pull_t, c, axis=1)
        if f is not None:
            p *= np.take(f, c)
        return p

    p0 = at(corners[0])
    d1 = at(corners[1])
    d1 -= p0
    d2 = at(corners[2])
    d2 -= p0
    del p0
    b = (d2 * A1).sum(axis=0) + (d1 * A2).sum(axis=0)
    c = (N[0] * (d1[1] * d2[2] - d1[2] * d2[1]) + N[1] * (d1[2] * d2[0] - d1[0] * d2[2])
         + N[2] * (d1[0] * d2[1] - d1[1] * d2[0]))
    return b, c


def _lowest_sigma(b: np.ndarray, c: np.ndarray, top: float) -> np.ndarray:
    r"""``(k,)``: the least :math:`\sigma_t(s) = 1 + b s + c s^2` over :math:`s \in [0, top]`
    (:func:`skin_scale` compares it with ``min_area`` as it is from the rest skin, where
    :math:`\sigma_t(0) = 1`: adding :math:`\sigma_t(0) - 1 = 0` would change no comparison).
    """
    low = 1.0 + b * top + c * top * top
    up = np.flatnonzero(c > 0)  # only a convex one dips inside: the vertex -b / 2c there
    bu, cu = np.take(b, up), np.take(c, up)
    vertex = -bu / (2.0 * cu)
    inside = np.flatnonzero((vertex > 0) & (vertex < top))
    bi, ci = np.take(bu, inside), np.take(cu, inside)
    at = np.take(up, inside)
    low[at] = np.minimum(np.take(low, at), 1.0 - bi * bi / (4.0 * ci))
    return low


_GRAPH_CACHE_EDGES = 1 << 20  # skins with more edges build their graph per frame, small


def _edge_graph(size: np.ndarray, terms: dict, reach: float) -> dict:
    r"""The graph :func:`_limits` searches, for the pulls' lengths ``size`` ``(n,)``: edges
    ``a``, ``b``, their rest ``length`` and weights ``w`` ``(e,)``,
    :math:`|x_v - x_w| / (\text{reach} \max(|p_v|, |p_w|))` (``inf``, no path, where
    neither end is pulled), kept up to date by :func:`_reweigh` as the factors change; and
    ``mat``, a CSR matrix ``(n + 1, n + 1)`` of those weights, each edge both ways, with a
    last row, the source, joined to every vertex (its weights, the last ``n`` entries, are
    set by each search; ``inf``, no edge, where unused).

    The edges are all the skin's, and the matrix's structure (:func:`_edge_structure`) is
    built once per skin and kept in ``terms``, up to :data:`_GRAPH_CACHE_EDGES` edges; a
    larger skin takes only its edges with a pulled end, structured for this frame (what is
    kept would outweigh the frame). Either way a path runs only through pulled edges.
    """
    e, length = _terms_edges(terms)  # sorted (pull_terms)
    live = np.flatnonzero(np.maximum(size[e[:, 0]], size[e[:, 1]]) > 0)
    if len(e) <= _GRAPH_CACHE_EDGES:
        st = terms.get("edge_structure")
        if st is None:
            st = terms["edge_structure"] = _edge_structure(e, len(size))
        graph: dict[str, Any] = {"a": e[:, 0], "b": e[:, 1], "length": length,
                                 "w": np.full(len(e), np.inf)}
    else:
        st = _edge_structure(e[live], len(size))
        graph = {"a": e[live, 0], "b": e[live, 1], "length": length[live]}
        live = np.arange(len(live))
        graph["w"] = np.empty(len(live))
    graph.update(reach=reach, slot=st["slot"], slots=st["slots"], indptr=st["indptr"])
    graph["w"][live] = _weights(graph, live, size)
    data = np.full(len(st["indices"]), np.inf)
    data[st["slots"][0, live]] = graph["w"][live]
    data[st["slots"][1, live]] = graph["w"][live]
    graph["mat"] = sp.csr_matrix((data, st["indices"], st["indptr"]),
                                 shape=(len(size) + 1, len(size) + 1), copy=False)
    return graph


def _edge_structure(edges: np.ndarray, n: int) -> dict:
    """The structure of :func:`_edge_graph`'s matrix for the skin's ``edges`` ``(e, 2)`` on
    ``n`` vertices (each edge sorted, the edges by first end then second, as
    :func:`pull_terms` keeps them), once per skin: ``indices`` and ``indptr`` (each edge both
    ways, by row then column, then the source's row to every vertex), ``slot`` ``(2 e,)``,
    the edge of each stored entry, and ``slots`` ``(2, e)``, the two entries of each edge.
    Row v holds the edges ending at v (columns below v, in the order of a stable sort of the
    second ends) and then those starting there (columns above v, already in order): one
    counting sort of ``e`` keys (:func:`_by_second_end`).
    """
    a, b = edges[:, 0], edges[:, 1]
    m = len(a)
    index = np.int32 if n < 2**31 - 2 and 2 * m + n < 2**31 - 1 else np.intp
    into, out_ = np.bincount(b, minlength=n), np.bincount(a, minlength=n)
    indptr = np.concatenate([[0], np.cumsum(into + out_), [2 * m + n]])
    ids = np.arange(m)
    by_b = _by_second_end(a, b, out_, n)  # ends at v: grouped by v, then by first end
    first_in = np.cumsum(into) - into
    rev = np.empty(m, dtype=np.intp)
    rev[by_b] = indptr[b[by_b]] + ids - first_in[b[by_b]]
    fwd = indptr[a] + into[a] + ids - (np.cumsum(out_) - out_)[a]
    indices = np.empty(2 * m + n, dtype=index)
    indices[rev], indices[fwd], indices[2 * m:] = a, b, np.arange(n)
    slot = np.empty(2 * m, dtype=index)
    slot[rev], slot[fwd] = ids, ids
    return {"indices": indices, "indptr": indptr.astype(index), "slot": slot,
            "slots": np.stack([fwd, rev]).astype(index)}


def _by_second_end(a: np.ndarray, b: np.ndarray, out_: np.ndarray, n: int) -> np.ndarray:
    """``(e,)``: the edges ``a``, ``b`` ``(e,)`` (sorted by first end, then second) ordered
    by second end, stably: ``np.argsort(b, kind="stable")``, found as the transpose of the
    CSR matrix whose row ``v`` holds the edges starting at ``v`` (``out_`` ``(n,)`` of them;
    their ids as values), a counting sort that keeps each column's entries in row order.
    """
    indptr = np.concatenate([[0], np.cumsum(out_)])
    ids = np.arange(len(a))
    return sp.csr_matrix((ids, b, indptr), shape=(n, n)).tocsc().data.astype(np.intp,
                                                                              copy=False)


def _ranges(indptr: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """``(p,)``: the positions ``indptr[v]`` to ``indptr[v + 1]`` of every ``v`` in ``rows``
    ``(k,)``, one row's after another (the entries of those rows of a CSR structure).
    """
    lo, hi = indptr[rows].astype(np.intp), indptr[rows + 1].astype(np.intp)
    count = hi - lo
    ends = np.cumsum(count)
    return np.arange(int(ends[-1]) if len(ends) else 0) + np.repeat(lo - (ends - count), count)


def _distinct(ids: np.ndarray, size: int) -> np.ndarray:
    """``(q,)``: the distinct values of ``ids`` ``(p,)`` (in ``[0, size)``) ascending, by a
    mark over ``size`` (a memset and a scan of bytes: several times faster than
    ``np.unique``'s hashing or sorting, even for few ``ids``).
    """
    mark = np.zeros(size, bool)
    mark[ids] = True
    return np.flatnonzero(mark)


def _weights(graph: dict, j: np.ndarray, lift_of: np.ndarray) -> np.ndarray:
    """``(k,)``: the weights of the edges ``j`` ``(k,)`` of ``graph`` for the pulls' lengths
    ``lift_of`` ``(n,)`` (``inf``, no path through it, where both ends' pulls are 0).
    """
    lift = np.maximum(lift_of[graph["a"][j]], lift_of[graph["b"][j]])
    with np.errstate(divide="ignore"):
        return np.maximum(graph["length"][j] / (graph["reach"] * lift), 1e-300)


def _reweigh(graph: dict, changed: np.ndarray, lift_of: np.ndarray) -> None:
    """Update ``graph``'s weights in place on the edges with an end in ``changed`` ``(k,)``
    (vertices whose pulls' lengths ``lift_of`` ``(n,)`` just changed), found through the
    graph's rows (the work goes with the changed vertices, not with the skin: each edge
    once, ascending, :func:`_distinct`).
    """
    at = _ranges(graph["indptr"], changed)
    j = _distinct(np.take(graph["slot"], at), len(graph["w"]))
    w = _weights(graph, j, lift_of)
    graph["w"][j] = w
    data = graph["mat"].data
    data[np.take(graph["slots"][0], j)] = w
    data[np.take(graph["slots"][1], j)] = w


def _limits(s_star: np.ndarray, corners: np.ndarray, graph: dict, top: float,
            local: bool = False) -> np.ndarray:
    r"""``(n,)``: :math:`F_v`, the least over bad triangles :math:`t` (``corners``
    ``(k, 3)``, their :math:`s^*_t` ``(k,)``) of :math:`s^*_t` plus the shortest path from
    :math:`t` to :math:`v` along the skin's edges, an edge :math:`vw` weighing
    :math:`|x_v - x_w| / (\text{reach} \max(|p_v|, |p_w|))` for the pulls' lengths
    :math:`|p|` (the edges and weights of :func:`_edge_graph` ``graph``); ``inf`` beyond
    ``top`` and wherever no pull connects :math:`v` to a bad triangle.

    With ``local`` (a search expected to settle few vertices), :func:`_local_limits` tries
    first; past its budget, or without ``local``, scipy's search over the whole matrix. Both
    give the same array, bit for bit (``docs/model.md``, the pull guard's small searches).
    """
    if local:
        got = _local_limits(s_star, corners, graph, top, _LOCAL_BUDGET)
        if got is not None:
            return got
    mat = graph["mat"]
    n = mat.shape[0] - 1
    least = mat.data[-n:] if n else mat.data[:0]  # the source's edges: a corner of
    least[:] = np.inf  # several bad triangles takes their least s*
    np.minimum.at(least, corners.ravel(), np.maximum(np.repeat(s_star, 3), 1e-12))
    dist = csgraph.dijkstra(mat, directed=True, indices=n, limit=top)
    return dist[:n]


_LOCAL_BUDGET = 64  # a round's search that settles at most this many vertices runs here


def _local_limits(s_star: np.ndarray, corners: np.ndarray, graph: dict, top: float,
                  budget: int) -> np.ndarray | None:
    r"""``(n,)``: :func:`_limits`'s :math:`F` by Dijkstra's search in Python from the bad
    triangles' corners (``corners`` ``(k, 3)``, :math:`s^*_t` ``(k,)``) over ``graph``'s
    matrix rows, or None once it would settle more than ``budget`` vertices. Each corner
    starts at the least :math:`\max(s^*_t, 10^{-12})` of its triangles (``np.minimum.at``,
    as :func:`_limits`'s source row), a vertex is reached by :math:`d_u + w_{ux}` (the same
    IEEE sums) only where that is at most ``top`` (scipy's ``limit``): the values are the
    least left-to-right sums over paths, whatever the order of the search, so the same bits
    as scipy's search (``docs/model.md``); the cost goes with the vertices settled, not with
    the skin's ``n`` (a round with one bad triangle settles a handful).
    """
    n = graph["mat"].shape[0] - 1
    ids, inv = np.unique(corners.ravel(), return_inverse=True)
    least = np.full(len(ids), np.inf)
    np.minimum.at(least, inv.ravel(), np.maximum(np.repeat(s_star, 3), 1e-12))
    best = {v: d for v, d in zip(ids.tolist(), least.tolist(), strict=True)
            if d <= top}
    heap = [(d, v) for v, d in best.items()]
    heapq.heapify(heap)
    indptr, cols, w = graph["mat"].indptr, graph["mat"].indices, graph["mat"].data
    done: dict[int, float] = {}
    while heap:
        d, v = heapq.heappop(heap)
        if v in done:
            continue
        done[v] = d
        if len(done) > budget:
            return None
        lo, hi = int(indptr[v]), int(indptr[v + 1])
        for x, wx in zip(cols[lo:hi].tolist(), w[lo:hi].tolist(), strict=True):
            nd = d + wx
            if x not in done and nd <= top and nd < best.get(x, np.inf):
                best[x] = nd
                heapq.heappush(heap, (nd, x))
    out = np.full(n, np.inf)
    out[list(done)] = list(done.values())
    return out


def _pulled_triangles(terms: dict, moving: np.ndarray, base: np.ndarray,
                      start: np.ndarray | None) -> tuple:
    r"""The triangles of :func:`pull_terms` ``terms`` with a corner where ``moving``
    ``(n,)``: their ``rows`` ``(k,)``, ``corners`` ``(3, k)``, rest normals ``N`` ``(3, k)``
    and the terms :math:`\sigma_t(0)`, :math:`A_1`, :math:`A_2` of their signed areas
    (those of ``base`` when a ``start`` skin is given).
    """
    rows, corners, Nt, A1, A2 = _triangles_of(terms, moving, start is not None)
    if start is None:
        a0 = np.ones(len(rows))
    else:  # (the rest skin's A1, A2 not asked for: those of ``base`` replace them)
        a0, A1, A2 = _start_terms(Nt, base, corners)
    return rows, corners, Nt, a0, A1, A2


def _columns(a: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """``(3, k)``, column-major: the columns ``rows`` ``(k,)`` of ``a`` ``(3, m)``, as
    ``a[:, rows]`` gives them (the same values and layout; a take and a copy, several times
    faster than the fancy index).
    """
    return np.asfortranarray(np.take(a, rows, axis=1))


_SUBSETS = 8  # the pulled regions a skin's terms remember (an expression's muscles, ...)
_SUBSET_BYTES = 1 << 24  # and at most this many bytes of them together


def _triangles_of(terms: dict, moving: np.ndarray, normals_only: bool = False) -> tuple:
    r"""The triangles of :func:`pull_terms` ``terms`` with a corner where ``moving``
    ``(n,)``: their ``rows`` ``(k,)`` and ``corners``, ``N``, ``A1``, ``A2`` ``(3, k)``
    (with ``normals_only``, ``A1`` and ``A2`` are None and not taken: a step from a skin
    of its own, :func:`_start_terms`, replaces them).

    Where more than three quarters of the triangles are pulled (a refined frame's fresh
    skin: then the wrinkle step's take theirs as well), every triangle's rows are found once
    (:func:`_terms_rows`, kept) and both take theirs (:func:`_columns`): cheaper than each
    computing its own, and the same values in the same layout.

    These depend on the rest skin and on which vertices move only, so they are kept in
    ``terms`` for the last few moving sets (a frame of the same muscles, at any
    activation, finds them there: :data:`_SUBSETS` of them, :data:`_SUBSET_BYTES` in all,
    the least recently used dropped first); every triangle: the terms themselves, not
    copies.
    """
    key = (normals_only, np.flatnonzero(moving).tobytes())
    memo = terms.setdefault("subsets", {})
    hit = memo.pop(key, None)
    if hit is not None:
        memo[key] = hit  # the most recent last
        return hit
    c0, c1, c2 = terms["corners"]
    rows = np.flatnonzero(moving[c0] | moving[c1] | moving[c2])
    names = ("corners", "N") if normals_only else ("corners", "N", "A1", "A2")
    if len(rows) == c0.shape[0]:
        hit = (rows, terms["corners"], *_terms_rows(terms))
    elif "N" in terms or 4 * len(rows) > 3 * c0.shape[0]:  # (most: every row, then taken)
        _terms_rows(terms)
        hit = (rows, *(_columns(terms[k], rows) for k in names))
    else:  # each triangle's terms alone: those of every triangle's, bit for bit, laid out
        corners = terms["corners"][:, rows]  # as taking them would (column-major: einsum's
        hit = (rows, corners,  # sums on their rows follow it)
               *_row_terms(terms["rest"], corners, normals_only, order="F"))
    hit = hit if len(hit) == 5 else (*hit, None, None)
    memo[key] = hit

    def size(entry: tuple) -> int:
        return sum(a.nbytes for a in entry if a is not None)

    while len(memo) > _SUBSETS or (memo and sum(map(size, memo.values())) > _SUBSET_BYTES):
        memo.pop(next(iter(memo)))  # (a subset larger than the budget is not kept at all)
    return hit


def skin_scale(rest: np.ndarray, deformed: np.ndarray, triangles: np.ndarray,
               min_area: float = 0.2, knee: float = 0.5, iterations: int = 20,
               reach: float = 4.0, terms: dict | None = None,
               start: np.ndarray | None = None) -> np.ndarray:
    r"""``(n,)`` in ``(0, 1]``: the factor on each vertex's pull ``deformed - rest``
    ``(n, 3)`` that keeps every triangle ``(m, 3)`` at :math:`\sigma_t \ge`
    ``min_area`` (module notes); exactly 1 where no triangle near the vertex comes within
    the knee (no triangle reaches ``min_area`` before the pull is :math:`1/\kappa` times
    what it is), and wherever the pull is too small to matter.

    Scaling one vertex's pull and not its neighbours' would shear the skin and turn other
    triangles over, so the factor varies slowly against the pull: a triangle :math:`t` whose
    pull may only go to :math:`s^*_t` bounds the vertices around it by
    :math:`F_v = \min_t \big(s^*_t + d_t(v)\big)`, :math:`d_t(v)` the shortest path from
    :math:`t` to :math:`v` along edges weighing :math:`|x_v - x_w| / (\text{reach}
    \max(|p_v|, |p_w|))` (so that :math:`|F_v - F_w| \max(|p_v|, |p_w|) \le |x_v - x_w| /`
    ``reach`` on every edge: the shear the factor adds stays below 1 / ``reach``, and the
    bound grows fast where the pull fades: the guard stays where the pulls are), and the
    factor is :func:`soft_clamp` of 1 below :math:`F_v`. The step is repeated
    ``iterations`` times on the scaled pull (the factors only decrease). Only the
    triangles with a pulled corner are looked at, and of a pull from the rest skin first
    only those that are not cold (:func:`_cold_pass`). ``terms``: :func:`pull_terms` of
    the rest skin, when cached. ``start`` ``(n, 3)``: a skin the step begins from (default
    ``rest``): the step is then ``deformed - start``, and :math:`\sigma_t(s) = \sigma_t(0)
    + b s + c s^2` is still the signed area along the *rest* normal relative to the rest
    area: a chain of steps guarded so never turns a triangle over against the rest skin.
    """
    rest = np.asarray(rest, dtype=float)
    if terms is None:
        terms = pull_terms(rest, triangles)
    base = rest if start is None else np.asarray(start, dtype=float)
    pull_t = np.ascontiguousarray((np.asarray(deformed, dtype=float) - base).T)
    f = np.ones(len(rest))
    size = np.sqrt((pull_t * pull_t).sum(axis=0))
    top = 1.0 / knee
    if start is None and _cold_pass(terms, pull_t, size, min_area, top):
        return f  # (the exact check below would find no triangle below min_area either)
    rows, corners, Nt, a0, A1, A2 = _pulled_triangles(terms, size > 0, base, start)
    if not len(rows):
        return f
    b, c = _quadratic(pull_t, corners, Nt, A1, A2)
    low = _lowest_sigma(b, c, top) if start is None else a0 - 1.0 + _lowest_sigma(b, c, top)
    return _rounds(f, pull_t, size, terms, corners, (Nt, A1, A2, a0), b, c, low,
                   (min_area, knee, iterations, reach))


def _rounds(f: np.ndarray, pull_t: np.ndarray, size: np.ndarray, terms: dict,
            corners: np.ndarray, rows_terms: tuple, b: np.ndarray, c: np.ndarray,
            low: np.ndarray, knobs: tuple) -> np.ndarray:
    r""":func:`skin_scale`'s steps on the pulled triangles ``corners`` ``(3, k)`` (their
    ``rows_terms``: ``N``, ``A1``, ``A2`` ``(3, k)`` and :math:`\sigma_t(0)` ``(k,)``; their
    :math:`b`, :math:`c` and least signed areas ``low`` ``(k,)`` of the pull ``pull_t``
    ``(3, n)``, lengths ``size`` ``(n,)``): the factors ``f`` ``(n,)``, scaled in place and
    returned. ``knobs``: ``min_area``, ``knee``, ``iterations``, ``reach``.

    What a step changes is found through the changed vertices: the scaled pull
    :math:`f p` and its lengths :math:`f |p|` are kept (each vertex's product as it was
    computed whole), the changed triangles' terms are taken together as rows once many
    change (:func:`_redo_rows`) and the changed edges through the graph's rows: the same
    values bit for bit.
    """
    min_area, knee, iterations, reach = knobs
    top = 1.0 / knee
    a0 = rows_terms[3]
    graph = None  # the edges' weights, built only when a triangle is bad
    packed: dict[str, np.ndarray] = {}  # the terms as rows, once many change (_redo_rows)
    reached = 0  # the last round's vertices below top: a small one searches locally
    for _ in range(iterations):
        bad = np.flatnonzero(low < min_area)
        if not len(bad):
            break
        if graph is None:
            graph = _edge_graph(size, terms, reach)
            scaled, lift = pull_t.copy(), size.copy()
        s_star = _first_root(np.maximum(a0[bad] - min_area, 1e-12), b[bad], c[bad])
        local = 2 * max(reached, 3 * len(bad)) <= _LOCAL_BUDGET
        limit = _limits(s_star, corners[:, bad].T, graph, top, local)
        near = np.flatnonzero(limit < top)
        reached = len(near)
        step = soft_clamp(np.ones(len(near)), limit[near], knee)
        if np.all(step == 1.0):
            break
        f[near] *= step
        changed = near[step != 1.0]
        moved = np.take(f, changed)
        scaled[:, changed] = np.take(pull_t, changed, axis=1) * moved
        lift[changed] = moved * np.take(size, changed)
        _update(b, c, low, scaled, changed, corners, rows_terms, top, packed)
        _reweigh(graph, changed, lift)
    return f


_COLD_MARGIN = 1e-9  # the cold bound's room for the exact check's rounding (docs/model.md)


def _cold_limits(terms: dict, min_area: float, top: float) -> np.ndarray:
    r"""``(n,)``: at each vertex the least :math:`\tau_t` of the triangles around it, of
    :func:`pull_terms` ``terms`` (``inf`` on no triangle): where each corner's pull is at
    most :math:`\tau_t` long, :math:`\sigma_t(s) \ge`
    ``min_area`` :math:`+ \mu` on :math:`[0, top]` (``docs/model.md``, "The cold
    triangles"). With :math:`d_i = p_i - p_0`, :math:`|d_i| \le 2\tau`, so
    :math:`|b| \le 2\tau \alpha_t`, :math:`\alpha_t = |A_1| + |A_2|`, and
    :math:`|c| \le 4\tau^2 \nu_t`, :math:`\nu_t = |N / |N|^2|`; :math:`\tau_t` is the
    positive root of :math:`4\,top^2 \nu_t \tau^2 + 2\,top\,\alpha_t \tau =
    1 - \sigma_{\min} - \mu`, lowered by :math:`10^{-6}` relative (``inf`` for a triangle
    with no area: its :math:`b = c = 0`). Rest-only: kept in ``terms`` per
    ``(min_area, top)``.
    """
    key = ("cold_limits", float(min_area), float(top))
    got = terms.get(key)
    if got is None:
        N, A1, A2 = _terms_rows(terms)
        alpha = np.sqrt((A1 * A1).sum(axis=0)) + np.sqrt((A2 * A2).sum(axis=0))
        alpha *= 2.0 * top * (1.0 + 1e-9)
        nu = np.sqrt((N * N).sum(axis=0))
        nu *= 4.0 * top * top * (1.0 + 1e-9)
        room = 1.0 - min_area - _COLD_MARGIN
        with np.errstate(divide="ignore", invalid="ignore"):
            tau = 2.0 * room / (alpha + np.sqrt(alpha * alpha + 4.0 * nu * room))
        tau = np.where(alpha > 0, tau * (1.0 - 1e-6), np.inf)
        got = terms[key] = np.full(len(terms["rest"]), np.inf)  # per vertex: the least
        np.minimum.at(got, terms["corners"].ravel(), np.tile(tau, 3))  # of its triangles'
    return got


def _cold_pass(terms: dict, pull_t: np.ndarray, size: np.ndarray, min_area: float,
               top: float) -> bool:
    r"""Whether :func:`skin_scale`'s exact check of the pull ``pull_t`` ``(3, n)`` (the
    lengths ``size`` ``(n,)``) from the rest skin finds no triangle below ``min_area``,
    shown without looking at the *cold* triangles, those whose corners' pulls are all at
    most :func:`_cold_limits` long (they cannot be below it): the exact check runs on the
    others alone (the same values, bit for bit, as on every triangle). False where that
    check finds one, and where ``terms`` has not yet computed every triangle's rows (an
    earlier frame pulled every triangle, the physical skin's, whose solve moves every
    vertex by at least its rounding, or three quarters of them), or where the pull is
    local (it moves at most half the skin's vertices, the geometric skin's, or fewer than
    half of those it moves are cold:
    then the exact check over the pulled triangles, kept per moving set, is as cheap):
    then the exact check decides.
    """
    if "N" not in terms:
        return False
    moving = np.count_nonzero(size)
    if 2 * moving <= len(size):  # (a local pull: no limits built)
        return False
    warm = ~(size <= _cold_limits(terms, min_area, top))  # (a NaN pull is warm)
    count = np.count_nonzero(warm)
    if not count:
        return True
    if 2 * count >= moving:  # (mostly warm)
        return False
    c0, c1, c2 = terms["corners"]
    hot = np.flatnonzero(warm[c0] | warm[c1] | warm[c2])
    N, A1, A2 = (np.take(terms[k], hot, axis=1) for k in ("N", "A1", "A2"))  # (takes: the
    b, c = _quadratic(pull_t, np.take(terms["corners"], hot, axis=1), N, A1, A2)  # same bits)
    return not bool((_lowest_sigma(b, c, top) < min_area).any())


def _packed(corners: np.ndarray, rows_terms: tuple) -> tuple[np.ndarray, np.ndarray]:
    r"""``(k, 3)`` and ``(k, 10)``: the triangles ``corners`` ``(3, k)`` and their
    ``rows_terms`` (``N``, ``A1``, ``A2`` ``(3, k)``, :math:`\sigma_t(0)` ``(k,)``) as rows,
    C-ordered: one take of rows gathers all a triangle's terms (:func:`_update`).
    """
    Nt, A1, A2, a0 = rows_terms
    return (np.ascontiguousarray(corners.T),
            np.ascontiguousarray(np.vstack([Nt, A1, A2, a0[None]]).T))


def _redo_rows(redo: np.ndarray, corners: np.ndarray, rows_terms: tuple, cache: dict
               ) -> tuple[np.ndarray, ...]:
    r"""``(3, r)`` four times, then ``(r,)``: the corners, ``N``, ``A1``, ``A2`` and
    :math:`\sigma_t(0)` of the triangles ``redo`` ``(r,)`` of ``corners`` ``(3, k)`` (their
    ``rows_terms``, ``(3, k)`` thrice and ``(k,)``), indexed column by column, or, once a
    round asks for more than an eighth of them, from rows packed then and kept in ``cache``
    (:func:`_packed`: one take of rows; the same values).
    """
    if "rows" not in cache and 8 * len(redo) > corners.shape[1]:
        cache["corners"], cache["rows"] = _packed(corners, rows_terms)
    if "rows" not in cache:  # (indexing: a take of a column-major array copies it first)
        return (corners[:, redo], *(t[..., redo] for t in rows_terms))
    rows = np.take(cache["rows"], redo, axis=0).T  # (10, r)
    return np.take(cache["corners"], redo, axis=0).T, rows[0:3], rows[3:6], rows[6:9], rows[9]


def _update(b: np.ndarray, c: np.ndarray, low: np.ndarray, scaled: np.ndarray,
            changed: np.ndarray, corners: np.ndarray, rows_terms: tuple, top: float,
            cache: dict) -> None:
    r"""Recompute in place :math:`b`, :math:`c` and the least signed area over the clamp's
    range, ``low`` (``(k,)`` each), of the triangles ``corners`` ``(3, k)`` with a corner
    in ``changed`` (vertices whose factor just changed), for the scaled pull ``scaled``
    ``(3, n)`` (the pull times the factors); ``rows_terms``: their ``N``, ``A1``, ``A2``
    ``(3, k)`` and :math:`\sigma_t(0)` ``(k,)``, taken by :func:`_redo_rows` (``cache``).
    The others' terms are the same as before, bit for bit.
    """
    mark = np.zeros(scaled.shape[1], bool)
    mark[changed] = True
    c0, c1, c2 = corners
    redo = np.flatnonzero(mark[c0] | mark[c1] | mark[c2])
    rc, Nt, A1, A2, a0 = _redo_rows(redo, corners, rows_terms, cache)
    rb, rq = _quadratic(scaled, rc, Nt, A1, A2)
    b[redo], c[redo] = rb, rq
    low[redo] = a0 - 1.0 + _lowest_sigma(rb, rq, top)


def _first_root(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    r"""``(t,)``: the smallest :math:`s > 0` with :math:`a + b s + c s^2 = 0` (``a`` > 0),
    ``inf`` where there is none; ``a``, ``b``, ``c`` ``(t,)``: :math:`-a / b` where
    :math:`|c| \le 10^{-12} |b|` (linear), else the least positive of
    :math:`(-b \mp \sqrt{b^2 - 4 a c}) / 2c`. Both branches are evaluated on every entry and
    the right one is picked (fewer array calls than masking each: this runs once per
    iteration of :func:`skin_scale`).
    """
    a = np.broadcast_to(np.asarray(a, dtype=float), b.shape)
    lin = np.abs(c) <= 1e-12 * np.maximum(np.abs(b), 1e-300)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        disc = b * b - 4.0 * a * c
        ok = disc >= 0
        sq = np.sqrt(np.where(ok, disc, 0.0))
        c2 = 2.0 * c
        r1 = (-b - sq) / c2
        r2 = (-b + sq) / c2
        r1 = np.where(r1 > 0, r1, np.inf)
        r2 = np.where(r2 > 0, r2, np.inf)
        quad = np.where(ok, np.minimum(r1, r2), np.inf)
        linear = np.where(b < 0, -a / b, np.inf)
    return np.where(lin, linear, quad)
