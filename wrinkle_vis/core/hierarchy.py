r"""Adaptive refinement for animation: a subdivision hierarchy built once, frames that look up.

New vertices have fixed rest positions, so everything that depends on the rest skin alone is
built once per skin (and per muscle) and shared by every frame:

* :class:`Hierarchy`: the uniform 1-to-4 subdivision of the skin's triangles down to the
  deepest level, built node by node where a frame first splits one (with the nodes across
  its edges, whose children border it: :meth:`Hierarchy.ensure`). New vertices sit on the
  Phong midpoints of their edges (:func:`~wrinkle_vis.core.mesh.phong_midpoints`), as
  :func:`~wrinkle_vis.core.refine.refine_triangles` puts them. Each new vertex also keeps its
  *ring*: its six neighbours in the uniform mesh of the level it was made at.
* :class:`MuscleLevels`: one muscle's rest data on the hierarchy's vertices (:math:`\lambda`,
  :math:`\gamma`, :math:`l`, :math:`w`, :math:`H`, :math:`At`, the unit pull) and the Eq. 10
  weights of its ring edges.

Every quantity of a frame at a vertex is then a function of that vertex alone, whichever
triangles the frame splits ("topology-free"): the displacement from the vertex's rest data,
:math:`\tau` (Eq. 9) on its ring edges, :math:`\varepsilon` (Eq. 10) over them, :math:`W`
(Eq. 4) and the normal it is moved along (the area-weighted normal of its deformed ring). A
vertex of the skin keeps the values of the unrefined frame exactly; a frame only decides
which triangles split (:func:`refined_topology`: the red-green closure as table look-ups)
and evaluates the vertices it selected. So the refined surface does not pop when the set of
split triangles changes: a vertex that stays keeps its position, and one that appears sits
where the surface through its ring puts it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .cache import HoldsArrays
from .equations import stretch_coefficients
from .mesh import TriangleSurface, phong_midpoints, unit_rows, vector_lengths
from .muscle import Muscle

__all__ = ["Hierarchy", "MuscleLevels", "canonical_order", "conforming_triangles",
           "corner_angle", "distinct", "first_seen", "grown", "longest_edge", "refined_topology",
           "six_entries", "split_in_order"]

_KEY = np.int64(1 << 31)


def six_entries(shape: np.ndarray) -> np.ndarray:
    """``(n, 6)``: the xx, yy, zz, xy, xz, yz entries of symmetric ``(n, 3, 3)``."""
    return np.stack([shape[:, 0, 0], shape[:, 1, 1], shape[:, 2, 2], shape[:, 0, 1],
                     shape[:, 0, 2], shape[:, 1, 2]], axis=1)


def corner_angle(normals: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """``(t,)``: the largest angle (radians) between two of the unit ``normals`` ``(n, 3)``
    at the corners of each of ``triangles`` ``(t, 3)``.
    """
    a, b, c = (normals[triangles[:, k]] for k in range(3))
    cos = np.minimum.reduce([(a * b).sum(axis=1), (b * c).sum(axis=1), (c * a).sum(axis=1)])
    return np.arccos(np.clip(cos, -1.0, 1.0))


def longest_edge(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """``(t,)``: the longest edge of each of ``triangles`` ``(t, 3)`` over ``points``
    ``(n, 3)``.
    """
    a, b, c = (points[triangles[:, k]] for k in range(3))
    return np.sqrt(np.maximum.reduce([((a - b) ** 2).sum(axis=1), ((b - c) ** 2).sum(axis=1),
                                      ((c - a) ** 2).sum(axis=1)]))


#: The children of a node (a, b, c) with edge midpoints (m01, m12, m20), as pairs of the
#: nine edges between those six points: child k's edges are _CHILD_PAIRS[k].
_PAIRS = ((0, 3), (3, 5), (5, 0), (3, 1), (1, 4), (4, 3), (5, 4), (4, 2), (2, 5))
_CHILD_PAIRS = ((0, 1, 2), (3, 4, 5), (6, 7, 8), (5, 6, 1))


def _children_geometry(normals, points, *corners):
    """``(4 p,)`` each: :func:`corner_angle` and :func:`longest_edge` of the children of
    ``p`` nodes, from the ids ``(p,)`` each of their corners a, b, c and midpoints m01,
    m12, m20 (each point gathered once, each shared edge measured once).
    """
    n = [normals.take(v, axis=0) for v in corners]
    x = [points.take(v, axis=0) for v in corners]
    cos = [np.einsum("ij,ij->i", n[i], n[j]) for i, j in _PAIRS]
    sq = [np.einsum("ij,ij->i", x[i] - x[j], x[i] - x[j]) for i, j in _PAIRS]
    bend = np.stack([np.minimum.reduce([cos[k] for k in kid]) for kid in _CHILD_PAIRS], axis=1)
    edge = np.stack([np.maximum.reduce([sq[k] for k in kid]) for kid in _CHILD_PAIRS], axis=1)
    return np.arccos(np.clip(bend, -1.0, 1.0)).ravel(), np.sqrt(edge).ravel()


def grown(a: np.ndarray, more: np.ndarray) -> np.ndarray:
    """``a`` with the rows ``more`` appended, amortized: ``a`` is a prefix of a buffer with
    spare rows (grown by doubling), so appending copies only ``more``.

    ``a`` is an array of its own or one this function returned (a view of a buffer it made
    is taken for a prefix of it: comparing data addresses cost more than the append).
    """
    n, k = len(a), len(more)
    base = a.base
    if (base is not None and type(base) is np.ndarray and base.shape[1:] == a.shape[1:]
            and base.dtype == a.dtype and len(base) >= n + k and a.strides == base.strides):
        base[n:n + k] = more
        return base[:n + k]
    base = np.empty((max(2 * (n + k), 1024), *a.shape[1:]), a.dtype)
    base[:n] = a
    base[n:n + k] = more
    return base[:n + k]


class Hierarchy:
    """The uniform subdivision hierarchy of a skin, ``depth`` levels deep, built on demand.

    A node gets its four children the first time a frame splits it or a node across one of
    its edges (:meth:`ensure`), and only once the nodes across its parent's edges have
    theirs. So a node with children has all its neighbours of its own level
    (:attr:`node_nbr`; a node without may miss some until they are built), and what is
    built is the subdivision of the split nodes and one ring of nodes around them, level by
    level.

    Parameters
    ----------
    skin : TriangleSurface
        The root skin (its triangles are the root nodes, its vertices the root vertices).
    normals, slide_normals : (n, 3) float
        Unit rest normals (for the Phong midpoints) and the normals the skin slides along.
    shape : (n, 3, 3) float
        Shape operators of ``slide_normals``.
    depth : int
        Levels below the root.

    Attributes
    ----------
    rest, normal, slide : (v, 3) float
        Every built vertex's rest position, Phong normal and slide normal (root ones first).
    shape6 : (v, 6) float
        Their shape operators (xx, yy, zz, xy, xz, yz).
    level : (v,) int8
        The level a vertex was made at (0 for the skin's).
    ring : (v, 6) int
        A new vertex's neighbours in the uniform mesh of its level, counter-clockwise seen
        from outside, ``-1`` where a side lies beyond the skin's boundary (or is not built
        yet: ``final`` tells).
    final : (v,) bool
        New vertices whose ring is complete (and ``ring_len`` ``(v, 6)`` its rest lengths).
    node_tri : (N, 3) int
        Corners of every node (root triangles first, then children in fours).
    node_child : (N,) int
        Each node's first child, ``-1`` while unbuilt or at the deepest level.
    node_mid : (N, 3) int
        The midpoints of a node's edges 01, 12, 20 (``-1`` likewise).
    node_level, node_root, node_parent : (N,) int
        A node's level, root triangle and parent (-1 for a root).
    node_nbr : (N, 3) int
        The node of the same level across each edge, ``-1`` at the skin's boundary (or
        where it is not built yet).
    node_across : (N, 2) int
        The neighbours of a node's parent across the parent's edges that the node lies on
        (-1: none, a root, the centre child, or the boundary), for the closure's level rule.
    node_ready : (N,) bool
        Nodes that may split (:meth:`ensure` ran for them).
    node_bend : (N,) float
        The largest angle (radians) between the rest normals at a node's corners: how much
        the rest skin itself bends across it (:func:`corner_angle`).
    node_edge : (N,) float
        A node's longest rest edge.
    """

    def __init__(self, skin: TriangleSurface, normals, slide_normals, shape, depth: int):
        n0, t0 = skin.n_points, skin.n_triangles
        self.skin, self.depth, self.n_root = skin, int(depth), n0
        self.rest = np.array(skin.points, dtype=float)
        self.normal = np.array(normals, dtype=float)
        self.slide = np.array(slide_normals, dtype=float)
        self.shape6 = six_entries(np.asarray(shape, dtype=float))
        self.level = np.zeros(n0, np.int8)
        self.ring = np.full((n0, 6), -1, np.int64)
        self.ring_len = np.ones((n0, 6))
        self.final = np.zeros(n0, bool)
        self.node_tri = np.asarray(skin.triangles, dtype=np.int64).copy()
        self.node_child = np.full(t0, -1, np.int64)
        self.node_mid = np.full((t0, 3), -1, np.int64)
        self.node_level = np.zeros(t0, np.int8)
        self.node_root = np.arange(t0, dtype=np.int64)
        self.node_parent = np.full(t0, -1, np.int64)
        self.node_across = np.full((t0, 2), -1, np.int64)
        self.node_ready = np.zeros(t0, bool)
        self.node_bend = corner_angle(self.normal, self.node_tri)
        self.node_edge = longest_edge(self.rest, self.node_tri)
        self._keys = np.zeros(0, np.int64)  # sorted edge keys (lo * 2**31 + hi)
        self._mids = np.zeros(0, np.int64)  # their midpoints
        self.root_nbrs = _edge_neighbours(skin)
        self.node_nbr = self.root_nbrs.copy()
        self.version = 0  # bumped whenever vertices or ring data are added

    @property
    def n_points(self) -> int:
        """Vertices built so far."""
        return len(self.rest)

    @property
    def n_roots(self) -> int:
        """Root nodes: the skin's triangles."""
        return len(self.root_nbrs)

    def point_scratch(self) -> np.ndarray:
        """``(v,) int``, all -1: working space for :func:`first_seen` over vertex ids."""
        if len(getattr(self, "_point_scratch", ())) != self.n_points:
            self._point_scratch = np.full(self.n_points, -1, np.int64)
        return self._point_scratch

    def scratch(self) -> np.ndarray:
        """``(N,) int``, all -1: working space for :func:`distinct` over node ids."""
        if len(getattr(self, "_scratch", ())) != len(self.node_tri):
            self._scratch = np.full(len(self.node_tri), -1, np.int64)
        return self._scratch

    def ensure(self, nodes: np.ndarray) -> bool:
        """Make ``nodes`` ``(k,)`` (above the deepest level) ready to split: give them and
        the nodes across their edges children, and complete the rings of their edges'
        midpoints.

        Returns whether anything was added.
        """
        nodes = np.asarray(nodes, dtype=np.int64)
        nodes = nodes[~self.node_ready[nodes]]
        if not len(nodes):
            return False
        nodes = np.unique(nodes)
        if (self.node_level[nodes] >= self.depth).any():
            raise ValueError(f"a node of the deepest level ({self.depth}) cannot split: "
                             "the hierarchy holds no level below it")
        self._prepare(nodes)  # their neighbours of their level exist from now on
        nbrs = self.node_nbr.take(nodes, axis=0).ravel()
        self._expand(np.concatenate([nodes, nbrs[nbrs >= 0]]))
        self._finalize(nodes)
        self.node_ready[nodes] = True
        self.version += 1
        return True

    def edge_midpoints(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """``(k,)``: the built midpoint of each edge ``(a, b)``, ``-1`` where there is none."""
        keys = np.minimum(a, b) * _KEY + np.maximum(a, b)
        pos = np.minimum(np.searchsorted(self._keys, keys), max(len(self._keys) - 1, 0))
        if not len(self._keys):
            return np.full(len(keys), -1, np.int64)
        return np.where(self._keys[pos] == keys, self._mids[pos], -1)

    # ------------------------------------------------------------------ building
    def _expand(self, nodes: np.ndarray) -> None:
        """Give children to those of ``nodes`` without, after the nodes across their
        parents' edges (so their children's neighbours exist).
        """
        nodes = nodes[self.node_child[nodes] < 0]
        if not len(nodes):
            return
        nodes = np.unique(nodes)
        self._prepare(nodes)
        nodes = nodes[self.node_child[nodes] < 0]  # some were prepared
        level = self.node_level[nodes]
        for k in np.unique(level):  # the coarser first
            self._children(nodes[level == k], int(k) + 1)

    def _prepare(self, nodes: np.ndarray) -> None:
        """Give children to the nodes across the edges of ``nodes``' parents."""
        parents = self.node_parent[nodes]
        up = self.node_nbr.take(parents[parents >= 0], axis=0).ravel()
        self._expand(up[up >= 0])

    def _children(self, nodes: np.ndarray, level: int) -> None:
        """Build the four children of each of ``nodes`` ``(p,)`` (of ``level - 1``)."""
        a, b, c = self.node_tri.take(nodes, axis=0).T
        m01, m12, m20 = self._midpoints(np.concatenate([a, b, c]),
                                        np.concatenate([b, c, a]), level).reshape(3, -1)
        first = len(self.node_tri) + 4 * np.arange(len(nodes))
        kids = np.stack([a, m01, m20, m01, b, m12, m20, m12, c, m01, m12, m20],
                        axis=1).reshape(-1, 3)  # corner a, b, c and centre children
        self.node_child[nodes] = first
        self.node_mid[nodes] = np.stack([m01, m12, m20], axis=1)
        self._half_rings(a, b, c, m01, m12, m20)
        across = self.node_nbr.take(nodes, axis=0)[:, np.maximum(_CHILD_EDGES, 0)]  # (p, 4, 2)
        self._link(nodes, first)
        self.node_tri = grown(self.node_tri, kids)
        self.node_child = grown(self.node_child, np.full(len(kids), -1))
        self.node_mid = grown(self.node_mid, np.full((len(kids), 3), -1))
        self.node_level = grown(self.node_level, np.full(len(kids), level))
        self.node_root = grown(self.node_root, np.repeat(self.node_root[nodes], 4))
        self.node_parent = grown(self.node_parent, np.repeat(nodes, 4))
        self.node_across = grown(self.node_across,
                                 np.where(_CHILD_EDGES >= 0, across, -1).reshape(-1, 2))
        self.node_ready = grown(self.node_ready, np.zeros(len(kids), bool))
        bend, edge = _children_geometry(self.normal, self.rest, a, b, c, m01, m12, m20)
        self.node_bend = grown(self.node_bend, bend)
        self.node_edge = grown(self.node_edge, edge)

    def _link(self, parents: np.ndarray, first: np.ndarray) -> None:
        """Set the neighbours of the children ``first + 0..3`` of ``parents`` (and of the
        built children across their edges) from the parents' neighbours: a parent's edge
        ``j`` is halved by its children ``j`` and ``j + 1`` (their edge ``j``); across it,
        the neighbour's edge ``j'`` is traversed the other way.
        """
        kids = first[:, None] + np.arange(4)
        nbr = self.node_nbr
        nbr = grown(nbr, np.full((4 * len(parents), 3), -1))
        c0, c1, c2, c3 = kids.T
        nbr[c3, 0], nbr[c1, 2] = c1, c3
        nbr[c3, 1], nbr[c2, 0] = c2, c3
        nbr[c3, 2], nbr[c0, 1] = c0, c3
        for j in range(3):
            other = nbr[parents, j]
            ok = other >= 0
            ok[ok] = self.node_child[other[ok]] >= 0
            p, q = parents[ok], other[ok]
            jj = np.argmax(nbr[q] == p[:, None], axis=1)  # q's edge back to p
            mine_a, mine_b = kids[ok, j], kids[ok, (j + 1) % 3]
            qk = self.node_child[q]
            theirs_a, theirs_b = qk + (jj + 1) % 3, qk + jj
            nbr[mine_a, j], nbr[theirs_a, jj] = theirs_a, mine_a
            nbr[mine_b, j], nbr[theirs_b, jj] = theirs_b, mine_b
        self.node_nbr = nbr

    def _midpoints(self, a: np.ndarray, b: np.ndarray, level: int) -> np.ndarray:
        """The midpoint vertex of each edge ``(a, b)``, made (on the Phong surface) where
        it is new.
        """
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        keys = lo * _KEY + hi
        uniq, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
        mids = self.edge_midpoints(lo[first], hi[first])
        new = mids < 0
        if new.any():
            pairs = np.stack([lo[first][new], hi[first][new]], axis=1)
            ids = self.n_points + np.arange(len(pairs))
            mids[new] = ids
            self._add_vertices(pairs, level)
            at = np.searchsorted(self._keys, uniq[new])  # both sorted: merge, no sort
            self._keys = np.insert(self._keys, at, uniq[new])
            self._mids = np.insert(self._mids, at, ids)
        return mids[inverse.ravel()]

    def _before(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """``(k,) bool``: vertex ``a`` comes before ``b`` (each ``(k,)``) in the
        lexicographic order of their rest positions: an order of an edge's ends that does
        not depend on the order the vertices were built in (nor then do the rings, nor the
        order their sums run in).
        """
        pa, pb = self.rest.take(a, axis=0), self.rest.take(b, axis=0)
        lt, eq = pa < pb, pa == pb
        return lt[:, 0] | (eq[:, 0] & (lt[:, 1] | (eq[:, 1] & lt[:, 2])))

    def _add_vertices(self, pairs: np.ndarray, level: int) -> None:
        pairs = np.where(self._before(pairs[:, 0], pairs[:, 1])[:, None], pairs, pairs[:, ::-1])
        mid, mid_normals = phong_midpoints(self.rest, self.normal, pairs)
        self.rest = grown(self.rest, mid)
        self.normal = grown(self.normal, mid_normals)
        p0, p1 = pairs.T
        slide = self.slide.take(p0, axis=0) + self.slide.take(p1, axis=0)
        shape6 = self.shape6.take(p0, axis=0) + self.shape6.take(p1, axis=0)
        self.slide = grown(self.slide, unit_rows(slide))
        self.shape6 = grown(self.shape6, shape6 / 2)  # their mean
        self.level = grown(self.level, np.full(len(pairs), level))
        ring = np.full((len(pairs), 6), -1, np.int64)
        ring[:, 0], ring[:, 3] = pairs[:, 1], pairs[:, 0]  # the later end, the earlier
        self.ring = grown(self.ring, ring)
        self.ring_len = grown(self.ring_len, np.ones((len(pairs), 6)))
        self.final = grown(self.final, np.zeros(len(pairs), bool))

    def _half_rings(self, a, b, c, m01, m12, m20) -> None:
        """Fill the ring sides that the nodes ``(a, b, c)`` give their edges' midpoints:
        the midpoint of directed edge ``x -> y`` (opposite ``z``) sees ``y, m_yz, m_zx, x``
        counter-clockwise; the side of the edge it fills is 0 where ``x`` comes before
        ``y`` (:meth:`_before`), else 1.
        """
        for x, y, mxy, myz, mzx in ((a, b, m01, m12, m20), (b, c, m12, m20, m01),
                                    (c, a, m20, m01, m12)):
            low = self._before(x, y)
            self.ring[mxy[low], 1], self.ring[mxy[low], 2] = myz[low], mzx[low]
            self.ring[mxy[~low], 4], self.ring[mxy[~low], 5] = myz[~low], mzx[~low]

    def _finalize(self, nodes: np.ndarray) -> None:
        """Complete the rings of the midpoints of ``nodes`` (they and the nodes across their
        edges have children): their rest lengths.
        """
        v = self.node_mid.take(nodes, axis=0).ravel()
        v = np.unique(v[~self.final[v]])
        ring = self.ring.take(v, axis=0)
        safe = np.where(ring >= 0, ring, v[:, None])
        edge = self.rest.take(safe, axis=0) - self.rest.take(v, axis=0)[:, None]
        self.ring_len[v] = np.where(ring >= 0, vector_lengths(edge), 1.0)
        self.final[v] = True

    def safe_ring(self, v: np.ndarray) -> np.ndarray:
        """``(k, 6)``: the rings of vertices ``v``, the vertex itself where none."""
        ring = self.ring.take(v, axis=0)
        return np.where(ring >= 0, ring, v[:, None])


def _edge_neighbours(skin: TriangleSurface) -> np.ndarray:
    """``(m, 3)``: the triangle across each triangle's edges 01, 12, 20, ``-1`` at a boundary
    (and at non-manifold edges).
    """
    te = skin.triangle_edges.ravel()
    owner = np.repeat(np.arange(skin.n_triangles), 3)
    order = np.argsort(te, kind="stable")
    counts = np.bincount(te, minlength=len(skin.edges))
    out = np.full(len(te), -1, np.int64)
    pair = counts[te[order]] == 2
    s = order[pair].reshape(-1, 2)  # the two slots of each interior edge, adjacent
    out[s[:, 0]], out[s[:, 1]] = owner[s[:, 1]], owner[s[:, 0]]
    return out.reshape(-1, 3)


@dataclass
class MuscleLevels(HoldsArrays):
    """One muscle's rest data on a :class:`Hierarchy`'s new vertices (rows: its AOI).

    Built for the vertices the hierarchy has when :meth:`update` runs; the Eq. 10 weights
    (and the ``"gradient"`` option's triangle coefficients) once a vertex's ring is complete.
    """

    muscle: Muscle
    ids: np.ndarray  # (k,) vertex ids, ascending (added in the order the hierarchy builds them)
    lam: np.ndarray
    gamma: np.ndarray
    l: np.ndarray
    at: np.ndarray
    w: np.ndarray  # nan outside the wrinkling region
    h: np.ndarray
    unit: np.ndarray  # (k, 3) tangent unit pull
    direction: np.ndarray  # (k, 3) unit contraction direction (0 where undefined)
    weights: np.ndarray  # (k, 6) Eq. 10 weights of the ring edges
    coef: np.ndarray  # (k, 6, 2) "gradient" option only: ring triangles' coefficients
    area: np.ndarray  # (k, 6) and their normalized rest areas (empty for the others)
    done: int = 0  # vertices looked at (ids below this)
    final_version: int = -1
    root_dir: np.ndarray | None = None

    @classmethod
    def empty(cls, muscle: Muscle) -> MuscleLevels:
        """No rows yet (:meth:`update` adds them)."""
        z = np.zeros(0)
        return cls(muscle, np.zeros(0, np.int64), z, z, z, z, z, z, np.zeros((0, 3)),
                   np.zeros((0, 3)), np.zeros((0, 6)), np.zeros((0, 6, 2)), np.zeros((0, 6)))

    def update(self, hier: Hierarchy, tangential) -> bool:
        """Add the vertices built since the last call; fill ring data that became complete.
        Returns whether anything changed.
        """
        changed = False
        if hier.n_points > max(self.done, hier.n_root):
            self._add(hier, np.arange(max(self.done, hier.n_root), hier.n_points), tangential)
            self.done = hier.n_points
            changed = True
        if self.final_version != hier.version:
            todo = np.flatnonzero(hier.final[self.ids] & ~np.isfinite(self.weights[:, 0]))
            if len(todo):
                self._ring_data(hier, todo)
                changed = True
            self.final_version = hier.version
        return changed

    def _add(self, hier: Hierarchy, v: np.ndarray, tangential) -> None:
        rest = hier.rest.take(v, axis=0)
        reg = self.muscle.region(rest)
        keep = reg["in_aoi"].copy()
        inside = np.flatnonzero(keep)
        keep[inside[self.muscle.hidden(rest[inside], hier.skin)]] = False  # as the skin's
        v = v[keep]
        d = np.nan_to_num(reg["direction"][keep], nan=0.0)
        unit = tangential(self.muscle.unit_displacement(rest[keep]), hier.slide.take(v, axis=0))
        k = len(v)
        self.ids = grown(self.ids, v)
        for name, key in (("lam", "lam"), ("gamma", "gamma"), ("l", "l"), ("at", "At"),
                          ("w", "w"), ("h", "H")):
            setattr(self, name, grown(getattr(self, name), reg[key][keep]))
        self.unit = grown(self.unit, unit)
        self.direction = grown(self.direction, unit_rows(d))
        self.weights = grown(self.weights, np.full((k, 6), np.nan))
        if self.muscle.compression == "gradient":  # the others need no triangle data
            self.coef = grown(self.coef, np.zeros((k, 6, 2)))
            self.area = grown(self.area, np.zeros((k, 6)))

    def _ring_data(self, hier: Hierarchy, rows: np.ndarray) -> None:
        v = self.ids[rows]
        ring = hier.safe_ring(v)
        edge = hier.rest.take(ring, axis=0) - hier.rest.take(v, axis=0)[:, None]
        length = hier.ring_len.take(v, axis=0)  # complete rings: 1 where no neighbour (edge 0)
        cos = np.abs(np.einsum("kjc,kc->kj", edge, self.direction.take(rows, axis=0)))
        cos = np.where(length > 0, cos / np.where(length > 0, length, 1.0), 0.0)
        total = cos.sum(axis=1, keepdims=True)
        self.weights[rows] = np.where(total > 0, cos / np.where(total > 0, total, 1.0), 0.0)
        if self.muscle.compression == "gradient":
            self._gradient_data(hier, rows, v, ring)

    def _gradient_data(self, hier, rows, v, ring) -> None:
        """Coefficients of the ring triangles ``(v, r_i, r_{i+1})`` as
        :func:`~wrinkle_vis.core.equations.gradient_compression_operator` makes them.
        """
        if self.root_dir is None:
            reg = self.muscle.region(hier.skin.points)
            self.root_dir = unit_rows(np.nan_to_num(reg["direction"], nan=0.0))
        dirs = np.zeros((hier.n_points, 3))
        dirs[:hier.n_root] = self.root_dir
        dirs[self.ids] = self.direction
        nxt = np.roll(ring, -1, axis=1)
        a = np.repeat(v, 6)
        b, c = ring.ravel(), nxt.ravel()
        coef, area = stretch_coefficients(hier.rest[a], hier.rest[b], hier.rest[c],
                                          dirs[a] + dirs[b] + dirs[c])
        area = area.reshape(-1, 6)
        total = area.sum(axis=1, keepdims=True)
        self.coef[rows] = coef.reshape(-1, 6, 2)
        self.area[rows] = np.where(total > 0, area / np.where(total > 0, total, 1.0), 0.0)


#: The edges of its parent (01, 12, 20) that each child (corner a, b, c, centre) lies on.
_CHILD_EDGES = np.array([[0, 2], [0, 1], [1, 2], [-1, -1]])


def refined_topology(hier: Hierarchy, split: np.ndarray, new: np.ndarray):
    """Close a set of split nodes conformingly from the nodes ``new`` ``(k,)`` (above the
    deepest level) that split: a leaf with two or three split neighbours is split too (a
    green bisection closes one hanging vertex only), and so is the neighbour of a split
    node's parent across an edge the node lies on (neighbours differ by one level at most).

    Only the neighbourhood of what changed is looked at: each round takes the nodes split in
    the round before. The hierarchy is built where the closure reaches
    (:meth:`Hierarchy.ensure`), in one batch per pass: a pass runs its rounds on the
    hierarchy as it is (a node not built yet has no children to look at, and may miss
    neighbours), then the nodes it looked at that were not built are built and looked at
    again, until a pass meets only built nodes.

    Returns
    -------
    split : (N,) bool
        The closed set (longer than ``split`` ``(n,)`` where the hierarchy grew).
    added : (a,) int
        The nodes split in all, ``new`` first.
    """
    new = np.asarray(new, dtype=np.int64)
    ext = _with_sentinel(split, hier)  # a missing neighbour (-1) reads the last entry: False
    ext[new] = True
    done, frontier = [new], new
    while len(frontier):
        looked = [frontier]
        while len(frontier):
            frontier = _closure_round(hier, ext, frontier)
            ext[frontier] = True
            looked.append(frontier)
        done += looked[1:]
        seen = np.concatenate(looked)
        frontier = seen[~hier.node_ready[seen]]  # the others saw all they border
        if hier.ensure(frontier):
            ext = _with_sentinel(ext[:-1], hier)
    return ext[:-1], np.concatenate(done)


def _closure_round(hier: Hierarchy, ext: np.ndarray, frontier: np.ndarray) -> np.ndarray:
    """``(c,)``: the nodes that must split because ``frontier`` did (``ext`` ``(N + 1,)``:
    the split set and a False sentinel).
    """
    mark = hier.scratch()  # dedupes without sorting
    kids = hier.node_child[frontier]
    kids = (kids[kids >= 0][:, None] + np.arange(4)).ravel()
    near = np.concatenate([hier.node_nbr.take(frontier, axis=0).ravel(), kids])
    near = distinct(near[near >= 0], mark)
    near = near[~ext[near]]
    e0, e1, e2 = ext[hier.node_nbr.take(near, axis=0)].T
    crowded = (e0 & (e1 | e2)) | (e1 & e2)  # two or three neighbours split
    cand = np.concatenate([hier.node_across.take(frontier, axis=0).ravel(), near[crowded]])
    cand = distinct(cand[cand >= 0], mark)
    return cand[~ext[cand] & (hier.node_level[cand] < hier.depth)]


def _with_sentinel(split: np.ndarray, hier: Hierarchy) -> np.ndarray:
    """``(N + 1,) bool``: ``split`` over all of ``hier``'s nodes, then False."""
    out = np.zeros(len(hier.node_tri) + 1, bool)
    out[:len(split)] = split
    return out


def distinct(ids: np.ndarray, slot: np.ndarray) -> np.ndarray:
    """``ids`` without repeats, in linear time; ``slot`` ``(N,) int`` is all -1 before and
    after.
    """
    at = np.arange(len(ids))
    slot[ids] = at  # the last occurrence of each id wins
    out = ids[slot[ids] == at]
    slot[ids] = -1
    return out


def split_in_order(hier: Hierarchy, split: np.ndarray, roots: np.ndarray | None = None):
    """The split set ``split`` ``(N,) bool`` walked breadth first: level by level, the
    nodes in the order of their parents (roots by index, children by corner): an order
    that does not depend on the order the hierarchy was built in. ``roots`` ``(r,)``
    (increasing) restricts the walk to their subtrees.

    Returns
    -------
    split_ids : (s,) int
        The split nodes, in that order.
    leaves : (l,) int
        The nodes of the mesh (not split, a root or a split node's child), in that order.
    """
    nodes = np.arange(hier.n_roots) if roots is None else roots
    splits, leaves = [], []
    while len(nodes):
        s = split[nodes]
        leaves.append(nodes[~s])
        nodes = nodes[s]
        splits.append(nodes)
        first = hier.node_child[nodes]
        if len(first) and first.min() < 0:
            raise ValueError(f"split node {int(nodes[first.argmin()])} has no children in "
                             "the hierarchy: close the split set with refined_topology "
                             "(it builds what splits) before assembling its mesh")
        nodes = (first[:, None] + np.arange(4)).ravel()
    return np.concatenate(splits), np.concatenate(leaves)


def canonical_order(hier: Hierarchy, split: np.ndarray,
                    split_ids: np.ndarray | None = None) -> np.ndarray:
    """``(v,)``: the vertices of the mesh of the closed split set ``split`` in an order that
    does not depend on the order the hierarchy was built in: the skin's vertices, then the
    midpoints of the split nodes as :func:`split_in_order` meets them (``split_ids``, if
    given: those of a walk from roots that hold every split root, as
    :func:`conforming_triangles` returns them; the walk is not made again).
    """
    if split_ids is None:
        split_ids, _ = split_in_order(hier, split, np.flatnonzero(split[:hier.n_roots]))
    mids = hier.node_mid.take(split_ids, axis=0).ravel()
    return np.concatenate([np.arange(hier.n_root), first_seen(mids, hier.point_scratch())])


def first_seen(ids: np.ndarray, slot: np.ndarray) -> np.ndarray:
    """``ids`` without repeats, each where it first occurs (:func:`distinct`, which keeps
    the last occurrence, of the reversed ids).
    """
    return distinct(ids[::-1], slot)[::-1]


def _present(hier: Hierarchy, split_ids: np.ndarray) -> np.ndarray:
    """``(n_points + 1,) bool``: the vertices of the mesh of ``split_ids``, then False (what
    a missing midpoint, -1, reads).
    """
    present = np.zeros(hier.n_points + 1, bool)
    present[:hier.n_root] = True
    present[hier.node_mid.take(split_ids, axis=0).ravel()] = True
    return present


def _check_level_rule(hier: Hierarchy, split: np.ndarray, split_ids: np.ndarray) -> None:
    """Refuse (``ValueError``) split nodes ``split_ids`` ``(s,)`` whose parent's neighbour
    across an edge they lie on (``node_across``) is not in ``split`` ``(N,) bool``.
    """
    across = hier.node_across.take(split_ids, axis=0).ravel()
    ok = split.take(np.maximum(across, 0)) | (across < 0)
    if not ok.all():
        bad = int(np.flatnonzero(~ok)[0])
        raise ValueError(f"the split set is not closed: node {int(split_ids[bad // 2])} "
                         f"split but node {int(across[bad])}, across its parent's edge, did "
                         "not (the level rule); close it with refined_topology before "
                         "assembling its mesh")


def conforming_triangles(hier: Hierarchy, split: np.ndarray, roots: np.ndarray | None = None,
                         *, check: bool = True):
    """The mesh of a closed split set: every leaf, bisected where one edge has a midpoint
    (of ``roots``' subtrees only, if given: then a leaf is bisected where a node among them
    split).

    A split node without children is refused (``ValueError``). With ``check``, so is a set
    that :func:`refined_topology` did not close otherwise: where a node breaks the level
    rule (a split node's parent has a neighbour across an edge the node lies on that did
    not split: neighbours would differ by two levels, and the finer side's vertex would
    hang on the coarser side's edge) or a leaf has more than one split neighbour. The
    refinement engine, whose sets come from :func:`refined_topology`, leaves ``check`` off
    in its frame loop.

    Returns
    -------
    triangles : (t, 3) int
        Hierarchy vertex ids, counter-clockwise; whole leaves in the order of
        :func:`split_in_order`, then the halves of the bisected ones (the same rows,
        renamed, whatever order the hierarchy was built in).
    nodes : (t,) int
        The node each triangle lies in.
    present : (v,) bool
        The vertices the mesh uses.
    split_ids : (s,) int
        The split nodes under those roots, as :func:`split_in_order` walks them.
    """
    split_ids, leaf = split_in_order(hier, split, roots)
    if check:
        _check_level_rule(hier, split, split_ids)
    present = _present(hier, split_ids)
    tri = hier.node_tri.take(leaf, axis=0)
    mids = hier.node_mid.take(leaf, axis=0)
    h0, h1, h2 = present[mids].T  # a closed set's leaf has at most one midpoint
    cut = h0 | h1 | h2
    whole = np.flatnonzero(~cut)
    g = np.flatnonzero(cut)
    if check and (np.count_nonzero(h0) + np.count_nonzero(h1) + np.count_nonzero(h2)
                  != len(g)):
        raise ValueError("the split set is not closed: a leaf has two or three split "
                         "neighbours (a green bisection closes one); close it with "
                         "refined_topology before assembling its mesh")
    at = 3 * g + h1[g] + 2 * h2[g]  # the cut edge's first corner k, in tri.ravel()
    nxt = at + np.where(h2[g], -2, 1)  # corner k + 1
    vk, vk1, vk2 = (tri.take(i) for i in (at, nxt, 9 * g + 3 - at - nxt))
    m = mids.take(at)
    triangles = np.concatenate([tri.take(whole, axis=0), np.stack([vk, m, vk2], axis=1),
                                np.stack([m, vk1, vk2], axis=1)])
    nodes = np.concatenate([leaf.take(whole), leaf.take(g), leaf.take(g)])
    return triangles, nodes, present[:-1], split_ids
