r"""The fold guard: keep the skin from passing through itself (the paper's future work).

Two guards, each a function of the rest skin, the skin deformed by the muscles' pulls, the
wrinkle amplitude :math:`W` and the triangles, so any skin model can use them:

* **Wrinkles** (:func:`guard_wrinkles`). Each vertex moves by :math:`W` along its normal.
  With :math:`r_\pm(x)` the radius of the largest ball empty of the skin that touches it at
  :math:`x` on the side :math:`\pm n` (the medial ball: empty of the vertices,
  :func:`medial_radii`, and of every triangle not incident to :math:`x`,
  :func:`triangle_radii`), the point
  :math:`x + t\,n(x)` with :math:`0 \le t < r_+(x)` (or :math:`-r_-(x) < t \le 0`) has
  :math:`x` as its unique closest skin point. Two skin points moved by less than their own
  medial radius therefore never land on the same place, whatever the neighbour does: the
  displaced skin is injective (``docs/model.md`` has the proof). The guard bounds
  :math:`|W|` by :math:`B = \eta\, r_{\operatorname{sign} W}` with the soft clamp
  :func:`soft_clamp`, the identity up to a knee :math:`\kappa B`, so :math:`W` stays the
  paper's, bit for bit, wherever it is far from any collision.
* **Pulls** (:func:`skin_scale`). A pull that drags skin over its neighbour turns triangles
  over before any wrinkle. Each triangle's signed area along its rest normal,
  :math:`\sigma_t(s) = N_t \cdot (e_1 + s\,\delta_1) \times (e_2 + s\,\delta_2) / |N_t|^2`
  for the pull scaled by :math:`s` (a quadratic with :math:`\sigma_t(0) = 1`), must stay
  above :math:`\sigma_{\min}`; the first :math:`s^*_t` where it would not bounds the pull of
  the triangle's corners, again through :func:`soft_clamp` (the pull is untouched where every
  triangle around the vertex keeps :math:`\sigma_{\min}` up to :math:`1/\kappa` times it).
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from itertools import chain
from typing import Any, Literal

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph
from scipy.spatial import cKDTree

from .certificate import (
    _corner_columns,
    _narrow_phase,
    _normals,
)
from .mesh import _closest_on_triangles as _mesh_closest

__all__ = ["Certified", "FoldGuard", "GuardResult", "certify", "fold_radii", "guard_amount",
           "guard_fans", "guard_frame", "guard_wrinkles", "guarded", "medial_radii", "pull_terms",
           "skin_scale", "soft_clamp", "triangle_radii"]


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
    fans : bool
        Also keep each vertex's displaced fan off the triangles of its two rings
        (:func:`guard_fans`; ``docs/model.md``, "The fans"). Off by default: it acts on no
        built-in frame at default parameters, and it adds 36-119 % to the default guard's
        refined frames and the geometric skin's unrefined ones (``docs/benchmarks.md``,
        stop 40); turn it on (the command line's ``--fold-guard fans``) for stiff muscles
        (k0 raised several times) on a refined scan whose rest skin folds on itself.
    """

    eta: float = 0.5
    knee: float = 0.5
    min_area: float = 0.2
    min_area_wrinkles: float = 0.05
    knee_wrinkles: float = 0.8
    eta_deformed: float = 0.7
    fans: bool = False

    def __post_init__(self):
        for name in ("eta", "knee", "min_area", "min_area_wrinkles", "knee_wrinkles",
                     "eta_deformed"):
            v = getattr(self, name)
            if not 0.0 < v < 1.0:
                raise ValueError(f"FoldGuard.{name} = {v:g} is outside (0, 1)")


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


def _enclosing_sq(points: np.ndarray, tri: np.ndarray) -> np.ndarray:
    r"""``(m,)``: an upper bound of :math:`\rho_t^2`, the squared radius of the smallest disc
    holding the triangles ``tri`` ``(m, 3)`` on ``points`` ``(n, 3)``: half the longest edge
    where the triangle is right or obtuse (:math:`c^2 \ge a^2 + b^2`), else its circumradius
    :math:`a^2 b^2 c^2 / (16 A^2)`; never above :math:`\ell^2 / 3` (Jung), and raised by
    :math:`10^{-9}` of itself against rounding.
    """
    a, b, c = points[tri[:, 0]], points[tri[:, 1]], points[tri[:, 2]]
    a2 = np.einsum("ij,ij->i", b - c, b - c)
    b2 = np.einsum("ij,ij->i", c - a, c - a)
    c2 = np.einsum("ij,ij->i", a - b, a - b)
    top = np.maximum(np.maximum(a2, b2), c2)  # the longest edge's square, and the rest:
    rest = a2 + b2 + c2 - top  # the other two's sum (obtuse or right: top >= rest)
    area16 = 2.0 * (a2 * b2 + b2 * c2 + c2 * a2) - (a2 * a2 + b2 * b2 + c2 * c2)
    acute = (top < rest) & (area16 > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        circ = np.where(acute, a2 * b2 * c2 / np.where(acute, area16, 1.0), 0.0)
    rho = np.where(acute, np.minimum(circ, top / 3.0), 0.25 * top)
    return rho * (1.0 + 1e-9)


def _lift(points: np.ndarray, tri: np.ndarray) -> dict:
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
    near :math:`\sqrt T`.)
    """
    rho_t = _enclosing_sq(points, tri) if len(tri) else np.zeros(0)
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
        classes.append((cKDTree(lifted, balanced_tree=False), ids, Tk))
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
    asks a ball query for the rest (after every class, only where not cleared).
    """
    c4 = np.column_stack([centres, np.zeros(len(centres))])
    cleared = np.ones(len(centres), bool) if clear else np.zeros(len(centres), bool)
    balls, verts, fulls = [], [], []
    for tree, ids, Tk in lift["classes"]:
        r2T = radii * radii + Tk
        bound = np.sqrt(r2T * (1.0 + 2e-9))
        k = min(_SUSPECTS_K, len(ids))  # k nearest first (arrays); a full row: a ball query
        d, i = tree.query(c4, k=k, distance_upper_bound=float(bound.max()))
        d, i = d.reshape(len(c4), k), i.reshape(len(c4), k)
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
    o, dd = own[ball], []
    cs = [cj.take(t) for cj in cols]
    keep = np.flatnonzero((cs[0] != o) & (cs[1] != o) & (cs[2] != o))  # not own's
    ball, t, vert = ball[keep], t[keep], vert[keep]
    cs = [cj[keep] for cj in cs]
    c = centres[ball]
    for cj in cs:
        d = points[cj] - c
        dd.append(np.einsum("ij,ij->i", d, d))
    r2 = radii[ball] ** 2
    near = np.minimum(np.minimum(dd[0], dd[1]), dd[2]) <= (r2 + lift["rho_t"][t]) * (1.0 + 1e-9)
    rho, T = lift["rho"], lift["T"]
    found = [dd[j] - rho[cs[j]] <= r2 + 1.5e-9 * (r2 + T[cs[j]]) for j in range(3)]
    first = np.where(found[0] | ~(found[1] | found[2]), cs[0], np.where(found[1], cs[1], cs[2]))
    keep = near & (first == vert)
    return ball[keep], t[keep]


def _expand(lift: dict, ball: np.ndarray, verts: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(p,)`` thrice: each pair of ``ball`` and ``verts`` ``(q,)`` repeated for every
    triangle of that vertex (ball, triangle, vertex), from :func:`_lift`'s incidence.
    """
    if "ptr" not in lift:  # the vertex-triangle incidence, built on first need (a
        tri = lift["tri"]  # counting sort: each vertex's triangles in ascending order)
        m = len(tri)
        inc = sp.coo_matrix((np.ones(3 * m, np.int8), (tri.ravel(), np.repeat(np.arange(m), 3))),
                            shape=(lift["n"], m)).tocsr()
        lift["by_vertex"] = inc.indices.astype(np.intp, copy=False)
        lift["ptr"] = inc.indptr.astype(np.intp, copy=False)
    ptr = lift["ptr"]
    deg = ptr[verts + 1] - ptr[verts]
    total = int(deg.sum())
    starts = np.repeat(ptr[verts] - np.concatenate([[0], np.cumsum(deg)[:-1]]), deg)
    t = lift["by_vertex"][starts + np.arange(total)]
    return np.repeat(ball, deg), t, np.repeat(verts, deg)


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
        ball, t = _first_found(lift, x + r[:, None] * n, r, ids[rows], points,
                               *_expand(lift, *found))
    if not len(ball):
        return out
    out[rows, cols] = _shrink_on_triangles(r, ball, x[ball], n[ball], points[tri[t]],
                                           iterations)
    return out


def _shrink_on_triangles(r: np.ndarray, ball: np.ndarray, xb: np.ndarray, nb: np.ndarray,
                         corners: np.ndarray, iterations: int) -> np.ndarray:
    r"""``(k,)``: the shrinking-ball search of :func:`triangle_radii` on the balls' radii
    ``r`` ``(k,)`` (lowered in place) over their candidate pairs: the ball ``ball`` ``(p,)``
    tangent at ``xb`` ``(p, 3)`` along ``nb`` ``(p, 3)`` (towards the ball) and the
    triangle ``corners`` ``(p, 3, 3)``.
    """
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
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
    its corners' ball about their mean :math:`g`, radius :math:`R = \max_i |v_i - g|`
    (which holds the triangle, the corners' hull), is, :math:`|o - g| > r' + R(1 +
    10^{-6}) + \tau`; with :math:`r' = r(1 + 10^{-6}) + \tau` and :math:`\tau = 10^{-12}(1
    + \max |v|)` against rounding (far above that of the nearest point's distance, so a
    pair found apart is never one the search's rounding puts inside).
    """
    if not len(a):
        return np.zeros(0, bool)
    tau = 1e-12 * (1.0 + max(float(np.abs(a).max()), float(np.abs(b).max()),
                             float(np.abs(c).max()), float(np.abs(centres).max())))
    lim = radii * (1.0 + 1e-6) + tau
    N = _cross(b - a, c - a)
    h = np.einsum("ij,ij->i", centres - a, N)
    out = h * h > lim * lim * np.einsum("ij,ij->i", N, N)
    g = (a + b + c) / 3.0
    R2 = np.maximum(np.maximum(_sq(a - g), _sq(b - g)), _sq(c - g))
    return out | (_sq(centres - g) > (lim + np.sqrt(R2) * (1.0 + 1e-6) + tau) ** 2)


def _sq(d: np.ndarray) -> np.ndarray:
    """``(p,)``: the rows' squared lengths of ``d`` ``(p, 3)``."""
    return np.einsum("ij,ij->i", d, d)


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
    e = points[tri] - points[np.roll(tri, 1, axis=1)]
    L = float(np.sqrt(np.einsum("ijk,ijk->ij", e, e).max())) if len(tri) else 0.0
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


def _row_terms(points: np.ndarray, corners: np.ndarray, normals_only: bool = False,
               order: Literal["C", "F"] = "C") -> tuple[np.ndarray, ...]:
    r"""``(3, k)`` thrice: :math:`N / |N|^2`, :math:`A_1 = N \times e_1 / |N|^2` and
    :math:`A_2 = e_2 \times N / |N|^2` of the triangles ``corners`` ``(3, k)`` on ``points``
    ``(n, 3)`` (0 for a triangle with no area); with ``normals_only`` :math:`N / |N|^2`
    alone (a 1-tuple). Computed as rows, component by component (the products of
    :func:`numpy.cross`, in its order; :math:`|N|^2` by ``einsum`` on rows), into arrays
    of the memory ``order`` ``"C"`` or ``"F"`` (the same values).
    """
    pts = np.ascontiguousarray(np.asarray(points, dtype=float).T)
    r0 = np.take(pts, corners[0], axis=1)
    e1 = np.take(pts, corners[1], axis=1)
    e1 -= r0
    e2 = np.take(pts, corners[2], axis=1)
    e2 -= r0
    del r0
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
    st = np.ascontiguousarray(np.asarray(start, dtype=float).T)  # rows x, y, z
    r0 = np.take(st, corners[0], axis=1)
    e1 = np.take(st, corners[1], axis=1)
    e1 -= r0
    e2 = np.take(st, corners[2], axis=1)
    e2 -= r0
    del r0
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
    if edges is None:
        edges = _skin_edges(terms["corners"], len(rest))
    edges = np.asarray(edges, dtype=np.intp)
    key = edges[:, 0] * len(rest) + edges[:, 1]
    if len(key) > 1 and not np.all(key[1:] > key[:-1]):  # by first end, then second
        edges = edges[np.argsort(key, kind="stable")]
    del key
    terms["edges"], terms["length"] = edges, np.linalg.norm(rest[edges[:, 0]]
                                                            - rest[edges[:, 1]], axis=1)
    return terms["edges"], terms["length"]


def _skin_edges(corners: np.ndarray, n: int) -> np.ndarray:
    r"""``(e, 2)``: the unique edges of the triangles ``corners`` ``(3, m)`` on ``n``
    vertices, each sorted, sorted by first end then second: one sort of a key
    :math:`\min \cdot n + \max` per directed edge (32-bit where :math:`n^2` fits; a
    refined frame's skin is new on each frame, and this runs on each it limits a pull of).
    """
    key_type = np.int32 if n * n < 2**31 else np.int64
    a = corners.astype(key_type).ravel()  # the corners 0, 1, 2 of every triangle ...
    b = np.roll(corners, -1, axis=0).astype(key_type).ravel()  # ... and 1, 2, 0
    key = np.minimum(a, b)
    key *= key_type(n)
    key += np.maximum(a, b)
    key.sort()
    first = np.ones(len(key), bool)
    first[1:] = key[1:] != key[:-1]
    key = key[first]
    return np.stack([key // n, key % n], axis=1).astype(np.intp)


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
    sort of ``e`` keys.
    """
    a, b = edges[:, 0], edges[:, 1]
    m = len(a)
    index = np.int32 if n < 2**31 - 2 and 2 * m + n < 2**31 - 1 else np.intp
    into, out_ = np.bincount(b, minlength=n), np.bincount(a, minlength=n)
    indptr = np.concatenate([[0], np.cumsum(into + out_), [2 * m + n]])
    ids = np.arange(m)
    by_b = np.argsort(b, kind="stable")  # ends at v: grouped by v, then by first end
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
    graph's rows (the work goes with the changed vertices, not with the skin).
    """
    indptr = graph["indptr"]
    lo, hi = indptr[changed].astype(np.intp), indptr[changed + 1].astype(np.intp)
    count = hi - lo
    ends = np.cumsum(count)
    at = np.arange(int(ends[-1]) if len(ends) else 0) + np.repeat(lo - (ends - count), count)
    mark = np.zeros(len(graph["w"]), bool)  # each edge once, ascending (a memset and a
    mark[graph["slot"][at]] = True  # scan of bytes: cheaper than sorting the region's)
    j = np.flatnonzero(mark)
    w = _weights(graph, j, lift_of)
    graph["w"][j] = w
    data = graph["mat"].data
    data[graph["slots"][0, j]] = w
    data[graph["slots"][1, j]] = w


def _limits(s_star: np.ndarray, corners: np.ndarray, graph: dict, top: float) -> np.ndarray:
    r"""``(n,)``: :math:`F_v`, the least over bad triangles :math:`t` (``corners``
    ``(k, 3)``, their :math:`s^*_t` ``(k,)``) of :math:`s^*_t` plus the shortest path from
    :math:`t` to :math:`v` along the skin's edges, an edge :math:`vw` weighing
    :math:`|x_v - x_w| / (\text{reach} \max(|p_v|, |p_w|))` for the pulls' lengths
    :math:`|p|` (the edges and weights of :func:`_edge_graph` ``graph``); ``inf`` beyond
    ``top`` and wherever no pull connects :math:`v` to a bad triangle.
    """
    mat = graph["mat"]
    n = mat.shape[0] - 1
    least = mat.data[-n:] if n else mat.data[:0]  # the source's edges: a corner of
    least[:] = np.inf  # several bad triangles takes their least s*
    np.minimum.at(least, corners.ravel(), np.maximum(np.repeat(s_star, 3), 1e-12))
    dist = csgraph.dijkstra(mat, directed=True, indices=n, limit=top)
    return dist[:n]


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


_SUBSETS = 8  # the pulled regions a skin's terms remember (an expression's muscles, ...)
_SUBSET_BYTES = 1 << 24  # and at most this many bytes of them together


def _triangles_of(terms: dict, moving: np.ndarray, normals_only: bool = False) -> tuple:
    r"""The triangles of :func:`pull_terms` ``terms`` with a corner where ``moving``
    ``(n,)``: their ``rows`` ``(k,)`` and ``corners``, ``N``, ``A1``, ``A2`` ``(3, k)``
    (with ``normals_only``, ``A1`` and ``A2`` are None and not taken: a step from a skin
    of its own, :func:`_start_terms`, replaces them).

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
    elif "N" in terms:
        hit = (rows, *(terms[k][:, rows] for k in names))
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
    graph = None  # the edges' weights, built only when a triangle is bad
    for _ in range(iterations):
        bad = np.flatnonzero(low < min_area)
        if not len(bad):
            break
        if graph is None:
            graph = _edge_graph(size, terms, reach)
        s_star = _first_root(np.maximum(a0[bad] - min_area, 1e-12), b[bad], c[bad])
        limit = _limits(s_star, corners[:, bad].T, graph, top)
        near = np.flatnonzero(limit < top)
        step = soft_clamp(np.ones(len(near)), limit[near], knee)
        if np.all(step == 1.0):
            break
        f[near] *= step
        changed = near[step != 1.0]
        _update(b, c, low, pull_t, f, changed, corners, (Nt, A1, A2, a0), top)
        _reweigh(graph, changed, f * size)
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
    earlier frame pulled every triangle: the physical skin's, whose solve moves every
    vertex by at least its rounding), or where the pull is local (it moves at most half the
    skin's vertices, the geometric skin's, or fewer than half of those it moves are cold:
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


def _update(b: np.ndarray, c: np.ndarray, low: np.ndarray, pull_t: np.ndarray, f: np.ndarray,
            changed: np.ndarray, corners: np.ndarray, rows_terms: tuple, top: float) -> None:
    r"""Recompute in place :math:`b`, :math:`c` and the least signed area over the clamp's
    range, ``low`` (``(k,)`` each), of the triangles ``corners`` ``(3, k)`` with a corner
    in ``changed`` (vertices whose factor in ``f`` ``(n,)`` just changed), for the pull
    ``pull_t`` ``(3, n)`` times ``f``; ``rows_terms``: their ``N``, ``A1``, ``A2`` ``(3, k)``
    and :math:`\sigma_t(0)` ``(k,)``. The others' terms are the same as before, bit for bit.
    """
    mark = np.zeros(len(f), bool)
    mark[changed] = True
    c0, c1, c2 = corners
    redo = np.flatnonzero(mark[c0] | mark[c1] | mark[c2])
    Nt, A1, A2, a0 = rows_terms
    b[redo], c[redo] = _quadratic(pull_t, corners[:, redo], Nt[:, redo], A1[:, redo],
                                  A2[:, redo], f)
    low[redo] = a0[redo] - 1.0 + _lowest_sigma(b[redo], c[redo], top)


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


def guard_wrinkles(W: np.ndarray, radii: np.ndarray, guard: FoldGuard = FoldGuard()
                   ) -> np.ndarray:
    r"""``(n,)``: :math:`W` ``(n,)`` kept below :math:`\eta\, r_{\operatorname{sign} W}`
    (``radii`` ``(n, 2)``: :math:`r_+, r_-`) by :func:`soft_clamp`.
    """
    W = np.asarray(W, dtype=float)
    ids = np.flatnonzero(W)  # W = 0 is never clamped: the nonzero part decides
    w = W[ids]
    bound = guard.eta * np.where(w >= 0, radii[ids, 0], radii[ids, 1])
    out = W.copy()
    out[ids] = soft_clamp(w, np.maximum(bound, 1e-300), guard.knee)
    return out


@dataclass(frozen=True)
class GuardResult:
    """A guarded frame.

    Attributes
    ----------
    deformed : (n, 3) float
        The deformed skin with each pull scaled by ``scale``.
    points : (n, 3) float
        The final skin.
    W : (n,) float
        The guarded wrinkle amplitude.
    scale : (n,) float
        The factor on each vertex's pull (1 where the pull guard does not act).
    acted : (n,) bool
        Where either guard changed the frame.
    """

    deformed: np.ndarray
    points: np.ndarray
    W: np.ndarray
    scale: np.ndarray
    acted: np.ndarray


def _rewrinkled(points: np.ndarray, d2: np.ndarray, W: np.ndarray, W2: np.ndarray,
                moved: np.ndarray, tri: np.ndarray, terms: dict) -> np.ndarray:
    """``(n, 3)``: the final ``points`` with the guarded deformed skin ``d2`` ``(n, 3)``
    where the pull was scaled (``moved`` ``(n,)``) and :math:`x' + W' n'` where the pull
    moved a vertex's ring or the clamp changed ``W`` to ``W2`` ``(n,)``; ``points`` itself
    where neither happened.
    """
    changed_w = W2 != W
    if not (moved.any() or changed_w.any()):
        return points
    if moved.any():  # (where only the clamp acted, no ring moved: no scan of the skin)
        ring = np.zeros(len(points), bool)
        ring[tri[_any_corner(moved, tri)].ravel()] = True
        redo = np.flatnonzero((ring & (W2 != 0.0)) | changed_w)
    else:
        redo = np.flatnonzero(changed_w)
    p2 = points.copy()
    p2[moved] = d2[moved]
    if len(redo):
        p2[redo] = d2[redo] + W2[redo, None] * _vertex_normals(d2, tri, redo, terms)
    return p2


def _clamped(W: np.ndarray, radii, certified: bool, d2: np.ndarray, tri: np.ndarray,
             terms: dict, guard: FoldGuard, deformed: bool, step: np.ndarray | None,
             empty: np.ndarray | None = None, clear: np.ndarray | None = None
             ) -> np.ndarray:
    r"""``(n,)``: :math:`W` ``(n,)`` clamped by :func:`guard_wrinkles` on the rest ``radii``
    ``(n, 2)`` (or a function giving them, called only when they are needed), lowered by
    the deformed skin ``d2``'s (:func:`_deformed_radii`) when ``deformed``; ``W`` itself
    where the clamp is ``certified`` (the identity on the rest radii) and no deformed ball
    shrank. ``step``: the frame's :math:`W n` when ``d2`` is its deformed skin; ``empty``
    ``(n,)`` bool: the vertices whose deformed balls are certified empty (not searched),
    ``clear`` ``(n,)`` bool: those certified empty of triangles (:func:`_gaps_clear`).
    """
    low = _deformed_lows(d2, tri, W, terms, guard, step, empty, clear) if deformed else None
    if certified and low is None:
        return W
    if callable(radii):
        radii = radii()
    if low is not None:
        rows, values = low
        radii = np.array(radii, dtype=float, copy=True)
        radii[rows] = np.minimum(radii[rows], values)
    return guard_wrinkles(W, radii, guard)


def _held_wrinkles(rest: np.ndarray, d2: np.ndarray, p2: np.ndarray, W2: np.ndarray,
                   tri: np.ndarray, guard: FoldGuard, terms: dict
                   ) -> tuple[np.ndarray, np.ndarray]:
    r"""The wrinkles' own step :math:`x' \to x' + W' n'` (``d2`` to ``p2``, ``(n, 3)``)
    held by :func:`skin_scale` against the rest skin's signed areas: the points and ``W2``
    ``(n,)`` scaled by its factor where it is below 1 (as they are elsewhere).
    """
    h = skin_scale(rest, p2, tri, guard.min_area_wrinkles, guard.knee_wrinkles, terms=terms,
                   start=d2)
    held = np.flatnonzero(h < 1.0)
    if not len(held):
        return p2, W2
    p2 = np.array(p2, dtype=float, copy=True)
    p2[held] = d2[held] + h[held, None] * (p2[held] - d2[held])
    W2 = W2.copy()
    W2[held] *= h[held]
    return p2, W2


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
    half = val // 2
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
    key = (np.minimum(a, b).astype(np.int64) * n + np.maximum(a, b)) * 2 + (a > b)
    order = np.argsort(key, kind="stable")
    s = key[order]
    new = np.empty(len(s), bool)
    new[:1], new[1:] = True, s[1:] != s[:-1]
    return order, s, new


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
    up = np.flatnonzero((val[1:] == val[:-1] + 1) & (val[:-1] % 2 == 0))
    twin[up], twin[up + 1] = starts[up + 1], starts[up]
    half = val // 2
    own = (val % 2 == 0) & (half // n == half % n)
    twin[own] = starts[own]
    at = twin[np.cumsum(new) - 1]
    third = tri[:, [2, 0, 1]].ravel()  # the corner opposite each edge
    across = np.empty(len(s), np.intp)
    across[order] = np.where(at >= 0, third[order[np.maximum(at, 0)]], -1)
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
            half = runs[1][runs[2]] // 2
            key = half[np.r_[True, half[1:] != half[:-1]]]
            edges = np.stack([key // n, key % n], axis=1)
        ends = np.concatenate([edges[:, 0], edges[:, 1]])
        order = np.argsort(ends, kind="stable")
        start = np.concatenate([[0], np.cumsum(np.bincount(ends, minlength=n))])
        graph = terms["fan_edges"] = {
            "edges": np.asarray(edges, dtype=np.intp), "start": start,
            "edge": order % len(edges),
            "nbr": np.concatenate([edges[:, 1], edges[:, 0]])[order]}
    return graph


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
    (:func:`_fan_edges`).
    """
    mask = np.zeros(n, bool)
    mask[rows] = True
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
            return region, _two_rings(changed[region["ask"]], region)
    S = changed
    if memo and memo[-1]["rest"] == flag and (changed & memo[-1]["S"]).any():
        S = changed | memo.pop()["S"]
    n = len(changed)
    graph = _fan_edges(tri, n, terms)
    ask = _ring(_ring(np.flatnonzero(S), graph, n), graph, n)
    inside = np.full(n, -1)
    inside[ask] = np.arange(len(ask))
    e = inside[graph["edges"]]
    e = e[(e[:, 0] >= 0) & (e[:, 1] >= 0)]
    region = {"S": S, "rest": flag, "ask": ask, "e0": e[:, 0].copy(), "e1": e[:, 1].copy(),
              "pairs": {}}
    if rest is not None:
        region["rest_region"] = _rest_region(rest, tri, ask, terms)
        region["rest_fails"] = ~_rest_sure(rest, tri, terms)[ask]
    memo.append(region)
    while len(memo) > _FAN_REGIONS:
        memo.pop(0)
    return region, _two_rings(changed[ask], region)


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
    """
    n, t = len(p), tri[sub]
    c0, c1, c2 = (p[t[:, k]] for k in range(3))
    A = _cross(c1 - c0, c2 - c0)
    la = np.maximum(np.sqrt(_rows_dot(A, A)), 1e-300)
    m = np.stack([np.bincount(t.ravel(), np.repeat(A[:, k], 3), n) for k in range(3)], axis=1)
    m = m / np.maximum(np.sqrt(_rows_dot(m, m)), 1e-300)[:, None]
    c = np.full(n, np.inf)
    angle = np.zeros(n)
    for k, (a, b, o) in enumerate(((c1, c2, c0), (c2, c0, c1), (c0, c1, c2))):
        mv = m[t[:, k]]
        up = _rows_dot(A, mv)
        np.minimum.at(c, t[:, k], up / la)
        e1, e2 = a - o, b - o
        flat = _rows_dot(e1, e2) - _rows_dot(e1, mv) * _rows_dot(e2, mv)
        angle += np.bincount(t[:, k], np.arctan2(up, flat), n)
    star = (c > _FAN_MARGIN) & (angle < 3.0 * np.pi)
    return m, c, star


def _certified_fans(p: np.ndarray, tri: np.ndarray, ask: np.ndarray, fans: dict,
                    terms: dict) -> tuple[np.ndarray, np.ndarray]:
    r"""``(k,)`` bool twice, for vertices ``ask`` ``(k,)`` on ``p`` ``(n, 3)``: whose fan is
    a star (its triangles meet only in shared vertices and edges), and whose fan meets
    the triangles of its two rings only in shared vertices and edges, certainly
    (``docs/model.md``, "The fans"). Seen along the vertex's :math:`m_v`
    (:func:`_fan_terms`): the vertex and its ring are closed (not ``open``), its fan is a
    star once around it, its link turns left at every ring vertex :math:`u` (the
    projected fan :math:`S_v` is convex), and every :math:`u`'s fan is a star once around
    it (along :math:`m_u` with :math:`c_u > |m_v - m_u|`, which makes it one along
    :math:`m_v`, or else checked along :math:`m_v`, :func:`_stars_along`).
    """
    n = len(p)
    inc = _fan_incidence(tri, n, terms)
    asked = np.zeros(n, bool)
    asked[ask] = True
    ring = _ring(ask, _fan_edges(tri, n, terms), n)
    at_ring = np.zeros(len(tri), bool)
    at_ring[_sub_rows(inc, ring)[1]] = True
    sub = np.flatnonzero(at_ring)  # the triangles at the asked ones' rings
    m, c, star = _fan_terms(p, tri, sub)
    star &= ~fans["open"]
    t = tri[sub]
    rows = np.flatnonzero(asked[t.T.ravel()])  # the asked vertices' corners
    k, rows = rows // len(sub), rows % len(sub)
    v, u, w = t[rows, k], t[rows, (k + 1) % 3], t[rows, (k + 2) % 3]
    before = fans["across"][sub[rows], k]  # the ring vertex before u (across edge v-u)
    e_in, e_out = p[u] - p[np.maximum(before, 0)], p[w] - p[u]
    turn = _rows_dot(_cross(e_in, e_out), m[v])
    left = turn > _FAN_MARGIN * np.sqrt(_rows_dot(e_in, e_in) * _rows_dot(e_out, e_out))
    ok = asked & star
    ok[v[~(star[u] & left)]] = False
    dm = m[v] - m[u]
    along = c[u] > np.sqrt(_rows_dot(dm, dm)) + _FAN_MARGIN
    rows = np.flatnonzero(ok[v] & ~along)  # u's star along m_v, checked
    if len(rows):
        ok[v[rows[~_stars_along(p, tri, inc, v[rows], u[rows], m)]]] = False
    return star[ask], ok[ask]


def _rows_dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(k,)``: the dot products of the rows of ``a`` and ``b`` ``(k, 3)``."""
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def _stars_along(p: np.ndarray, tri: np.ndarray, inc: sp.csr_matrix, v: np.ndarray,
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


def _fan_incidence(tri: np.ndarray, n: int, terms: dict) -> sp.csr_matrix:
    """``(n, m)``: :func:`_incidence` of ``tri``, cached in ``terms`` (as
    :func:`_vertex_normals` caches it).
    """
    inc = terms.get("incidence")
    if inc is None:
        inc = terms["incidence"] = _incidence(tri, n)
    return inc


def _sub_rows(inc: sp.csr_matrix, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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


def _fan_pairs(tri: np.ndarray, inc: sp.csr_matrix, loose: np.ndarray, edges: np.ndarray
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
    cache (:func:`pull_terms`' dict, of ``rest`` when it is given).
    """
    tri = np.asarray(triangles, dtype=np.intp)
    terms = {} if terms is None else terms
    d, p0 = np.asarray(deformed, dtype=float), np.asarray(points, dtype=float)
    moved = p0 != d
    changed = moved = moved[:, 0] | moved[:, 1] | moved[:, 2]
    if not moved.any():
        return points, W
    if rest is not None and not terms.get("fans_seen"):
        # a skin's first frame is guarded without the rest filter: its margins cost a
        # pass over the whole skin (three times the frame's exact checks on a refined
        # frame's skin, new on each frame); a skin seen again pays for them once
        terms["fans_seen"] = True
        rest = None
    h = np.ones(len(d))
    p, rounds = p0, 0
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
    terms.pop("fan_runs", None)  # (the edges' sort, if the fans' structure did not take it)
    if p is p0:
        return points, W
    return p, np.asarray(W, dtype=float) * h


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
    if check.any():
        star[check], sure[check] = _certified_fans(p, tri, ask[check],
                                                   _fan_structure(tri, n, terms), terms)
    return _pairs_of(tri, n, terms, region, ask[~sure], ask[~star])


def _pairs_of(tri: np.ndarray, n: int, terms: dict, region: dict, loose: np.ndarray,
              open_fans: np.ndarray) -> np.ndarray:
    """:func:`_fan_pairs` of the vertices ``loose`` ``(a,)`` (sorted; certificate not
    holding) and ``open_fans`` (their fans not stars): the edges with both ends loose
    found through the skin's edge lists, the pairs kept in the ``region``
    (:func:`_fan_region`) for the last :data:`_FAN_PAIRS` such sets.
    """
    key = (loose.tobytes(), open_fans.tobytes())
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


def guard_frame(rest: np.ndarray, deformed: np.ndarray, points: np.ndarray, W: np.ndarray,
                triangles: np.ndarray, radii: np.ndarray | Callable[[], np.ndarray],
                guard: FoldGuard = FoldGuard(),
                pulls: bool = True, terms: dict | None = None, deformed_radii: bool = False,
                certified: Certified | None = None) -> GuardResult:
    r"""The guards on one frame: ``rest``, ``deformed`` (before :math:`W`) and final
    ``points`` ``(n, 3)``, ``W`` ``(n,)``, ``triangles`` ``(m, 3)``, rest ``radii``
    ``(n, 2)`` (:func:`medial_radii`); ``terms``: :func:`pull_terms` of ``rest``, when cached.

    1. The pulls are scaled by :func:`skin_scale` (no triangle keeps less than
       ``min_area`` of its rest signed area); ``pulls=False`` skips it.
    2. :math:`W` is clamped by :func:`guard_wrinkles` (below :math:`\eta\, r_\pm`); with
       ``deformed_radii``, :math:`r_\pm` at each wrinkled vertex is the lesser of ``radii``
       and the medial radii of the guarded deformed skin itself (the surface :math:`W`
       displaces; the pulls may have pressed it together), its balls empty of its
       triangles (:func:`triangle_radii`), not only of its vertices.
    3. The wrinkles' own step, :math:`x' \to x' + W' n'`, is held to the same rule as the
       pulls, against the guarded deformed skin: :math:`W'` is scaled by
       :func:`skin_scale` of that step (a steep furrow on small triangles would otherwise
       turn them over).
    4. With ``guard.fans``: no vertex's displaced fan passes through the triangles of its
       two rings (:func:`guard_fans`: :math:`W'` scaled back where a pair would cross).

    ``certified`` (:func:`certify`): the checks it certifies are skipped (each would have
    returned what skipping gives); a pull the exact check does scale voids the others.
    ``radii`` may be a function giving them, called only where they are needed.

    Where no guard acts, the frame's points are returned as they are (bit for bit).
    Elsewhere the final point is :math:`x' + W' n'`, with :math:`x'` the scaled pull and
    :math:`n'` the area-weighted unit normal of the guarded deformed skin; a vertex whose
    deformed ring moved keeps its own :math:`W` along the new normal.
    """
    tri = np.asarray(triangles, dtype=np.intp)
    rest = np.asarray(rest, dtype=float)
    if terms is None:
        terms = pull_terms(rest, tri)
    cert = certified if certified is not None else Certified(False, False, False, False)
    f = (skin_scale(rest, deformed, tri, guard.min_area, guard.knee, terms=terms)
         if pulls and not cert.pulls else np.ones(len(rest)))
    W = np.asarray(W, dtype=float)
    moved = f < 1.0
    d2, p2 = np.asarray(deformed, dtype=float), np.asarray(points, dtype=float)
    if moved.any():
        d2 = d2.copy()
        d2[moved] = rest[moved] + f[moved, None] * (d2[moved] - rest[moved])
        cert = Certified(False, False, False, False)  # certified for the unscaled pull only
    search, step = deformed_radii and not cert.balls, None if moved.any() else p2 - d2
    empty, clear = _gaps_skip(rest, d2, W, tri, terms, guard, cert.empty, step) if search \
        else (cert.empty, None)
    W2 = _clamped(W, radii, cert.clamp, d2, tri, terms, guard, search, step, empty, clear)
    p2 = _rewrinkled(p2, d2, W, W2, moved, tri, terms)
    if not cert.step:
        p2, W2 = _held_wrinkles(rest, d2, p2, W2, tri, guard, terms)
    if guard.fans:  # no fan through its two rings
        p2, W2 = guard_fans(d2, p2, W2, tri, terms, rest)
    acted = moved | (W2 != W)
    if p2 is not points:  # (ors of the columns: a reduction over rows of 3 is slow)
        differ = p2 != points
        acted |= differ[:, 0] | differ[:, 1] | differ[:, 2]
    return GuardResult(d2, p2, W2, f, acted)


def guard_amount(rest: np.ndarray, deformed: np.ndarray, points: np.ndarray, W: np.ndarray,
                 result: GuardResult) -> np.ndarray:
    r"""``(n,)`` in ``[0, 1]``: how much the guard took away at each vertex, the field
    ``fold_guard`` (0 where it did not act), from the raw frame (``rest``, ``deformed``,
    ``points`` ``(n, 3)``, ``W`` ``(n,)``) and its :class:`GuardResult`: the largest of the
    pull's reduction :math:`1 - f`, :math:`W`'s, :math:`1 - |W'| / |W|`, and the final
    point's shift relative to the raw displacement,
    :math:`|x'_f - x_f| / (|W| + |x_d - x_r|)` (a vertex whose normal turned with its
    guarded neighbours).
    """
    W = np.asarray(W, dtype=float)
    ratio = np.divide(np.abs(result.W), np.abs(W), out=np.ones(len(W)), where=W != 0)
    amount = np.maximum(1.0 - result.scale, 1.0 - ratio)
    rows = np.flatnonzero(result.acted)
    if len(rows):
        shift = np.linalg.norm(result.points[rows] - np.asarray(points)[rows], axis=1)
        size = np.abs(W[rows]) + np.linalg.norm(
            np.asarray(deformed)[rows] - np.asarray(rest)[rows], axis=1)
        amount[rows] = np.maximum(amount[rows], np.minimum(
            np.divide(shift, size, out=np.ones(len(rows)), where=size > 0), 1.0))
    return amount


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
    L = _longest_edge(deformed, tri, terms)
    samples, local, t_loc = _local_skin(deformed, tri, lo - L, hi + L)
    # the balls to search (_to_search): the vertices' search where a vertex lies inside
    # (medial_radii), then the triangles' (a ball empty of vertices may hold a triangle)
    c = x + np.where(W[ids] >= 0, 1.0, -1.0)[:, None] * start[:, None] * n
    free = np.zeros(len(ids), bool) if clear is None else clear[ids]
    todo, lift, near = _to_search(samples, t_loc, c, start, local[ids], free)
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
    pick = at_start[near[0]]
    found = ((np.cumsum(at_start) - 1)[near[0][pick]], near[1][pick])  # rows of plain
    r[plain] = triangle_radii(own[plain], n[plain], r[plain], samples, t_loc, lift=lift,
                              clear=False, found=found)
    o = hit[~free[hit]]
    r[o] = triangle_radii(own[o], n[o], r[o], samples, t_loc, lift=lift, clear=False)


def _to_search(samples: np.ndarray, t_loc: np.ndarray, c: np.ndarray, start: np.ndarray,
               own: np.ndarray, free: np.ndarray
               ) -> tuple[np.ndarray, dict | None, tuple[np.ndarray, np.ndarray]]:
    r"""The balls of :func:`_deformed_lows` to search ``(k,)`` (ascending), the lifted
    classes of the local skin ``samples`` ``(s, 3)``, ``t_loc`` ``(t, 3)`` (None where not
    needed) and the pairs (ball, vertex) ``(q,)`` twice of :func:`_lifted_near`, the balls
    as rows of the result: those certified ``free`` ``(b,)`` of triangles (the vertices'
    search alone), and of the others, centres ``c`` ``(b, 3)``, radii ``start`` ``(b,)``
    at the local vertices ``own`` ``(b,)``, those :func:`_cleared` does not clear (one
    nearest-point query of the lifted vertices clears a ball no vertex and no triangle not
    incident to its vertex can enter; the same queries find the others' candidates).
    """
    if free.all():
        none = np.zeros(0, np.intp)
        return np.flatnonzero(free), None, (none, none)
    lift = _lift(samples, t_loc)
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
    box = _in_box(points, lo, hi)
    local = np.full(len(points), -1, dtype=np.intp)
    local[box] = np.arange(len(box))
    t_loc = np.take(local, tri)  # (takes, not fancy indexing, and three compares and two
    keep = np.flatnonzero((t_loc[:, 0] >= 0) & (t_loc[:, 1] >= 0) & (t_loc[:, 2] >= 0))
    return np.take(points, box, axis=0), local, np.take(t_loc, keep, axis=0)  # ands: faster)


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
    skin's first frame or with no vertex to look at.
    """
    terms["gap_frames"] = seen = terms.get("gap_frames", 0) + 1
    ids = np.flatnonzero(W if skip is None else (W != 0) & ~skip)
    if seen < 2 or not len(ids):
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


def _longest_edge(points: np.ndarray, tri: np.ndarray, terms: dict) -> float:
    """The longest edge of the skin ``points`` ``(n, 3)``, ``tri`` ``(m, 3)``, its edges'
    ends kept in ``terms`` as two contiguous arrays: each triangle's three sides on a
    skin's first frame; from its second (the terms of a skin that is guarded again: an
    unrefined face's), its unique edges (:func:`_terms_edges`), half as many, the same
    lengths (a side's length does not depend on its direction).
    """
    ends, unique = terms.get("edge_ends", (None, False))
    if ends is None or not unique:
        unique = ends is not None or "edges" in terms  # (a second frame, or found already)
        edges = _terms_edges(terms)[0] if unique else np.vstack(
            [tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
        ends = (np.ascontiguousarray(edges[:, 0], dtype=np.intp),
                np.ascontiguousarray(edges[:, 1], dtype=np.intp))
        terms["edge_ends"] = (ends, unique)
    if not len(ends[0]):
        return 0.0
    e = np.take(points, ends[0], axis=0)  # (a take: several times faster than points[ends])
    e -= np.take(points, ends[1], axis=0)
    return float(np.sqrt(np.einsum("ij,ij->i", e, e).max()))


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


def guarded(face, state, guard: FoldGuard = FoldGuard()):
    r"""Apply :func:`guard_frame` to a frame ``state`` of ``face`` (unrefined or refined) in
    place: its ``deformed_points``, ``points`` and ``W`` become the guarded ones,
    ``W_raw`` keeps the raw :math:`W` and ``fold_guard`` ``(n,)`` in ``[0, 1]`` says how
    much the guard took away (:func:`guard_amount`). Returns ``state``.

    On the face's own skin, where the pull guard scales a pull, the frame is evaluated
    again on the guarded deformed skin (as the physical skin's frames are, from their
    skin): the compression :math:`\varepsilon` (Eq. 9, 10), :math:`A` and :math:`W` of every
    muscle, and ``state.fields``, are those of the skin the wrinkles sit on; then
    :math:`W` is guarded on it. ``W_raw`` stays the unguarded frame's :math:`W`.

    A refined frame is guarded on its refined skin (the pulls of its vertices as the
    subdivision hierarchy evaluated them), with the rest skin's terms cached on the refined
    face (frames with the same split set share it); its fields stay those of the unguarded
    pull.
    """
    if not np.any(state.W) and state.deformed_points is state.rest_points:
        return state
    cert = certify(face, state, guard)
    if cert is not None and cert.all:  # no check can act: the frame as it is
        return state
    radii = fold_radii(face, state.face, state.W, guard) if cert is None or not cert.clamp \
        else lambda: fold_radii(face, state.face, state.W, guard)  # asked for if needed
    skin = state.face  # the face's own skin, or the refined one of this frame
    terms = getattr(skin._rest, "pull_terms", None)
    if terms is None:
        surface = skin.skin  # (its edges found only where a pull is limited, when the
        terms = skin._rest.pull_terms = pull_terms(  # surface has not found them already)
            surface.points, surface.triangles, vars(surface).get("edges"))
    g = guard_frame(state.rest_points, state.deformed_points, state.points, state.W,
                    state.triangles, radii, guard, terms=terms,
                    deformed_radii=True, certified=cert)
    if not g.acted.any():
        return state
    if state.face is face and np.any(g.scale < 1.0):  # the fields see the guarded pull
        scale, acted = g.scale, g.acted
        del radii  # g's points and W, and the radii, are not needed again: freed first
        fresh = face._frame(dict(state.activations), g.deformed)
        del g
        radii = fold_radii(face, state.face, fresh.W, guard)  # the fresh frame's W
        w = guard_frame(state.rest_points, fresh.deformed_points, fresh.points, fresh.W,
                        state.triangles, radii, guard, pulls=False, terms=terms,
                        deformed_radii=True)
        g = GuardResult(w.deformed, w.points, w.W, scale, acted | w.acted)
        state.fields = fresh.fields
    W = np.asarray(state.W)
    amount = guard_amount(state.rest_points, state.deformed_points, state.points, W, g)
    for name, value in (("W_raw", W), ("deformed_points", g.deformed), ("points", g.points),
                        ("W", g.W), ("fold_guard", amount)):
        value = np.asarray(value)
        value.setflags(write=False)
        setattr(state, name, value)
    return state


# ---------------------------------------------------------------- certified skips
#
# Conservative certificates that an unrefined frame of the geometric skin cannot make a
# guard act (``docs/model.md``, "Certified skips"): each is a handful of operations on
# numbers kept per skin and per set of active muscles, and where it holds the exact check it
# stands for is skipped; where it does not, the exact check runs as before. A skipped check
# would have returned exactly what skipping gives (the frame's own arrays), so the frames are
# bit for bit those of the exact checks.

_CERT_MAX_POINTS = 20_000  # larger skins keep no pairs and radii for the certificates
_CERT_REACH = 6.0  # the pairs' reach D, in median edge lengths
_CERT_ASSEMBLIES = 32  # the active sets whose bounds a skin keeps


@dataclass(frozen=True)
class Certified:
    r"""Which checks of :func:`guard_frame` a frame's certificate lets it skip.

    Attributes
    ----------
    pulls : bool
        No triangle can fall below ``min_area`` under the pull (:func:`skin_scale` gives 1).
    step : bool
        No triangle can fall below ``min_area_wrinkles`` under the wrinkles' step.
    balls : bool
        No deformed vertex, and no deformed triangle not incident to the ball's vertex,
        meets any ball :func:`_deformed_radii` tests.
    clamp : bool
        :math:`|W| \le \kappa\eta r` at every vertex with the rest radii: the clamp is
        the identity where the deformed skin's radii are not lower.
    empty : (n,) bool or None
        Where ``balls`` fails: the vertices whose own ball is certified empty
        (:func:`_empty_balls`; :func:`_deformed_lows` does not search them).

    Each of ``step``, ``balls`` and ``clamp`` holds for the frame's own pull: where the
    pulls' check scales it, they say nothing (:func:`guard_frame` then runs every check).
    """

    pulls: bool
    step: bool
    balls: bool
    clamp: bool
    empty: np.ndarray | None = field(default=None, compare=False, repr=False)

    @property
    def all(self) -> bool:
        """Every check certified: the guard cannot act on the frame."""
        return self.pulls and self.step and self.balls and self.clamp


def _skin_bounds(face) -> dict | None:
    r"""What the certificates need of ``face``'s rest skin, computed once and kept with its
    rest frame (None for a skin of more than :data:`_CERT_MAX_POINTS` vertices):

    * ``radii`` ``(n, 2)``: every rest radius in full, as lower bounds
      (:func:`_verified_radii`; the exact checks keep their own, searched as a frame needs),
      at the vertices a muscle's wrinkles may reach (:func:`_may_wrinkle`), 0 (no bound)
      elsewhere;
    * ``sep`` ``(n,)``: each vertex's distance to the nearest other vertex or triangle not
      incident to it, :math:`s_x` (:func:`_triangle_seps`, at the same vertices; elsewhere
      the nearest vertex's), ``near`` ``(n,)``: to the nearest other vertex, and ``L`` the
      longest edge;
    * ``K`` ``(m,)``: :math:`\|E_t^+\|_2 = 1/\sigma_{\min}(E_t)` of each triangle's rest
      edges :math:`E_t = [e_1\ e_2]`, and ``Einv`` ``(m, 2, 3)``: :math:`E_t^+`;
    * ``pairs`` ``(p, 2)`` and ``dist`` ``(p,)``: every pair of vertices at most
      :math:`D` = ``reach`` apart (:data:`_CERT_REACH` median edges).
    """
    rest = face._rest
    got = getattr(rest, "fold_bounds", None)
    if got is not None:
        return got or None
    skin = face.skin
    if skin.n_points > _CERT_MAX_POINTS or skin.n_points < 2:
        rest.fold_bounds = {}
        return None
    pts = np.asarray(skin.points, dtype=float)
    tri = np.asarray(skin.triangles, dtype=np.intp)
    d, _ = skin.kdtree.query(pts, k=2)
    lift = _skin_lift(face)
    rows = _may_wrinkle(face)
    sep, L = _triangle_seps(pts, tri, d[:, 1], lift, rows)  # vertex or triangle not its own
    radii = _verified_radii(pts, rest.normals, skin.kdtree, sep, tri, lift, rows)
    E = np.stack([pts[tri[:, 1]] - pts[tri[:, 0]], pts[tri[:, 2]] - pts[tri[:, 0]]], axis=2)
    Einv = np.linalg.pinv(E)  # (m, 2, 3); 0 rows for a triangle with no area
    sv = np.linalg.svd(E, compute_uv=False)
    with np.errstate(divide="ignore"):
        K = np.where(sv[:, 1] > 0, 1.0 / sv[:, 1], np.inf)
    reach = _CERT_REACH * float(np.median(skin.rest_edge_lengths))
    pairs = skin.kdtree.query_pairs(reach, output_type="ndarray").astype(np.int32)
    dist = np.linalg.norm(pts[pairs[:, 0]] - pts[pairs[:, 1]], axis=1)
    rest.fold_bounds = got = {"radii": radii, "sep": sep, "near": d[:, 1], "K": K, "Einv": Einv,
                              "pairs": pairs, "dist": dist, "reach": reach, "L": L,
                              "size": float(np.abs(pts).max()), "assemblies": {}}
    return got


def _may_wrinkle(face, rings: int = 2) -> np.ndarray:
    """``(k,)``: the vertices of ``face``'s skin in any of its muscles' areas of influence
    and ``rings`` rings of edges about them (a refined vertex takes the radii of its three
    nearest skin vertices): where its frames' :math:`W` may be nonzero. A radius left 0
    elsewhere only takes the clamp's certificate from a frame whose :math:`W` reaches there
    (a muscle moved since): ``|W| <= 0`` fails and the exact check runs.
    """
    inside = np.zeros(face.skin.n_points, bool)
    for m in face.muscles:
        inside[face.muscle_data(m).aoi] = True
    edges = np.asarray(face.skin.edges, dtype=np.intp)
    for _ in range(rings):
        grow = inside[edges[:, 0]] | inside[edges[:, 1]]
        inside[edges[grow].ravel()] = True
    return np.flatnonzero(inside)


def _verified_radii(pts: np.ndarray, normals: np.ndarray, tree: cKDTree, sep: np.ndarray,
                    tri: np.ndarray, lift: dict | None = None, rows: np.ndarray | None = None
                    ) -> np.ndarray:
    r"""``(n, 2)``: lower bounds of the rest radii that any search of :func:`fold_radii`
    cannot go below: the search in full (from twice the diagonal), each ball checked empty
    of vertices (0 where the search stopped before it was: its iteration cap), then emptied
    of the triangles (:func:`triangle_radii`, ``tri`` ``(m, 3)``), times
    :math:`1 - 4 \cdot 10^{-9} (r / s)^2` (``sep`` ``(n,)``: :math:`s`, the distance to the
    nearest other vertex or triangle not the vertex's own). A search stops at a ball with no
    vertex or triangle point deeper than
    :math:`10^{-9} r` inside; a vertex that deep in a ball of radius :math:`r` and at
    least :math:`s` from :math:`x` bounds a ball of radius at least
    :math:`r (1 - 2 \cdot 10^{-9} (r / s)^2)` (``docs/model.md``).
    """
    rows = np.arange(len(pts)) if rows is None else np.asarray(rows, dtype=np.intp)
    out = np.zeros((len(pts), 2))
    r_max = 2.0 * float(np.linalg.norm(np.ptp(pts, axis=0)))
    x, n = pts[rows], normals[rows]
    r = medial_radii(x, n, samples=pts, r_max=r_max, tree=tree)
    for col, side in enumerate((1.0, -1.0)):
        dist, _ = tree.query(x + side * r[:, col, None] * n)
        r[dist < r[:, col] * (1.0 - 1e-9), col] = 0.0  # not converged: no bound
    r = triangle_radii(rows, n, r, pts, tri, lift=lift, clear=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        loss = 4e-9 * (r / np.where(sep[rows] > 0, sep[rows], 0.0)[:, None]) ** 2
    out[rows] = np.where(loss < 1.0, r * (1.0 - loss), 0.0)
    return out


def _assembly_bounds(face, asm, skin: dict) -> dict:
    r"""What the certificates need of the active set ``asm`` (a ``_StackedMuscles``), per
    muscle :math:`m` in its order, from its unit displacement :math:`U_m` (the tangent pull
    at activation 1, 0 outside its AOI):

    * ``G`` ``(M,)``: :math:`\hat G_m = \max_t \|J_{m,t}\|_2`, :math:`J_{m,t} = [U_1 - U_0\
      \ U_2 - U_0]\,E_t^+` the gradient of :math:`U_m` on triangle :math:`t`;
    * ``U`` ``(M,)``: :math:`\hat U_m = \max_v |U_m(v)|`;
    * ``Lip`` ``(M,)``: :math:`\max |U_m(v) - U_m(w)| / |x_v - x_w|` over the pairs at most
      :math:`D` apart, and ``LipW`` ``(v, M)``: the same over the pairs of each wrinkled
      vertex (``asm.wrinkled``), :math:`\mathrm{Lip}_m(x)`;
    * ``Gt`` ``(T, M)``: :math:`\|J_{m,t}\|_2` on each triangle with a moved corner, and
      ``Um`` ``(3 u, M)``: :math:`U_m` at the moved vertices (``asm.moved``, their x, y
      and z in turn);

    and of the set: ``Kp``, ``Kw``, the largest :math:`K_t` of the triangles with a moved
    corner and with a wrinkled one; ``S``, the largest Frobenius norm of the slide's shape
    operators; ``sep``, the least :math:`s_x` of the wrinkled vertices.
    """
    memo = skin["assemblies"]  # by the assembly itself: the same names may be other muscles
    got = memo.pop(id(asm), None)
    if got is None or got[0] is not asm:
        got = (asm, _build_assembly_bounds(face, asm, skin))
    memo[id(asm)] = got  # (holding the assembly: its id is not reused while kept)
    while len(memo) > _CERT_ASSEMBLIES:
        memo.pop(next(iter(memo)))
    return got[1]


def _build_assembly_bounds(face, asm, skin: dict) -> dict:
    """:func:`_assembly_bounds`, computed."""
    tri = np.asarray(face.skin.triangles, dtype=np.intp)
    n = face.skin.n_points
    moved = np.zeros(n, bool)
    moved[asm.moved] = True
    pulled = np.flatnonzero(moved[tri].any(axis=1))
    G, U, Lip = [], [], []
    Gt = np.zeros((len(pulled), len(asm.names)))
    Um = np.zeros((len(asm.moved), 3, len(asm.names)))
    LipW = np.zeros((len(asm.wrinkled), len(asm.names)))
    for k, name in enumerate(asm.names):
        data = face.muscle_data(face.muscle(name))
        rows, norms, g, top, lip, lip_v = _muscle_bounds(face, data, skin)
        LipW[:, k] = lip_v[asm.wrinkled]
        G.append(g)
        U.append(top)
        Lip.append(lip)
        Gt[np.searchsorted(pulled, rows), k] = norms  # (its triangles are pulled ones)
        u = np.zeros((n, 3))
        u[data.aoi] = data.unit_disp
        Um[:, :, k] = u[asm.moved]  # (as rows x, y, z of each moved vertex)
    wrinkled = np.zeros(n, bool)
    wrinkled[asm.wrinkled] = True
    K = skin["K"]
    s = asm.slide_s
    frob = np.sqrt(s[0] ** 2 + s[1] ** 2 + s[2] ** 2 + 2.0 * (s[3] ** 2 + s[4] ** 2 + s[5] ** 2))

    def most(values: np.ndarray) -> float:
        return float(values.max()) if len(values) else 0.0

    return {"G": np.array(G), "U": np.array(U), "Lip": np.array(Lip), "Gt": Gt,
            # the triangles near the wrinkled vertices, found when a frame first asks
            "L": partial(_near_edges, np.asarray(face.skin.points, dtype=float),
                         np.asarray(face.skin.triangles, dtype=np.intp), asm.wrinkled,
                         0.5 * skin["reach"]),
            "ULG": np.ascontiguousarray(np.stack([U, Lip, G], axis=1)),
            "Um": np.ascontiguousarray(Um.reshape(-1, len(asm.names))), "LipW": LipW,
            "moved": asm.moved, "wrinkled": asm.wrinkled, "clamp": {},
            "Kp": most(K[moved[tri].any(axis=1)]), "Kw": most(K[wrinkled[tri].any(axis=1)]),
            "S": most(frob),
            # the vertices' separation (the triangles near x: "L", _near_edges)
            "sep": float(skin["near"][asm.wrinkled].min()) if len(asm.wrinkled) else np.inf}


def _muscle_bounds(face, data, skin: dict) -> tuple:
    r"""One muscle's part of :func:`_assembly_bounds`, from its rest data ``data`` (a
    ``_MuscleData``, shared by every face whose muscle has the same geometry, so a drag
    recomputes only the dragged muscle's): the triangles of its AOI ``(t,)`` and
    :math:`\|J_{m,t}\|_2` on them ``(t,)``, :math:`\hat G_m`, :math:`\hat U_m` and its
    Lipschitz bound, over all its pairs and ``(n,)`` over each vertex's. Kept per skin by
    the data itself (held, so its id is not reused).
    """
    memo = skin.setdefault("muscles", {})
    got = memo.pop(id(data), None)
    if got is None or got[0] is not data:
        got = (data, _build_muscle_bounds(face, data, skin))
    memo[id(data)] = got
    while len(memo) > 4 * _CERT_ASSEMBLIES:
        memo.pop(next(iter(memo)))
    return got[1]


def _build_muscle_bounds(face, data, skin: dict) -> tuple:
    """:func:`_muscle_bounds`, computed."""
    tri = np.asarray(face.skin.triangles, dtype=np.intp)
    n = face.skin.n_points
    pairs, dist = skin["pairs"], skin["dist"]
    u = np.zeros((n, 3))
    u[data.aoi] = data.unit_disp
    inside = np.zeros(n, bool)
    inside[data.aoi] = True
    rows = np.flatnonzero(inside[tri].any(axis=1))
    c = tri[rows]
    D = np.stack([u[c[:, 1]] - u[c[:, 0]], u[c[:, 2]] - u[c[:, 0]]], axis=2)
    J = D @ skin["Einv"][rows]
    norms = np.linalg.norm(J, ord=2, axis=(1, 2))
    near = np.flatnonzero(inside[pairs[:, 0]] | inside[pairs[:, 1]])
    p = pairs[near]
    diff = np.linalg.norm(u[p[:, 0]] - u[p[:, 1]], axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(diff > 0, diff / dist[near], 0.0)
    lip = np.zeros(n)  # per vertex: the largest ratio of its pairs
    np.maximum.at(lip, p[:, 0], ratio)
    np.maximum.at(lip, p[:, 1], ratio)
    return (rows, norms, float(norms.max()) if len(rows) else 0.0,
            float(np.linalg.norm(u, axis=1).max()), float(ratio.max()) if len(ratio) else 0.0,
            lip)


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


def _near_of(bounds: dict, R: float) -> dict | None:
    """:func:`_near_table` of the triangles near an active set's wrinkled vertices
    (:func:`_near_edges`, ``bounds["L"]``), found on first use and kept; ``R``: the pairs'
    reach. None for bounds that have none (a test's skin of vertices alone).
    """
    near = bounds.get("L")
    if callable(near):
        near = bounds["L"] = _near_table(near(), len(bounds["wrinkled"]), R)
    return near


_TABLE_STEPS = 32  # the near triangles' bounds are kept at Lambda = j / 32, j = 0..32
_TABLE_CUTS = (0.125, 0.25, 0.5, 1.0)  # and over the triangles within these parts of D


def _near_table(near: tuple, count: int, R: float) -> dict:
    r"""The triangles near ``count`` wrinkled vertices (:func:`_near_edges` ``near``; ``R``
    the pairs' reach) as a table the balls' certificates read in constant time:

    * ``F`` ``(count, c, J + 1)``: per vertex :math:`x`, cut :math:`l` and step :math:`j`,
      :math:`\min_t \max_k \min_i (h_{ki} - \Lambda_j m_i)` over :math:`x`'s triangles with
      :math:`d_{x,t} \le` ``cut[l]`` (:data:`_TABLE_CUTS` of the near triangles' reach
      :math:`D`), :math:`\Lambda_j = j / J` (:data:`_TABLE_STEPS`), ``inf`` where none;
      ``G`` ``(c, J + 1)``: its least over the vertices;
    * ``far`` ``(count,)`` bool: whether a corner of one of :math:`x`'s triangles lies
      beyond the pairs (:math:`m_i > R (1 - 10^{-9})`, its move bounded by :math:`2P`
      alone); ``cut`` ``(c,)``.

    Each entry is non-increasing in :math:`\Lambda` (:math:`m_i \ge 0`) and in the cut
    (a minimum over more triangles), so a frame's :math:`\Lambda` and reach read the entry
    at the next step and cut above them: a lower bound of the one they ask for.
    """
    d, h, m, D, owner = near[:5]
    J = _TABLE_STEPS
    cut = np.array(_TABLE_CUTS) * D
    steps = np.arange(J + 1) / J
    level = np.minimum(np.searchsorted(cut, d, side="left"), len(cut) - 1)
    key = owner * len(cut) + level
    order = np.argsort(key, kind="stable")  # the rows by vertex and cut
    g = np.empty((len(d), J + 1))
    for lo in range(0, len(d), 8192):  # max_k min_i (h_ki - lam_j m_i), 8192 rows at a time
        rows = order[lo:lo + 8192]
        lm = [m[rows, i, None] * steps for i in range(3)]
        for k in range(h.shape[1]):
            hk = h[rows, k]
            low = np.minimum(np.minimum(hk[:, 0, None] - lm[0], hk[:, 1, None] - lm[1]),
                             hk[:, 2, None] - lm[2])
            g[lo:lo + len(rows)] = low if k == 0 else np.maximum(g[lo:lo + len(rows)], low)
    F = np.full((count * len(cut), J + 1), np.inf)
    if len(d):
        key = key[order]
        starts = np.flatnonzero(np.concatenate([[True], key[1:] != key[:-1]]))
        F[key[starts]] = np.minimum.reduceat(g, starts, axis=0)
    F = np.minimum.accumulate(F.reshape(count, len(cut), J + 1), axis=1)
    far = np.zeros(count, bool)
    far[owner[(m > R * (1.0 - 1e-9)).any(axis=1)]] = True
    return {"F": F, "G": F.min(axis=0) if count else np.full((len(cut), J + 1), np.inf),
            "far": far, "cut": cut, "D": D}


def _table_bounds(table: dict, lam: np.ndarray, far: np.ndarray,
                  rows: np.ndarray | None = None) -> np.ndarray:
    r"""``(k,)``: lower bounds of :math:`\min_t \max_k \min_i (h_{ki} - \Lambda m_i)` over
    the triangles within ``far`` ``(k,)`` of each of the wrinkled vertices ``rows`` ``(k,)``
    (their rows of the table; None: the least over all, :func:`_near_table`'s ``G``) at
    :math:`\Lambda` = ``lam`` ``(k,)``: ``-inf`` where :math:`\Lambda > 1` or ``far``
    exceeds the table's reach.
    """
    J = _TABLE_STEPS
    j = np.ceil(lam * J * (1.0 + 1e-9)).astype(np.intp)  # the next step above lam
    j = np.where(j / J >= lam, j, j + 1)
    l = np.searchsorted(table["cut"], far, side="left")
    ok = (j <= J) & (l < len(table["cut"])) & (lam >= 0)
    j, l = np.where(ok, j, 0), np.where(ok, l, 0)
    got = table["G"][l, j] if rows is None else table["F"][rows, l, j]
    return np.where(ok, got, -np.inf)


def _clamp_limit(skin: dict, bounds: dict, guard: FoldGuard) -> np.ndarray:
    r"""``(v,)``: :math:`(1 - 10^{-5})\,\kappa\,\eta \min(r_+, r_-)` on the rest radii in
    full at the wrinkled vertices of an active set (its ``bounds``), kept per guard:
    :math:`|W|` at or below it leaves the clamp the identity and asks :func:`fold_radii`
    for no search.
    """
    key = (guard.eta, guard.knee)
    got = bounds["clamp"].get(key)
    if got is None:
        r = skin["radii"][bounds["wrinkled"]].min(axis=1)
        got = bounds["clamp"][key] = (1.0 - 1e-5) * guard.knee * guard.eta * r
    return got


def certify(face, state, guard: FoldGuard = FoldGuard()) -> Certified | None:
    r"""The certificates of an unrefined frame ``state`` of ``face``'s geometric skin; of
    any other frame (refined, physical) the clamp's alone (:func:`_clamp_only`); None for a
    skin too large to keep their data.

    With :math:`a_m` the activations, :math:`D = \sum_m a_m U_m` the summed tangent pull and
    :math:`b_v n_v` the slide (:func:`~wrinkle_vis.core.refined.slide_bend`), so the pull is
    :math:`p = D - b\,n`:

    * :math:`D_{\max} = \sum_m a_m \hat U_m`, :math:`b_{\max} = \min(\tfrac12 S D_{\max}^2,
      0.3 D_{\max})`, :math:`P = D_{\max} + b_{\max}` bound :math:`|D|`, :math:`|b|`, :math:`|p|`;
    * :math:`g = \sum_m a_m \hat G_m + 2\sqrt2\,K_p b_{\max}` bounds the pull's gradient on
      every triangle, :math:`\|J_t\|_2`;
    * pulls: :math:`(1 - g/\kappa)^2 \ge \sigma_{\min}` (then
      :math:`\sigma_t(s) = \det(I + s P_t J_t) \ge (1 - s g)^2` on :math:`[0, 1/\kappa]`);
    * step: :math:`g_w = 2\sqrt2\,K_w \max|W|`, :math:`(1 - g - g_w/\kappa_w)^2 \ge
      \sigma_{\min,w}`;
    * balls: :math:`\Lambda' = \max(\sum_m a_m \mathrm{Lip}_m, 2P/D) < 1`,
      :math:`2\rho + 2P \le D/2` and, with :math:`\delta = 2\rho(1 + 10^{-6}) + \tau`,
      :math:`\delta + 2b_{\max} \le s(1 - \Lambda')` and :math:`\le \min_t \max_u \min_i
      (h_i - \Lambda' m_i)` over the triangles within :math:`2\rho + 2P` of a wrinkled
      vertex (:func:`_near_edges`, read off :func:`_near_table`),
      :math:`\rho = \max|W| / (\kappa \eta_d)\,(1 + 10^{-6})` (no deformed vertex but
      :math:`x`, and no triangle not its own, within :math:`2\rho` of :math:`x`); where it
      fails, vertex by vertex (:func:`_balls_per_vertex`);
    * clamp: :math:`|W| \le` :func:`_clamp_limit` everywhere.

    ``docs/model.md`` ("Certified skips") has the proofs.
    """
    if state.face is not face or state.skin_model != "geometric":
        return _clamp_only(face, state, guard)
    acts = state.activations
    active = tuple(n for n, a in acts.items() if a > 0.0)
    if not active:
        return None
    skin = getattr(face._rest, "fold_bounds", None)
    if skin is None:
        skin = _skin_bounds(face)
    if not skin:
        return None
    asm = face._assembly(active)  # the face's own (faces derived by edits share the skin)
    got = skin["assemblies"].get(id(asm))
    bounds = got[1] if got is not None and got[0] is asm else _assembly_bounds(face, asm, skin)
    a = np.array([acts[m] for m in active])
    w = np.abs(np.take(state.W, bounds["wrinkled"]))  # W is 0 off the wrinkled vertices
    w_max = float(w.max()) if len(w) else 0.0
    clamp = bool((w <= _clamp_limit(skin, bounds, guard)).all())
    d_max, lam, g = (a @ bounds["ULG"]).tolist()  # sums of a_m U_m, a_m Lip_m, a_m G_m
    b_max = min(0.5 * bounds["S"] * d_max * d_max, 0.3 * d_max)
    lam *= 1.0 + 1e-9
    pulls, step, balls = _certificates(g, d_max, b_max, lam, w_max, bounds, skin, guard)
    if not (pulls and step and balls):  # the frame's own pull: tighter, a few calls more
        tight = _measured(state, a, (d_max, b_max, lam, w_max), bounds, skin, guard)
        pulls, step, balls = pulls or tight[0], step or tight[1], balls or tight[2]
        d_max, b_max = tight[3], tight[4]
    empty = None
    if not balls:  # each vertex's own ball, on its own |W| and separation
        balls, empty = _balls_per_vertex(len(state.W), a, w, b_max, d_max, bounds, skin,
                                         guard)
    return Certified(bool(pulls), bool(step), bool(balls), clamp, empty)


def _balls_per_vertex(n: int, a: np.ndarray, w: np.ndarray, b_max: float, d_max: float,
                      bounds: dict, skin: dict, guard: FoldGuard
                      ) -> tuple[bool, np.ndarray | None]:
    r"""The balls' certificate of :func:`certify` vertex by vertex (:func:`_empty_balls`),
    from the activations ``a`` ``(M,)`` and :math:`|W|` ``w`` ``(v,)`` at the active set's
    wrinkled vertices: whether every ball is certified empty, else the ``(n,)`` bool mask of
    those that are (None when none is), with :math:`\Lambda_x = \sum_m a_m
    \mathrm{Lip}_m(x)`, the vertices' separations and the triangles near each vertex
    (:func:`_near_edges`).
    """
    lam_x = (bounds["LipW"] @ a) * (1.0 + 1e-9)
    wrinkled = bounds["wrinkled"]
    ok = _empty_balls(w, skin["near"][wrinkled], lam_x, b_max, d_max, skin, guard,
                      partial(_near_of, bounds, skin["reach"]))
    if ok.all():
        return True, None
    if not ok.any():
        return False, None
    empty = np.zeros(n, bool)
    empty[wrinkled[ok]] = True
    return False, empty


def _empty_balls(w: np.ndarray, sep: np.ndarray, lam: np.ndarray, b_max: float,
                 d_max: float, skin: dict, guard: FoldGuard,
                 near: dict | Callable[[], dict | None] | None) -> np.ndarray:
    r"""``(v,)`` bool: the balls' certificate of :func:`certify` per wrinkled vertex, from
    its :math:`|W|` ``w`` ``(v,)``, rest separation from the other vertices :math:`s_x`
    ``sep`` ``(v,)``, Lipschitz bound :math:`\Lambda_x` ``lam`` ``(v,)`` (of the summed
    pull over the pairs of :math:`x` at most :math:`D` apart) and the triangles near it
    ``near`` (:func:`_near_table`, or a function giving it, called only if a vertex passes
    the other tests). With :math:`\rho_x = |W_x| / (\kappa\eta_d)(1 + 10^{-6})`,
    :math:`\delta_x = 2\rho_x(1 + 10^{-6}) + \tau` and :math:`P = d_{\max} + b_{\max}`:

    * vertices: :math:`\Lambda_x < 1`, :math:`\delta_x \le \min(s_x(1 - \Lambda_x) -
      2b_{\max}, D - 2P)`;
    * triangles not incident to :math:`x`: :math:`\delta_x + 2b_{\max} \le \min_t \max_k
      \min_i (h_{ki} - \Lambda'_x m_i)` over those with :math:`d_{x,t} \le \delta_x + 2P`
      (within the near triangles' reach), :math:`\Lambda'_x = \Lambda_x`, or
      :math:`\max(\Lambda_x, 2P/D)` where a corner lies beyond the pairs; read off the
      table (:func:`_table_bounds`).

    Then no deformed vertex but :math:`x'`, and no point of a deformed triangle not
    incident to :math:`x'`, lies within :math:`2\rho_x` of :math:`x'`, so its ball holds
    none (``docs/model.md``, "Certified skips").
    """
    tau = 1e-12 * (1.0 + skin["size"])
    room = 2.0 * w / (guard.knee * guard.eta_deformed) * (1.0 + 1e-6) * (1.0 + 1e-6) + tau
    P = d_max + b_max
    ok = (lam < 1.0) & (room <= sep * (1.0 - lam) - 2.0 * b_max) \
        & (room <= skin["reach"] - 2.0 * P)
    if not ok.any():
        return ok
    table = near() if callable(near) else near
    if table is None:  # no triangles kept: no vertex is certified for them
        return np.zeros(len(ok), bool)
    far = room + 2.0 * P  # beyond it no point of the skin comes within room of x
    lam_t = np.where(table["far"], np.maximum(lam, 2.0 * P / skin["reach"]), lam)
    ask = np.flatnonzero(ok & (w > 0))  # (a vertex with W = 0 has no ball to search)
    low = _table_bounds(table, lam_t[ask], far[ask], ask)
    ok[ask] &= room[ask] + 2.0 * b_max <= low
    return ok


def _clamp_only(face, state, guard: FoldGuard) -> Certified | None:
    r"""The clamp's certificate alone, for a frame whose pull is not known in closed form
    (refined, or the physical skin's): :math:`|W| \le` :func:`_clamp_limit` at every vertex,
    a refined vertex's limit the least of those of the three nearest vertices of ``face``'s
    skin (whose radii :func:`fold_radii` gives it). None where the skin keeps no bounds.
    """
    skin = getattr(face._rest, "fold_bounds", None)
    if skin is None:
        skin = _skin_bounds(face)
    if not skin:
        return None
    fine = state.face._rest
    limit = getattr(fine, "fold_clamp_limit", None)
    key = (guard.eta, guard.knee)
    if limit is None or limit[0] != key:
        r = skin["radii"]
        base = (1.0 - 1e-5) * guard.knee * guard.eta * np.minimum(r[:, 0], r[:, 1])
        if state.face is face or state.face.skin is face.skin:
            limit = (key, base)
        else:
            limit = (key, _refined_limits(face, state.face, base, key))
        fine.fold_clamp_limit = limit
    clamp = bool((np.abs(state.W) <= limit[1]).all())
    return Certified(False, False, False, clamp)


def _refined_limits(face, skin_face, base: np.ndarray, key: tuple) -> np.ndarray:
    r"""``(n,)``: the clamp's limit at each vertex of the refined ``skin_face``, the least of
    ``base`` ``(N,)`` (the limits on ``face``'s skin, for the guard's ``key``) at its three
    nearest vertices of ``face``'s skin (:func:`_nearest_skin_vertices`).

    A refined face is new on nearly every frame of an animation, its vertices rows
    ``order`` of the subdivision hierarchy (its rest frame's ``refined_from``; the rows
    are append-only), so the limits are kept per hierarchy row with ``face``'s rest frame
    (``fold_clamp_rows``: the hierarchy, ``key``, the limits, NaN where not yet found)
    and a frame takes them (one take of ``n``) and finds only the rows no frame asked for.
    """
    src = getattr(skin_face._rest, "refined_from", None)
    if src is None:
        idx = _nearest_skin_vertices(face, skin_face)
        return np.minimum(np.minimum(np.take(base, idx[:, 0]), np.take(base, idx[:, 1])),
                          np.take(base, idx[:, 2]))
    hier, order = src
    memo = getattr(face._rest, "fold_clamp_rows", None)
    rows = memo[2] if memo is not None and memo[0] is hier and memo[1] == key else \
        np.zeros(0)
    if len(rows) < hier.n_points:
        rows = np.concatenate([rows, np.full(hier.n_points - len(rows), np.nan)])
    out = np.take(rows, order)
    todo = np.flatnonzero(np.isnan(out))
    if len(todo):
        idx = np.take(_nearest_skin_vertices(face, skin_face), todo, axis=0)
        out[todo] = np.minimum(np.minimum(np.take(base, idx[:, 0]), np.take(base, idx[:, 1])),
                               np.take(base, idx[:, 2]))
        rows[np.take(order, todo)] = out[todo]
    face._rest.fold_clamp_rows = (hier, key, rows)
    return out


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


def _measured(state, a: np.ndarray, loose: tuple[float, ...], bounds: dict, skin: dict,
              guard: FoldGuard) -> tuple[bool, bool, bool, float, float]:
    r""":func:`_certificates` with the frame's own pull measured, and the bounds
    :math:`|D| \le` ``d_max`` and :math:`|b| \le` ``b_max`` it used: the slide
    :math:`|p - D|` (``D`` from the kept :math:`U_m` and the activations ``a`` ``(M,)``), the
    gradient bound :math:`\max_t \sum_m a_m \|J_{m,t}\|` and, where the balls' far term
    asks for it, :math:`|D|`; ``loose``: the bounds ``d_max``, ``b_max``, ``lam``,
    ``w_max`` from the per-muscle maxima.
    """
    d_max, b_max, lam, w_max = loose
    moved = bounds["moved"]
    slide = np.take(state.deformed_points, moved, axis=0)
    slide -= np.take(state.rest_points, moved, axis=0)
    D = (bounds["Um"] @ a).reshape(-1, 3)  # the summed tangent pull
    slide -= D
    tol = 1e-12 * (1.0 + skin["size"])
    b_max = min(b_max, math.sqrt(float(np.einsum("ij,ij->i", slide, slide).max())) + tol)
    g = float((bounds["Gt"] @ a).max())
    tight = _certificates(g, d_max, b_max, lam, w_max, bounds, skin, guard)
    if not tight[2]:  # the balls' far term may ask for the measured |D|
        d_max = min(d_max, math.sqrt(float(np.einsum("ij,ij->i", D, D).max())) + tol)
        tight = _certificates(g, d_max, b_max, lam, w_max, bounds, skin, guard)
    return (*tight, d_max, b_max)


def _certificates(g: float, d_max: float, b_max: float, lam: float, w_max: float,
                  bounds: dict, skin: dict, guard: FoldGuard) -> tuple[bool, bool, bool]:
    r"""The pulls', the wrinkle step's and the balls' certificates of :func:`certify` from
    the bounds :math:`\sum_m a_m \|J_{m,t}\|` (``g``, before the slide's part),
    :math:`|D| \le` ``d_max``, :math:`|b| \le` ``b_max``, :math:`\Lambda` (``lam``) and
    :math:`\max|W|` (``w_max``); plain floats (a few microseconds).
    """
    g = (g + _TWO_SQRT2 * bounds["Kp"] * b_max) * (1.0 + 1e-9) + 1e-12
    top = g / guard.knee
    pulls = top < 1.0 and (1.0 - top) ** 2 >= guard.min_area * (1.0 + 1e-9) + 1e-12
    x = g + (_TWO_SQRT2 * bounds["Kw"] * w_max * (1.0 + 1e-9) + 1e-12) / guard.knee_wrinkles
    step = x < 1.0 and (1.0 - x) ** 2 >= guard.min_area_wrinkles * (1.0 + 1e-9) + 1e-12
    room = 2.0 * w_max / (guard.knee * guard.eta_deformed) * (1.0 + 1e-6) * (1.0 + 1e-6) \
        + 1e-12 * (1.0 + skin["size"])  # 2 rho (1 + 1e-6) + tau
    P = d_max + b_max
    far = room + 2.0 * P  # beyond it no point of the skin comes within room of x
    lam = max(lam, 2.0 * P / skin["reach"])  # (a corner beyond the pairs: |p - p'| <= 2P)
    if lam >= 1.0 or far > 0.5 * skin["reach"]:  # (the near triangles' reach)
        return pulls, step, False
    need = room + 2.0 * b_max
    balls = need <= bounds["sep"] * (1.0 - lam)
    # the triangles near the wrinkled vertices (_near_edges, _near_table), found once, by
    table = _near_of(bounds, skin["reach"]) if balls else None  # the first frame that
    if balls and table is not None:  # gets this far: |q' - x'| >= min_i (h_i - lam m_i) - 2b
        low = _table_bounds(table, np.array([lam]), np.array([far]))
        balls = bool(low[0] >= need)
    return pulls, step, balls


_TWO_SQRT2 = 2.0 * math.sqrt(2.0)
