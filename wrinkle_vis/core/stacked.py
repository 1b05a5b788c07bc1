r"""A frame of the face model, stacked over its active muscles (see :doc:`/model`).

Everything that depends only on the rest skin and a muscle's parameters is computed once per
muscle and cached (:class:`_MuscleData`). Everything that depends on which muscles are active
is stacked once per set of active muscles (:class:`_StackedMuscles`), so a frame is a fixed number
of vectorized steps whatever the number of muscles:

1. skin displacement: one sparse sum of the active muscles' unit displacements times their
   activations; the skin slides along its rest surface (each muscle's pull is made tangent
   to the rest surface once, and the summed pull :math:`D` is bent back onto the surface by
   the second fundamental form, :math:`-\tfrac12 D^T S D\, n`);
2. :math:`\tau` (Eq. 9) on the edges the active muscles touch, then :math:`\varepsilon` of
   every active muscle (Eq. 10) in one sparse mat-vec; for the muscles whose ``compression``
   option is ``"gradient"``, the stretch :math:`|F_t d_t|` of their triangles instead, all
   stacked, and their area-weighted means in a second mat-vec;
3. :math:`W = \sum_m H\,A(\varepsilon)\,At` (Eq. 4, 11) summed by one sparse mat-vec;
4. final points: the deformed points moved by :math:`W` along the outward unit normal of the
   deformed skin, which is computed only where :math:`W` is defined.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from .equations import anisotropy
from .hierarchy import six_entries
from .mesh import TriangleSurface, triangle_normals, unit_rows
from .refined import slide_bend

if TYPE_CHECKING:
    from .muscledata import _MuscleData
    from .restgeometry import _RestGeometry


def _summing(ids_list: list[np.ndarray]) -> tuple[np.ndarray, sp.csr_matrix]:
    """Union of id arrays and the ``(union, sum of lengths)`` 0/1 matrix that sums into it."""
    stacked = np.concatenate(ids_list) if ids_list else np.zeros(0, np.intp)
    union, inverse = _unique_ids(stacked, return_inverse=True)
    mat = sp.csr_matrix((np.ones(len(stacked)), (inverse, np.arange(len(stacked)))),
                        shape=(len(union), len(stacked)))
    return union, mat


def _unique_ids(ids: np.ndarray, return_inverse: bool = False):
    """``np.unique`` of non-negative integer ids ``(k,)`` (with the inverse ``(k,)``), by a
    mask as long as the largest id rather than a sort: the same values, ascending.
    """
    ids = np.asarray(ids)
    seen = np.zeros(int(ids.max(initial=-1)) + 1, bool)
    seen[ids] = True
    union = np.flatnonzero(seen)
    if not return_inverse:
        return union
    position = np.zeros(len(seen), np.intp)
    position[union] = np.arange(len(union))
    return union, position[ids]


def morton_order(points: np.ndarray, bits: int = 10) -> np.ndarray:
    """``(n,)``: an ordering of ``(n, 3)`` points along a Z-order (Morton) curve.

    Vertices that are close in space end up close in memory, which keeps the frame's
    gathers in cache.
    """
    lo = points.min(axis=0)
    span = np.maximum(points.max(axis=0) - lo, 1e-300)
    q = ((points - lo) / span * (2**bits - 1)).astype(np.uint64)
    code = np.zeros(len(points), np.uint64)
    for bit in range(bits):
        for axis in range(3):
            code |= ((q[:, axis] >> np.uint64(bit)) & np.uint64(1)) << np.uint64(3 * bit + axis)
    return np.argsort(code, kind="stable")


@dataclass(frozen=True, eq=False)
class _StackedMuscles:
    """Stacked operators for one set of active muscles.

    The frame works on a compact *local* copy of the vertices it touches, in Morton order and
    as ``(3, L)`` coordinate rows, so its gathers stay in cache even on a huge skin.
    """

    names: tuple[str, ...]
    k_counts: np.ndarray  # (M,) AOI sizes
    k_offsets: np.ndarray  # (M + 1,)
    r_offsets: np.ndarray  # (M + 1,)
    local: np.ndarray  # (L,) global ids of the vertices a frame touches
    rest_local: np.ndarray  # (3, L)
    moved_local: np.ndarray  # (u,) local ids of vertices that any active muscle moves
    moved: np.ndarray  # (u,) their global ids
    disp_rows: np.ndarray  # (K,) local row of each stacked AOI entry
    unit_disp: np.ndarray  # (3, K)
    e0: np.ndarray  # (q,) local first vertex of each touched edge
    e1: np.ndarray  # (q,)
    rest_len: np.ndarray  # (q,)
    eps_op: sp.csr_matrix  # (K, q)
    g0: np.ndarray  # (T,) local corners a, b, c of the stacked "gradient" triangles
    g1: np.ndarray  # (T,)
    g2: np.ndarray  # (T,)
    g_coef: np.ndarray  # (2, T)
    grad_op: sp.csr_matrix  # (K, T)
    region_pos: np.ndarray  # (R,) into the K stack
    hat: np.ndarray  # (R,) H * At
    wrinkled: np.ndarray  # (v,) global ids of vertices in any active wrinkling region
    wrinkled_local: np.ndarray  # (v,)
    w_sum: sp.csr_matrix  # (v, R)
    tris: np.ndarray  # (3, t) local corners of the triangles around the wrinkled vertices
    tri_inc: sp.csr_matrix  # (v, t)
    slide_n: np.ndarray  # (3, u) rest unit normals of the moved vertices
    slide_s: np.ndarray  # (6, u) their shape operators: xx, yy, zz, xy, xz, yz

    @classmethod
    def build(cls, skin: TriangleSurface, names, datas: list[_MuscleData],
              rest: _RestGeometry) -> _StackedMuscles:
        k_counts = np.array([len(d.aoi) for d in datas], dtype=np.intp)
        k_offsets = np.concatenate([[0], np.cumsum(k_counts)])
        r_offsets = np.concatenate([[0], np.cumsum([len(d.region_pos) for d in datas])])
        edge_union, inverse = _unique_ids(np.concatenate([d.edge_ids for d in datas]),
                                          return_inverse=True)
        blocks, start = [], 0
        for d in datas:
            cols = inverse[start:start + len(d.edge_ids)]
            start += len(d.edge_ids)
            coo = d.eps_op.tocoo()
            blocks.append(sp.csr_matrix((coo.data, (coo.row, cols[coo.col])),
                                        shape=(coo.shape[0], len(edge_union))))
        wrinkled, w_sum = _summing([d.region for d in datas])
        inc = skin.incidence[wrinkled]
        tri_ids = _unique_ids(inc.indices)
        stacked_aoi = np.concatenate([d.aoi for d in datas])
        edges = skin.edges[edge_union]
        tris = skin.triangles[tri_ids]
        g_tris = skin.triangles[np.concatenate([d.tri_ids for d in datas])]
        local = _unique_ids(np.concatenate([stacked_aoi, edges.ravel(), tris.ravel(),
                                          g_tris.ravel()]))
        local = local[morton_order(skin.points[local])]
        to_local = np.full(skin.n_points, -1, np.intp)
        to_local[local] = np.arange(len(local))
        edge_order = np.lexsort((to_local[edges[:, 1]], to_local[edges[:, 0]]))
        tri_order = np.argsort(to_local[tris[:, 0]], kind="stable")
        eps_op = sp.vstack(blocks, format="csr")[:, edge_order].tocsr()
        g_local = to_local[g_tris].reshape(-1, 3)
        g_order = np.argsort(g_local[:, 0], kind="stable")
        grad_op = sp.block_diag([d.grad_op for d in datas], format="csr")[:, g_order].tocsr()
        g_coef = np.concatenate([d.tri_coef for d in datas])[g_order]
        moved = _unique_ids(stacked_aoi)
        shape = rest.shape_at(moved)
        return cls(
            names=tuple(names), k_counts=k_counts, k_offsets=k_offsets, r_offsets=r_offsets,
            local=local, rest_local=np.ascontiguousarray(skin.points[local].T),
            moved_local=to_local[moved], moved=moved, disp_rows=to_local[stacked_aoi],
            unit_disp=np.ascontiguousarray(np.concatenate([d.unit_disp for d in datas]).T),
            e0=to_local[edges[edge_order, 0]], e1=to_local[edges[edge_order, 1]],
            rest_len=skin.rest_edge_lengths[edge_union][edge_order], eps_op=eps_op,
            g0=g_local[g_order, 0], g1=g_local[g_order, 1], g2=g_local[g_order, 2],
            g_coef=np.ascontiguousarray(g_coef.T), grad_op=grad_op,
            region_pos=np.concatenate(
                [d.region_pos + o for d, o in zip(datas, k_offsets[:-1], strict=True)]),
            hat=np.concatenate([d.h * d.at[d.region_pos] for d in datas]),
            wrinkled=wrinkled, wrinkled_local=to_local[wrinkled], w_sum=w_sum,
            tris=np.ascontiguousarray(to_local[tris[tri_order]].T),
            tri_inc=inc[:, tri_ids[tri_order]].tocsr(),
            slide_n=np.ascontiguousarray(rest.slide_normals[moved].T),
            slide_s=np.ascontiguousarray(six_entries(shape).T))

    def _slide(self, p: np.ndarray) -> None:
        r"""Bend the summed tangent pull :math:`D` of the moved vertices back onto the rest
        surface, in place: :math:`x \mathrel{-}= b\, n`, :math:`b` from
        :func:`~wrinkle_vis.core.refined.slide_bend`.
        """
        d = np.take(p, self.moved_local, axis=1) - np.take(self.rest_local, self.moved_local,
                                                              axis=1)
        p[:, self.moved_local] -= slide_bend(d, self.slide_s) * self.slide_n

    def arrays(self) -> list[np.ndarray]:
        """Every array a frame reads (for the memory-stream floor of the benchmarks)."""
        out = []
        for key, value in vars(self).items():
            if key == "local":  # only the build (and another skin model's frame) uses it
                continue
            if isinstance(value, np.ndarray):
                out.append(value)
            elif sp.issparse(value):
                out += [value.data, value.indices, value.indptr]
        return out

    def displaced(self, a: np.ndarray) -> np.ndarray:
        """``(3, L)``: the touched vertices displaced by the muscles at activations ``a``
        ``(M,)`` and slid along the rest surface (the geometric skin).
        """
        p = self.rest_local.copy()
        scale = np.repeat(a, self.k_counts)
        for c in range(3):
            p[c] += np.bincount(self.disp_rows, weights=self.unit_disp[c] * scale,
                                minlength=p.shape[1])
        self._slide(p)
        return p

    def frame(self, rest: np.ndarray, a: np.ndarray, skin_points: np.ndarray | None = None
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """One frame for activations ``a`` ``(M,)``; ``skin_points`` ``(n, 3)``: the
        deformed skin when another skin model computed it (the physical skin), else the
        geometric displacement (:meth:`displaced`).

        Returns
        -------
        tuple
            Deformed points ``(n, 3)``, final points ``(n, 3)``, total W ``(n,)``, and the
            compact ``eps`` ``(K,)`` and ``W`` ``(R,)`` of the active muscles, stacked.
        """
        if skin_points is None:
            p = self.displaced(a)
        else:
            p = np.ascontiguousarray(np.take(skin_points, self.local, axis=0).T)
        d = np.take(p, self.e1, axis=1)
        d -= np.take(p, self.e0, axis=1)
        tau = 1.0 - np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) / self.rest_len
        eps = self.eps_op @ tau
        if len(self.g0):  # muscles with compression="gradient": eps = mean of 1 - |F_t d_t|
            a = np.take(p, self.g0, axis=1)
            g = self.g_coef[0] * (np.take(p, self.g1, axis=1) - a)
            g += self.g_coef[1] * (np.take(p, self.g2, axis=1) - a)
            eps += self.grad_op @ (1.0 - np.sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]))
        w_region = self.hat * anisotropy(eps[self.region_pos])
        w_sum = self.w_sum @ w_region
        normals = unit_rows(self.tri_inc @ triangle_normals(p, self.tris))

        if skin_points is None:
            deformed = rest.copy()
            deformed[self.moved] = np.take(p, self.moved_local, axis=1).T
        else:
            deformed = np.array(skin_points, dtype=float)
        wrinkled = np.take(p, self.wrinkled_local, axis=1).T + w_sum[:, None] * normals
        points = deformed.copy()
        points[self.wrinkled] = wrinkled
        total = np.zeros(len(rest))
        total[self.wrinkled] = w_sum
        return deformed, points, total, {"eps": eps, "W": w_region}
