r"""Refined frames from a :class:`~wrinkle_vis.core.hierarchy.Hierarchy`: per frame, only
what the frame changes.

A frame (:meth:`RefinedEngine.frame`) starts from the unrefined frame of the skin, then level
after level marks the triangles that an active muscle influences and whose vertex normals
differ by more than the threshold, splits them (the closure as look-ups in the hierarchy's
tables, :func:`~wrinkle_vis.core.hierarchy.refined_topology`) and evaluates the vertices
that appeared. Every vertex's values depend on the vertex alone:

* deformed point :math:`x = X + \sum_m a_m u_m(X)`, bent onto the rest surface (the slide);
* :math:`\tau_{ij} = 1 - |x_j - x_i| / |X_j - X_i|` (Eq. 9) on the vertex's ring edges and
  :math:`\varepsilon_i = \sum_j |\cos\theta_{ij}|\,\tau_{ij} / \sum_j |\cos\theta_{ij}|`
  (Eq. 10) over them, per muscle;
* :math:`W_i = \sum_m H\,A(\varepsilon_i)\,At` (Eq. 4, 11), and the final point
  :math:`x + W_i\, n_i` with :math:`n_i` the area-weighted normal of the deformed ring.

The skin's own vertices keep the unrefined frame's values exactly.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from .cache import ByteBudgetCache, HoldsArrays
from .equations import anisotropy
from .hierarchy import (
    Hierarchy,
    MuscleLevels,
    conforming_triangles,
    distinct,
    grown,
    refined_topology,
)

if TYPE_CHECKING:
    from .face import FaceModel
    from .muscle import Muscle

__all__ = ["RefinedEngine", "bent", "slide_bend"]

#: A triangle where a muscle wrinkles splits until its longest edge is at most this many
#: times shorter than the muscle's half period u (Eq. 6).
EDGES_PER_HALF_PERIOD = 2.0

#: A frame assembles its refined mesh over the root triangles within this many rings of
#: those an active muscle influences (the zone). The closure's level rule carries splits
#: past the influenced triangles, and a closure that leaves the zone makes the frame
#: assemble it again, wider: with one ring that happened on 20 of the 31 frames of
#: surprise's ramp at three levels (pucker 27, squint 20), with two on none of the ramps
#: of surprise, fear, frown, smile, pucker and squint.
ZONE_RINGS = 2


def bent(triangles: np.ndarray, points: np.ndarray, angle_deg: float,
         candidates: np.ndarray, rest_bend: np.ndarray | None = None) -> np.ndarray:
    """``(t,) bool``: the ``candidates`` among ``triangles`` ``(t, 3)`` whose vertex normals
    at ``points`` ``(3, v)`` (area-weighted over ``triangles``) differ by more than
    ``angle_deg`` beyond ``rest_bend`` ``(t,)`` (radians; how much the rest skin bends
    across each triangle; none: 0).
    """
    t0, t1, t2 = triangles.T
    n = points.shape[1]
    ax, ay, az = (p.take(t0) for p in points)
    ux, uy, uz = (p.take(t1) - a for p, a in zip(points, (ax, ay, az), strict=True))
    vx, vy, vz = (p.take(t2) - a for p, a in zip(points, (ax, ay, az), strict=True))
    fn = (uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx)
    vn = _unit(*(np.bincount(t0, f, n) + np.bincount(t1, f, n) + np.bincount(t2, f, n)
                 for f in fn))  # (3, n)
    c = np.flatnonzero(candidates)
    corner = [vn.take(t[c], axis=1) for t in (t0, t1, t2)]  # (3, k) each
    cos = np.minimum.reduce([(corner[i] * corner[(i + 1) % 3]).sum(axis=0) for i in range(3)])
    limit = np.radians(angle_deg)
    if rest_bend is not None:
        limit = np.minimum(limit + rest_bend[c], np.pi)
    out = np.zeros(len(triangles), bool)
    out[c] = cos < np.cos(limit)
    return out


def _unit(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """``(3, k)``: the vectors ``(x, y, z)`` ``(k,)`` each, scaled to unit length."""
    v = np.stack([x, y, z]).astype(float, copy=False)  # bincount of no weights is int
    v /= np.maximum(np.sqrt(x * x + y * y + z * z), 1e-300)
    return v


class _RefinedRows(HoldsArrays):
    r"""The active muscles' data on the hierarchy's new vertices, one row per vertex that a
    muscle moves and one column per muscle acting there (padded with an inactive one),
    built once per active set and extended as the hierarchy grows.

    Attributes
    ----------
    moved : (r,) int
        The vertices, increasing; ``slot`` ``(v,)`` maps a vertex to its row (-1: none).
    muscle : (r, c) int
        The muscles acting on each (their index in the active set; ``M``: padding).
    unit, weights, hat : (r, c, 3), (r, c, 6), (r, c) float
        Their unit tangent pulls, Eq. 10 ring weights (0 for the ``"gradient"`` option),
        and :math:`H\,At` (0 outside the wrinkling region and in padding).
    coef, area : (r, c, 6, 2), (r, c, 6) float
        The ``"gradient"`` option's ring triangle data (only if a muscle has it).
    unfinished : (u,) int
        Vertices among ``moved`` whose rings are not complete yet (their ring weights come
        when they are, :meth:`extend`).
    half_period : (v,) float
        At every vertex, the smallest half period :math:`u` (Eq. 6) of the muscles whose
        wrinkling region holds it (``inf``: none); the skin's vertices once
        :meth:`set_root_periods` ran.
    """

    # the rows (:data:`_ROW_FIELDS`, from :func:`_stacked_rows`)
    moved: np.ndarray  # (r,) int
    muscle: np.ndarray  # (r, c) int
    unit: np.ndarray  # (r, c, 3)
    weights: np.ndarray  # (r, c, 6)
    hat: np.ndarray  # (r, c)
    coef: np.ndarray  # (r, c, 6, 2): only with has_grad
    area: np.ndarray  # (r, c, 6): only with has_grad
    # the vertices
    slot: np.ndarray  # (v,) int: each vertex's row, -1: none
    influenced: np.ndarray  # (v,) bool: slot >= 0
    half_period: np.ndarray  # (v,)
    unfinished: np.ndarray  # (u,) int
    # the active set and the hierarchy the rows were made for
    muscles: list[Muscle]
    has_grad: bool  # whether a muscle has the "gradient" option (coef and area are there)
    root_periods: bool  # whether half_period is set on the skin's vertices
    version: tuple[int, int]  # the hierarchy's version and number of vertices

    def __init__(self, hier: Hierarchy, levels: list[MuscleLevels]):
        self.muscles = [m.muscle for m in levels]
        self.has_grad = any(m.muscle.compression == "gradient" for m in levels)
        rows = _stacked_rows(levels, 0)
        for name in _ROW_FIELDS:
            if name in rows:
                setattr(self, name, rows[name])
        self.slot = np.full(hier.n_points, -1, np.int64)
        self.slot[self.moved] = np.arange(len(self.moved))
        self.influenced = self.slot >= 0
        self.half_period = np.full(hier.n_points, np.inf)  # root part: set_root_periods
        self.half_period[self.moved] = rows["u"].min(axis=1)  # where a muscle wrinkles
        self.unfinished = self.moved[~hier.final[self.moved]]  # rings not complete yet
        self.root_periods = False
        self.version = hier.version, hier.n_points

    def extend(self, hier: Hierarchy, levels: list[MuscleLevels]) -> bool:
        """Bring the rows up to date after the hierarchy grew (``levels`` updated): rows
        for the new vertices, and the ring weights of the vertices whose rings were
        completed since. Returns False where the new rows need more columns (build anew).
        """
        start = self.version[1]
        rows = _stacked_rows(levels, start)
        width = self.muscle.shape[1]
        if rows["muscle"].shape[1] > width:
            return False
        k = len(rows["moved"])
        for name in _ROW_FIELDS:
            if name in rows:
                setattr(self, name, grown(getattr(self, name), _padded(rows[name], width,
                                                                     len(levels))))
        n = hier.n_points
        slot = np.full(n - start, -1, np.int64)
        slot[rows["moved"] - start] = np.arange(len(self.moved) - k, len(self.moved))
        self.slot = grown(self.slot, slot)
        self.influenced = grown(self.influenced, slot >= 0)
        half = np.full(n - start, np.inf)
        half[rows["moved"] - start] = rows["u"].min(axis=1)
        self.half_period = grown(self.half_period, half)
        done = hier.final[self.unfinished]
        self._refresh_rings(levels, self.unfinished[done])
        self.unfinished = np.concatenate([self.unfinished[~done],
                                          rows["moved"][~hier.final[rows["moved"]]]])
        self.version = hier.version, n
        return True

    def _refresh_rings(self, levels: list[MuscleLevels], v: np.ndarray) -> None:
        """Copy the ring data of vertices ``v`` ``(k,)`` (rows of this assembly, rings now
        complete) from ``levels``.
        """
        r = self.slot[v]
        for i, m in enumerate(levels):
            c = np.argmax(self.muscle[r] == i, axis=1)
            mine = self.muscle[r, c] == i
            pos = np.searchsorted(m.ids, v[mine])  # ids increase
            grad = m.muscle.compression == "gradient"
            self.weights[r[mine], c[mine]] = 0.0 if grad else np.nan_to_num(m.weights[pos])
            if self.has_grad:
                self.coef[r[mine], c[mine]] = m.coef[pos] if grad else 0.0
                self.area[r[mine], c[mine]] = m.area[pos] if grad else 0.0

    def set_root_periods(self, face) -> None:
        """Fill :attr:`half_period` on the skin's vertices (once): the smallest half period
        :math:`u` (Eq. 6) of the active muscles whose wrinkling region on ``face`` holds
        them.
        """
        if self.root_periods:
            return
        for m in self.muscles:
            region = face.muscle_data(m).region
            self.half_period[region] = np.minimum(self.half_period[region], float(m.u))
        self.root_periods = True

    def undersampled(self, hier: Hierarchy, triangles: np.ndarray, nodes: np.ndarray,
                     W: np.ndarray, angle: float) -> np.ndarray:
        r"""``(t,) bool``: the ``triangles`` ``(t, 3)`` (in ``nodes``) too coarse for the
        wrinkles at a corner: the node's longest edge :math:`h` exceeds
        ``1 / EDGES_PER_HALF_PERIOD`` of the half period :math:`u` (Eq. 6) of a muscle
        wrinkling the corner, and a furrow of the corner's depth :math:`|W|` would bend
        the skin across :math:`h` by more than ``angle`` (radians):
        :math:`|W| \pi^2 h / u^2 > \theta`, the change of slope of
        :math:`|W| \sin(\pi s / u)` over :math:`h`. There the vertex normals sample the
        furrows too coarsely to see them bend; a faint wrinkle does not split.
        """
        h = hier.node_edge[nodes]
        out = np.zeros(len(triangles), bool)
        for k in range(3):
            v = triangles[:, k]
            u = self.half_period.take(v)
            depth = np.abs(W.take(v))
            out |= (h * EDGES_PER_HALF_PERIOD > u) & (depth * np.pi ** 2 * h > angle * u * u)
        return out


#: The per-row arrays of a :class:`_RefinedRows` (``coef`` and ``area`` only with the
#: ``"gradient"`` option).
_ROW_FIELDS = ("moved", "muscle", "unit", "weights", "coef", "area", "hat")


def _stacked_rows(levels: list[MuscleLevels], start: int) -> dict:
    """The muscles' rows of the vertices ``start`` and above, stacked: one row a vertex,
    one column a muscle acting there (padded), as :class:`_RefinedRows` holds them, and
    ``u`` ``(r, c)``: the half periods where a muscle wrinkles (``inf`` elsewhere).
    """
    first_row = [int(np.searchsorted(m.ids, start)) for m in levels]  # ids increase
    counts = np.array([len(m.ids) - f for m, f in zip(levels, first_row, strict=True)])
    ids = np.concatenate([m.ids[f:] for m, f in zip(levels, first_row, strict=True)])
    order = np.argsort(ids, kind="stable")
    ids = ids[order]
    first = np.flatnonzero(np.r_[True, ids[1:] != ids[:-1]]) if len(ids) else \
        np.zeros(0, np.int64)
    row = np.repeat(np.arange(len(first)), np.diff(np.append(first, len(ids))))
    col = np.arange(len(ids)) - first[row]
    shape = (len(first), int(col.max()) + 1 if len(col) else 1)
    at = row * shape[1] + col  # in the rows and columns flattened

    def dense(parts, fill=0.0):
        flat = np.take(np.concatenate(parts), order, axis=0)
        out = np.full(shape + flat.shape[1:], fill, flat.dtype)
        out.reshape(-1, *flat.shape[1:])[at] = flat  # a view: out is new, contiguous
        return out

    tail = [(m, f, m.muscle.compression == "gradient")
            for m, f in zip(levels, first_row, strict=True)]
    out = {"moved": ids[first],  # each vertex's rows are adjacent
           "muscle": dense([np.full(n, i) for i, n in enumerate(counts)], len(levels)),
           "unit": dense([m.unit[f:] for m, f, _ in tail]),
           "weights": dense([np.zeros_like(m.weights[f:]) if g else
                             np.nan_to_num(m.weights[f:]) for m, f, g in tail])}
    if any(g for _, _, g in tail):  # zero rows for the muscles without the option
        out["coef"] = dense([m.coef[f:] if g else np.zeros((len(m.ids) - f, 6, 2))
                             for m, f, g in tail])
        out["area"] = dense([m.area[f:] if g else np.zeros((len(m.ids) - f, 6))
                             for m, f, g in tail])
    hat = [m.h[f:] * m.at[f:] for m, f, _ in tail]
    out["hat"] = dense([np.nan_to_num(h) for h in hat])  # 0 outside the wrinkling region
    out["u"] = dense([np.where(np.isfinite(h), float(m.muscle.u), np.inf)
                      for (m, _, _), h in zip(tail, hat, strict=True)], np.inf)
    return out


def _padded(rows: np.ndarray, width: int, n_muscles: int) -> np.ndarray:
    """``rows`` ``(r, c, ...)`` widened to ``width`` columns (padding: the inactive muscle
    ``n_muscles`` in integer arrays, 0 in the others); 1-d arrays as they are.
    """
    if rows.ndim < 2 or rows.shape[1] == width:
        return rows
    fill = n_muscles if rows.dtype.kind == "i" else 0.0
    out = np.full((len(rows), width, *rows.shape[2:]), fill, rows.dtype)
    out[:, :rows.shape[1]] = rows
    return out


class _Dynamic:
    """One frame's values on the hierarchy's vertices, computed where asked.

    ``buffers`` (the engine's, reused frame after frame: only what the last frame changed
    is reset) or fresh arrays.
    """

    def __init__(self, hier: Hierarchy, asm: _RefinedRows, root, a: np.ndarray, buffers=None,
                 root_influenced: np.ndarray | None = None):
        self.hier, self.asm, self.a, self.face = hier, asm, a, root.face
        asm.set_root_periods(root.face)
        self.a_padded = np.append(a, 0.0)  # the padding muscle does not act
        n, n0 = hier.n_points, hier.n_root
        if buffers is None or buffers["deformed"].shape[1] != n:
            rest = np.ascontiguousarray(hier.rest.T)
            buffers = {"deformed": rest, "points": rest.copy(), "W": np.zeros(n),
                       "evaluated": np.zeros(n, bool), "computed": np.zeros(n, bool),
                       "moved": np.zeros(0, np.int64), "touched": np.zeros(0, np.int64)}
        self.buffers = buffers
        d, moved, touched = buffers["deformed"], buffers["moved"], buffers["touched"]
        d[:, moved] = hier.rest.take(moved, axis=0).T  # undo the last frame
        buffers["computed"][moved] = False
        buffers["evaluated"][touched] = False
        buffers["W"][touched] = 0.0
        d[:, :n0] = root.deformed_points.T
        self.deformed, self.points, self.W = d, buffers["points"], buffers["W"]  # (3, n)
        self.points[:, :n0] = root.points.T
        self.W[:n0] = root.W
        self.evaluated, self.computed = buffers["evaluated"], buffers["computed"]
        self.evaluated[:n0] = True
        self.computed[:n0] = True
        self._touched, self._moved = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
        self._influenced = asm.influenced.copy()
        self._influenced[:n0] = (_moved_or_wrinkled(root) if root_influenced is None
                                 else root_influenced)
        self._carry = _skin_correction(root)
        self._carried: np.ndarray | None = None

    def grow(self, asm: _RefinedRows) -> None:
        """Take in the vertices the hierarchy built since (``asm``: the assembly brought up
        to date): they start at rest, not evaluated; what was evaluated keeps its values
        (a vertex's values depend on its own data alone).
        """
        n_old, n = self.W.shape[0], self.hier.n_points
        if n == n_old and asm is self.asm:
            return
        self.asm = asm
        asm.set_root_periods(self.face)
        more = np.ascontiguousarray(self.hier.rest[n_old:].T)
        b = self.buffers
        b["deformed"] = self.deformed = np.concatenate([self.deformed, more], axis=1)
        b["points"] = self.points = np.concatenate([self.points, more], axis=1)
        b["W"] = self.W = np.append(self.W, np.zeros(n - n_old))
        b["evaluated"] = self.evaluated = np.append(self.evaluated, np.zeros(n - n_old, bool))
        b["computed"] = self.computed = np.append(self.computed, np.zeros(n - n_old, bool))
        self._influenced = np.append(self._influenced, asm.influenced[n_old:])

    def _slot(self, n: int) -> np.ndarray:
        slot = self.buffers.get("slot")
        if slot is None or len(slot) != n:
            slot = self.buffers["slot"] = np.full(n, -1, np.int64)
        return slot

    def influenced(self) -> np.ndarray:
        """``(v,) bool``: the skin's vertices the unrefined frame moved or wrinkled and the
        new vertices in an active muscle's AOI.
        """
        return self._influenced

    def finish(self) -> None:
        """Record what this frame changed, for the next one to undo."""
        self.buffers["touched"] = np.concatenate(self._touched)
        self.buffers["moved"] = np.concatenate(self._moved)

    def _deform(self, v: np.ndarray) -> None:
        r"""Deformed points of new vertices ``v`` ``(k,)``: the pull
        :math:`D = \sum_m a_m u_m`, bent onto the rest surface (the slide).
        """
        if not len(v):
            return
        self.deformed[:, v] = self._pulled(v).T
        self.computed[v] = True
        self._moved.append(v)

    def _pulled(self, v: np.ndarray) -> np.ndarray:
        """``(k, 3)``: the deformed points of new vertices ``v`` ``(k,)`` (:meth:`_deform`)."""
        asm, hier = self.asm, self.hier
        p = asm.slot[v]
        has = np.flatnonzero(p >= 0)
        p = p[has]
        scale = self.a_padded.take(asm.muscle.take(p, axis=0))  # (k, c)
        pull = np.zeros((len(v), 3))
        pull[has] = np.einsum("kc,kcx->kx", scale, asm.unit.take(p, axis=0))
        bend = slide_bend(pull.T, hier.shape6.take(v, axis=0).T)
        moved = hier.rest.take(v, axis=0) + pull - bend[:, None] * hier.slide.take(v, axis=0)
        if self._carry is not None:
            moved += self.carried().take(v, axis=0)
        return moved

    def carried(self) -> np.ndarray:
        r"""``(v, 3)``: what another skin model (the physical skin) adds to the muscles'
        pull, carried to the hierarchy's vertices: on the skin's vertices the root frame's
        deformed points minus the geometric ones, on a new vertex the mean of the values at
        its edge's ends, level by level (linear along each edge, as smooth as the skin
        model's own displacement). Rebuilt when the hierarchy grows.
        """
        hier, n0 = self.hier, self.hier.n_root
        n = hier.n_points
        if self._carried is None or len(self._carried) != n:
            out = np.zeros((n, 3))
            out[:n0] = self._carry
            level = hier.level[:n]
            for lv in range(1, int(level.max(initial=0)) + 1):
                ids = np.flatnonzero(level == lv)
                ids = ids[ids >= n0]
                out[ids] = 0.5 * (out[hier.ring[ids, 0]] + out[hier.ring[ids, 3]])
            self._carried = out
        return self._carried

    def evaluate(self, v: np.ndarray) -> None:
        """Evaluate the new vertices ``v`` ``(k,)`` (rings complete)."""
        if not len(v):
            return
        hier, asm = self.hier, self.asm
        deltas = self.ring_deltas(v)  # (3, 6, k)
        dx, dy, dz = deltas
        tau = 1.0 - np.sqrt(dx * dx + dy * dy + dz * dz) / hier.ring_len.take(v, axis=0).T
        normal = _ring_normal(deltas)
        normal /= np.maximum(np.sqrt((normal * normal).sum(axis=0)), 1e-300)
        p = asm.slot[v]
        has = np.flatnonzero(p >= 0)
        p = p[has]
        eps = np.einsum("kcj,jk->kc", asm.weights.take(p, axis=0), tau[:, has])  # (k, c)
        if asm.has_grad:
            eps += _stretch_mean(asm.coef[p], asm.area[p], *(e[:, has].T[:, None] for e in
                                                             (dx, dy, dz)))
        w = np.zeros(len(v))
        w[has] = (asm.hat.take(p, axis=0) * anisotropy(eps)).sum(axis=1)
        self.W[v] = w
        self.points[:, v] = self.deformed.take(v, axis=1) + w * normal
        self.evaluated[v] = True
        self._touched.append(v)

    def ring_deltas(self, v: np.ndarray) -> np.ndarray:
        """``(3, 6, k)``: x, y and z of the deformed ring edges of vertices ``v`` ``(k,)``
        (zero where there is no neighbour); ring-major, so a ring position's values are
        contiguous.
        """
        ring = self.hier.safe_ring(v)
        need = np.concatenate([v, ring.ravel()])
        need = need[~self.computed[need]]
        self._deform(distinct(need, self._slot(len(self.W))))
        ring = np.ascontiguousarray(ring.T)
        out = np.empty((3, *ring.shape))
        for c, dc in enumerate(self.deformed):  # per component: 6x faster at 3,000 rows
            np.subtract(dc.take(ring), dc.take(v), out=out[c])
        return out

    def compression(self, levels: MuscleLevels, rows: np.ndarray) -> np.ndarray:
        r"""``(k,)``: one muscle's :math:`\varepsilon` at its rows ``rows`` (present
        vertices), from this frame's deformed points.
        """
        v = levels.ids[rows]
        dx, dy, dz = self.ring_deltas(v).transpose(0, 2, 1)  # (k, 6) each
        if levels.muscle.compression == "gradient":
            return _stretch_mean(levels.coef[rows], levels.area[rows], dx, dy, dz)
        tau = 1.0 - np.sqrt(dx * dx + dy * dy + dz * dz) / self.hier.ring_len[v]
        return (levels.weights[rows] * tau).sum(axis=1)


class _DynamicAt(_Dynamic):
    """A frame's values at a few of the hierarchy's vertices (:meth:`compression` where a
    probe reads them): the deformed points of those and their rings alone, computed as
    :class:`_Dynamic` computes them (bit for bit), with no array as long as the hierarchy.
    """

    def __init__(self, hier: Hierarchy, asm: _RefinedRows, root, a: np.ndarray):
        self.hier, self.asm, self.a, self.face, self._root = hier, asm, a, root.face, root
        self.a_padded = np.append(a, 0.0)  # the padding muscle does not act
        self._carry = _skin_correction(root)
        self._carried = None
        self._deltas: dict[bytes, np.ndarray] = {}

    def ring_deltas(self, v: np.ndarray) -> np.ndarray:
        """``(3, 6, k)``: :meth:`_Dynamic.ring_deltas`, from the deformed points of ``v``
        ``(k,)`` and their rings only (kept for ``v``: the probe's muscles share them).
        """
        key = v.tobytes()
        if key not in self._deltas:
            self._deltas[key] = self._ring_deltas(v)
        return self._deltas[key]

    def _ring_deltas(self, v: np.ndarray) -> np.ndarray:
        k = len(v)
        need = np.concatenate([v, self.hier.safe_ring(v).ravel()])  # rows: v, then rings
        old = need < self.hier.n_root
        if old.all():
            points = self._root.deformed_points.take(need, axis=0)
        else:
            points = np.empty((len(need), 3))
            points[old] = self._root.deformed_points.take(need[old], axis=0)
            points[~old] = self._pulled(need[~old])
        ring = np.arange(k, 7 * k).reshape(k, 6).T.copy()  # (6, k): the rings' rows
        at = np.arange(k)
        out = np.empty((3, *ring.shape))
        for c, dc in enumerate(np.ascontiguousarray(points.T)):
            np.subtract(dc.take(ring), dc.take(at), out=out[c])
        return out


class _Zone(NamedTuple):
    """The root triangles a frame's levels look at (:meth:`RefinedEngine.zone`)."""

    influenced: np.ndarray  # (n,) bool: the skin vertices it was made for
    ids: np.ndarray  # (z,) increasing: its root triangles
    inside: np.ndarray  # (T,) bool: the same, as a mask
    triangles: np.ndarray  # (z, 3): theirs
    outside: np.ndarray  # (T - z, 3): the skin's others, in order


def _renumbered(triangles: np.ndarray, used: np.ndarray, slot: np.ndarray) -> np.ndarray:
    """``(t, 3)``: ``triangles`` on the vertices ``used`` ``(u,)``, renumbered by their
    place in it (``slot`` ``(v,) int``: all -1 before and after).
    """
    slot[used] = np.arange(len(used))
    out = slot.take(triangles)
    slot[used] = -1
    return out


def _any_corner(flag: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """``(t,) bool``: the ``triangles`` ``(t, 3)`` with a corner where ``flag`` ``(v,)``."""
    a, b, c = flag.take(triangles).T
    return a | b | c


def _around(triangles: np.ndarray, ids: np.ndarray, rings: int, n_points: int) -> np.ndarray:
    """``(z,)``, increasing: the ``triangles`` ``(T, 3)`` (on ``n_points`` vertices) within
    ``rings`` rings of those numbered ``ids`` (sharing a vertex with them, then with those,
    and so on).
    """
    keep = np.zeros(len(triangles), bool)
    keep[ids] = True
    corner = np.zeros(n_points, bool)
    for _ in range(rings):
        corner[triangles[keep]] = True
        keep = _any_corner(corner, triangles)
    return np.flatnonzero(keep)


def _skin_correction(root) -> np.ndarray | None:
    """``(n, 3)``: a frame's deformed skin minus the muscles' geometric pull (the
    displacement a skin model other than the geometric one adds), or None for a geometric
    frame.
    """
    if getattr(root, "skin_model", "geometric") == "geometric":
        return None
    face = root.face
    pull = getattr(root, "muscle_pull", None)  # what the physical skin was solved for
    if pull is None:
        pull = face.muscle_displacement(root.activations)
    return root.deformed_points - face.skin.points - pull


def _moved_or_wrinkled(root) -> np.ndarray:
    """``(n,) bool``: the skin's vertices that the unrefined frame ``root`` moved or
    wrinkled (the influenced ones).
    """
    return (root.W != 0.0) | (root.deformed_points != root.rest_points).any(axis=1)


def _stretch_mean(coef, area, dx, dy, dz) -> np.ndarray:
    r"""``(...)``: :math:`\sum_j a_j (1 - |F_j d_j|)` over the ring triangles
    :math:`(i, r_j, r_{j+1})`, with :math:`F_j d_j = c_0 e_j + c_1 e_{j+1}` (``coef``
    ``(..., 6, 2)``, ``area`` ``(..., 6)``, ring edges ``(..., 6)`` each, broadcast).
    """
    c0, c1 = coef[..., 0], coef[..., 1]
    g = [c0 * e + c1 * np.roll(e, -1, axis=-1) for e in (dx, dy, dz)]
    stretch = np.sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2])
    return (area * (1.0 - stretch)).sum(axis=-1)


def _ring_normal(e: np.ndarray) -> np.ndarray:
    r"""``(3, k)``: :math:`\sum_j e_j \times e_{j+1}` over the ring edges ``e``
    ``(3, 6, k)``, cyclically: twice the area-weighted normal of the ring's triangles.
    """
    x, y, z = e

    def wedge(a, b):  # sum_j a_j b_{j+1} - b_j a_{j+1}, j cyclic; a, b (6, k)
        return (a[:-1] * b[1:] - b[:-1] * a[1:]).sum(axis=0) + a[-1] * b[0] - b[-1] * a[0]

    return np.stack([wedge(y, z), wedge(z, x), wedge(x, y)])


def slide_bend(d: np.ndarray, s: np.ndarray) -> np.ndarray:
    r"""``(u,)``: how far the skin's slide bends pulls ``d`` ``(3, u)`` back along the
    slide normal, with shape operators ``s`` ``(6, u)`` (xx, yy, zz, xy, xz, yz):
    :math:`b = \beta / \sqrt{1 + (\beta / 0.3\|D\|)^2}`, :math:`\beta = \tfrac12 D^T S D`.

    Second order in :math:`D`, exact to that order where the pull is short beside the
    radius of curvature, and never more than :math:`0.3\|D\|` where it is not (there the
    quadratic would overshoot). The unrefined frame and the refined one both use it.
    """
    x, y, z = d
    q = (s[0] * x * x + s[1] * y * y + s[2] * z * z
         + 2.0 * (s[3] * x * y + s[4] * x * z + s[5] * y * z))
    reach = 0.3 * np.sqrt(x * x + y * y + z * z)
    return 0.5 * q / np.sqrt(1.0 + (0.5 * q / np.maximum(reach, 1e-300)) ** 2)


class RefinedEngine:
    """Refined frames of one skin at one depth: its hierarchy, the muscles' data on it and
    the stacked rows of each active set, in a byte budget.

    Parameters
    ----------
    hier : Hierarchy
    budget : int
        Bytes the muscles' data and stacked rows may hold together (least recently used
        first out); the hierarchy itself is bounded by the skin: at most the uniform
        subdivision of the triangles the muscles can influence (and the latest zone, kept
        outside the budget, by its triangles).
    tangential : callable
        ``tangential(vectors, normals)``, the face's tangent projection of pulls.
    """

    def __init__(self, hier: Hierarchy, budget: int, tangential):
        self.hier = hier
        self.cache = ByteBudgetCache(budget)
        self._tangential = tangential
        # (key, face, order) of the latest split set (FaceModel._refined_face)
        self.last: tuple[tuple[Any, ...], FaceModel, np.ndarray] | None = None
        self.buffers: dict[str, np.ndarray] | None = None  # the frame arrays, reused
        self._current: dict[tuple[Any, ...], Any] = {}  # the latest active set's data
        self._zone: _Zone | None = None  # the latest frame's

    def levels(self, muscle) -> MuscleLevels:
        """``muscle``'s data on the hierarchy, brought up to date."""
        key = ("muscle", muscle)
        lv = self.cache.get(key, lambda: self._current.get(key) or MuscleLevels.empty(muscle))
        if lv.update(self.hier, self._tangential):
            self.cache.reweigh(key)
        return lv

    def assembly(self, muscles) -> _RefinedRows:
        """The stacked rows of the active ``muscles``, for the hierarchy as it is now.

        The latest active set's data is also held outside the cache, so a working set
        larger than the budget is not rebuilt every frame (the budget then holds the rest).
        """
        key = ("assembly", tuple(muscles))
        asm = self._current.get(key)
        if asm is not None and asm.version == (self.hier.version, self.hier.n_points):
            return asm  # its muscles' data were brought up to date with it
        levels = [self.levels(m) for m in muscles]
        asm = self.cache.get(key, lambda: self._current.get(key)
                             or _RefinedRows(self.hier, levels))
        if asm.version != (self.hier.version, self.hier.n_points):
            if not asm.extend(self.hier, levels):
                asm = _RefinedRows(self.hier, levels)
            self.cache.put(key, asm)
        self._current = {key: asm, **{("muscle", m): lv for m, lv in zip(muscles, levels,
                                                                         strict=True)}}
        return asm

    def frame(self, root, muscles, a: np.ndarray, angle_deg: float, n_levels: int):
        """Refine the unrefined frame ``root`` (a FaceState) of active ``muscles`` with
        activations ``a`` ``(M,)``.

        Returns
        -------
        dyn : _Dynamic
            The frame's values on the hierarchy.
        triangles : (t, 3) int
            The refined mesh, in hierarchy vertex ids, in an order that depends on the
            split set and the influenced vertices alone (not on earlier frames).
        split : (N,) bool
            The split nodes.
        split_ids : (s,) int
            The same, as :func:`~wrinkle_vis.core.hierarchy.split_in_order` walks them
            (for :func:`~wrinkle_vis.core.hierarchy.canonical_order`).
        """
        hier = self.hier
        influenced = _moved_or_wrinkled(root)
        zone = self.zone(influenced)
        dyn = _Dynamic(hier, self.assembly(muscles), root, a, self.buffers, influenced)
        split = np.zeros(len(hier.node_tri), bool)
        split_ids = np.zeros(0, np.int64)
        tris, nodes = zone.triangles, zone.ids
        # bent sees the mesh on its own vertices (normal sums as long as those, not as the
        # whole hierarchy)
        local, points = tris, dyn.points[:, :hier.n_root]
        present = None  # the mesh's vertices, once it has new ones
        for _ in range(n_levels):
            if present is not None:
                used = np.flatnonzero(present)
                local = _renumbered(tris, used, hier.point_scratch())
                points = dyn.points.take(used, axis=1)
            cand = _any_corner(dyn.influenced(), tris) & (hier.node_level[nodes] < hier.depth)
            marked = bent(local, points, angle_deg, cand, hier.node_bend[nodes])
            marked |= cand & dyn.asm.undersampled(hier, tris, nodes, dyn.W,
                                                    np.radians(angle_deg))
            if not marked.any():
                break
            split, _ = refined_topology(hier, split, distinct(nodes[marked], hier.scratch()))
            if dyn.asm.version != (hier.version, hier.n_points):  # the hierarchy grew
                dyn.grow(self.assembly(muscles))
            tris, nodes, present, split_ids = conforming_triangles(hier, split, zone.ids,
                                                                   check=False)  # closed
            dyn.evaluate(np.flatnonzero(present & ~dyn.evaluated))
        tris, split_ids = self._whole(split, split_ids, zone, tris, dyn)
        dyn.finish()
        self.buffers = dyn.buffers
        return dyn, tris, split, split_ids

    def zone(self, influenced: np.ndarray) -> _Zone:
        """The zone of a frame whose skin vertices ``influenced`` ``(n,) bool`` an active
        muscle moved or wrinkled: the root triangles within :data:`ZONE_RINGS` rings of
        those with an influenced corner (the latest one is kept: a ramp keeps its
        influenced vertices from its first moving frame on).
        """
        last = self._zone
        if last is not None and np.array_equal(last.influenced, influenced):
            return last
        tris = self.hier.skin.triangles
        ids = _around(tris, np.flatnonzero(_any_corner(influenced, tris)), ZONE_RINGS,
                      self.hier.n_root)
        inside = np.zeros(len(tris), bool)
        inside[ids] = True
        self._zone = _Zone(influenced.copy(), ids, inside, tris[ids], tris[~inside])
        return self._zone

    def _whole(self, split: np.ndarray, split_ids: np.ndarray, zone: _Zone,
               zone_tris: np.ndarray, dyn: _Dynamic) -> tuple[np.ndarray, np.ndarray]:
        """``(t, 3)``: the whole mesh: the zone's, then the root triangles outside it, when
        the split set keeps to the zone and its neighbours are in it (no triangle outside
        is bisected); else the zone grows by the split root triangles outside it and their
        neighbours, is assembled anew (its new vertices evaluated), and the root triangles
        outside it follow (none of them borders a split one). Also ``(s,)``: the split
        nodes as that mesh's walk met them (``split_ids``, the zone's walk, where it kept
        to the zone).
        """
        hier = self.hier
        n_roots = hier.n_roots
        roots = np.flatnonzero(split[:n_roots])
        near = hier.root_nbrs[roots]
        near = near[near >= 0]
        if zone.inside[roots].all() and zone.inside[near].all():
            return np.concatenate([zone_tris, zone.outside]), split_ids
        in_zone = zone.inside.copy()
        in_zone[roots] = True
        in_zone[near] = True
        tris, _, present, split_ids = conforming_triangles(hier, split,
                                                           np.flatnonzero(in_zone),
                                                           check=False)  # closed
        dyn.evaluate(np.flatnonzero(present & ~dyn.evaluated))
        return np.concatenate([tris, hier.skin.triangles[~in_zone]]), split_ids

    def dynamic(self, root, muscles, a: np.ndarray) -> _Dynamic:
        """A frame's values in arrays of their own, computed where asked (for a state's
        fields, which must not change when the engine moves on to the next frame).
        """
        return _Dynamic(self.hier, self.assembly(muscles), root, a)

    def dynamic_at(self, root, muscles, a: np.ndarray) -> _DynamicAt:
        """:meth:`dynamic` for values at a few vertices (a probe's): no full-length array."""
        return _DynamicAt(self.hier, self.assembly(muscles), root, a)
