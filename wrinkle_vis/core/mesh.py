"""Triangle surfaces as numpy arrays: validation, edges, adjacency, normals, welding."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order, connected_components
from scipy.spatial import cKDTree

from .certificate import _abs_cross, _apart_pairs, _clear_stars, _cross, _star_pairs

__all__ = ["MeshError", "MeshReport", "TriangleSurface", "barycentric_points", "block_pcg",
           "closest_on_triangles", "closest_points", "cotangent_laplacian", "occluded",
           "phong_midpoints", "ray_on_triangles", "self_intersections", "shape_operators",
           "smoothed_normals", "subdivide", "surface_coordinates", "tangent_bases",
           "triangle_normals", "two_level_preconditioner", "unit_rows", "vector_lengths"]


class MeshError(ValueError):
    """A mesh that cannot be used as it is; the message names the problem and the fix."""


@dataclass(frozen=True)
class MeshReport:
    """What is wrong, or merely notable, about a triangle surface.

    Attributes
    ----------
    degenerate_triangles : (k,) int
        Triangles with a repeated vertex or zero area.
    duplicate_triangles : (k,) int
        Triangles whose vertex set repeats an earlier triangle's.
    boundary_edges : (k, 2) int
        Edges used by one triangle only (an open surface has them; that is allowed).
    non_manifold_edges : (k, 2) int
        Edges used by three or more triangles.
    unused_vertices : (k,) int
        Vertices that no triangle uses.
    n_components : int
        Connected components of the triangle graph.
    consistently_oriented : bool
        Whether every interior edge is traversed once in each direction.
    """

    degenerate_triangles: np.ndarray
    duplicate_triangles: np.ndarray
    boundary_edges: np.ndarray
    non_manifold_edges: np.ndarray
    unused_vertices: np.ndarray
    n_components: int
    consistently_oriented: bool

    @property
    def ok(self) -> bool:
        """True when there is nothing to clean (boundaries are allowed)."""
        return not (
            len(self.degenerate_triangles)
            or len(self.duplicate_triangles)
            or len(self.non_manifold_edges)
            or len(self.unused_vertices)
        ) and self.consistently_oriented

    def __str__(self) -> str:
        parts = [
            f"{len(self.degenerate_triangles)} degenerate triangle(s)",
            f"{len(self.duplicate_triangles)} duplicate triangle(s)",
            f"{len(self.boundary_edges)} boundary edge(s)",
            f"{len(self.non_manifold_edges)} non-manifold edge(s)",
            f"{len(self.unused_vertices)} unused vertex(es)",
            f"{self.n_components} connected component(s)",
            "consistently oriented" if self.consistently_oriented else "NOT consistently oriented",
        ]
        return ", ".join(parts)


def _as_points(points) -> np.ndarray:
    arr = np.array(points, dtype=float, copy=True)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise MeshError(f"points must have shape (n, 3); got {arr.shape}")
    bad = ~np.isfinite(arr).all(axis=1)
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise MeshError(
            f"{int(bad.sum())} point(s) have non-finite coordinates (first: point {first} = "
            f"{arr[first].tolist()}); repair or remove those vertices before loading the mesh"
        )
    arr.setflags(write=False)
    return arr


def _as_triangles(triangles, n_points: int) -> np.ndarray:
    tri = np.asarray(triangles)
    if tri.ndim != 2 or tri.shape[1] != 3:
        raise MeshError(
            f"triangles must have shape (m, 3); got {tri.shape}. Triangulate polygons first"
        )
    if tri.size and not np.issubdtype(tri.dtype, np.integer):
        if not np.all(np.mod(tri, 1) == 0):
            raise MeshError("triangle indices must be integers")
    tri = np.array(tri, dtype=np.int64, copy=True)
    if len(tri) == 0:
        raise MeshError("the surface has no triangles")
    bad = (tri < 0) | (tri >= n_points)
    if bad.any():
        first = int(np.flatnonzero(bad.any(axis=1))[0])
        raise MeshError(
            f"{int(bad.any(axis=1).sum())} triangle(s) index vertices outside 0..{n_points - 1} "
            f"(first: triangle {first} = {tri[first].tolist()}); the index array does not "
            "belong to these points"
        )
    tri.setflags(write=False)
    return tri


@dataclass(frozen=True, eq=False)
class TriangleSurface:
    """An immutable triangle surface.

    Parameters
    ----------
    points : (n, 3) array_like of float
        Vertex positions; every coordinate must be finite.
    triangles : (m, 3) array_like of int
        Vertex indices of each triangle, counter-clockwise seen from outside.

    Raises
    ------
    MeshError
        For wrong shapes, non-finite coordinates or indices out of range. Degenerate and
        duplicate triangles, boundaries and non-manifold edges are not errors here; see
        :meth:`report` and :meth:`cleaned`.
    """

    points: np.ndarray
    triangles: np.ndarray

    def __post_init__(self):
        pts = _as_points(self.points)
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "triangles", _as_triangles(self.triangles, len(pts)))

    @classmethod
    def _derived(cls, points: np.ndarray, triangles: np.ndarray) -> TriangleSurface:
        """A surface the library derived from a valid one (finite float ``(n, 3)``
        ``points``, int64 ``(m, 3)`` ``triangles`` indexing them), taken as it is, without
        the checks and copies of the constructor; the arrays become read-only.
        """
        surface = object.__new__(cls)
        for name, value in (("points", points), ("triangles", triangles)):
            value.setflags(write=False)
            object.__setattr__(surface, name, value)
        return surface

    @property
    def n_points(self) -> int:
        """Number of vertices."""
        return len(self.points)

    @property
    def n_triangles(self) -> int:
        """Number of triangles."""
        return len(self.triangles)

    def with_points(self, points) -> TriangleSurface:
        """The same connectivity on other positions, ``(n, 3)``."""
        pts = np.asarray(points, dtype=float)
        if pts.shape != self.points.shape:
            raise MeshError(f"points must have shape {self.points.shape}; got {pts.shape}")
        return TriangleSurface(pts, self.triangles)

    # ------------------------------------------------------------------ topology
    @cached_property
    def _directed_edges(self) -> np.ndarray:
        t = self.triangles
        return np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])

    @cached_property
    def _edge_inverse(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        d = self._directed_edges
        lo, hi = np.minimum(d[:, 0], d[:, 1]), np.maximum(d[:, 0], d[:, 1])
        n = np.int64(max(self.n_points, 1))
        # one int64 key per edge sorts in the same (lo, hi) order as rows, much faster
        keys, inverse, counts = np.unique(lo.astype(np.int64) * n + hi, return_inverse=True,
                                          return_counts=True)
        edges = np.stack([keys // n, keys % n], axis=1).astype(d.dtype)
        return edges, inverse.ravel(), counts

    @cached_property
    def edges(self) -> np.ndarray:
        """``(e, 2) int``: unique undirected edges, each as ``(i, j)`` with ``i < j``."""
        edges = self._edge_inverse[0]
        edges.setflags(write=False)
        return edges

    @cached_property
    def triangle_edges(self) -> np.ndarray:
        """``(m, 3) int``: edge ids of each triangle's edges (01, 12, 20)."""
        return self._edge_inverse[1].reshape(3, -1).T.copy()

    @cached_property
    def rest_edge_lengths(self) -> np.ndarray:
        """``(e,) float``: length of each edge at these positions."""
        e = self.edges
        return np.linalg.norm(self.points[e[:, 1]] - self.points[e[:, 0]], axis=1)

    @cached_property
    def mean_edge_length(self) -> float:
        """The mean of :attr:`rest_edge_lengths`."""
        return float(np.mean(self.rest_edge_lengths))

    @cached_property
    def adjacency(self) -> sp.csr_matrix:
        """``(n, n)`` symmetric sparse vertex adjacency (1 where an edge joins two vertices)."""
        e = self.edges
        n = self.n_points
        data = np.ones(2 * len(e))
        rows = np.concatenate([e[:, 0], e[:, 1]])
        cols = np.concatenate([e[:, 1], e[:, 0]])
        return sp.csr_matrix((data, (rows, cols)), shape=(n, n))

    @cached_property
    def incidence(self) -> sp.csr_matrix:
        """``(n, m)`` sparse vertex-triangle incidence (1 where a vertex is a corner)."""
        m = self.n_triangles
        rows = self.triangles.ravel()
        cols = np.repeat(np.arange(m), 3)
        return sp.csr_matrix((np.ones(3 * m), (rows, cols)), shape=(self.n_points, m))

    @cached_property
    def kdtree(self) -> cKDTree:
        """A ``scipy.spatial.cKDTree`` of the vertices (built on first use)."""
        return cKDTree(self.points)

    # ------------------------------------------------------------------ geometry
    @cached_property
    def _corners(self) -> np.ndarray:
        return np.ascontiguousarray(self.triangles.T)

    def face_normals(self, points=None) -> np.ndarray:
        """``(m, 3)``: triangle normals scaled by twice the area, at ``points`` (or rest)."""
        p = self.points if points is None else np.asarray(points, dtype=float)
        return triangle_normals(np.ascontiguousarray(p.T), self._corners)

    def vertex_normals(self, points=None) -> np.ndarray:
        r"""``(n, 3)``: unit area-weighted vertex normals at ``points`` (or the rest points).

        .. math:: n_i = \frac{\sum_{t \ni i} (b_t - a_t) \times (c_t - a_t)}
                              {\left\|\sum_{t \ni i} (b_t - a_t) \times (c_t - a_t)\right\|}

        They point outwards for an outward-oriented surface (see :meth:`oriented`). A vertex
        whose summed normal vanishes gets a zero vector.
        """
        return unit_rows(self.incidence @ self.face_normals(points))

    def signed_volume(self) -> float:
        """Signed enclosed volume; positive for an outward orientation of a closed surface."""
        p = self.points - self.points.mean(axis=0)
        t = self.triangles
        return float(np.einsum("ij,ij->", p[t[:, 0]], np.cross(p[t[:, 1]], p[t[:, 2]])) / 6.0)

    def triangle_areas(self) -> np.ndarray:
        """``(m,)``: area of each triangle."""
        return 0.5 * np.linalg.norm(self.face_normals(), axis=1)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``((3,), (3,))``: lower and upper corner of the bounding box."""
        return self.points.min(axis=0), self.points.max(axis=0)

    # ------------------------------------------------------------------ checks
    def report(self) -> MeshReport:
        """Everything :class:`MeshReport` lists, computed without raising."""
        t = self.triangles
        repeated = (t[:, 0] == t[:, 1]) | (t[:, 1] == t[:, 2]) | (t[:, 0] == t[:, 2])
        degenerate = np.flatnonzero(repeated | (self.triangle_areas() <= 0.0))
        _, first = np.unique(np.sort(t, axis=1), axis=0, return_index=True)
        duplicate = np.setdiff1d(np.arange(len(t)), first)
        edges, inverse, counts = self._edge_inverse
        used = np.zeros(self.n_points, bool)
        used[t.ravel()] = True
        n_comp = connected_components(self._triangle_graph(), directed=False)[0]
        return MeshReport(
            degenerate_triangles=degenerate,
            duplicate_triangles=duplicate,
            boundary_edges=edges[counts == 1],
            non_manifold_edges=edges[counts > 2],
            unused_vertices=np.flatnonzero(~used),
            n_components=int(n_comp),
            consistently_oriented=self._consistently_oriented(),
        )

    def _consistently_oriented(self) -> bool:
        d = self._directed_edges
        _, inverse, counts = self._edge_inverse
        forward = (d[:, 0] < d[:, 1]).astype(np.int64)
        n_forward = np.bincount(inverse, weights=forward, minlength=len(counts))
        interior = counts == 2
        return bool(np.all(n_forward[interior] == 1))

    def _triangle_graph(self) -> sp.csr_matrix:
        """``(m, m)`` adjacency of triangles that share an edge (manifold edges only)."""
        _, inverse, counts = self._edge_inverse
        m = self.n_triangles
        tri_of = np.tile(np.arange(m), 3)
        order = np.argsort(inverse, kind="stable")
        inv_sorted = inverse[order]
        tri_sorted = tri_of[order]
        pair = (inv_sorted[:-1] == inv_sorted[1:]) & (counts[inv_sorted[:-1]] == 2)
        a, b = tri_sorted[:-1][pair], tri_sorted[1:][pair]
        data = np.ones(2 * len(a))
        return sp.csr_matrix(
            (data, (np.concatenate([a, b]), np.concatenate([b, a]))), shape=(m, m)
        )

    # ------------------------------------------------------------------ repairs
    def welded(self, tolerance: float = 0.0) -> TriangleSurface:
        """Merge vertices closer than ``tolerance`` (identical ones at 0), e.g. UV seams.

        Returns
        -------
        TriangleSurface
            The welded surface; triangles that collapse are dropped, unused vertices too.
        """
        p = self.points
        if tolerance <= 0.0:
            _, first, label = np.unique(p, axis=0, return_index=True, return_inverse=True)
            label = label.ravel()
            new_points = p[first]
        else:
            pairs = cKDTree(p).query_pairs(tolerance, output_type="ndarray")
            graph = sp.coo_matrix(
                (np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(p), len(p))
            )
            n, label = connected_components(graph, directed=False)
            counts = np.bincount(label, minlength=n)
            new_points = np.zeros((n, 3))
            np.add.at(new_points, label, p)
            new_points /= counts[:, None]
        tri = label[self.triangles]
        keep = (tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 0] != tri[:, 2])
        return TriangleSurface(new_points, tri[keep]).without_unused()

    def without_unused(self) -> TriangleSurface:
        """The surface with vertices that no triangle uses removed."""
        used = np.zeros(self.n_points, bool)
        used[self.triangles.ravel()] = True
        if used.all():
            return self
        new_index = np.cumsum(used) - 1
        return TriangleSurface(self.points[used], new_index[self.triangles])

    def cleaned(self) -> TriangleSurface:
        """Drop degenerate and duplicate triangles, then unused vertices."""
        rep = self.report()
        drop = np.union1d(rep.degenerate_triangles, rep.duplicate_triangles)
        keep = np.setdiff1d(np.arange(self.n_triangles), drop)
        return TriangleSurface(self.points, self.triangles[keep]).without_unused()

    def largest_component(self) -> TriangleSurface:
        """The connected component (across manifold edges) with the most triangles."""
        n_comp, comp = connected_components(self._triangle_graph(), directed=False)
        if n_comp == 1:
            return self
        keep = comp == np.argmax(np.bincount(comp))
        return TriangleSurface(self.points, self.triangles[keep]).without_unused()

    def oriented(self) -> TriangleSurface:
        """Consistently oriented triangles, outward (positive signed volume) where closed.

        Each connected component is walked breadth first across manifold edges; a triangle
        is flipped when it traverses a shared edge in the same direction as its parent.
        """
        graph = self._triangle_graph()
        n_comp, comp = connected_components(graph, directed=False)
        tri = self.triangles.copy()
        flip = np.zeros(self.n_triangles, bool)
        for c in range(n_comp):
            seed = int(np.flatnonzero(comp == c)[0])
            order, pred = breadth_first_order(graph, seed, directed=False)
            for t in order[1:]:
                parent = pred[t]
                flip[t] = flip[parent] ^ _same_direction(tri[parent], tri[t])
        tri[flip] = tri[flip][:, ::-1]
        out = TriangleSurface(self.points, tri)
        if out.signed_volume() < 0:
            out = TriangleSurface(self.points, tri[:, ::-1])
        return out


def closest_points(surface: TriangleSurface, queries) -> np.ndarray:
    """``(k, 3)``: the closest point of ``surface`` to each of ``(k, 3)`` query points.

    Exact among the triangles around the few nearest vertices, which is the closest point
    on an even triangulation.
    """
    tri, bary = surface_coordinates(surface, queries)
    return barycentric_points(surface, tri, bary)


def surface_coordinates(surface: TriangleSurface, queries, exact: bool = False
                        ) -> tuple[np.ndarray, np.ndarray]:
    r"""Where on ``surface`` the closest points to ``queries`` lie, as triangles and weights.

    Parameters
    ----------
    surface : TriangleSurface
        The surface.
    queries : (k, 3) array_like
        Points anywhere.
    exact : bool
        False (the default): the closest point among the triangles around the four nearest
        vertices, which is the closest point on an even triangulation. True: the closest
        point of the whole surface, on any triangulation (see Notes).

    Returns
    -------
    triangles : (k,) int ndarray
        The triangle of each closest point.
    barycentric : (k, 3) float ndarray
        Its barycentric coordinates in that triangle (rows sum to 1). The same coordinates on
        a surface with the same triangles and moved points (:meth:`TriangleSurface.with_points`)
        carry a point from one to the other, e.g. from the deformed skin to the rest skin.

    Notes
    -----
    With ``exact``: if :math:`c` is the closest point and :math:`\delta` the distance to the
    best point found among the first candidates, the corner :math:`v` of :math:`c`'s
    triangle nearest to :math:`c` has :math:`|x - v| \le |x - c| + |c - v| \le \delta + L`
    (:math:`L` the longest edge), so the triangles around the vertices within
    :math:`\delta + L` of :math:`x` hold :math:`c`; they are searched wherever that ball
    holds a vertex the first candidates did not.
    """
    q = np.atleast_2d(np.asarray(queries, dtype=float))
    k = min(4, surface.n_points)
    far, near = surface.kdtree.query(q, k=k)
    near, far = np.atleast_2d(near), np.atleast_2d(far)
    best_tri = np.empty(len(q), dtype=np.intp)
    best = np.empty_like(q)
    for i, (point, verts) in enumerate(zip(q, near, strict=True)):
        best_tri[i], best[i] = _closest_around(surface, point, verts)
    if exact:
        _closest_exactly(surface, q, far[:, -1], best_tri, best)
    return best_tri, _barycentric(surface.points[surface.triangles[best_tri]], best)


def _closest_around(surface: TriangleSurface, point: np.ndarray, verts
                    ) -> tuple[int, np.ndarray]:
    """The triangle and closest point ``(3,)`` to ``point`` among the triangles around
    vertices ``verts``.
    """
    inc = surface.incidence  # row v's triangles read off the CSR arrays (a scipy row
    ptr, ids = inc.indptr, inc.indices  # slice per vertex cost 70 us: 5 s a head's skull)
    tris = np.unique(np.concatenate([ids[ptr[v]:ptr[v + 1]] for v in verts]))
    cand = _closest_on_triangles(point, surface.points[surface.triangles[tris]])
    j = int(np.argmin(np.linalg.norm(cand - point, axis=1)))
    return int(tris[j]), cand[j]


def _closest_exactly(surface: TriangleSurface, q: np.ndarray, kth: np.ndarray,
                     best_tri: np.ndarray, best: np.ndarray) -> None:
    r"""Search again, in place, the queries ``q`` ``(k, 3)`` whose ball of radius
    :math:`\delta + L` (:func:`surface_coordinates`' Notes) reaches past their farthest
    first candidate, at distance ``kth`` ``(k,)``.
    """
    reach = float(surface.rest_edge_lengths.max(initial=0.0))
    delta = np.linalg.norm(best - q, axis=1)
    again = np.flatnonzero(delta + reach > kth)
    if not len(again):
        return
    balls = surface.kdtree.query_ball_point(q[again], delta[again] + reach)
    for i, verts in zip(again, balls, strict=True):
        best_tri[i], best[i] = _closest_around(surface, q[i], verts)


def closest_on_triangles(surface: TriangleSurface, candidates,
                         point) -> tuple[int, np.ndarray]:
    """Where among triangles ``candidates`` ``(t,)`` of ``surface`` the point closest to
    ``point`` ``(3,)`` lies: its triangle and barycentric coordinates ``(3,)`` (summing to 1,
    each in ``[0, 1]``). One candidate: where a point picked on that triangle lies in it.
    """
    ids = np.atleast_1d(np.asarray(candidates, dtype=np.intp))
    p = np.asarray(point, dtype=float).reshape(3)
    corners = surface.points[surface.triangles[ids]]
    cand = _closest_on_triangles(p, corners)
    j = int(np.argmin(np.linalg.norm(cand - p, axis=1)))
    bary = np.clip(_barycentric(corners[j:j + 1], cand[j:j + 1])[0], 0.0, 1.0)
    return int(ids[j]), bary / bary.sum()


def ray_on_triangles(surface: TriangleSurface, candidates, origin,
                     direction) -> tuple[int, np.ndarray] | None:
    r"""Where the line through ``origin`` ``(3,)`` along ``direction`` ``(3,)`` meets the
    triangles ``candidates`` ``(t,)`` of ``surface`` nearest to ``origin``: the triangle and
    the barycentric coordinates ``(3,)`` of the hit; None if it meets none of them.

    Möller-Trumbore: :math:`o + s\,d = a + u\,(b - a) + v\,(c - a)` with
    :math:`u, v \ge 0,\ u + v \le 1` (a tolerance of :math:`10^{-9}` on the edges).
    """
    ids = np.atleast_1d(np.asarray(candidates, dtype=np.intp))
    o, d = np.asarray(origin, float).reshape(3), np.asarray(direction, float).reshape(3)
    det, u, v, s = _moller_trumbore(o, d, surface.points.take(
        surface.triangles.take(ids, axis=0), axis=0))
    tol = 1e-9
    hit = (np.abs(det) > 0) & (u >= -tol) & (v >= -tol) & (u + v <= 1 + tol)
    if not hit.any():
        return None
    j = int(np.flatnonzero(hit)[np.argmin(np.abs(s[hit]))])
    bary = np.clip(np.array([1.0 - u[j] - v[j], u[j], v[j]]), 0.0, 1.0)
    return int(ids[j]), bary / bary.sum()


def occluded(surface: TriangleSurface, points, direction, min_distance: float,
             triangles=None) -> np.ndarray:
    r"""``(k,) bool``: which of ``points`` ``(k, 3)`` have ``surface`` in front of them
    along ``direction`` ``(3,)``: the ray :math:`p + t\,d`, :math:`t >` ``min_distance``
    (a length: :math:`d` is ``direction`` normalized), meets one of its ``triangles``
    (default all). ``min_distance`` steps over the surface a point lies on or next to.

    The triangles are binned on a grid of the plane normal to ``direction`` (cells about one
    triangle across), so each ray is tested against the few triangles over its cell
    (Möller-Trumbore, as :func:`ray_on_triangles`).
    """
    p = np.atleast_2d(np.asarray(points, dtype=float))
    d = np.asarray(direction, dtype=float).reshape(3)
    d = d / np.linalg.norm(d)
    ids = np.arange(surface.n_triangles) if triangles is None else np.asarray(
        triangles, dtype=np.intp)
    if not len(p) or not len(ids):
        return np.zeros(len(p), bool)
    e1_axis = np.cross(d, [1.0, 0.0, 0.0] if abs(d[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1_axis /= np.linalg.norm(e1_axis)
    axes = np.stack([e1_axis, np.cross(d, e1_axis)])  # (2, 3): the plane normal to d
    puv = p @ axes.T
    over = _triangles_over(surface, ids, triangles is None, surface.points @ axes.T, puv)
    if over is None:
        return np.zeros(len(p), bool)
    corners, lo, hi = over
    query, pair_tri = _binned_pairs(lo, hi, puv)
    hit = _ray_hits(p[query], d, corners[pair_tri], min_distance)
    return np.bincount(query[hit], minlength=len(p)) > 0


def _triangles_over(surface: TriangleSurface, ids: np.ndarray, every: bool, uv: np.ndarray,
                    puv: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Of triangles ``ids`` (``every``: all the surface's, in order), those whose
    projection on a plane (their vertices there: ``uv`` ``(n, 2)``) overlaps the span of
    the rays' points there ``puv`` ``(k, 2)``: their corners ``(t, 3, 3)`` and bounding
    boxes' corners ``lo``, ``hi`` ``(t, 2)`` on the plane; None when none does.
    """
    # a triangle over the rays' span has its corners within an edge's length of it
    reach = 1.001 * float(surface.rest_edge_lengths.max(initial=0.0))
    lo, hi = puv.min(axis=0) - reach, puv.max(axis=0) + reach
    near = (uv[:, 0] >= lo[0]) & (uv[:, 0] <= hi[0]) & (uv[:, 1] >= lo[1]) & (uv[:, 1] <= hi[1])
    t = surface._corners if every else surface.triangles[ids].T  # (3, k)
    ids = ids[near[t[0]] & near[t[1]] & near[t[2]]]
    tris = surface.triangles[ids]
    a, b, c = uv[tris[:, 0]], uv[tris[:, 1]], uv[tris[:, 2]]
    lo, hi = np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c)
    over = ((hi >= puv.min(axis=0)) & (lo <= puv.max(axis=0))).all(axis=1)  # the rays' span
    if not over.any():
        return None
    return surface.points[tris[over]], lo[over], hi[over]


def _binned_pairs(lo: np.ndarray, hi: np.ndarray, puv: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The (ray, triangle) pairs to test: the triangles' bounding boxes ``lo``, ``hi``
    ``(t, 2)`` binned on a grid of cells about one triangle across, each ray's point
    ``puv`` ``(k, 2)`` paired with the triangles over its cell. Returns ``(p,)`` rays and
    ``(p,)`` triangles.
    """
    cell = max(float(np.median((hi - lo).max(axis=1))), 1e-12)
    origin = np.minimum(lo.min(axis=0), puv.min(axis=0))
    i0, i1 = (np.floor((b - origin) / cell).astype(np.int64) for b in (lo, hi))
    width = int(max(i1[:, 1].max(), np.floor((puv[:, 1] - origin[1]) / cell).max())) + 1
    # every (cell, triangle) pair of the triangles' bounding boxes
    spans = i1 - i0 + 1
    count = spans[:, 0] * spans[:, 1]
    tri = np.repeat(np.arange(len(lo)), count)
    k = np.arange(len(tri)) - np.repeat(np.cumsum(count) - count, count)
    cx = i0[tri, 0] + k // spans[tri, 1]
    cy = i0[tri, 1] + k % spans[tri, 1]
    key = cx * width + cy
    order = np.argsort(key, kind="stable")
    key, tri = key[order], tri[order]
    qc = np.floor((puv - origin) / cell).astype(np.int64)
    qkey = qc[:, 0] * width + qc[:, 1]
    start, stop = np.searchsorted(key, qkey), np.searchsorted(key, qkey, side="right")
    n = stop - start
    query = np.repeat(np.arange(len(puv)), n)
    return query, tri[np.repeat(start, n) + np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)]


def _ray_hits(origins: np.ndarray, d: np.ndarray, c: np.ndarray, min_distance: float
              ) -> np.ndarray:
    r"""``(p,) bool``: whether the ray :math:`o + t\,d`, :math:`t >` ``min_distance``, from
    each of ``origins`` ``(p, 3)`` meets its triangle of corners ``c`` ``(p, 3, 3)``
    (Möller-Trumbore).
    """
    det, u, v, dist = _moller_trumbore(origins, d, c)
    return (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (dist > min_distance)


def _cross_any(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    r"""``(..., 3)``: :math:`a \times b` of ``a`` and ``b`` ``(..., 3)`` (broadcast), the
    same products and differences as ``np.cross`` (so its values, bit for bit) without its
    general-axis handling: a ray test's few triangles pay for that overhead, not the work.
    """
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def _moller_trumbore(origins: np.ndarray, d: np.ndarray, c: np.ndarray
                     ) -> tuple[np.ndarray, ...]:
    r"""``(k,)`` four times: :math:`\det`, :math:`u`, :math:`v` and :math:`t` of the line
    :math:`o + t\,d = a + u\,(b - a) + v\,(c - a)` from ``origins`` ``(3,)`` or ``(k, 3)``
    along ``d`` ``(3,)`` through the triangles of corners ``c`` ``(k, 3, 3)``
    (Möller-Trumbore; inf or nan where :math:`\det = 0`).
    """
    e1, e2 = c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]
    h = _cross_any(d, e2)
    det = np.einsum("ij,ij->i", e1, h)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        t = origins - c[:, 0]
        u = np.einsum("ij,ij->i", t, h) * inv
        q = _cross_any(t, e1)
        v = (q @ d) * inv
        dist = np.einsum("ij,ij->i", e2, q) * inv
    return det, u, v, dist


def barycentric_points(surface: TriangleSurface, triangles, barycentric,
                       points=None) -> np.ndarray:
    """``(k, 3)``: the points at ``barycentric`` ``(k, 3)`` in ``triangles`` ``(k,)``, on the
    surface's vertices or on ``points`` ``(n, 3)`` (the same triangles elsewhere, e.g.
    deformed).
    """
    verts = surface.points if points is None else np.asarray(points, dtype=float)
    corners = verts[surface.triangles[np.asarray(triangles)]]
    return np.einsum("kj,kjd->kd", np.asarray(barycentric, dtype=float), corners)


def quadratic_points(surface: TriangleSurface, triangles, barycentric, values) -> np.ndarray:
    r"""``(k, d)``: ``values`` ``(n, d)`` given at the surface's vertices, interpolated at
    ``barycentric`` ``(k, 3)`` in ``triangles`` ``(k,)`` by a local quadratic fit: a moving
    least-squares quadratic in the triangle's plane over the vertices of the triangles that
    touch it (its corners and their neighbours, about 12), exact for a field quadratic in
    the position on a flat patch, where :func:`barycentric_points` is exact only for a
    linear one.

    With :math:`q` the point, :math:`(x_j, y_j)` the vertices' offsets from it in the
    triangle's plane over the mean edge length :math:`h`, and
    :math:`b = (1, x, y, x^2, xy, y^2)`, the value at :math:`q` is the constant term
    :math:`c_0` of

    .. math::

        c = \arg\min_c \sum_j e^{-(x_j^2 + y_j^2)} \, \| b(x_j, y_j) \cdot c - v_j \|^2

    (a pseudo-inverse, so a stencil too small for a quadratic, as on a border, still gets
    the best fit it allows).
    """
    tri = np.asarray(triangles, dtype=np.intp)
    v = np.asarray(values, dtype=float)
    idx, mask = _touching_vertices(surface, tri)
    corners = surface.points[surface.triangles[tri]]
    u_axis, v_axis = tangent_bases(unit_rows(np.cross(corners[:, 1] - corners[:, 0],
                                                      corners[:, 2] - corners[:, 0])))
    d = surface.points[idx] - barycentric_points(surface, tri, barycentric)[:, None, :]
    x, y = (np.einsum("kmd,kd->km", d, a) / surface.mean_edge_length for a in (u_axis, v_axis))
    root = np.sqrt(mask * np.exp(-(x * x + y * y)))  # (k, m) square roots of the weights
    basis = np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], axis=2) * root[..., None]
    first = np.linalg.pinv(basis, rcond=1e-10)[:, 0, :]  # (k, m): the row giving c_0
    return np.einsum("km,km,kmd->kd", first, root, v.reshape(len(v), -1)[idx]).reshape(
        (len(tri), *v.shape[1:]))


def _touching_vertices(surface: TriangleSurface, tri: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """``(k, m)`` ids and ``(k, m)`` 0/1 mask: the vertices of the triangles touching each of
    ``tri`` ``(k,)`` (corners and their neighbours), padded to the longest row.
    """
    n, k = surface.n_points, len(tri)
    corners = sp.csr_matrix((np.ones(3 * k), surface.triangles[tri].ravel(),
                             np.arange(0, 3 * k + 1, 3)), shape=(k, n))
    ring = (corners @ (surface.adjacency + sp.identity(n, format="csr"))).tocsr()
    count = np.diff(ring.indptr)
    rows = np.repeat(np.arange(k), count)
    cols = np.arange(len(ring.indices)) - ring.indptr[rows]
    idx = np.zeros((k, max(int(count.max(initial=0)), 1)), dtype=np.intp)
    mask = np.zeros(idx.shape)
    idx[rows, cols], mask[rows, cols] = ring.indices, 1.0
    return idx, mask


def _barycentric(tri: np.ndarray, p: np.ndarray) -> np.ndarray:
    """``(k, 3)``: barycentric coordinates of points ``(k, 3)`` in triangles ``(k, 3, 3)``."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    v0, v1, v2 = b - a, c - a, p - a
    d00, d01, d11 = (np.einsum("ij,ij->i", x, y) for x, y in ((v0, v0), (v0, v1), (v1, v1)))
    d20, d21 = np.einsum("ij,ij->i", v2, v0), np.einsum("ij,ij->i", v2, v1)
    denom = d00 * d11 - d01 * d01
    with np.errstate(divide="ignore", invalid="ignore"):
        v = np.where(denom != 0, (d11 * d20 - d01 * d21) / denom, 0.0)
        w = np.where(denom != 0, (d00 * d21 - d01 * d20) / denom, 0.0)
    return np.stack([1.0 - v - w, v, w], axis=1)


def _closest_on_triangles(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """``(t, 3)``: closest point to ``p`` on each triangle of ``(t, 3, 3)`` (Ericson 5.1.5)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = np.einsum("ij,ij->i", ab, ap), np.einsum("ij,ij->i", ac, ap)
    bp, cp = p - b, p - c
    d3, d4 = np.einsum("ij,ij->i", ab, bp), np.einsum("ij,ij->i", ac, bp)
    d5, d6 = np.einsum("ij,ij->i", ab, cp), np.einsum("ij,ij->i", ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    denom = va + vb + vc
    with np.errstate(divide="ignore", invalid="ignore"):
        v = np.where(denom != 0, vb / denom, 0.0)
        w = np.where(denom != 0, vc / denom, 0.0)
        out = a + v[:, None] * ab + w[:, None] * ac
        t_ab = np.clip(d1 / (d1 - d3), 0, 1)
        t_ac = np.clip(d2 / (d2 - d6), 0, 1)
        t_bc = np.clip((d4 - d3) / ((d4 - d3) + (d5 - d6)), 0, 1)
    cases = [
        (d1 <= 0) & (d2 <= 0), (d3 >= 0) & (d4 <= d3), (d6 >= 0) & (d5 <= d6),
        (vc <= 0) & (d1 >= 0) & (d3 <= 0), (vb <= 0) & (d2 >= 0) & (d6 <= 0),
        (va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0),
    ]
    values = [a, b, c, a + t_ab[:, None] * ab, a + t_ac[:, None] * ac,
              b + t_bc[:, None] * (c - b)]
    for case, value in zip(cases[::-1], values[::-1], strict=True):
        out = np.where(case[:, None], value, out)
    out = np.where((cases[0])[:, None], a, out)
    # nearly no area (|ab x ac|^2 = denom below 1e-12 |ab|^2 |ac|^2): Ericson's regions
    # may miss p's nearest point; the nearer of it and the edges' nearest
    thin = np.flatnonzero(denom <= 1e-12 * np.einsum("ij,ij->i", ab, ab)
                          * np.einsum("ij,ij->i", ac, ac))
    if len(thin):
        q = np.broadcast_to(p, out.shape)[thin]
        edge = _closest_on_edges(q, tri[thin])
        nearer = np.einsum("ij,ij->i", edge - q, edge - q) \
            < np.einsum("ij,ij->i", out[thin] - q, out[thin] - q)
        out[thin[nearer]] = edge[nearer]
    return out


def _closest_on_edges(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """``(t, 3)``: the point of the three edges of each triangle ``(t, 3, 3)`` nearest to
    ``p`` ``(t, 3)`` (the closest point of a triangle with no area).
    """
    cand = []
    for i, j in ((0, 1), (1, 2), (2, 0)):
        s, e = tri[:, i], tri[:, j] - tri[:, i]
        ee = np.einsum("ij,ij->i", e, e)
        w = np.clip(np.einsum("ij,ij->i", p - s, e) / np.where(ee > 0, ee, 1.0), 0.0, 1.0)
        cand.append(s + w[:, None] * e)
    c = np.stack(cand)  # (3, t, 3)
    best = np.argmin(np.einsum("kij,kij->ki", c - p, c - p), axis=0)
    return c[best, np.arange(len(p))]


def triangle_normals(p: np.ndarray, corners: np.ndarray) -> np.ndarray:
    r"""``(t, 3)``: twice-area normals :math:`(b - a) \times (c - a)`.

    Parameters
    ----------
    p : (3, n) float
        Coordinates as rows (x, y and z), so the gathers are contiguous ``take`` calls.
    corners : (3, t) int
        The triangles' corners as rows.
    """
    a = np.take(p, corners[0], axis=1)
    u = np.take(p, corners[1], axis=1) - a
    v = np.take(p, corners[2], axis=1) - a
    out = np.empty((corners.shape[1], 3))
    out[:, 0] = u[1] * v[2] - u[2] * v[1]
    out[:, 1] = u[2] * v[0] - u[0] * v[2]
    out[:, 2] = u[0] * v[1] - u[1] * v[0]
    return out


def unit_rows(v: np.ndarray) -> np.ndarray:
    """``(n, 3)``: rows scaled to unit length; zero rows stay zero."""
    norm = np.sqrt(np.einsum("ij,ij->i", v, v))
    return v / np.where(norm > 0, norm, 1.0)[:, None]


def vector_lengths(e: np.ndarray) -> np.ndarray:
    """``(...)``: the lengths of vectors ``e`` ``(..., 3)``: ``np.linalg.norm(e, axis=-1)``
    to the bit, without its reduction over an axis of three (several times slower).
    """
    x, y, z = e[..., 0], e[..., 1], e[..., 2]
    return np.sqrt(x * x + y * y + z * z)


def _same_direction(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether triangles ``a`` and ``b`` traverse their shared edge in the same direction."""
    da = {(int(a[i]), int(a[(i + 1) % 3])) for i in range(3)}
    return any((int(b[i]), int(b[(i + 1) % 3])) in da for i in range(3))


def subdivide(surface: TriangleSurface, levels: int = 1) -> TriangleSurface:
    """Uniform 1-to-4 midpoint subdivision, ``levels`` times (no smoothing).

    Returns
    -------
    TriangleSurface
        ``4**levels`` times as many triangles; the first ``n`` vertices are the original ones
        and each new vertex is the midpoint of an edge.
    """
    for _ in range(int(levels)):
        p, t = surface.points, surface.triangles
        e = surface.edges
        mid = 0.5 * (p[e[:, 0]] + p[e[:, 1]])
        n = len(p)
        te = surface.triangle_edges + n
        a, b, c = t[:, 0], t[:, 1], t[:, 2]
        ab, bc, ca = te[:, 0], te[:, 1], te[:, 2]
        new_t = np.concatenate(
            [np.c_[a, ab, ca], np.c_[ab, b, bc], np.c_[ca, bc, c], np.c_[ab, bc, ca]]
        )
        surface = TriangleSurface(np.vstack([p, mid]), new_t)
    return surface


def tangent_bases(normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``((n, 3), (n, 3))``: two unit vectors spanning each tangent plane, ``u``, ``v``, with
    ``(u, v, normal)`` right-handed; zero normals get an arbitrary basis.
    """
    n = np.asarray(normals, dtype=float)
    helper = np.where((np.abs(n[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    u = unit_rows(np.cross(helper, n))
    return u, np.cross(n, u)


def _ring_least_squares(row: np.ndarray, n: int, eu, ev, nu, nv
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""``(n,)`` each: the entries :math:`a, b, c` of :math:`[[a, b], [b, c]]` that fit,
    in the least-squares sense over the edges of each vertex (``row`` ``(e,)``, the vertex
    of each edge), :math:`a e_u + b e_v = n_u` and :math:`b e_u + c e_v = n_v` (edge and
    normal change in the vertex's tangent basis, ``(e,)`` each); a vertex with no edge
    gets a tiny ridge and no curvature.
    """
    def acc(w):
        return np.bincount(row, weights=w, minlength=n)

    m = np.empty((n, 3, 3))  # the normal equations
    m[:, 0, 0] = acc(eu * eu)
    m[:, 0, 1] = m[:, 1, 0] = acc(eu * ev)
    m[:, 1, 1] = acc(ev * ev + eu * eu)
    m[:, 1, 2] = m[:, 2, 1] = acc(eu * ev)
    m[:, 0, 2] = m[:, 2, 0] = 0.0
    m[:, 2, 2] = acc(ev * ev)
    rhs = np.stack([acc(eu * nu), acc(ev * nu + eu * nv), acc(ev * nv)], axis=1)
    scale = np.trace(m, axis1=1, axis2=2)[:, None, None]
    m += 1e-9 * np.maximum(scale, 1e-300) * np.eye(3)  # lonely vertices: no curvature
    a, b, c = np.linalg.solve(m, rhs[:, :, None])[:, :, 0].T
    return a, b, c


def shape_operators(surface: TriangleSurface, normals=None, at=None) -> np.ndarray:
    r"""``(n, 3, 3)``: the shape operator :math:`S` of the surface at each vertex.

    Parameters
    ----------
    surface : TriangleSurface
        The surface.
    normals : (n, 3) float, optional
        Unit vertex normals; default :meth:`TriangleSurface.vertex_normals`.
    at : (k,) int, optional
        Only at these vertices (``(k, 3, 3)``, the same values to the bit as the rows
        ``at`` of all of them).

    Returns
    -------
    (n, 3, 3) float
        Symmetric, acting on the tangent plane, with :math:`S e \approx n_j - n_i` for every
        edge :math:`e = x_j - x_i` from the vertex (least squares over its one-ring, both
        projected onto the tangent plane). The second fundamental form is
        :math:`I\!I(v, v) = v^T S v`: a sphere of radius :math:`\rho` with outward normals has
        :math:`S = P/\rho` (:math:`P` the tangent projector), and a tangent step :math:`v`
        leaves the surface by :math:`I\!I(v, v)/2` along the normal, to second order.
    """
    nrm = surface.vertex_normals() if normals is None else np.asarray(normals, dtype=float)
    e = surface.edges
    i = np.concatenate([e[:, 0], e[:, 1]])
    j = np.concatenate([e[:, 1], e[:, 0]])
    n = surface.n_points
    row = i  # each edge's row of the output
    if at is not None:  # the edges from the vertices ``at``, in the same order
        at = np.asarray(at, dtype=np.intp)
        position = np.full(n, -1, np.intp)
        position[at] = np.arange(len(at))
        keep = np.flatnonzero(position[i] >= 0)
        i, j = i[keep], j[keep]
        row, n = position[i], len(at)
    u, v = tangent_bases(nrm if at is None else nrm[at])
    pts = surface.points
    d = np.take(pts, j, axis=0) - np.take(pts, i, axis=0)
    dn = np.take(nrm, j, axis=0) - np.take(nrm, i, axis=0)
    ui, vi = np.take(u, row, axis=0), np.take(v, row, axis=0)
    eu, ev = np.einsum("ij,ij->i", d, ui), np.einsum("ij,ij->i", d, vi)
    nu, nv = np.einsum("ij,ij->i", dn, ui), np.einsum("ij,ij->i", dn, vi)
    a, b, c = _ring_least_squares(row, n, eu, ev, nu, nv)
    uu = u[:, :, None] * u[:, None, :]
    vv = v[:, :, None] * v[:, None, :]
    uv = u[:, :, None] * v[:, None, :]
    return a[:, None, None] * uu + b[:, None, None] * (uv + uv.transpose(0, 2, 1)) + \
        c[:, None, None] * vv


def phong_midpoints(points: np.ndarray, normals: np.ndarray, pairs: np.ndarray):
    r"""Edge midpoints on the smooth surface through the vertices and their tangent planes.

    Parameters
    ----------
    points : (n, 3) float
        Vertex positions.
    normals : (n, 3) float
        Unit vertex normals.
    pairs : (k, 2) int
        The edges' end vertices.

    Returns
    -------
    midpoints : (k, 3) float
        Phong tessellation's point (Boubekeur and Alexa 2008) at the edge's middle with
        shape factor :math:`1/2`,

        .. math::

            m^* = m - \tfrac14\left[((m - p_0)\cdot n_0)\, n_0 + ((m - p_1)\cdot n_1)\, n_1
            \right], \qquad m = \tfrac12 (p_0 + p_1),

        which lies on a sphere through :math:`p_0, p_1` with normals :math:`n_0, n_1` to
        second order in the edge's angle (the straight midpoint misses it by the sagitta).
    normals : (k, 3) float
        :math:`\mathrm{unit}(n_0 + n_1)`, the normals for the next level.
    """
    p0, p1 = (np.take(points, pairs[:, k], axis=0) for k in (0, 1))
    n0, n1 = (np.take(normals, pairs[:, k], axis=0) for k in (0, 1))
    m = 0.5 * (p0 + p1)
    k0 = np.einsum("ij,ij->i", m - p0, n0)
    k1 = np.einsum("ij,ij->i", m - p1, n1)
    mid = m - 0.25 * (k0[:, None] * n0 + k1[:, None] * n1)
    return mid, unit_rows(n0 + n1)


def cotangent_laplacian(surface: TriangleSurface) -> tuple[sp.csr_matrix, np.ndarray]:
    r"""The cotangent stiffness matrix and the lumped vertex areas.

    Returns
    -------
    stiffness : (n, n) sparse float
        Symmetric positive semi-definite, :math:`K_{ij} = -\tfrac12(\cot\alpha_{ij} +
        \cot\beta_{ij})` for an edge and :math:`K_{ii} = -\sum_j K_{ij}`, so
        :math:`x^T K x = \int \|\nabla x\|^2`.
    areas : (n,) float
        A third of the area of each vertex's triangles.
    """
    p, t = surface.points, surface.triangles
    # the corner k faces the edge of corners k + 1, k + 2: triangle_edges' column k + 1
    facing = surface.triangle_edges[:, [1, 2, 0]]
    weight = np.zeros(len(surface.edges))
    for k in range(3):
        i, j, o = t[:, (k + 1) % 3], t[:, (k + 2) % 3], t[:, k]
        po = np.take(p, o, axis=0)
        u, v = np.take(p, i, axis=0) - po, np.take(p, j, axis=0) - po
        (ux, uy, uz), (vx, vy, vz) = u.T, v.T
        cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx  # np.cross's
        cross = np.sqrt(cx * cx + cy * cy + cz * cz)  # its norm, to the bit
        cot = np.einsum("ij,ij->i", u, v) / np.maximum(cross, 1e-300)
        weight += np.bincount(facing[:, k], weights=-0.5 * cot, minlength=len(weight))
    n = surface.n_points
    e = surface.edges
    off = sp.csr_matrix((np.concatenate([weight, weight]),
                         (np.concatenate([e[:, 0], e[:, 1]]), np.concatenate([e[:, 1], e[:, 0]]))),
                        shape=(n, n))
    stiffness = off - sp.diags(np.asarray(off.sum(axis=1)).ravel())
    return stiffness.tocsr(), surface.incidence @ surface.triangle_areas() / 3.0


def smoothed_normals(surface: TriangleSurface, normals, radius: float,
                     rtol: float = 1e-8) -> np.ndarray:
    r"""``(n, 3)``: unit normals smoothed over about ``radius`` by heat diffusion.

    .. math:: (M + t K)\,\bar n = M n, \qquad t = r^2 / 2,

    with :math:`K` and :math:`M` from :func:`cotangent_laplacian` (one implicit step of the
    heat equation, a kernel of width about :math:`r` whatever the mesh resolution), then
    normalized.

    The three columns are solved together by conjugate gradients (:func:`block_pcg`, from
    zero to a residual of ``rtol`` times the right-hand side's; 1e-8 moves the normals by
    under 1e-5 degrees) preconditioned by one multilevel V-cycle
    (:func:`multilevel_preconditioner`): Jacobi smoothing and coarse corrections on
    aggregates of vertices, aggregates of those and so on. The unknowns are numbered in
    reverse Cuthill-McKee order first (neighbours close in memory: each sparse product
    reads ``x`` about in order, 1.5-2x faster on a subdivided scan whose new vertices sit
    at the end). Jacobi alone needs iterations in proportion to :math:`r / h` (the radius
    over the edge length); with the cycle they grow slowly: 17, 19, 23 and 27 on the
    procedural face at 20 k, 82 k, 326 k and 1.3 M triangles (one two-level cycle on
    aggregates of 6 h: 40-50).
    """
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    n = np.asarray(normals, dtype=float)
    if radius <= 0:
        return n
    stiffness, areas = cotangent_laplacian(surface)
    system = (sp.diags(areas) + 0.5 * radius**2 * stiffness).tocsr()
    order = reverse_cuthill_mckee(system, symmetric_mode=True)
    system = _permuted(system, order)
    spacing = float(np.sqrt(2.0 * surface.triangle_areas().mean()))
    precondition = multilevel_preconditioner(system, surface.points[order], 3.0 * spacing)
    rhs = areas[order, None] * n[order]
    out = np.empty_like(n)
    out[order] = block_pcg(system, rhs, np.zeros_like(rhs), precondition, rtol)
    return unit_rows(out)


def _permuted(matrix: sp.csr_matrix, order: np.ndarray) -> sp.csr_matrix:
    """``(n, n)``: ``matrix[order][:, order]``, the columns renumbered in place of numpy's
    column indexing (a sort of every row's few entries instead of a second gather).
    """
    rows = matrix[order]
    inverse = np.empty_like(order)
    inverse[order] = np.arange(len(order), dtype=order.dtype)
    rows.indices = inverse[rows.indices].astype(rows.indices.dtype, copy=False)
    rows.has_sorted_indices = False
    rows.sort_indices()
    return rows


def _aggregates(points: np.ndarray, size: float) -> np.ndarray:
    """``(n,)``: the number of each point's cube of side ``size``, 0..c-1 in the cubes'
    order (z, then y, then x).
    """
    cell = np.floor((points - points.min(axis=0)) / max(size, 1e-300)).astype(np.int64)
    dims = cell.max(axis=0) + 1
    _, agg = np.unique((cell[:, 2] * dims[1] + cell[:, 1]) * dims[0] + cell[:, 0],
                       return_inverse=True)
    return agg.ravel()


def _coarse_factor(coarse: sp.csr_matrix):
    """The SuperLU factors of the symmetric positive definite ``coarse`` ``(c, c)``, in a
    symmetric fill-reducing order (minimum degree on :math:`A + A^T`, no pivoting: half
    the fill of the default column order), or None where it is singular.
    """
    from scipy.sparse.linalg import splu

    try:
        return splu(coarse.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                    options={"SymmetricMode": True})
    except RuntimeError:  # singular coarse matrix
        return None


def multilevel_preconditioner(system: sp.csr_matrix, points: np.ndarray, size: float,
                              omega: float = 2.0 / 3.0, growth: float = 3.0,
                              coarsest: int = 2000):
    r"""One symmetric multilevel V-cycle for the symmetric positive definite ``system``
    ``A`` ``(n, n)`` whose unknowns sit at ``points`` ``(n, 3)``, as a function of ``R``
    ``(n, k)``.

    The levels are those of :func:`two_level_preconditioner` (aggregates in cubes of side
    ``size``, smoothed aggregation), except that the coarse matrix :math:`A_c` is solved by
    the same cycle on the aggregates' centroids in cubes ``growth`` times larger, until it
    has at most ``coarsest`` unknowns; that one is factorized (SuperLU). The cycle at each
    level is

    .. math:: z_1 = \omega D^{-1} r, \quad z_2 = z_1 + P\,C(P^T (r - A z_1)), \quad
              z = z_2 + \omega D^{-1} (r - A z_2),

    with :math:`C` the next level's cycle (or :math:`A_c^{-1}`): symmetric and positive
    definite, so conjugate gradients may use it. Where a coarse matrix cannot be factorized
    its level smooths with Jacobi (:math:`D^{-1}`) alone.
    """
    dinv = 1.0 / system.diagonal()
    pts = np.asarray(points, float)
    agg = _aggregates(pts, size)
    n, c = len(pts), int(agg.max()) + 1
    if c >= n:  # nothing to aggregate: the system is as small as its coarse one
        factor = _coarse_factor(system)
        return (lambda r: dinv[:, None] * r) if factor is None else factor.solve
    p0 = sp.csr_matrix((np.ones(n), (np.arange(n), agg)), shape=(n, c))
    prolong = (p0 - omega * (sp.diags(dinv) @ (system @ p0))).tocsr()
    restrict = prolong.T  # a CSC view: its product reads the rows of P once
    coarse = (restrict @ system @ prolong).tocsr()
    if c <= coarsest:
        factor = _coarse_factor(coarse)
        if factor is None:
            return lambda r: dinv[:, None] * r
        solve = factor.solve
    else:
        count = np.bincount(agg, minlength=c)[:, None]
        centroids = np.column_stack([np.bincount(agg, weights=pts[:, k], minlength=c)
                                     for k in range(3)]) / count
        solve = multilevel_preconditioner(coarse, centroids, growth * size, omega, growth,
                                          coarsest)
    wdinv = omega * dinv[:, None]

    def cycle(r: np.ndarray) -> np.ndarray:  # in place where it can: big scans
        z = wdinv * r
        s = system @ z
        np.subtract(r, s, out=s)
        z += prolong @ solve(np.asarray(restrict @ s))
        s = system @ z
        np.subtract(r, s, out=s)
        s *= wdinv
        z += s
        return z

    return cycle


def two_level_preconditioner(system: sp.csr_matrix, points: np.ndarray, size: float,
                             omega: float = 2.0 / 3.0):
    r"""One symmetric two-level cycle for the symmetric positive definite ``system`` ``A``
    ``(n, n)`` whose unknowns sit at ``points`` ``(n, 3)``, as a function of ``R`` ``(n, k)``.

    Aggregates are the points in each cube of side ``size``; :math:`P_0` ``(n, c)`` maps an
    aggregate to its points, smoothed to :math:`P = (I - \omega D^{-1} A) P_0` (smoothed
    aggregation, :math:`D` the diagonal of :math:`A`), and the coarse matrix
    :math:`A_c = P^T A P` is factorized once (SuperLU). The cycle is

    .. math:: z_1 = \omega D^{-1} r, \quad z_2 = z_1 + P A_c^{-1} P^T (r - A z_1), \quad
              z = z_2 + \omega D^{-1} (r - A z_2),

    symmetric and positive definite, so conjugate gradients may use it. Where the coarse
    matrix cannot be factorized, Jacobi (:math:`D^{-1}`) is returned.
    (:func:`multilevel_preconditioner` with one coarse level, however big.)
    """
    return multilevel_preconditioner(system, points, size, omega, coarsest=system.shape[0])


def block_pcg(system: sp.csr_matrix, rhs: np.ndarray, guess: np.ndarray, precondition,
              rtol: float, maxiter: int = 5000) -> np.ndarray:
    r"""``(n, k)``: preconditioned conjugate gradients for ``system @ X = rhs`` ``(n, k)``,
    the ``k`` columns side by side (one sparse product a step for all of them), from
    ``guess`` (overwritten), until every column's residual is at most ``rtol`` times its
    right-hand side's (or ``maxiter`` steps).

    .. math:: \alpha = \frac{r^T z}{p^T A p}, \quad x \mathrel{+}= \alpha p, \quad
              r \mathrel{-}= \alpha A p, \quad z = M^{-1} r, \quad
              p = z + \frac{r^T z}{r_{old}^T z_{old}} p
    """
    x = guess
    r = rhs - system @ x
    z = precondition(r)
    p = z.copy()
    rz = np.einsum("ij,ij->j", r, z)
    limit = (rtol * np.linalg.norm(rhs, axis=0))**2
    for _ in range(maxiter):
        if np.all(np.einsum("ij,ij->j", r, r) <= limit):  # a column's norm, squared
            break
        ap = system @ p
        alpha = rz / np.maximum(np.einsum("ij,ij->j", p, ap), 1e-300)
        x += alpha * p
        ap *= alpha
        r -= ap
        z = precondition(r)
        rz_new = np.einsum("ij,ij->j", r, z)
        p *= rz_new / np.where(rz == 0, 1.0, rz)
        p += z  # p = z + beta p, in place
        rz = rz_new
    return x


def self_intersections(surface: TriangleSurface, chunk: int = 200_000) -> np.ndarray:
    r"""``(k, 2)``: the pairs of triangles of ``surface`` that cross each other.

    Two triangles that share no edge cross when an edge of one passes through the other's
    interior (Moeller-Trumbore: the edge :math:`p + t (q - p)` meets the plane of
    :math:`(a, b, c)` at barycentric :math:`(1 - u - v, u, v)` with :math:`0 < t < 1`,
    :math:`u, v > 0`, :math:`u + v < 1`, all strictly, by a margin of 1e-9). A shared corner
    is a touch, not a crossing: a pair sharing a vertex crosses only if an edge away from
    that vertex passes through the other. Candidate pairs are those whose bounding boxes
    overlap (the certificate's grid, :mod:`~wrinkle_vis.core.certificate`), less the pairs
    sharing a vertex whose star the certificate proves cannot cross itself; the pairs come
    in lexicographic order. Coplanar overlaps are not reported.
    """
    pts = np.asarray(surface.points, float)
    tri = np.asarray(surface.triangles)
    if len(tri) < 2:
        return np.zeros((0, 2), np.intp)
    # pairs that share one vertex whose star may cross itself (every such pair has
    # overlapping boxes), and those that share no vertex and whose boxes overlap
    corners = pts[tri]
    e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    unclear = ~_clear_stars(pts, tri, _cross(e1, e2), _abs_cross(e1, e2))
    pairs = np.concatenate([_star_pairs(tri, unclear), _apart_pairs(tri, pts)])
    shared = (tri[pairs[:, 0]][:, :, None] == tri[pairs[:, 1]][:, None, :]).sum(axis=(1, 2))
    pairs = pairs[shared < 2]
    pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
    hits = np.zeros(len(pairs), bool)
    for start in range(0, len(pairs), chunk):
        part = pairs[start:start + chunk]
        for a, b in ((0, 1), (1, 0)):
            ta, tb = tri[part[:, a]], tri[part[:, b]]
            for i, j in ((0, 1), (1, 2), (2, 0)):
                share_end = ((ta[:, i][:, None] == tb).any(axis=1)
                             | (ta[:, j][:, None] == tb).any(axis=1))
                hit = _segment_crosses(pts[ta[:, i]], pts[ta[:, j]], pts[tb])
                hits[start:start + chunk] |= hit & ~share_end
    return pairs[hits]


def _segment_crosses(p: np.ndarray, q: np.ndarray, tri: np.ndarray, eps: float = 1e-9
                     ) -> np.ndarray:
    """``(k,)`` bool: segment ``p q`` ``(k, 3)`` passes through triangle ``(k, 3, 3)``'s
    interior, strictly.
    """
    d = q - p
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    h = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, h)
    scale = np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1) * np.linalg.norm(d, axis=1)
    ok = np.abs(det) > 1e-12 * np.maximum(scale, 1e-300)
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = p - tri[:, 0]
    u = np.einsum("ij,ij->i", s, h) * inv
    qv = np.cross(s, e1)
    v = np.einsum("ij,ij->i", d, qv) * inv
    t = np.einsum("ij,ij->i", e2, qv) * inv
    return ok & (u > eps) & (v > eps) & (u + v < 1 - eps) & (t > eps) & (t < 1 - eps)
