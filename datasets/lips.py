r"""Separating a scan's lips: the rest skin's lip sheets moved apart where they cross.

A scan of a closed mouth often has the upper and the lower lip passing a little through each
other at the slit (the Lee Perry-Smith head: 127 crossing triangle pairs, up to 3 mm deep).
The fold guard's proof (``docs/model.md``) needs a rest skin that does not cross itself, and
the certificate (:func:`~wrinkle_vis.core.certificate.fold_report`) counts every new pair two
crossing sheets make as they slide along each other, so the built-in head's derivation
(``scripts/write_lee_perry_smith.py``) separates them first, with :func:`separate_crossings`.

Each step takes the crossing pairs (a, b) inside the region (and every pair that ever
crossed), and asks each corner v of a that lies less than ``gap`` in front of b's plane
(unit normal :math:`\hat n_b`, the outside of b's lip) to move half the difference out of
it, :math:`t_v = \tfrac12 (g - \hat n_b \cdot (x_v - x_b)) \hat n_b` (the other half is b's
share), averaged over the pairs; then the displacement :math:`d` that keeps the surface
smooth is the least-squares solution of

.. math::

    \min_d \sum_{v \in C} |d_v - t_v|^2 + \lambda \sum_{(u, w) \in E} |d_u - d_w|^2 ,

over the vertices within ``rings`` edges of the asked ones C (the others stay put), so the
lip moves as a sheet, not vertex by vertex (moving only the crossing vertices by their own
targets makes spikes that cross the next triangles, and diverges).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from wrinkle_vis.core.certificate import intersecting_pairs

__all__ = ["separate_crossings"]


def _unit_normals(points: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """``(m, 3)``: unit normals of the triangles ``tri`` ``(m, 3)`` on ``points`` ``(n, 3)``."""
    c = points[tri]
    fn = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
    return fn / np.maximum(np.linalg.norm(fn, axis=1), 1e-300)[:, None]


def _over(points: np.ndarray, tri_b: np.ndarray, q: np.ndarray, slack: float = 0.25
          ) -> np.ndarray:
    """``(k, 3)`` bool: whether the points ``q`` ``(k, 3, 3)`` (in the planes of the
    triangles ``tri_b`` ``(k, 3)``) lie in them, widened by ``slack`` in barycentric
    coordinates (a plane says nothing about a corner beside its triangle).
    """
    c = points[tri_b]
    e1, e2 = c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]
    r = q - c[:, None, 0]
    d11, d12, d22 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
    r1, r2 = np.einsum("kij,kj->ki", r, e1), np.einsum("kij,kj->ki", r, e2)
    det = np.maximum(d11 * d22 - d12 * d12, 1e-300)[:, None]
    u = (d22[:, None] * r1 - d12[:, None] * r2) / det
    w = (d11[:, None] * r2 - d12[:, None] * r1) / det
    return (u >= -slack) & (w >= -slack) & (u + w <= 1.0 + slack)


def _targets(points: np.ndarray, tri: np.ndarray, pairs: np.ndarray, gap: float
             ) -> tuple[np.ndarray, np.ndarray]:
    r"""``(n, 3)`` targets :math:`t_v` and ``(n,)`` bool: where one is asked, for the
    triangle ``pairs`` ``(k, 2)`` (module notes).
    """
    fn = _unit_normals(points, tri)
    both = np.vstack([pairs, pairs[:, ::-1]])
    a, b = both[:, 0], both[:, 1]
    v = tri[a]  # (k, 3) corners of a
    nb = fn[b]
    sd = np.einsum("kij,kj->ki", points[v] - points[tri[b, 0]][:, None], nb)
    shared = (v[:, :, None] == tri[b][:, None, :]).any(axis=2)
    use = ~shared & (sd < gap) & _over(points, tri[b], points[v] - sd[..., None] * nb[:, None])
    acc = np.zeros_like(points)
    cnt = np.zeros(len(points))
    disp = 0.5 * (gap - sd)[..., None] * nb[:, None, :]
    np.add.at(acc, v[use], disp[use])
    np.add.at(cnt, v[use], 1.0)
    asked = cnt > 0
    acc[asked] /= cnt[asked, None]
    return acc, asked


def _smooth_step(adjacency: sp.csr_matrix, targets: np.ndarray, asked: np.ndarray,
                 smoothness: float, rings: int) -> np.ndarray:
    """``(n, 3)``: the least-squares displacement (module notes) on the vertices within
    ``rings`` edges of ``asked`` ``(n,)``, 0 elsewhere.
    """
    region = asked.copy()
    for _ in range(rings):
        region |= (adjacency @ region.astype(float)) > 0
    idx = np.flatnonzero(region)
    sub = adjacency[idx][:, idx]
    lap = sp.diags(np.asarray(adjacency[idx].sum(axis=1)).ravel()) - sub
    system = (sp.diags(asked[idx].astype(float)) + smoothness * lap
              + 1e-9 * sp.eye(len(idx))).tocsc()
    d = np.zeros_like(targets)
    for k in range(3):
        d[idx, k] = spsolve(system, targets[idx, k])
    return d


def folded_pairs(points: np.ndarray, triangles: np.ndarray, region: np.ndarray,
                 max_cos: float = -0.5) -> np.ndarray:
    """``(k, 2)`` int: pairs of triangles ``(m, 3)`` inside ``region`` ``(n,) bool`` that
    share a vertex and face each other (the cosine of their normals at most ``max_cos``):
    the skin folded back on itself around that vertex (the corners of a closed mouth).
    """
    tri = np.asarray(triangles, dtype=np.intp)
    m = len(tri)
    inc = sp.csr_matrix((np.ones(3 * m), (tri.ravel(), np.repeat(np.arange(m), 3))),
                        shape=(len(points), m))
    inc = inc[np.flatnonzero(region)]
    pairs = sp.triu(inc.T @ inc, k=1).tocoo()
    pairs = np.column_stack([pairs.row, pairs.col]).astype(np.intp)
    inside = np.asarray(region, bool)[tri].all(axis=1)
    pairs = pairs[inside[pairs].all(axis=1)]
    fn = _unit_normals(np.asarray(points, float), tri)
    cos = np.einsum("ij,ij->i", fn[pairs[:, 0]], fn[pairs[:, 1]])
    return pairs[cos <= max_cos]


def facing_pairs(points: np.ndarray, triangles: np.ndarray, region: np.ndarray,
                 distance: float, max_cos: float = -0.5) -> np.ndarray:
    """``(k, 2)`` int: pairs of triangles ``(m, 3)`` inside ``region`` ``(n,) bool`` with no
    common vertex, facing each other (cosine of their normals at most ``max_cos``), with
    corners closer than ``distance``: the two lips across a narrow slit.
    """
    from scipy.spatial import cKDTree

    tri = np.asarray(triangles, dtype=np.intp)
    pts = np.asarray(points, dtype=float)
    inside = np.flatnonzero(np.asarray(region, bool)[tri].all(axis=1))
    ids = np.unique(tri[inside])
    close = ids[cKDTree(pts[ids]).query_pairs(distance, output_type="ndarray")]
    m = len(tri)
    inc = sp.csr_matrix((np.ones(3 * len(inside)), (tri[inside].ravel(),
                                                    np.repeat(inside, 3))), shape=(len(pts), m))
    link = sp.csr_matrix((np.ones(len(close)), (close[:, 0], close[:, 1])),
                         shape=(len(pts), len(pts)))
    near = (inc.T @ (link + link.T) @ inc).tocoo()
    pairs = np.column_stack([near.row, near.col]).astype(np.intp)
    pairs = pairs[pairs[:, 0] < pairs[:, 1]]
    shared = (tri[pairs[:, 0]][:, :, None] == tri[pairs[:, 1]][:, None, :]).any(axis=(1, 2))
    fn = _unit_normals(pts, tri)
    cos = np.einsum("ij,ij->i", fn[pairs[:, 0]], fn[pairs[:, 1]])
    return pairs[~shared & (cos <= max_cos)]


def separate_crossings(points: np.ndarray, triangles: np.ndarray, region: np.ndarray,
                       gap: float = 1.0, smoothness: float = 1.0, rings: int = 2,
                       max_steps: int = 100, float32: bool = True, folds: bool = False,
                       hold: np.ndarray | None = None, strict: bool = True) -> np.ndarray:
    r"""``(n, 3)``: ``points`` ``(n, 3)`` with the sheets of ``triangles`` ``(m, 3)`` that
    cross each other inside ``region`` ``(n,) bool`` (both triangles' corners in it) moved
    apart until none does and every pair that crossed stands ``gap`` apart (to within
    5 %) along the other's normal (module notes); ``smoothness`` is :math:`\lambda`.
    ``float32``: the result rounded to float32 (as the package stores it) and checked so.
    ``folds``: the pairs of :func:`folded_pairs` at rest are held ``gap`` apart as well;
    so are the triangle pairs ``hold`` ``(h, 2)``. ``strict=False``: when the gap is not
    reached within ``max_steps``, the last step's skin that had no crossing is returned.

    Raises ``RuntimeError`` when crossings are left after ``max_steps`` steps.
    """
    tri = np.asarray(triangles, dtype=np.intp)
    pts = np.array(points, dtype=float, copy=True)
    n = len(pts)
    e = np.vstack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    adjacency = sp.coo_matrix((np.ones(2 * len(e)), (np.r_[e[:, 0], e[:, 1]],
                                                      np.r_[e[:, 1], e[:, 0]])),
                              shape=(n, n)).tocsr()
    adjacency.data[:] = 1.0
    inside = np.asarray(region, bool)[tri].all(axis=1)
    seen = folded_pairs(pts, tri, region) if folds else np.zeros((0, 2), np.intp)
    if hold is not None and len(hold):
        seen = np.unique(np.vstack([seen, np.sort(np.asarray(hold, np.intp), axis=1)]), axis=0)
    clear = None
    for _ in range(max_steps):
        if float32:
            pts = pts.astype(np.float32).astype(float)
        pairs = intersecting_pairs(pts, tri)
        pairs = pairs[inside[pairs].all(axis=1)] if len(pairs) else pairs
        seen = np.unique(np.vstack([seen, pairs]), axis=0) if len(pairs) else seen
        if not len(seen):
            return pts
        targets, asked = _targets(pts, tri, seen, gap)
        if not len(pairs):
            if np.linalg.norm(targets, axis=1).max() <= 0.025 * gap:
                return pts
            clear = pts.copy()
        pts += _smooth_step(adjacency, targets, asked, smoothness, rings)
    if clear is not None and not strict:
        return clear
    raise RuntimeError(f"the sheets still cross after {max_steps} steps; "
                       "raise max_steps or smoothness")
