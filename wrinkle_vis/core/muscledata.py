"""What one muscle defines on the rest skin, computed once per muscle and kept compact
(its area of influence's rows only): :class:`_MuscleData`, and the tangent projection
its pulls go through (:func:`tangential`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from .equations import compression_operator, gradient_compression_operator, triangle_stretch
from .mesh import TriangleSurface
from .muscle import Muscle


@dataclass(frozen=True, eq=False)
class _MuscleData:
    """What one muscle defines on the rest skin, compact (AOI rows only)."""

    aoi: np.ndarray  # (k,) vertex ids
    region_pos: np.ndarray  # (r,) positions within aoi of the wrinkling region
    unit_disp: np.ndarray  # (k, 3)
    lam: np.ndarray  # (k,)
    gamma: np.ndarray  # (k,)
    l: np.ndarray  # (k,)
    at: np.ndarray  # (k,)
    w: np.ndarray  # (r,)
    h: np.ndarray  # (r,)
    edge_ids: np.ndarray  # (q,) global edge ids incident to the AOI ("edges" only)
    eps_op: sp.csr_matrix  # (k, q): Eq. 10
    tri_ids: np.ndarray  # (t,) global triangle ids incident to the AOI ("gradient" only)
    tri_coef: np.ndarray  # (t, 2): F_t d_t = c0 (x_b - x_a) + c1 (x_c - x_a)
    grad_op: sp.csr_matrix  # (k, t): area-weighted mean of 1 - |F_t d_t|
    # compression_at's rest-only plans of a few rows, by the rows (the latest few)
    _plans: dict[bytes, tuple] = field(default_factory=dict, repr=False)

    @property
    def region(self) -> np.ndarray:
        """``(r,)`` vertex ids of the wrinkling region."""
        return self.aoi[self.region_pos]

    @classmethod
    def build(cls, skin: TriangleSurface, muscle: Muscle, normals: np.ndarray) -> _MuscleData:
        cand = muscle.candidates(skin)  # the AOI's neighbourhood: a big scan's is small
        reg = muscle.region(skin.points[cand])
        in_cand = reg["in_aoi"].copy()
        inside = np.flatnonzero(in_cand)
        in_cand[inside[muscle.hidden(skin.points[cand[inside]], skin)]] = False  # skin behind
        at = np.flatnonzero(in_cand)  # the AOI's positions in cand
        aoi = cand[at]
        in_aoi = np.zeros(skin.n_points, bool)
        in_aoi[aoi] = True
        region_pos = np.flatnonzero(reg["in_region"][at])
        directions = np.zeros((skin.n_points, 3))
        directions[cand] = np.nan_to_num(reg["direction"], nan=0.0)
        if muscle.compression == "gradient":
            edge_ids = np.zeros(0, np.intp)
            op = sp.csr_matrix((len(aoi), 0))
            tri_ids, coef, grad_op = gradient_compression_operator(
                skin.points, skin.triangles, directions, rows=aoi)
        else:
            edges = skin.edges
            edge_ids = np.flatnonzero(in_aoi[edges[:, 0]] | in_aoi[edges[:, 1]])
            op = compression_operator(skin.points, edges[edge_ids], directions, rows=aoi)
            tri_ids, coef = np.zeros(0, np.intp), np.zeros((0, 2))
            grad_op = sp.csr_matrix((len(aoi), 0))
        unit = tangential(muscle.unit_displacement(skin.points[aoi]), normals[aoi])
        return cls(aoi=aoi, region_pos=region_pos, unit_disp=unit, lam=reg["lam"][at],
                   gamma=reg["gamma"][at], l=reg["l"][at], at=reg["At"][at],
                   w=reg["w"][at][region_pos], h=reg["H"][at][region_pos],
                   edge_ids=edge_ids, eps_op=op, tri_ids=tri_ids, tri_coef=coef,
                   grad_op=grad_op)

    def compression(self, skin: TriangleSurface, points: np.ndarray) -> np.ndarray:
        r"""``(k,)``: :math:`\varepsilon` on the AOI for deformed ``points`` ``(n, 3)``
        (the muscle's own measure; the frame computes it stacked, this is for a muscle at
        rest).
        """
        e = skin.edges[self.edge_ids]
        vec = points[e[:, 1]] - points[e[:, 0]]
        tau = 1.0 - np.linalg.norm(vec, axis=1) / skin.rest_edge_lengths[self.edge_ids]
        stretch = triangle_stretch(points, skin.triangles[self.tri_ids], self.tri_coef)
        return self.eps_op @ tau + self.grad_op @ (1.0 - stretch)

    def compression_at(self, skin: TriangleSurface, points: np.ndarray,
                       rows: np.ndarray) -> np.ndarray:
        r"""``(r,)``: :meth:`compression` at the AOI's rows ``rows`` ``(r,)`` alone, bit for
        bit: the edges or triangles of those rows only (a probe's few vertices, not the
        whole AOI), each row's sum in the operator's order, as its product sums it. What
        depends on the rest skin alone is kept for the latest few sets of rows.
        """
        rows = np.asarray(rows, np.intp)
        out = np.zeros(len(rows))
        for kind, ends, const, coef, slots, shape in self._plan(skin, rows):
            if kind == "edges":  # tau of the rows' edges
                vec = points.take(ends[1], axis=0) - points.take(ends[0], axis=0)
                # np.linalg.norm(vec, axis=1)'s own sums, without its argument handling
                values = 1.0 - np.sqrt(np.add.reduce(vec * vec, axis=1)) / const
            else:  # "gradient": 1 - |F d| of the rows' triangles
                values = 1.0 - triangle_stretch(points, ends, const)
            out = out + _row_sums(coef * values, slots, shape)
        return out

    def _plan(self, skin: TriangleSurface, rows: np.ndarray) -> list[tuple]:
        """The rest-only part of :meth:`compression_at` for ``rows``: per operator with
        entries, its kind, the edges' ends ``(2, e)`` (or triangles ``(e, 3)``), their rest
        lengths (or coefficients), the entries' values ``(e,)`` and their slots in the
        ``(r, m + 1)`` table of :func:`_row_sums`.
        """
        key = rows.tobytes()
        plan = self._plans.get(key)
        if plan is not None and plan[0] is skin:
            return plan[1]
        parts = []
        if self.eps_op.nnz:
            cols, coef, slots, shape = _row_entries(self.eps_op, rows)
            ids = self.edge_ids.take(cols)
            ends = np.ascontiguousarray(skin.edges.take(ids, axis=0).T)
            parts.append(("edges", ends, skin.rest_edge_lengths.take(ids), coef, slots, shape))
        if self.grad_op.nnz:
            cols, coef, slots, shape = _row_entries(self.grad_op, rows)
            tris = skin.triangles.take(self.tri_ids.take(cols), axis=0)
            parts.append(("gradient", tris, self.tri_coef.take(cols, axis=0), coef, slots,
                          shape))
        if len(self._plans) >= 8:
            self._plans.clear()
        self._plans[key] = (skin, parts)
        return parts


def _row_entries(op: sp.csr_matrix, rows: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[int, int]]:
    """The stored entries of a CSR ``op``'s rows ``rows`` ``(r,)``, each row's in their
    stored order: their columns ``(e,)`` and values ``(e,)`` row after row, and the slots
    ``(e,)`` they fill in a flat table of shape ``(r, m + 1)`` (``m``: the longest row;
    column 0 left empty), with that shape.
    """
    start = op.indptr.take(rows)
    count = op.indptr.take(rows + 1) - start
    slots = np.arange(int(count.max(initial=0)))
    mask = slots < count[:, None]
    at = (start[:, None] + slots)[mask]
    shape = (len(rows), mask.shape[1] + 1)
    flat = (np.arange(len(rows))[:, None] * shape[1] + 1 + slots)[mask]
    return op.indices.take(at), op.data.take(at), flat, shape


def _row_sums(products: np.ndarray, slots: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    r"""``(r,)``: the sums of ``products`` ``(e,)`` (:math:`c_j x_j`) by rows of a table of
    ``shape`` ``(r, m + 1)`` whose flat ``slots`` ``(e,)`` they fill (row after row, column
    0 empty), added left to right from +0 as a CSR product adds them (a running sum: the
    product's sums, bit for bit; the empty slots after a row's last entry add +0, which
    leaves a sum from +0 as it is).
    """
    table = np.zeros(shape)
    table.ravel()[slots] = products
    return np.cumsum(table, axis=1)[:, -1]


def tangential(vectors: np.ndarray, normals: np.ndarray) -> np.ndarray:
    r"""``(k, 3)``: ``vectors`` ``(k, 3)`` without their part along unit ``normals``,
    :math:`v - (v \cdot n)\, n`.
    """
    return vectors - np.einsum("ij,ij->i", vectors, normals)[:, None] * normals
