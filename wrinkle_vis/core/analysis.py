"""Measurements of how a wrinkled surface reads: sections, crests and furrows, furrow runs,
fold angles, turned-over triangles and the direction of the normals' change.

Every function takes plain arrays on a :class:`~wrinkle_vis.core.mesh.TriangleSurface`, so it
works on any mesh: the built-in face, a refined skin (``state.face.skin``) or a scan. Units
are those of the points (millimetres for the built-in face); angles are in degrees.

Examples
--------
Furrows of the total wrinkle amplitude along the vertical line ``x = 8`` of a frame:

>>> lines = section(state.face.skin, state.W, (8.0, 0.0, 0.0), (1.0, 0.0, 0.0))  # doctest: +SKIP
>>> f = furrows(lines[0].s, lines[0].values, prominence=0.05)  # doctest: +SKIP
>>> f.s, f.depth, f.side_slope_deg  # doctest: +SKIP
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.signal import find_peaks
from scipy.sparse.csgraph import connected_components, depth_first_order
from scipy.spatial.distance import cdist

from .mesh import TriangleSurface, unit_rows

__all__ = [
    "Extrema",
    "region_union",
    "section_extrema",
    "FurrowRun",
    "Polyline",
    "crests",
    "dihedral_change",
    "edge_triangles",
    "furrow_runs",
    "furrows",
    "normal_change_anisotropy",
    "plateau_edge",
    "section",
    "shading_crease",
    "signed_dihedral",
    "turned_over",
]


# ---------------------------------------------------------------------- sections
@dataclass(frozen=True, eq=False)
class Polyline:
    """One connected piece of a plane's cut through a surface.

    Attributes
    ----------
    points : (k, 3) float
        The crossing points, in order along the cut.
    s : (k,) float
        Arc length from the first point.
    values : (k,) or (k, c) float, or None
        The field given to :func:`section`, interpolated linearly along the cut edges.
    edges : (k,) int
        The surface edge (row of ``surface.edges``) that each point lies on.
    t : (k,) float
        Where on its edge ``(i, j)`` each point lies: ``(1 - t) x_i + t x_j``.
    closed : bool
        Whether the cut is a loop; its last point then repeats its first.
    """

    points: np.ndarray
    s: np.ndarray
    values: np.ndarray | None
    edges: np.ndarray
    t: np.ndarray
    closed: bool

    def __len__(self) -> int:
        return len(self.s)

    @property
    def length(self) -> float:
        """Arc length of the whole polyline."""
        return float(self.s[-1])

    def sample(self, surface: TriangleSurface, field) -> np.ndarray:
        """``(k,)`` or ``(k, c)``: another per-vertex field ``(n,)`` or ``(n, c)`` of
        ``surface`` interpolated at these points (as :func:`section` interpolates
        ``values``).
        """
        f = np.asarray(field, dtype=float)
        e = surface.edges[self.edges]
        t = self.t.reshape((-1,) + (1,) * (f.ndim - 1))
        return (1.0 - t) * f[e[:, 0]] + t * f[e[:, 1]]


def section(surface: TriangleSurface, values, origin, normal, mask=None, *, points=None,
            order_axis=None) -> list[Polyline]:
    r"""Cut a surface with a plane: the ordered polylines where the plane crosses it.

    Parameters
    ----------
    surface : TriangleSurface
        The surface (its ``edges`` and ``triangle_edges`` are used).
    values : (n,) or (n, c) array_like of float, or None
        A per-vertex field to interpolate along the cut.
    origin : (3,) array_like of float
        A point of the plane.
    normal : (3,) array_like of float
        The plane's normal (any length but 0).
    mask : (n,) array_like of bool, optional
        Keep only where this holds: it is interpolated as 0/1 like ``values`` and each
        polyline is split into the runs of consecutive points where it is above 0.5 (a run
        stops at its last such crossing; nothing is clipped at 0.5).
    points : (n, 3) array_like of float, optional
        Cut the surface at these positions instead of ``surface.points`` (e.g. a deformed
        frame on the rest connectivity).
    order_axis : int or (3,) array_like of float, optional
        Each open polyline runs in the direction of increasing projection on this axis (an
        index 0, 1, 2 for x, y, z, or a vector) and the polylines are listed in the order of
        their first points' projection. By default the coordinate axis most nearly in the
        plane (the lowest index on a tie): y for a plane ``x = c``, x for ``y = c`` or
        ``z = c``. A loop starts at its lowest point on the axis and runs counter-clockwise
        about ``normal``.

    Returns
    -------
    list of Polyline
        Polylines of at least two points. Each point is where the plane crosses a surface
        edge; each crossed triangle joins its two crossed edges.

    Notes
    -----
    A vertex closer to the plane than :math:`10^{-9}` times the surface's extent counts as
    lying on its positive side, so a plane through vertices (a grid line, say) still gives one
    clean cut, whose crossings sit exactly on those vertices; crossing points closer than
    ten times that to the previous one are dropped. So a plane along a boundary row of
    vertices cuts along it when the surface lies on its negative side and misses it when
    the surface lies on its positive side. Cuts stop at non-manifold edges.
    """
    p = surface.points if points is None else np.asarray(points, dtype=float)
    n = _unit(normal)
    a = _order_axis(order_axis, n)
    tol = 1e-9 * (float(np.ptp(p, axis=0).max()) or 1.0)  # of the surface's extent
    crossed = _crossings(surface, p, origin, n, tol)
    if crossed is None:
        return []
    m = None if mask is None else np.asarray(mask, dtype=float)
    vals = None if values is None else np.asarray(values, dtype=float)
    out = [line for chain, closed in _chains(_crossing_graph(surface, crossed[0]), crossed[4],
                                             tol, a, n)
           for line in _chain_polylines(chain, closed, crossed, m, vals)]
    out.sort(key=lambda pl: float(pl.points[0] @ a))
    return out


def _chain_polylines(chain: np.ndarray, closed: bool, crossed: tuple, m: np.ndarray | None,
                     vals: np.ndarray | None) -> list[Polyline]:
    """The polylines of one chain of crossings (``crossed``: :func:`_crossings`'), split
    into its runs inside mask ``m`` ``(n,)`` when given, with ``vals`` interpolated.
    """
    cut, i, j, t, xp = crossed
    runs = [chain]
    if m is not None:
        inside = (1.0 - t[chain]) * m[i[chain]] + t[chain] * m[j[chain]] > 0.5
        runs = _runs(chain, inside, closed)
        closed = closed and bool(inside.all())
    return [_polyline(r, xp, t, cut, i, j, vals, closed) for r in runs if len(r) >= 2]


def _crossings(surface: TriangleSurface, p: np.ndarray, origin, n: np.ndarray, tol: float):
    """Where the plane through ``origin`` of unit normal ``n`` crosses the edges of
    ``surface`` at points ``p`` ``(n, 3)`` (a vertex within ``tol`` of it on its positive
    side): ``(cut, i, j, t, xp)``, the crossed edges ``(k,)``, their ends ``(k,)`` each,
    the crossing's parameter along them ``(k,)`` and the crossing points ``(k, 3)``; None
    when it crosses none.
    """
    d = (p - np.asarray(origin, dtype=float)) @ n
    pos = (d > 0.0) | (np.abs(d) < tol)
    E = surface.edges
    cut = np.flatnonzero(pos[E[:, 0]] != pos[E[:, 1]])
    if len(cut) == 0:
        return None
    i, j = E[cut, 0], E[cut, 1]
    t = np.clip(d[i] / (d[i] - d[j]), 0.0, 1.0)  # the sides differ: no division by 0
    return cut, i, j, t, p[i] + t[:, None] * (p[j] - p[i])


def _crossing_graph(surface: TriangleSurface, cut: np.ndarray) -> sp.csr_matrix:
    """``(k, k)``: the crossings of edges ``cut`` ``(k,)`` joined where a triangle has two
    of them (none through a crossing that more than two triangles would join: cuts stop at
    non-manifold edges).
    """
    node = np.full(len(surface.edges), -1)
    node[cut] = np.arange(len(cut))
    tn = -np.sort(-node[surface.triangle_edges], axis=1)  # crossed nodes first
    two = tn[:, 1] >= 0  # a crossed triangle has exactly two crossed edges
    u, v = tn[two, 0], tn[two, 1]
    degree = np.bincount(np.r_[u, v], minlength=len(cut))
    ok = (degree[u] <= 2) & (degree[v] <= 2)  # stop at non-manifold edges
    u, v = u[ok], v[ok]
    k = len(cut)
    return sp.csr_matrix((np.ones(2 * len(u)), (np.r_[u, v], np.r_[v, u])), shape=(k, k))


def _chains(graph: sp.csr_matrix, xp: np.ndarray, tol: float, a: np.ndarray, n: np.ndarray):
    """Each connected chain of crossings of ``graph`` as ``(chain, closed)``: the crossings
    in order (points ``xp``), without repeats closer than ``10 tol``, oriented along ``a``
    (a loop counter-clockwise about ``n``, its first crossing repeated at its end).
    """
    degree = np.diff(graph.indptr)
    n_comp, label = connected_components(graph, directed=False)
    order = np.argsort(label, kind="stable")
    starts = np.searchsorted(label[order], np.arange(n_comp + 1))
    for c in range(n_comp):
        members = order[starts[c]:starts[c + 1]]
        if len(members) < 2:
            continue
        ends = members[degree[members] == 1]
        closed = len(ends) == 0
        chain = depth_first_order(graph, int(ends[0] if len(ends) else members[0]),
                                  directed=False, return_predecessors=False)
        chain = _dedupe(chain, xp, 10.0 * tol, closed)
        if len(chain) < 2:
            continue
        chain = _oriented(chain, xp, a, n, closed)
        yield (np.r_[chain, chain[0]] if closed else chain), closed


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float).reshape(3)
    norm = np.linalg.norm(v)
    if not norm > 0:
        raise ValueError(f"a direction must be a non-zero 3-vector; got {v.tolist()}")
    return v / norm


def _order_axis(order_axis, n: np.ndarray) -> np.ndarray:
    if order_axis is None:
        return np.eye(3)[int(np.argmin(np.abs(n)))]
    if np.ndim(order_axis) == 0:
        return np.eye(3)[int(order_axis)]
    return _unit(order_axis)


def _dedupe(chain: np.ndarray, xp: np.ndarray, tol: float, closed: bool) -> np.ndarray:
    """``chain`` without points within ``tol`` of the previous kept one."""
    step = np.linalg.norm(np.diff(xp[chain], axis=0), axis=1)
    keep = np.r_[True, step > tol]
    if not keep.all():  # rare (a plane through vertices): walk it
        kept = [0]
        for q in range(1, len(chain)):
            if np.linalg.norm(xp[chain[q]] - xp[chain[kept[-1]]]) > tol:
                kept.append(q)
        chain = chain[kept]
    if closed and len(chain) > 2 and np.linalg.norm(xp[chain[-1]] - xp[chain[0]]) <= tol:
        chain = chain[:-1]
    return chain


def _oriented(chain, xp, a, n, closed) -> np.ndarray:
    q = xp[chain]
    if not closed:
        return chain[::-1] if (q[-1] - q[0]) @ a < 0 else chain
    area = np.cross(q, np.roll(q, -1, axis=0)).sum(axis=0) @ n
    if area < 0:
        chain = chain[::-1]
    return np.roll(chain, -int(np.argmin(xp[chain] @ a)))


def _runs(chain: np.ndarray, inside: np.ndarray, closed: bool) -> list[np.ndarray]:
    """The runs of consecutive ``chain`` entries where ``inside`` holds."""
    if inside.all():
        return [chain]
    if closed:  # start the loop outside so that no run wraps round
        chain, inside = chain[:-1], inside[:-1]
        first_out = int(np.flatnonzero(~inside)[0])
        chain, inside = np.roll(chain, -first_out), np.roll(inside, -first_out)
    edges = np.flatnonzero(np.diff(np.r_[0, inside.astype(np.int8), 0]))
    return [chain[b:e] for b, e in zip(edges[::2], edges[1::2], strict=True)]


def _polyline(r, xp, t, cut, i, j, vals, closed) -> Polyline:
    q = xp[r]
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))]
    v = None
    if vals is not None:
        w = t[r].reshape((-1,) + (1,) * (vals.ndim - 1))
        v = (1.0 - w) * vals[i[r]] + w * vals[j[r]]
    return Polyline(points=q, s=s, values=v, edges=cut[r], t=t[r], closed=closed)


# ---------------------------------------------------------------------- crests and furrows
@dataclass(frozen=True, eq=False)
class Extrema:
    r"""Crests (local maxima) or furrow bottoms (local minima) along a line.

    Attributes
    ----------
    index : (k,) int
        Sample index of each extremum.
    s : (k,) float
        Its position along the line.
    value : (k,) float
        The field there.
    prominence : (k,) float
        ``scipy.signal.peak_prominences`` of the field (crests) or of its negative
        (furrows): for a furrow, the height of the lower of its two bounding crests above
        its bottom.
    side_slope_deg : (k,) float
        The steepest wall between the extremum and its neighbouring extrema of the other
        kind, :math:`\arctan \max |dW/ds|` in degrees, from the segment slopes of the
        samples (the exact slopes of the piecewise-linear field along a section).
    """

    index: np.ndarray
    s: np.ndarray
    value: np.ndarray
    prominence: np.ndarray
    side_slope_deg: np.ndarray

    def __len__(self) -> int:
        return len(self.index)

    @property
    def depth(self) -> np.ndarray:
        """``(k,)``: the prominence; for furrows, the furrow depth."""
        return self.prominence


def crests(s, W, prominence: float) -> Extrema:
    """Local maxima of a field along a line, with at least a given prominence.

    Parameters
    ----------
    s : (k,) array_like of float
        Increasing positions along the line (e.g. :attr:`Polyline.s`).
    W : (k,) array_like of float
        The field there; finite.
    prominence : float
        The least absolute prominence (``scipy.signal.find_peaks``), in the units of ``W``.

    Returns
    -------
    Extrema
        The crests in order along the line; ``side_slope_deg`` is the steepest wall down to
        the neighbouring furrow bottoms (of the same prominence) or, where there is none, to
        the prominence bases.
    """
    return _extrema(s, W, prominence, 1.0)


def furrows(s, W, prominence: float) -> Extrema:
    r"""Local minima (furrow bottoms) of a field along a line.

    Parameters
    ----------
    s : (k,) array_like of float
        Increasing positions along the line.
    W : (k,) array_like of float
        The field there; finite.
    prominence : float
        The least absolute depth of a furrow.

    Returns
    -------
    Extrema
        The bottoms in order along the line. ``depth`` (the prominence of ``-W``) is the
        height of the lower of the two bounding crests above the bottom, and
        ``side_slope_deg`` is :math:`\arctan \max |dW/ds|` between the bottom and its
        neighbouring crests (of the same prominence; where there is none on a side, its
        prominence base), in degrees.
    """
    return _extrema(s, W, prominence, -1.0)


def _extrema(s, W, prominence: float, sign: float) -> Extrema:
    s = np.asarray(s, dtype=float)
    W = np.asarray(W, dtype=float)
    if s.shape != W.shape or s.ndim != 1:
        raise ValueError(f"s and W must be 1-D of one length; got {s.shape} and {W.shape}")
    idx, props = find_peaks(sign * W, prominence=prominence)
    if len(idx) == 0:
        empty = np.zeros(0)
        return Extrema(idx, empty, empty, empty, empty)
    other, _ = find_peaks(-sign * W, prominence=prominence)
    other = np.r_[-1, other, len(W)]  # sentinels: no neighbour on that side
    pos = np.searchsorted(other, idx)
    left, right = other[pos - 1], other[pos]
    lo = np.maximum(left, props["left_bases"])
    hi = np.minimum(right, props["right_bases"])
    ds, dW = np.diff(s), np.diff(W)
    slope = np.abs(np.divide(dW, ds, out=np.zeros_like(dW), where=ds > 0))
    steepest = np.array([slope[a:b].max() for a, b in zip(lo, hi, strict=True)])
    return Extrema(index=idx, s=s[idx], value=W[idx], prominence=props["prominences"],
                   side_slope_deg=np.degrees(np.arctan(steepest)))


# ---------------------------------------------------------------------- furrow runs
@dataclass(frozen=True, eq=False)
class FurrowRun:
    """A furrow followed across a series of parallel sections.

    Attributes
    ----------
    points : (k, 3) float
        Its bottom on each section, in order.
    sections : (k,) int
        The index into ``offsets`` of each of those sections.
    depth : (k,) float
        The furrow depth at each bottom.
    length : float
        Sum of the 3D distances between consecutive bottoms.
    """

    points: np.ndarray
    sections: np.ndarray
    depth: np.ndarray
    length: float

    def __len__(self) -> int:
        return len(self.sections)


def furrow_runs(surface: TriangleSurface, W, offsets, normal_axis=0, mask=None,
                prominence: float = 0.05, max_jump: float = 3.0, *, points=None,
                order_axis=None) -> list[FurrowRun]:
    """Furrows followed from section to section across a surface.

    Parameters
    ----------
    surface : TriangleSurface
        The surface.
    W : (n,) array_like of float
        The field whose furrows are followed (e.g. the total wrinkle amplitude).
    offsets : (p,) array_like of float
        Increasing offsets of the section planes along ``normal_axis``, e.g. ``x = c`` every
        2 mm across a forehead.
    normal_axis : int or (3,) array_like of float, default 0
        The planes' normal: a coordinate axis index or a vector; plane ``k`` is
        ``offsets[k] * unit(normal) + {v : v . normal = 0}``.
    mask : (n,) array_like of bool, optional
        Where to look (see :func:`section`).
    prominence : float, default 0.05
        The least furrow depth (:func:`furrows`).
    max_jump : float, default 3.0
        A bottom is linked to a bottom on the next section when the 3D distance between them
        is below ``max_jump`` plus the step between the two planes.
    points : (n, 3) array_like of float, optional
        Positions to cut and measure on instead of ``surface.points``.
    order_axis : int or (3,) array_like, optional
        Passed to :func:`section`.

    Returns
    -------
    list of FurrowRun
        Every run (a lone bottom is a run of length 0), longest first.

    Notes
    -----
    Links between two neighbouring sections are one to one: candidate pairs are taken in
    order of increasing distance, each bottom joining at most one on either side, so two
    furrows that approach each other do not merge. A run ends at a section with no matching
    bottom.
    """
    Wv = np.asarray(W, dtype=float)
    n = np.eye(3)[int(normal_axis)] if np.ndim(normal_axis) == 0 else _unit(normal_axis)
    offsets = np.asarray(offsets, dtype=float)
    p = surface.points if points is None else np.asarray(points, dtype=float)
    bottoms = [_section_bottoms(section(surface, Wv, c * n, n, mask, points=p,
                                        order_axis=order_axis), prominence)
               for c in offsets]
    runs = _linked_runs([b[0] for b in bottoms], offsets, max_jump)
    out = []
    for run in runs:
        sec = np.array([k for k, _ in run])
        run_points = np.array([bottoms[k][0][q] for k, q in run])
        run_depth = np.array([bottoms[k][1][q] for k, q in run])
        length = float(np.linalg.norm(np.diff(run_points, axis=0), axis=1).sum())
        out.append(FurrowRun(points=run_points, sections=sec, depth=run_depth, length=length))
    out.sort(key=lambda r: -r.length)
    return out


def _section_bottoms(lines: list[Polyline], prominence: float
                     ) -> tuple[np.ndarray, np.ndarray]:
    """The furrow bottoms of one section's polylines ``lines``: their points ``(k, 3)`` and
    depths ``(k,)`` (:func:`furrows`).
    """
    found: list[np.ndarray] = []
    depths: list[np.ndarray] = []
    for line in lines:
        f = furrows(line.s, line.values, prominence)
        found.append(line.points[f.index])
        depths.append(f.depth)
    return (np.concatenate(found) if found else np.zeros((0, 3)),
            np.concatenate(depths) if depths else np.zeros(0))


def _linked_runs(bottoms: list[np.ndarray], offsets: np.ndarray, max_jump: float
                 ) -> list[list[tuple[int, int]]]:
    """The bottoms ``(k_s, 3)`` of each section linked one to one into runs: each run the
    ``(section, bottom)`` pairs it goes through (see :func:`furrow_runs`).
    """
    run_of = [np.full(len(b), -1) for b in bottoms]
    runs: list[list[tuple[int, int]]] = []
    for k, pts in enumerate(bottoms):
        for q in range(len(pts)):
            if run_of[k][q] < 0:
                run_of[k][q] = len(runs)
                runs.append([(k, q)])
        if k + 1 == len(bottoms) or len(pts) == 0 or len(bottoms[k + 1]) == 0:
            continue
        dist = cdist(pts, bottoms[k + 1])
        limit = max_jump + abs(offsets[k + 1] - offsets[k])
        for a, b in _nearest_pairs(dist, limit):
            run = run_of[k][a]
            run_of[k + 1][b] = run
            runs[run].append((k + 1, int(b)))
    return runs


def _nearest_pairs(dist: np.ndarray, limit: float) -> list[tuple[int, int]]:
    """Pairs ``(a, b)`` of rows and columns of ``dist`` ``(m, k)`` closer than ``limit``,
    one to one, taken in order of increasing distance.
    """
    a, b = np.nonzero(dist < limit)
    taken_a, taken_b = set(), set()
    pairs = []
    for r in np.argsort(dist[a, b], kind="stable"):
        if a[r] in taken_a or b[r] in taken_b:
            continue
        taken_a.add(a[r])
        taken_b.add(b[r])
        pairs.append((a[r], b[r]))
    return pairs


# ---------------------------------------------------------------------- folds and flips
def edge_triangles(surface: TriangleSurface) -> np.ndarray:
    """``(e, 2) int``: the two triangles on each edge of ``surface.edges``, the first one
    traversing it from ``edges[:, 0]`` to ``edges[:, 1]`` where the surface is consistently
    oriented; ``-1`` in both columns for boundary and non-manifold edges.
    """
    te = surface.triangle_edges
    n_e = len(surface.edges)
    count = np.bincount(te.ravel(), minlength=n_e)
    flat = te.ravel()
    order = np.argsort(flat, kind="stable")
    first = np.searchsorted(flat[order], np.arange(n_e))
    out = np.full((n_e, 2), -1)
    two = np.flatnonzero(count == 2)
    out[two, 0] = order[first[two]] // 3
    out[two, 1] = order[first[two] + 1] // 3
    # put first the triangle that runs lo -> hi along the edge
    tri = surface.triangles[out[two, 0]]
    lo = surface.edges[two, 0]
    k = np.argmax(tri == lo[:, None], axis=1)
    forward = tri[np.arange(len(two)), (k + 1) % 3] == surface.edges[two, 1]
    out[two[~forward]] = out[two[~forward]][:, ::-1]
    return out


def signed_dihedral(surface: TriangleSurface, points=None) -> np.ndarray:
    r"""``(e,)``: signed bending angle across each edge in degrees, ``nan`` off manifold.

    The angle from the normal of the edge's first triangle (:func:`edge_triangles`) to that
    of its second, about the edge direction ``x_j - x_i``: 0 where flat, positive where an
    outward-oriented surface is convex, in :math:`(-180, 180]`.

    Parameters
    ----------
    surface : TriangleSurface
        The surface.
    points : (n, 3) array_like of float, optional
        Positions to measure at instead of ``surface.points``.
    """
    p = surface.points if points is None else np.asarray(points, dtype=float)
    et = edge_triangles(surface)
    ok = et[:, 0] >= 0
    fn = surface.face_normals(p)
    n1, n2 = fn[et[ok, 0]], fn[et[ok, 1]]
    e = surface.edges[ok]
    axis = unit_rows(p[e[:, 1]] - p[e[:, 0]])
    out = np.full(len(et), np.nan)
    out[ok] = np.degrees(np.arctan2(np.einsum("ij,ij->i", np.cross(n1, n2), axis),
                                    np.einsum("ij,ij->i", n1, n2)))
    return out


def dihedral_change(surface: TriangleSurface, rest_points, points) -> np.ndarray:
    r"""``(e,)``: how much the fold across each edge changes, in degrees.

    Parameters
    ----------
    surface : TriangleSurface
        The connectivity.
    rest_points, points : (n, 3) array_like of float
        The two positions to compare.

    Returns
    -------
    (e,) float ndarray
        :math:`|\theta(points) - \theta(rest)|` wrapped to ``[0, 180]`` for the signed
        dihedral :math:`\theta` (:func:`signed_dihedral`) of each row of ``surface.edges``;
        ``nan`` for boundary and non-manifold edges. The sign makes a fold that turns from
        convex to concave count fully. Zero for a rigid motion.
    """
    d = signed_dihedral(surface, points) - signed_dihedral(surface, rest_points)
    return np.abs((d + 180.0) % 360.0 - 180.0)


def shading_crease(surface: TriangleSurface, rest_normals, normals) -> np.ndarray:
    r"""``(e,)``: how much the turn of the shading normals across each edge changes, in
    degrees.

    Parameters
    ----------
    surface : TriangleSurface
        The connectivity (``surface.edges``).
    rest_normals, normals : (n, 3) array_like of float
        The unit vertex normals the skin is shaded with at rest and in the frame.

    Returns
    -------
    (e,) float ndarray
        With :math:`\Delta = n_j - n_i` and :math:`\Delta^0 = r_j - r_i` across the edge
        :math:`(i, j)`,

        .. math:: c = 2 \arcsin\left(\min\left(1, \tfrac12
                      \|\Delta - \Delta^0\|\right)\right),

        the angle of the chord :math:`\|\Delta - \Delta^0\|` on the unit sphere: 0 where
        the frame turns the normals across the edge as the rest does (a rigid turn of a
        region by :math:`\phi` changes it by at most :math:`\phi` times the rest's turn),
        the full turn of a new fold, and twice a fold that flips from convex to concave.

    Notes
    -----
    Smooth shading interpolates the vertex normals, so what a raking light shows as an edge
    is a jump of the normal between neighbouring vertices. :func:`dihedral_change` compares
    the facets; this compares the normals a renderer is given, which is what differs when a
    refined skin is shaded with its facets' own normals beside a coarse one shaded with
    interpolated normals (:func:`plateau_edge`).
    """
    e = surface.edges
    n = np.asarray(normals, dtype=float)
    r = np.asarray(rest_normals, dtype=float)
    d = (n[e[:, 1]] - n[e[:, 0]]) - (r[e[:, 1]] - r[e[:, 0]])
    half = np.minimum(1.0, 0.5 * np.sqrt(np.einsum("ij,ij->i", d, d)))
    return np.degrees(2.0 * np.arcsin(half))


def plateau_edge(state, floor: float = 1e-3) -> np.ndarray:
    r"""``(k,)``: the shading crease (:func:`shading_crease`, degrees) that the skin
    deformation alone adds to a frame as it is shown, on the edges of ``state.face.skin``
    with an end moved by more than ``floor`` times the skin's mean edge length.

    The frame without wrinkles (``state.deformed_points``) shaded with
    :meth:`~wrinkle_vis.core.state.FaceState.shading_normals`, against the rest skin shaded
    with the rest normals a renderer gives it (``state.face.rest_normals``: the vertex
    normals of the rest skin, and on a refined skin the Phong normals that carry them to
    the new vertices). A raised plateau whose sides show as edges under a raking light, or
    seams inside it, is a line of large values; the old measure
    (:func:`dihedral_change` of the refined frame against the refined rest) cannot see a
    seam that the refined rest skin itself has.
    """
    surface = state.face.skin
    rest, moved = state.rest_points, state.deformed_points
    shown = state.shading_normals(moved)
    change = shading_crease(surface, state.face.rest_normals, shown)
    far = np.linalg.norm(moved - rest, axis=1) > floor * surface.mean_edge_length
    return change[far[surface.edges].any(axis=1)]


def turned_over(surface: TriangleSurface, rest_points, points) -> np.ndarray:
    """``(m,) bool``: triangles whose normal at ``points`` does not point within 90 degrees
    of their normal at ``rest_points`` (dot product <= 0; a collapsed triangle counts).

    The comparison is in one frame: meant for deformations that leave the surface where it
    was (a face's expression), not for a rigid turn of the whole surface.

    Parameters
    ----------
    surface : TriangleSurface
        The connectivity.
    rest_points, points : (n, 3) array_like of float
        The two positions to compare.
    """
    a = surface.face_normals(np.asarray(rest_points, dtype=float))
    b = surface.face_normals(np.asarray(points, dtype=float))
    return np.einsum("ij,ij->i", a, b) <= 0.0


# ---------------------------------------------------------------------- anisotropy
def _fibre_frames(rest: np.ndarray, tri: np.ndarray, fibre):
    """Per triangle ``tri`` ``(m, 3)`` of ``rest`` ``(n, 3)``: the fibre ``(3,)`` or
    ``(m, 3)`` projected into its plane and made unit ``t``, ``b = normal x t``, the
    gradients of its corner-1 and corner-2 hat functions ``g1``, ``g2`` (``(m, 3)`` each),
    its squared double area ``nn`` ``(m,)`` and ``ok`` ``(m,) bool`` where the projected
    fibre is defined.
    """
    p0, p1, p2 = rest[tri[:, 0]], rest[tri[:, 1]], rest[tri[:, 2]]
    e1, e2 = p1 - p0, p2 - p0
    N = np.cross(e1, e2)
    nn = np.einsum("ij,ij->i", N, N)
    f = np.broadcast_to(np.asarray(fibre, dtype=float), N.shape)
    with np.errstate(divide="ignore", invalid="ignore"):
        unit_n = N / np.sqrt(nn)[:, None]
        t = f - np.einsum("ij,ij->i", f, unit_n)[:, None] * unit_n
        t_len = np.linalg.norm(t, axis=1)
        ok = (nn > 0) & (t_len > 1e-9 * np.linalg.norm(f, axis=1))
        t = t / t_len[:, None]
        b = np.cross(unit_n, t)
        g1 = np.cross(e2, N) / nn[:, None]  # gradient of the corner-1 hat function
        g2 = np.cross(N, e1) / nn[:, None]  # and of the corner-2 one
    return t, b, g1, g2, nn, ok


def normal_change_anisotropy(surface: TriangleSurface, rest_points, points, fibre,
                             mask=None) -> float:
    r"""The fraction of the normals' spatial change that runs across the fibres.

    Parameters
    ----------
    surface : TriangleSurface
        The connectivity.
    rest_points, points : (n, 3) array_like of float
        Rest and deformed (e.g. wrinkled) positions.
    fibre : (3,) or (m, 3) array_like of float
        The fibre (contraction) direction, one for all triangles or one per triangle.
    mask : (n,) array_like of bool, optional
        Count only the triangles whose three corners are in it (default all).

    Returns
    -------
    float
        With :math:`\Delta n_i = n_i(points) - n_i(rest)` the change of the unit vertex
        normals, :math:`G_t` the gradient of :math:`\Delta n` on rest triangle :math:`t`
        (the linear map on the triangle's plane that takes its three corner values), ``f``
        the fibre projected into the triangle's plane and normalised, and
        ``b = normal x f``:

        .. math:: \frac{\sum_t a_t |G_t f|^2}{\sum_t a_t (|G_t f|^2 + |G_t b|^2)}

        over the counted triangles (area :math:`a_t`; triangles whose plane is
        perpendicular to the fibre are skipped). 1 for straight furrows perpendicular to the
        fibre (the normal changes only along it), 0 for seams running along the fibre, and
        :math:`\cos^2\theta` for furrows at :math:`90° - \theta` to it. ``nan`` if the
        normals do not change where counted.

    Notes
    -----
    Why gradients per triangle rather than normal differences per edge: an edge measures
    the change along its own direction only, so each edge's :math:`|\Delta n_j - \Delta
    n_i|^2` is :math:`|\partial_f \Delta n|^2 \cos^2\phi` for a field varying along the
    fibre only and an edge at :math:`\phi` to it. Binning edges by direction (weight
    :math:`\cos^2\phi` to "across") gives :math:`\int\cos^4 / \int\cos^2 = 3/4` on an
    isotropic mesh: perfect furrows would read 0.75 and the measure would depend on the
    meshing. A triangle's gradient recovers the full in-plane derivative, exact for fields
    linear on the triangle, whatever the triangle's shape.
    """
    rest = np.asarray(rest_points, dtype=float)
    dn = surface.vertex_normals(np.asarray(points, dtype=float)) - surface.vertex_normals(rest)
    tri = surface.triangles
    t, b, g1, g2, nn, ok = _fibre_frames(rest, tri, fibre)
    if mask is not None:
        ok &= np.asarray(mask, dtype=bool)[tri].all(axis=1)
    d1 = dn[tri[ok, 1]] - dn[tri[ok, 0]]
    d2 = dn[tri[ok, 2]] - dn[tri[ok, 0]]
    area = 0.5 * np.sqrt(nn[ok])
    across = _gradient_energy(area, g1[ok], g2[ok], d1, d2, t[ok])
    total = across + _gradient_energy(area, g1[ok], g2[ok], d1, d2, b[ok])
    return across / total if total > 0 else float("nan")


def _gradient_energy(area, g1, g2, d1, d2, v) -> float:
    r""":math:`\sum_t a_t |G_t v_t|^2` with :math:`G_t v = d_1 (g_1 \cdot v) + d_2 (g_2
    \cdot v)`: the triangles' areas ``area`` ``(m,)``, hat-function gradients ``g1``,
    ``g2``, corner differences ``d1``, ``d2`` and directions ``v`` (``(m, 3)`` each).
    """
    gv = (np.einsum("ij,ij->i", g1, v)[:, None] * d1
          + np.einsum("ij,ij->i", g2, v)[:, None] * d2)
    return float(area @ np.einsum("ij,ij->i", gv, gv))


def region_union(face, prefix: str = "") -> np.ndarray:
    """``(n,) bool``: the union of the wrinkling regions (Eq. 3, 14) of the face's muscles
    whose names start with ``prefix``, on its rest skin.
    """
    rest = face.skin.points
    mask = np.zeros(len(rest), bool)
    for m in face.muscles:
        if m.name.startswith(prefix):
            mask |= np.asarray(m.region(rest)["in_region"], bool)
    return mask


def section_extrema(surface: TriangleSurface, W, axis: int, offsets, mask=None,
                    prominence: float = 0.05) -> list[dict]:
    """Crests and furrows of ``W`` on the planes ``x[axis] = c`` for ``c`` in ``offsets``.

    Parameters
    ----------
    surface : TriangleSurface
        The surface (its points are where the sections are cut, usually the rest skin).
    W : (n,) float
        The field, e.g. the total wrinkle amplitude.
    axis : int
        0, 1 or 2: the planes' normal axis.
    offsets : (k,) float
        The planes' positions along ``axis``.
    mask : (n,) bool, optional
        Keep only the parts of each section inside it (see :func:`section`).
    prominence : float
        The smallest crest or furrow counted (see :func:`crests`).

    Returns
    -------
    list of dict
        One per offset: ``offset``, ``length`` (of the kept sections), ``crests`` and
        ``furrows`` (counts), ``crest_s`` and ``furrow_s`` (positions along the section),
        ``furrow_points`` ``(f, 3)``, ``depths`` and ``side_slopes_deg`` of the furrows.
    """
    normal = np.eye(3)[axis]
    rows = []
    for c in offsets:
        lines = section(surface, W, c * normal, normal, mask)
        cr = [crests(ln.s, ln.values, prominence) for ln in lines]
        fu = [furrows(ln.s, ln.values, prominence) for ln in lines]
        rows.append({
            "offset": float(c),
            "length": float(sum(ln.length for ln in lines)),
            "crests": int(sum(len(e) for e in cr)),
            "furrows": int(sum(len(e) for e in fu)),
            "crest_s": [float(x) for e in cr for x in e.s],
            "furrow_s": [float(x) for e in fu for x in e.s],
            "furrow_points": np.concatenate(
                [ln.points[e.index] for ln, e in zip(lines, fu, strict=True)]
                or [np.zeros((0, 3))]),
            "depths": [float(x) for e in fu for x in e.depth],
            "side_slopes_deg": [float(x) for e in fu for x in e.side_slope_deg],
        })
    return rows
