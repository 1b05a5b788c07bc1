"""The fold guard's shared pieces: its parameters, the soft clamp and geometry helpers."""
from __future__ import annotations

from dataclasses import dataclass
from itertools import chain

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from ..mesh import _closest_on_triangles as _mesh_closest


@dataclass(frozen=True)
class FoldGuard:
    r"""The guard's parameters.

    Attributes
    ----------
    eta : float
        :math:`|W| \le \eta\, r_\pm`, in ``(0, 1)``.
    knee : float
        The clamps are the identity up to ``knee`` times their bound, in ``(0, 1)``.
    min_area : float
        :math:`\sigma_{\min}`: the fraction of its rest signed area a triangle keeps under
        the pulls, in ``(0, 1)``.
    min_area_wrinkles : float
        The same for the wrinkles' step, against the deformed skin, in ``(0, 1)`` (lower:
        the step is held only where a furrow comes close to turning a triangle over).
    eta_deformed : float
        :math:`|W| \le \eta_d\, r^{\text{def}}_\pm` as well, the medial radii of the
        deformed skin (before :math:`W`), in ``(0, 1)``.
    knee_wrinkles : float
        The knee of that step's clamp, in ``(0, 1)`` (it acts only where :math:`W` would
        bring a triangle to ``min_area_wrinkles`` at ``1 / knee_wrinkles`` times itself).
    fans : bool or "refined"
        Also keep each vertex's displaced fan off the triangles of its two rings
        (:func:`guard_fans`; ``docs/model.md``, "The fans"): True on every frame, False on
        none, ``"refined"`` (the default) on refined frames, the only ones where fans have
        been seen to cross (the refined head's eye corner with k0 at 5x its default); there
        it adds 6-21 ms to a paper-size refined frame (18-28 % of that frame guarded
        without it; ``docs/benchmarks.md``, stop 42), on unrefined frames it would add up
        to 17 % (physical skin) and 134-288 % (geometric skin, frames under 1.1 ms) for no
        crossing measured (stop 41). ``--fold-guard fans`` turns it on everywhere,
        ``--fold-guard light`` off.
    """

    eta: float = 0.5
    knee: float = 0.5
    min_area: float = 0.2
    min_area_wrinkles: float = 0.05
    knee_wrinkles: float = 0.8
    eta_deformed: float = 0.7
    fans: bool | str = "refined"

    def __post_init__(self):
        for name in ("eta", "knee", "min_area", "min_area_wrinkles", "knee_wrinkles",
                     "eta_deformed"):
            v = getattr(self, name)
            if not 0.0 < v < 1.0:
                raise ValueError(f"FoldGuard.{name} = {v:g} is outside (0, 1)")
        if self.fans not in (True, False, "refined"):
            raise ValueError(f"FoldGuard.fans = {self.fans!r}: use True, False or 'refined'")


def soft_clamp(x: np.ndarray, bound: np.ndarray, knee: float) -> np.ndarray:
    r"""``(n,)``: ``x`` ``(n,)`` with :math:`|x|` kept below ``bound`` ``(n,)`` (> 0), C1:

    .. math::

        c(x) = \begin{cases} x & |x| \le \kappa B \\
        \operatorname{sign}(x) \left(\kappa B + (1 - \kappa) B
        \tanh\frac{|x| - \kappa B}{(1 - \kappa) B}\right) & \text{else} \end{cases}

    The identity (bit for bit) below the knee :math:`\kappa B`, slope 1 at the knee,
    monotone, and :math:`|c(x)| < B`.
    """
    x = np.asarray(x, dtype=float)
    bound = np.broadcast_to(np.asarray(bound, dtype=float), x.shape)
    out = x.copy()
    over = np.flatnonzero(np.abs(x) > knee * bound)
    if len(over):
        b, a = bound[over], np.abs(x[over])
        soft = (1.0 - knee) * b
        out[over] = np.sign(x[over]) * (knee * b + soft * np.tanh((a - knee * b) / soft))
    return out


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``(k, 3)``: row-wise cross product (faster than :func:`numpy.cross` on short rows)."""
    return np.stack([u[:, 1] * v[:, 2] - u[:, 2] * v[:, 1],
                     u[:, 2] * v[:, 0] - u[:, 0] * v[:, 2],
                     u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]], axis=1)


def _closest_on_triangles(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray
                          ) -> np.ndarray:
    r"""``(k, 3)``: the point of each triangle ``a``, ``b``, ``c`` ``(k, 3)`` nearest to
    ``p`` ``(k, 3)`` (:func:`~wrinkle_vis.core.mesh._closest_on_triangles`, Ericson 5.1.5).
    """
    return _mesh_closest(p, np.stack([a, b, c], axis=1))


def _near_triangles(centres: np.ndarray, radii: np.ndarray, points: np.ndarray,
                    tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""``(p,)`` twice: the pairs (ball, triangle) of balls ``centres`` ``(k, 3)``,
    ``radii`` ``(k,)`` and triangles ``tri`` ``(m, 3)`` on ``points`` ``(n, 3)`` that may
    meet (every pair that does, once). A point :math:`q = \sum_i \lambda_i v_i` of a
    triangle has :math:`\sum_i \lambda_i |v_i - c|^2 = |q - c|^2 + \sum_i \lambda_i
    |v_i - q|^2` and :math:`\sum_i \lambda_i |v_i - q|^2 \le \ell^2 / 3` (its corners lie
    in a circle of radius :math:`\ell / \sqrt 3`, :math:`\ell` its longest edge), so a
    triangle meeting the ball has a corner within :math:`\sqrt{r^2 + \ell^2 / 3}` of the
    centre. The triangles are taken in classes of :math:`\ell` (doubling), each with its
    own corners' ``cKDTree``, so a few long triangles do not widen every query.
    """
    e = points[tri] - points[np.roll(tri, 1, axis=1)]
    longest = np.sqrt(np.einsum("ijk,ijk->ij", e, e).max(axis=1))
    top = float(longest.max()) if len(tri) else 0.0
    if not len(tri) or not len(centres) or top <= 0.0:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    level = np.ceil(np.log2(np.maximum(longest, top * 2.0 ** -12) / top)).astype(int)
    owners, tris = [], []
    for k in np.unique(level):
        group = np.flatnonzero(level == k)
        corners = np.unique(tri[group])
        bound = top * 2.0 ** float(k)
        tree = cKDTree(points[corners], balanced_tree=False)
        near = tree.query_ball_point(centres, np.sqrt(radii * radii + bound * bound / 3.0))
        counts = np.fromiter(map(len, near), np.intp, len(near))
        if not counts.sum():
            continue
        verts = corners[np.fromiter(chain.from_iterable(near), np.intp, int(counts.sum()))]
        owner = np.repeat(np.arange(len(centres)), counts)
        inc = _incidence(tri[group], len(points))[verts]
        owners.append(np.repeat(owner, np.diff(inc.indptr)))
        tris.append(group[inc.indices])
    if not owners:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    key = np.unique(np.concatenate(owners) * np.int64(len(tri)) + np.concatenate(tris))
    return (key // len(tri)).astype(np.intp), (key % len(tri)).astype(np.intp)

def _incidence(tri: np.ndarray, n: int) -> sp.csr_matrix:
    """``(n, m)``: the vertex-triangle incidence of ``tri`` ``(m, 3)`` on ``n`` vertices."""
    m = len(tri)
    return sp.csr_matrix((np.ones(3 * m), (tri.ravel(), np.repeat(np.arange(m), 3))),
                         shape=(n, m))


def _sq(d: np.ndarray) -> np.ndarray:
    """``(p,)``: the rows' squared lengths of ``d`` ``(p, 3)``."""
    return np.einsum("ij,ij->i", d, d)


def _terms_edges(terms: dict) -> tuple[np.ndarray, np.ndarray]:
    """``(e, 2)`` and ``(e,)``: the edges of :func:`pull_terms` ``terms`` (sorted by first
    end, then second) and their rest lengths, found on first use and kept in ``terms``.
    """
    got = terms.get("edges")
    if got is not None:
        return got, terms["length"]
    rest, edges = terms["rest"], terms.pop("edges_of", None)
    if callable(edges):
        edges = edges()
    if edges is None:  # (sorted, unique, intp: as built)
        edges = _skin_edges(terms["corners"], len(rest))
    else:
        edges = np.asarray(edges, dtype=np.intp)
        key = edges[:, 0] * len(rest) + edges[:, 1]
        if len(key) > 1 and not np.all(key[1:] > key[:-1]):  # by first end, then second
            edges = edges[np.argsort(key, kind="stable")]
        del key
    ends = (np.take(rest, edges[:, i], axis=0) for i in (0, 1))  # (takes: rest[...]'s rows)
    terms["edges"], terms["length"] = edges, np.linalg.norm(next(ends) - next(ends), axis=1)
    return terms["edges"], terms["length"]


def _skin_edges(corners: np.ndarray, n: int) -> np.ndarray:
    r"""``(e, 2)``: the unique edges of the triangles ``corners`` ``(3, m)`` on ``n``
    vertices, each sorted, sorted by first end then second: the structure of the CSR matrix
    with an entry at :math:`(\min, \max)` of each triangle's sides (a counting sort by
    first end, each row's columns sorted, duplicates merged: ``sum_duplicates``, boolean
    entries, a side met any number of times one entry) instead of a sort of keys: the same
    array, cheaper (a refined frame's skin is new on each frame, and this runs on each it
    limits a pull of).
    """
    a = corners.ravel()  # the corners 0, 1, 2 of every triangle ...
    b = np.roll(corners, -1, axis=0).ravel()  # ... and 1, 2, 0
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    mat = sp.csr_matrix((np.ones(len(lo), bool), (lo, hi)), shape=(n, n))
    mat.sum_duplicates()  # (canonical: sorted columns, no duplicate)
    rows = np.repeat(np.arange(n), np.diff(mat.indptr))
    return np.stack([rows, mat.indices], axis=1).astype(np.intp)


def _rows_dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(k,)``: the dot products of the rows of ``a`` and ``b`` ``(k, 3)``."""
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def _in_box(points: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """``(k,)``: the indices (ascending) of ``points`` ``(n, 3)`` in the closed box
    ``lo``-``hi`` ``(3,)``, filtered one coordinate at a time (the first over every point,
    the others over what is left).
    """
    x = points[:, 0]
    idx = np.flatnonzero((x >= lo[0]) & (x <= hi[0]))
    for k in (1, 2):
        c = points[idx, k]
        idx = idx[(c >= lo[k]) & (c <= hi[k])]
    return idx


def _vertex_normals(points: np.ndarray, tri: np.ndarray, ids: np.ndarray,
                    terms: dict) -> np.ndarray:
    r"""``(k, 3)``: unit area-weighted normals of ``points`` at vertices ``ids`` ``(k,)``
    (distinct): at each, :math:`\sum_t (c_1 - c_0) \times (c_2 - c_0)` over the triangles
    ``tri`` ``(m, 3)`` around it, summed from 0 in ascending triangle order (as the
    vertex-triangle incidence matrix's product summed them; a refined frame's skin is new
    on each frame, and a matrix built for it outweighed the sums). Only the triangles with
    a corner in ``ids`` are looked at. ``terms``: unused, kept for the callers.
    """
    at = np.full(len(points), -1, np.intp)  # each vertex's row in ids, -1 off them
    at[ids] = np.arange(len(ids))
    use = np.flatnonzero(_any_corner(at >= 0, tri))  # ascending
    c = points[tri[use]]
    fn = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
    row = np.take(at, tri[use]).ravel()  # triangle by triangle: each vertex's ascending
    keep = np.flatnonzero(row >= 0)
    row, src = row[keep], keep // 3
    n = np.stack([np.bincount(row, weights=fn[src, j], minlength=len(ids))
                  for j in range(3)], axis=1)
    return n / np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]


def _any_corner(mark: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """``(m,)`` bool: the triangles ``tri`` ``(m, 3)`` with a corner where ``mark`` ``(n,)``
    (three takes and two ors: ``mark[tri].any(axis=1)``, a reduction over rows of 3, is
    ten times slower).
    """
    return mark[tri[:, 0]] | mark[tri[:, 1]] | mark[tri[:, 2]]


def _near_edges(pts: np.ndarray, tri: np.ndarray, wrinkled: np.ndarray, D: float
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, np.ndarray, np.ndarray]:
    r"""``(k,)``, ``(k, 4, 3)``, ``(k, 3)``, a float and ``(k,)`` twice: for every pair of a
    ``wrinkled`` vertex :math:`x` of the skin ``pts`` ``(n, 3)``, ``tri`` ``(m, 3)`` and a
    triangle :math:`t` not incident to it that comes within :math:`D` (the pairs' reach / 2)
    of it, the distance :math:`d_{x,t}` from :math:`x` to :math:`t` (ascending), for each
    corner :math:`v_i` of :math:`t` its heights :math:`h_{ki} = u_k \cdot (v_i - x)` along
    four unit directions :math:`u_k` (to the closest point of :math:`t`, where
    :math:`h_{0i} \ge d_{x,t}`, and to each corner; a zero vector where that point is
    :math:`x`) and its distance :math:`m_i = |v_i - x|`; :math:`D`; the pair's vertex
    (its row of ``wrinkled``) and its triangle. Any unit :math:`u` bounds every point
    :math:`q = \sum_i \lambda_i v_i` of :math:`t`: :math:`|q - x| \ge u \cdot (q - x) =
    \sum_i \lambda_i h_i`.
    The balls' certificate asks for the triangles within :math:`2\rho + 2P` of a wrinkled
    vertex only (:func:`_certificates`, :func:`_empty_balls`), and for them only once a
    frame passes its other tests (kept per set of active muscles).
    """
    owner, t = _near_triangles(pts[wrinkled], np.full(len(wrinkled), D), pts, tri)
    keep = ~(tri[t] == wrinkled[owner, None]).any(axis=1)  # not the vertex's own
    owner, t = owner[keep], t[keep]
    x = pts[wrinkled[owner]]
    corners = pts[tri[t]] - x[:, None]  # (k, 3, 3): v_i - x
    q = _closest_on_triangles(x, pts[tri[t, 0]], pts[tri[t, 1]], pts[tri[t, 2]]) - x
    d = np.linalg.norm(q, axis=1)
    m = np.linalg.norm(corners, axis=2)
    # the directions u: to the closest point, and to each corner (0 where there is none)
    u = np.concatenate([q[:, None], corners], axis=1)  # (k, 4, 3)
    size = np.concatenate([d[:, None], m], axis=1)
    u /= np.where(size > 0, size, np.inf)[:, :, None]
    h = np.einsum("ikj,ilj->ikl", u, corners)  # (k, 4, 3): u_k . (v_l - x)
    within = np.flatnonzero(d <= D)
    order = within[np.argsort(d[within], kind="stable")]
    return (d[order], np.ascontiguousarray(h[order]), np.ascontiguousarray(m[order]), D,
            owner[order], t[order])
