r"""The face model: skin, skull and muscles, evaluated frame by frame (see :doc:`/model`).

Everything that depends only on the rest skin and a muscle's parameters is computed once per
muscle and cached (:class:`_MuscleData`). Everything that depends on which muscles are active
is stacked once per set of active muscles (:class:`_Assembly`), so a frame is a fixed number
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

import dataclasses
from collections import OrderedDict
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from functools import cached_property, lru_cache
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from .equations import (
    anisotropy,
    compression_operator,
    gradient_compression_operator,
    triangle_stretch,
)
from .expressions import Expression, paper_expressions
from .fields import FIELD_NAMES, check_field, field_spec
from .foldguard import guarded
from .hierarchy import Hierarchy, MuscleLevels, canonical_order, six_entries
from .mesh import (
    MeshError,
    TriangleSurface,
    shape_operators,
    smoothed_normals,
    triangle_normals,
    unit_rows,
)
from .muscle import Muscle, check_activation
from .refined import RefinedEngine, slide_bend
from .skin import DEFAULT_SKIN_MODEL, SkinMaterial, SpringSkin, check_skin_model
from .tracks import Track, TrackMapping, default_mapping, iter_activations
from .units import LENGTH_UNITS, check_unit, face_unit

__all__ = ["FIELD_NAMES", "FaceModel", "FaceState"]

#: The scale the skin slides at, as a fraction of the square root of the skin's area (about
#: 7.5 mm on the built-in face): features narrower than that move with the skin.
SLIDE_SCALE = 0.029

#: The most bytes the refinement engine of one skin keeps cached (the muscles' data on its
#: subdivision hierarchy and the stacked rows of each set of active muscles), however long an
#: animation runs; the least recently used go first (the latest active set's is kept too).
REFINE_CACHE_BYTES = 160 * 2**20


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


def tangential(vectors: np.ndarray, normals: np.ndarray) -> np.ndarray:
    r"""``(k, 3)``: ``vectors`` ``(k, 3)`` without their part along unit ``normals``,
    :math:`v - (v \cdot n)\, n`.
    """
    return vectors - np.einsum("ij,ij->i", vectors, normals)[:, None] * normals


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
class _Assembly:
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
              rest: _RestFrame) -> _Assembly:
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

    def frame(self, rest: np.ndarray, a: np.ndarray, skin_points: np.ndarray | None = None):
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


class _RestFrame:
    """The rest skin's normals and shape operators (built on first use), shared by every face
    on the same skin.

    ``normals`` are the geometric vertex normals (refinement builds on them). The skin slides
    along the surface seen at the scale ``radius``: ``slide_normals`` are the normals diffused
    over that radius, and ``shape`` the shape operators of that smoothed field, so a
    groove narrower than the radius (the mouth line, the fold under the brow) neither bends
    the pull nor scales its curvature correction, and the slide does not depend on the mesh
    resolution.
    """

    def __init__(self, skin: TriangleSurface, normals=None, radius: float | None = None):
        self._skin = skin
        if normals is not None:
            self.normals = np.asarray(normals, dtype=float)
        if radius is None:  # invariant under rigid motions
            radius = SLIDE_SCALE * float(np.sqrt(skin.triangle_areas().sum()))
        self.radius = radius
        self.shape6: np.ndarray | None = None  # (n, 6): set on a refined skin
        self._engines: dict[int, RefinedEngine] = {}

    def engine(self, depth: int) -> RefinedEngine:
        """The refinement engine of this skin ``depth`` levels deep (built on first use)."""
        engine = self._engines.get(depth)
        if engine is None:
            self._engines.clear()  # one depth at a time: the hierarchy is the big part
            hier = Hierarchy(self._skin, self.normals, self.slide_normals, self.shape, depth)
            engine = self._engines[depth] = RefinedEngine(hier, REFINE_CACHE_BYTES,
                                                          tangential)
        return engine

    @cached_property
    def normals(self) -> np.ndarray:
        """``(n, 3)``: unit outward normals of the rest skin."""
        return self._skin.vertex_normals()

    @cached_property
    def slide_normals(self) -> np.ndarray:
        """``(n, 3)``: :attr:`normals` diffused over :attr:`radius`
        (:func:`~wrinkle_vis.core.mesh.smoothed_normals`); a refined skin inherits its
        parent's, its new vertices taking unit(n_0 + n_1) of their edge's ends (and the mean
        of their shape operators): the slide is a property of the surface at the scale
        :attr:`radius`, which refinement does not change.
        """
        return smoothed_normals(self._skin, self.normals, self.radius)

    def shape_at(self, ids: np.ndarray) -> np.ndarray:
        """``(k, 3, 3)``: the rows ``ids`` ``(k,)`` of :attr:`shape`, computed at those
        vertices only unless all of them are there already.
        """
        if self.shape6 is not None or "shape" in self.__dict__:
            return self.shape[ids]
        return shape_operators(self._skin, self.slide_normals, at=ids)

    @cached_property
    def shape(self) -> np.ndarray:
        """``(n, 3, 3)``: shape operators of :attr:`slide_normals` (:func:`shape_operators`;
        a refined skin's from its hierarchy's six entries, :attr:`shape6`).
        """
        if self.shape6 is not None:
            return _from_six(self.shape6)
        return shape_operators(self._skin, self.slide_normals)


class FaceModel:
    """An anatomy-based face: skin, skull and muscles (paper Sec. 2.1).

    Parameters
    ----------
    skin : TriangleSurface
        The rest skin, outward oriented, no zero-length edges (see
        :meth:`TriangleSurface.welded` and :meth:`TriangleSurface.cleaned`).
    skull : TriangleSurface, optional
        The skull, for display and for placing attachments.
    muscles : iterable of Muscle
        Muscles with unique names.
    expressions : mapping of str to Expression, optional
        Named expressions; default the paper's (:func:`paper_expressions`).
    name : str
        A label for the face.
    landmarks : mapping of str to (3,) array_like, optional
        Named points on the skin (see :data:`wrinkle_vis.datasets.scans.LANDMARKS`); left and
        right pairs (``*_L``, ``*_R``) give the face's symmetry plane.
    unit : str, optional
        The unit of the face's lengths (a key of :data:`~wrinkle_vis.core.units.LENGTH_UNITS`);
        None for a face that does not say (labels then read
        :data:`~wrinkle_vis.core.units.DEFAULT_UNIT`, :func:`~wrinkle_vis.core.units.face_unit`).
    mapping : TrackMapping, optional
        Which muscles a recorded track's channels drive (its layout's ``"mapping"``);
        None: :func:`~wrinkle_vis.core.tracks.default_mapping` (:meth:`play`).
    skin_model : {"geometric", "physical"}, optional
        The skin model :meth:`evaluate` uses unless told otherwise (see
        :meth:`with_skin_model`); default :data:`~wrinkle_vis.core.skin.DEFAULT_SKIN_MODEL`.
    material : SkinMaterial, optional
        The physical skin's parameters (default :class:`SkinMaterial()`).

    Notes
    -----
    The model is immutable. :meth:`with_muscle` and :meth:`without_muscle` return a new
    model that shares the per-muscle caches of the unchanged muscles. One setting is not
    part of the model: :attr:`fold_guard` (default True), the default of :meth:`evaluate`'s
    ``fold_guard`` for this object (the command line's ``--fold-guard``).
    """

    fold_guard: bool = True

    def __init__(self, skin: TriangleSurface, skull: TriangleSurface | None = None,
                 muscles: Iterable[Muscle] = (), expressions=None, *, name: str = "face",
                 landmarks=None, unit: str | None = None,
                 mapping: TrackMapping | None = None, skin_model: str = DEFAULT_SKIN_MODEL,
                 material: SkinMaterial | None = None, _caches=None, _rest_normals=None):
        if not isinstance(skin, TriangleSurface):
            raise TypeError(f"skin must be a TriangleSurface; got {type(skin).__name__}")
        if skull is not None and not isinstance(skull, TriangleSurface):
            raise TypeError(f"skull must be a TriangleSurface or None; got {type(skull).__name__}")
        self.skin = skin
        self.skull = skull
        self.name = name
        self.unit: str | None = None if unit is None else check_unit(unit)
        self.skin_model: str = check_skin_model(skin_model)
        if material is not None and not isinstance(material, SkinMaterial):
            raise TypeError(f"material must be a SkinMaterial; got {type(material).__name__}")
        self.material: SkinMaterial = material or SkinMaterial()
        self.landmarks: dict[str, tuple] = {
            str(k): tuple(float(x) for x in v) for k, v in dict(landmarks or {}).items()}
        self.muscles: tuple[Muscle, ...] = tuple(muscles)
        seen: set[str] = set()
        for m in self.muscles:
            if not isinstance(m, Muscle):
                raise TypeError(f"muscles must be Muscle instances; got {type(m).__name__}")
            if m.name in seen:
                raise ValueError(f"two muscles are named {m.name!r}; muscle names must be "
                                 "unique in a face")
            seen.add(m.name)
        _check_scale(self.muscles, skin)
        self.expressions: dict[str, Expression] = dict(
            paper_expressions() if expressions is None else expressions
        )
        self.mapping = mapping
        if _caches is None:
            _check_skin(skin)
            _caches = ({}, OrderedDict(), _RestFrame(skin, _rest_normals))
        self._muscle_data: dict[Muscle, _MuscleData] = _caches[0]
        self._assemblies: OrderedDict = _caches[1] if _caches[1] is not None else OrderedDict()
        self._rest: _RestFrame = _caches[2]
        self._springs: dict[SkinMaterial, SpringSkin] = {}  # the physical skin, per material

    # ------------------------------------------------------------------ access
    @property
    def muscle_names(self) -> tuple[str, ...]:
        """Names of the muscles, in order."""
        return tuple(m.name for m in self.muscles)

    def muscle(self, name: str) -> Muscle:
        """The muscle called ``name``; ``KeyError`` lists the face's muscles."""
        for m in self.muscles:
            if m.name == name:
                return m
        raise KeyError(f"the face has no muscle {name!r}; its muscles are: "
                       f"{', '.join(self.muscle_names) or 'none'}")

    def with_muscle(self, muscle: Muscle, replacing: str | None = None) -> FaceModel:
        """A face with ``muscle`` in place of the one called ``replacing`` (default: the one
        of the same name), or added at the end if there is none.

        Replacing a muscle by one of another name renames it in every expression too.
        """
        old = muscle.name if replacing is None else replacing
        names = self.muscle_names
        if muscle.name != old and muscle.name in names:
            raise ValueError(f"a muscle named {muscle.name!r} exists already; choose another "
                             "name")
        muscles = list(self.muscles)
        if old in names:
            muscles[names.index(old)] = muscle
        elif replacing is not None:
            self.muscle(replacing)  # raises, naming the face's muscles
        else:
            muscles.append(muscle)
        expressions = self.expressions if muscle.name == old else {
            k: _renamed(ex, old, muscle.name) for k, ex in self.expressions.items()}
        return self._derived(muscles, expressions)

    def without_muscle(self, name: str) -> FaceModel:
        """A face without the muscle called ``name`` (dropped from the expressions too)."""
        self.muscle(name)
        expressions = {k: _renamed(ex, name, None) for k, ex in self.expressions.items()}
        return self._derived([m for m in self.muscles if m.name != name], expressions)

    def with_expressions(self, expressions) -> FaceModel:
        """A face with these expressions (``{name: Expression}``) and the same muscles."""
        return self._derived(self.muscles, dict(expressions))

    def symmetry_plane(self) -> tuple[np.ndarray, np.ndarray]:
        """``((3,), (3,))``: a point on the face's left-right symmetry plane and its unit
        normal (pointing to the subject's left).

        From the left and right landmark pairs (``name_L``, ``name_R``) where there are
        any: the normal is the mean of the unit ``L - R`` vectors and the point the mean of
        the pairs' midpoints. Without pairs, the plane ``x = 0`` of the built-in face's
        frame (x to the subject's left).
        """
        from .editing import symmetry_plane

        return symmetry_plane(self.landmarks)

    def _derived(self, muscles, expressions=None) -> FaceModel:
        cache = self._muscle_data
        if len(cache) > 4 * len(muscles) + 64:  # edits leave old versions behind: drop them
            keep = set(muscles)
            for m in [m for m in cache if m not in keep]:
                del cache[m]
        return FaceModel(self.skin, self.skull, muscles,
                         self.expressions if expressions is None else expressions,
                         name=self.name, landmarks=self.landmarks, unit=self.unit,
                         mapping=self.mapping, skin_model=self.skin_model,
                         material=self.material, _caches=(cache, None, self._rest))

    def with_skin_model(self, skin_model: str, material: SkinMaterial | None = None
                        ) -> FaceModel:
        """The same face whose :meth:`evaluate` uses ``skin_model`` (``"geometric"`` or
        ``"physical"``) and ``material`` (default: this face's) unless told otherwise; it
        shares every cache with this face (the physical skin's factorized matrices too).
        """
        face = self._derived(self.muscles)
        face.skin_model = check_skin_model(skin_model)
        face.material = material or self.material
        face._assemblies = self._assemblies
        face._springs = self._springs  # same skin, skull and muscles: same matrices
        return face

    def with_mapping(self, mapping: TrackMapping | None) -> FaceModel:
        """The same face whose recorded tracks play through ``mapping`` (None: the
        default); it shares every cache with this face.
        """
        face = self.with_skin_model(self.skin_model)
        face.mapping = mapping
        return face

    def muscle_data(self, muscle: Muscle) -> _MuscleData:
        """The cached rest-skin data of ``muscle`` (built on first use)."""
        data = self._muscle_data.get(muscle)
        if data is None:
            data = _MuscleData.build(self.skin, muscle, self._rest.slide_normals)
            self._muscle_data[muscle] = data
        return data

    def _assembly(self, names: tuple[str, ...]) -> _Assembly:
        return _lru(self._assemblies, names, 32, lambda: _Assembly.build(
            self.skin, names, [self.muscle_data(self.muscle(n)) for n in names], self._rest))

    # ------------------------------------------------------------------ physical skin
    def muscle_grip(self) -> np.ndarray:
        r"""``(n,)``: :math:`\omega_i`, where the face's muscles hold the skin: 1 on the
        area of influence of any muscle (active or not: a muscle lies under its zone and
        holds it, at rest where it does not pull), 0 elsewhere (:mod:`wrinkle_vis.core.skin`).

        Measured against weighting by each muscle's normalised pull, which lets the skin of
        a zone slip where the pull fades: that added more crease on the scanned head (99th
        percentile 5.9 against 3.3 degrees on surprise) and made the furrows shallower.
        """
        grip = np.zeros(self.skin.n_points)
        for m in self.muscles:
            grip[self.muscle_data(m).aoi] = 1.0
        return grip

    def physical_skin(self, material: SkinMaterial | None = None) -> SpringSkin:
        """The physically based skin of this face (:class:`~wrinkle_vis.core.skin.SpringSkin`)
        for ``material`` (default :class:`SkinMaterial()`), built once per face and
        material: its matrices are factorized again only for a new muscle layout (a new
        face) or material.
        """
        material = material or self.material
        cache = self._springs
        skin = cache.get(material)
        if skin is None:
            if len(cache) > 2:
                cache.clear()
            skin = cache[material] = SpringSkin(
                self.skin, self.muscle_grip(), material, LENGTH_UNITS[face_unit(self)],
                self.skull)
        return skin

    def muscle_displacement(self, activations: Mapping[str, float]) -> np.ndarray:
        """``(n, 3)``: the muscles' summed displacement at resolved ``activations``, slid
        along the rest skin (the geometric skin's deformation minus the rest skin).
        """
        out = np.zeros((self.skin.n_points, 3))
        active = tuple(n for n, a in activations.items() if a > 0.0)
        if active:
            asm = self._assembly(active)
            p = asm.displaced(np.array([activations[m] for m in active]))
            out[asm.moved] = np.take(p, asm.moved_local, axis=1).T - self.skin.points[asm.moved]
        return out

    def physical_state(self, activations: Mapping[str, float], skin_points: np.ndarray, *,
                       time: float | None = None, velocities: np.ndarray | None = None,
                       muscle_pull: np.ndarray | None = None) -> FaceState:
        """The frame whose deformed skin is ``skin_points`` ``(n, 3)`` (the physical
        skin's), every field computed as on the geometric skin; ``muscle_pull`` ``(n, 3)``,
        when the caller has it, is :meth:`muscle_displacement` at ``activations``
        (:attr:`FaceState.muscle_pull`).
        """
        state = self._frame(dict(activations), np.asarray(skin_points, dtype=float))
        state.skin_model = "physical"
        state.time = time
        state.velocities = None if velocities is None else _readonly(np.array(velocities))
        state.muscle_pull = None if muscle_pull is None else _readonly(np.array(muscle_pull))
        return state

    def simulator(self, timeline=None, *, material: SkinMaterial | None = None):
        """A :class:`~wrinkle_vis.core.simulation.Simulation` of the physically based skin
        for ``timeline`` (an expression name or activations: a step at t = 0; a callable
        ``t -> activations``), with ``step(dt)`` and ``reset()``.
        """
        from .simulation import Simulation

        return Simulation(self, timeline, material)

    def simulate(self, timeline, duration: float, dt: float | None = None, *,
                 material: SkinMaterial | None = None, refine: bool = False,
                 refine_angle_deg: float = 3.0, refine_levels: int = 3):
        """Yield the physically based skin's states over ``duration`` seconds, one every
        ``dt`` (default the material's ``time_step``), from rest at t = 0, for
        ``timeline`` (see :meth:`simulator`); each :class:`FaceState` has ``time`` and
        ``velocities``; with ``refine``, refined as :meth:`evaluate` does.
        """
        sim = self.simulator(timeline, material=material)
        for state in sim.run(duration, dt, guard=not refine):  # refined: guard the refined
            if refine:
                state = self.guarded(
                    self._refined_physical(state, refine_angle_deg, refine_levels), None)
            yield state

    def expression_states(self, expression: Expression, times, intensity: float = 1.0, *,
                          refine: bool = False, refine_angle_deg: float = 3.0,
                          refine_levels: int = 3):
        """Yield the states of ``expression``'s timeline (onset, hold, release:
        :meth:`Expression.at`) at ``times`` (seconds, ascending), one at a time: on the
        geometric skin each evaluated on its own; on the physical skin (the face's
        :attr:`skin_model`) simulated from rest at t = 0, the timeline as the command, at
        the material's time step and landing on each time.
        """
        times = [float(t) for t in times]
        if any(b < a for a, b in zip(times, times[1:], strict=False)):
            raise ValueError("times must be ascending")
        options = {"refine": refine, "refine_angle_deg": refine_angle_deg,
                   "refine_levels": refine_levels}
        if self.skin_model != "physical":
            for t in times:
                yield self.evaluate(expression.at(t, intensity), **options)
            return
        sim = self.simulator(lambda t: expression.at(t, intensity))
        for t in times:
            sim.advance_to(t)  # the fields only at the times asked for
            state = sim.state(guard=not refine)
            yield (self.guarded(self._refined_physical(state, refine_angle_deg,
                                                        refine_levels), None)
                   if refine else state)

    def _refined_physical(self, state: FaceState, angle_deg: float, levels: int) -> FaceState:
        if not (0.0 < angle_deg < 180.0):
            raise ValueError(f"refine_angle_deg = {angle_deg:g} is outside (0, 180)")
        if isinstance(levels, bool) or not isinstance(levels, (int, np.integer)) or levels < 0:
            raise ValueError(f"refine_levels = {levels!r} must be a whole number >= 0")
        refined = self._refined_frame(state, state.activations, angle_deg, int(levels))
        refined.skin_model, refined.time = "physical", state.time
        refined.velocities = None if refined is not state else state.velocities
        return refined

    # ------------------------------------------------------------------ evaluation
    def activations_for(self, activations, intensity: float = 1.0) -> dict[str, float]:
        """Resolve an expression name, an :class:`Expression` or a mapping to activations.

        Returns
        -------
        dict of str to float
            Every muscle of the face, in order, with its activation in ``[0, 1]``.
        """
        if isinstance(activations, str):
            if activations not in self.expressions:
                raise KeyError(f"unknown expression {activations!r}; this face has: "
                               f"{', '.join(self.expressions)}")
            activations = self.expressions[activations]
        if isinstance(activations, Expression):
            activations = activations.scaled(intensity)
        elif isinstance(activations, Mapping):
            k = float(intensity)
            if not (0.0 <= k <= 1.0):
                raise ValueError(f"intensity = {k:g} is outside [0, 1]")
            activations = {m: check_activation(m, a) * k for m, a in activations.items()}
        else:
            raise TypeError("activations must be an expression name, an Expression or a "
                            f"mapping of muscle name to activation; got {type(activations)}")
        unknown = sorted(set(activations) - set(self.muscle_names))
        if unknown:
            raise KeyError(f"no muscle named {', '.join(map(repr, unknown))} in this face; its "
                           f"muscles are: {', '.join(self.muscle_names) or 'none'}")
        return {n: float(activations.get(n, 0.0)) for n in self.muscle_names}

    def evaluate(self, activations=None, intensity: float = 1.0, *, refine: bool = False,
                 refine_angle_deg: float = 3.0, refine_levels: int = 3,
                 skin: str | None = None, material: SkinMaterial | None = None,
                 fold_guard: bool | None = None) -> FaceState:
        r"""One frame of the wrinkle model.

        Parameters
        ----------
        activations : str, Expression or mapping of str to float, optional
            An expression name (``"surprise"``), an :class:`Expression`, or muscle name to
            activation in ``[0, 1]``; ``None`` is neutral.
        intensity : float, default 1.0
            Scales every activation, in ``[0, 1]``.
        refine : bool, default False
            Refine the skin adaptively where the deformed surface bends (paper Sec. 3,
            Fig. 11): level after level, the triangles influenced by an active muscle (a
            corner moved or wrinkled) are split 1-to-4 where their vertex normals differ by
            more than ``refine_angle_deg`` beyond the rest skin's own bend across them (the
            curvature that the expression adds), or where the longest edge :math:`h` exceeds
            half the half period :math:`u` (Eq. 6) of a muscle wrinkling a corner as deep as
            :math:`|W| \pi^2 h / u^2 >` ``refine_angle_deg`` (normals that sample the
            furrows that coarsely cannot see them bend); the split is closed
            conformingly (:mod:`wrinkle_vis.core.refined`). New vertices get
            rest positions on the smooth surface through the rest vertices and their normals
            (not the straight edge midpoints, which would keep the coarse facets); each is
            evaluated on its own ring in the subdivision hierarchy, so its values do not
            depend on which triangles the frame splits, and the skin's own vertices keep the
            unrefined values. The hierarchy and the muscles' data on it are built once per
            skin and shared by every frame (:data:`REFINE_CACHE_BYTES`).
        refine_angle_deg : float, default 3.0
            The bending threshold, beyond the rest skin's bend (3 degrees and 3 levels come
            as close to the model along the forehead furrows as VTK's butterfly subdivision
            twice over, with about a quarter of its triangles:
            ``benchmarks/bench_refine_fidelity.py``).
        refine_levels : int, default 3
            At most this many levels.
        fold_guard : bool, optional
            Default: the face's :attr:`fold_guard` (True). Keep the skin from passing
            through itself (:mod:`wrinkle_vis.core.foldguard`): on an unrefined frame each
            pull is limited where a triangle would keep less than a fifth of its rest
            signed area; on every frame :math:`|W|` is kept below half the radius of the
            empty ball that touches the rest skin on the side :math:`W` pushes to; both by
            clamps that are the identity far from those bounds. ``state.W_raw`` is the
            unguarded :math:`W` and ``state.fold_guard`` how much the guard took away (0
            where it did not act).

        skin : {"geometric", "physical"}, optional
            The skin model (default the face's :attr:`skin_model`): the muscles' summed
            pulls (:mod:`wrinkle_vis.core.face`), or the physically based skin's
            equilibrium (:mod:`wrinkle_vis.core.skin`), on which every field is computed by
            the same code.
        material : SkinMaterial, optional
            The physical skin's parameters (default the face's :attr:`material`).

        Returns
        -------
        FaceState
            Deformed and wrinkled points, total :math:`W`, and per-muscle fields; with
            ``refine`` its ``face`` and ``triangles`` are the refined ones.
        """
        acts = self.activations_for({} if activations is None else activations, intensity)
        if check_skin_model(skin or self.skin_model) == "physical":
            springs = self.physical_skin(material)
            pull = self.muscle_displacement(acts)
            x = springs.equilibrium(pull)
            state = self.physical_state(acts, x, velocities=np.zeros_like(x), muscle_pull=pull)
            if refine:
                state = self._refined_physical(state, refine_angle_deg, refine_levels)
            return self.guarded(state, fold_guard)
        state = self._frame(acts)
        if refine:
            if not (0.0 < refine_angle_deg < 180.0):
                raise ValueError(f"refine_angle_deg = {refine_angle_deg:g} is outside (0, 180)")
            if isinstance(refine_levels, bool) or \
                    not isinstance(refine_levels, (int, np.integer)) or refine_levels < 0:
                raise ValueError(f"refine_levels = {refine_levels!r} must be a whole number "
                                 ">= 0")
            state = self._refined_frame(state, acts, refine_angle_deg, int(refine_levels))
        return self.guarded(state, fold_guard)

    def guarded(self, state: FaceState, fold_guard: bool | None = None) -> FaceState:
        """``state`` through the fold guard (:func:`~wrinkle_vis.core.foldguard.guarded`)
        when ``fold_guard`` (None: the face's :attr:`fold_guard`) says so, on either skin.
        """
        on = self.fold_guard if fold_guard is None else fold_guard
        return guarded(self, state) if on else state

    def play(self, track: Track, fps: float | None = None, *, smooth_s: float = 0.0,
             mapping: TrackMapping | None = None, **evaluate_options) -> Iterator[FaceState]:
        """The states of a recorded track (:class:`~wrinkle_vis.core.tracks.Track`), one a
        frame: at the track's own frames, or at ``fps`` from its start to its end
        (:meth:`~wrinkle_vis.core.tracks.Track.frame_times`, smoothed over ``smooth_s``
        seconds). Channels become activations through ``mapping`` (default the face's,
        else :func:`~wrinkle_vis.core.tracks.default_mapping`), restricted to this face's
        muscles; ``evaluate_options`` go to :meth:`evaluate` (``refine=True``, ...).
        """
        chosen = mapping or self.mapping or default_mapping()
        for _, acts in iter_activations(track, chosen, self.muscle_names, fps=fps,
                                        smooth_s=smooth_s):
            yield self.evaluate(acts, **evaluate_options)

    def _refined_frame(self, root: FaceState, acts: dict[str, float], angle_deg: float,
                       levels: int) -> FaceState:
        """Refine the unrefined frame ``root`` with this skin's refinement engine
        (:mod:`wrinkle_vis.core.refined`): the subdivision hierarchy and the muscles' data
        on it are built once and shared by every frame; a frame splits, closes and evaluates
        only the vertices it selected.
        """
        active = [m for m in self.muscles if acts[m.name] > 0.0]
        if not active or levels == 0:
            return root
        engine = self._rest.engine(levels)
        a = np.array([acts[m.name] for m in active])
        dyn, tris, split, split_ids = engine.frame(root, tuple(active), a, angle_deg, levels)
        if not split.any():
            return root
        face, order = self._refined_face(engine, split, split_ids, tris)
        source = _RefinedSource(root, engine, (tuple(active), a), order)
        deformed = np.ascontiguousarray(np.take(dyn.deformed, order, axis=1).T)
        points = np.ascontiguousarray(np.take(dyn.points, order, axis=1).T)
        return FaceState(face, acts, deformed, points,
                         dyn.W[order], None, {}, source)

    def _refined_face(self, engine: RefinedEngine, split, split_ids, tris):
        """The face on the refined skin of a split set (the latest one is kept, so frames
        with the same split set share their face, triangles and rest skin).
        """
        key = (self.muscles, np.packbits(split).tobytes())
        last = engine.last
        if last is not None and last[0] == key:
            return last[1], last[2]
        hier = engine.hier
        order = canonical_order(hier, split, split_ids)
        remap = np.full(hier.n_points, -1, np.int64)
        remap[order] = np.arange(len(order))
        surface = TriangleSurface._derived(np.take(hier.rest, order, axis=0),
                                           np.take(remap, tris))
        rest = _RestFrame(surface, np.take(hier.normal, order, axis=0), self._rest.radius)
        rest.slide_normals = np.take(hier.slide, order, axis=0)
        rest.shape6 = np.take(hier.shape6, order, axis=0)
        face = FaceModel(surface, self.skull, self.muscles, self.expressions, name=self.name,
                         landmarks=self.landmarks, unit=self.unit, _caches=({}, None, rest))
        engine.last = (key, face, order)
        return face, order

    def _frame(self, acts: dict[str, float], skin_points: np.ndarray | None = None
               ) -> FaceState:
        """The unrefined frame for resolved activations (on the deformed skin
        ``skin_points`` ``(n, 3)`` of another skin model when given).
        """
        active = tuple(n for n, a in acts.items() if a > 0.0)
        rest = self.skin.points
        n = self.skin.n_points
        if not active:
            zero = np.zeros(n)
            d = rest if skin_points is None else skin_points
            return FaceState(self, acts, d, d, zero, None, {})
        asm = self._assembly(active)
        deformed, points, total, compact = asm.frame(rest, np.array([acts[m] for m in active]),
                                                     skin_points)
        return FaceState(self, acts, deformed, points, total, asm, compact)


def _from_six(six: np.ndarray) -> np.ndarray:
    """``(n, 3, 3)`` symmetric matrices from their xx, yy, zz, xy, xz, yz entries."""
    xx, yy, zz, xy, xz, yz = six.T
    return np.stack([np.stack([xx, xy, xz], 1), np.stack([xy, yy, yz], 1),
                     np.stack([xz, yz, zz], 1)], axis=1)


def _renamed(expression: Expression, old: str, new: str | None) -> Expression:
    """``expression`` with muscle ``old`` called ``new`` (None: dropped)."""
    if old not in expression.activations:
        return expression
    acts = {(new if k == old else k): v for k, v in expression.activations.items()
            if k != old or new is not None}
    return dataclasses.replace(expression, activations=acts)


def _lru(cache: OrderedDict, key, size: int, build):
    """``cache[key]``, built by ``build()`` when missing; keeps the ``size`` latest."""
    value = cache.get(key)
    if value is None:
        value = cache[key] = build()
        while len(cache) > size:
            cache.popitem(last=False)
    else:
        cache.move_to_end(key)
    return value


#: The largest furrow depth factor :math:`k_0` and pull :math:`K` of a muscle, as a multiple
#: of the skin's size (the diagonal of its bounding box): a deeper furrow or a longer pull
#: than the whole face is a typo or a wrong unit, and far beyond it the wrinkles overflow.
MAX_DEPTH_RATIO = 1.0


def _check_scale(muscles, skin: TriangleSurface) -> None:
    r"""Refuse a muscle whose :math:`k_0` or :math:`K` exceeds :data:`MAX_DEPTH_RATIO` times
    the skin's size (one line naming the muscle, the value and the bound).
    """
    if not muscles:
        return
    size = float(np.linalg.norm(np.ptp(skin.points, axis=0)))
    for m in muscles:
        for param, value in (("k0", m.k0), ("strength", m.strength_value)):
            if value > MAX_DEPTH_RATIO * size:
                raise ValueError(
                    f"muscle {m.name!r}: {param} = {value:g} is larger than the whole face "
                    f"({size:.4g} across, in its units); furrows and pulls are a fraction of "
                    "it: check the value and the layout's unit")


def _check_skin(skin: TriangleSurface) -> None:
    zero = np.flatnonzero(skin.rest_edge_lengths == 0.0)
    if len(zero):
        e = skin.edges[zero[0]]
        raise MeshError(
            f"the skin has {len(zero)} edge(s) of zero length (first joins vertices {e[0]} and "
            f"{e[1]}); weld coincident vertices with skin.welded() and drop degenerate "
            "triangles with skin.cleaned()"
        )
    t = np.sort(skin.triangles, axis=1).astype(np.int64)
    n = np.int64(skin.n_points)
    if skin.n_points < 2_000_000:  # one int64 key per triangle (n**3 < 2**63)
        rep_dupes = len(np.unique((t[:, 0] * n + t[:, 1]) * n + t[:, 2]))
    else:
        rep_dupes = len(np.unique(t, axis=0))
    if rep_dupes != skin.n_triangles:
        raise MeshError(
            f"the skin has {skin.n_triangles - rep_dupes} duplicate triangle(s); remove them "
            "with skin.cleaned()"
        )


@dataclass(frozen=True, eq=False)
class _Frame:
    """What the lazy field views of a state need (not the state: no reference cycle)."""

    face: FaceModel
    deformed_points: np.ndarray
    assembly: _Assembly | None
    compact: dict
    source: _RefinedSource | None = None

    @property
    def n_points(self) -> int:
        return len(self.deformed_points)


class _FieldMap(Mapping):
    """A mapping over the field catalogue (:data:`FIELD_NAMES`), each field built on
    first access and kept in ``_cache``.
    """

    _cache: dict[str, np.ndarray]

    def __iter__(self):
        return iter(FIELD_NAMES)

    def __len__(self) -> int:
        return len(FIELD_NAMES)


class _MuscleFields(_FieldMap):
    """The fields of one muscle in one state, full length, ``nan`` where undefined."""

    def __init__(self, state: _Frame, muscle: Muscle):
        self._state = state
        self._muscle = muscle
        self._cache: dict[str, np.ndarray] = {}
        self._dynamic: dict[str, np.ndarray] | None = None

    def __getitem__(self, key: str) -> np.ndarray:
        if key not in self._cache:
            spec = field_spec(key)  # KeyError lists the fields
            arr = np.array(spec.compute(self), dtype=float)  # a copy: ours to freeze
            if arr.shape != (self._state.n_points,):
                raise ValueError(f"field {key!r} computed shape {arr.shape}; expected "
                                 f"({self._state.n_points},), one value per skin vertex")
            arr.setflags(write=False)
            self._cache[key] = arr
        return self._cache[key]

    # ---------------------------------------------------------------- for compute()
    # The catalogue's built-in entries (core/fields.py) compute through these two.
    def static(self, key: str, attr: str, where: str) -> np.ndarray:
        """``(n,)``: the muscle's rest-skin quantity ``attr`` of its data (``lam``,
        ``gamma``, ``l``, ``at``, ``w``, ``h``) on its ``"aoi"`` or ``"region"``, ``nan``
        elsewhere; on a refined frame, field ``key`` from the refinement engine.
        """
        if self._state.source is not None:
            return self._state.source.static(self._muscle, key, attr)
        data = self._state.face.muscle_data(self._muscle)
        return self._full(data.aoi if where == "aoi" else data.region, getattr(data, attr))

    def frame_value(self, key: str, where: str) -> np.ndarray:
        """``(n,)``: the frame's ``eps`` or ``A`` (on the AOI) or ``W`` (on the region) of
        the muscle, ``nan`` elsewhere.
        """
        if self._state.source is not None:
            return self._state.source.dynamic(self._muscle, key)
        data = self._state.face.muscle_data(self._muscle)
        return self._full(data.aoi if where == "aoi" else data.region, self.dynamic()[key])

    def frame_attr(self, key: str) -> np.ndarray:
        """``(n,)``: a field of the whole frame (catalogue ``where="frame"``): none on one
        muscle's mapping, ``nan`` everywhere (:meth:`FaceState.field_values` reads it).
        """
        return np.full(self._state.n_points, np.nan)

    def _full(self, ids: np.ndarray, values: np.ndarray) -> np.ndarray:
        out = np.full(self._state.n_points, np.nan)
        out[ids] = values
        return out

    def at(self, vertices: np.ndarray) -> _PointFields:
        """The fields at skin vertices ``vertices`` ``(k,)``: ``at(v)[key]`` equals
        ``self[key][v]``, read from the compact per-muscle data.
        """
        return _PointFields(self, np.asarray(vertices, np.intp))

    def dynamic(self) -> dict[str, np.ndarray]:
        """Eps and A on the AOI, W on the region (compact), for this muscle in this frame."""
        if self._dynamic is None:
            self._dynamic = self._compact_dynamic()
        return self._dynamic

    def _compact_dynamic(self) -> dict[str, np.ndarray]:
        """Eps and A on the AOI, W on the region, for this muscle in this state."""
        state, name = self._state, self._muscle.name
        data = state.face.muscle_data(self._muscle)
        asm = state.assembly
        if asm is not None and name in asm.names:
            i = asm.names.index(name)
            ks, ke = asm.k_offsets[i], asm.k_offsets[i + 1]
            rs, re = asm.r_offsets[i], asm.r_offsets[i + 1]
            c = state.compact
            eps = c["eps"][ks:ke]
            return {"eps": eps, "A": anisotropy(eps), "W": c["W"][rs:re]}
        # an inactive muscle: its compression is defined, but it makes no wrinkles
        eps = data.compression(state.face.skin, state.deformed_points)
        return {"eps": eps, "A": anisotropy(eps), "W": np.zeros(len(data.region_pos))}


def _rows_of(ids: np.ndarray, vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(k,)`` rows of ``ids`` ``(r,)`` holding ``vertices`` ``(k,)`` and ``(k,) bool``
    whether each is there at all (its row is then meaningless).
    """
    if not len(ids):
        return np.zeros(len(vertices), np.intp), np.zeros(len(vertices), bool)
    hit = ids == vertices[:, None]
    return hit.argmax(axis=1), hit.any(axis=1)


class _PointFields(_FieldMap):
    """The fields of one muscle in one state at a few skin vertices ``(k,)``: each ``(k,)``,
    the values the full fields have there, picked from the muscle's compact data (a field
    whose ``compute`` is not pointwise, or already built full, is read from its full array).
    """

    def __init__(self, fields: _MuscleFields, vertices: np.ndarray):
        self._fields, self._vertices = fields, vertices
        self._state, self._muscle = fields._state, fields._muscle
        self._cache: dict[str, np.ndarray] = {}
        self._rows: dict[str, tuple[np.ndarray, np.ndarray]] = {}

    def __getitem__(self, key: str) -> np.ndarray:
        if key not in self._cache:
            self._cache[key] = self._computed(key)
        return self._cache[key]

    @cached_property
    def defined(self) -> bool:
        """Whether one of the vertices is in the muscle's AOI (elsewhere its fields are
        ``nan``, as every field is outside the AOI).
        """
        if self._state.source is not None:
            return self._state.source.defined_at(self._muscle, self._vertices)
        return bool(self._rows_in("aoi")[1].any())

    def _computed(self, key: str) -> np.ndarray:
        spec = field_spec(key)  # KeyError lists the fields
        if key not in self._fields._cache and spec.pointwise:
            if not self.defined:
                return np.full(len(self._vertices), np.nan)
            arr = np.array(spec.compute(self), dtype=float)
            if arr.shape == self._vertices.shape:
                return arr
        return self._fields[key][self._vertices]

    def _rows_in(self, where: str) -> tuple[np.ndarray, np.ndarray]:
        """The vertices' rows in the muscle's ``"aoi"`` or ``"region"`` and whether each
        is there (:func:`_rows_of`).
        """
        if where not in self._rows:
            data = self._state.face.muscle_data(self._muscle)
            self._rows[where] = _rows_of(data.aoi if where == "aoi" else data.region,
                                         self._vertices)
        return self._rows[where]

    # ---------------------------------------------------------------- for compute()
    def static(self, key: str, attr: str, where: str) -> np.ndarray:
        """``(k,)``: :meth:`_MuscleFields.static` at the vertices."""
        if self._state.source is not None:
            return self._state.source.static_at(self._muscle, key, attr, self._vertices)
        data = self._state.face.muscle_data(self._muscle)
        return self._picked(where, lambda: getattr(data, attr))

    def frame_value(self, key: str, where: str) -> np.ndarray:
        """``(k,)``: :meth:`_MuscleFields.frame_value` at the vertices."""
        if self._state.source is not None:
            return self._state.source.dynamic_at(self._muscle, key, self._vertices)
        return self._picked(where, lambda: self._fields.dynamic()[key])

    def _picked(self, where: str, values) -> np.ndarray:
        """``(k,)``: compact ``values()`` (on the muscle's ``where``) at the vertices,
        ``nan`` at those outside it (``values`` is not called when all are).
        """
        rows, found = self._rows_in(where)
        out = np.full(len(self._vertices), np.nan)
        if found.any():
            out[found] = values()[rows[found]]
        return out


class _RefinedAt(NamedTuple):
    """A muscle's fields at a few skin vertices of a refined frame: which vertices are the
    unrefined skin's (``old``, ``(k,) bool``), the unrefined frame's fields there
    (``root``), the muscle's levels and their ``rows`` holding the new vertices ``found``
    there, and the compression there once computed (``eps``).
    """

    old: np.ndarray
    root: _PointFields
    levels: MuscleLevels | None
    rows: np.ndarray
    found: np.ndarray
    eps: dict

    def start(self, key: str) -> np.ndarray:
        """``(k,)``: field ``key`` of the unrefined frame on its vertices, ``nan`` else."""
        out = np.full(len(self.old), np.nan)
        out[self.old] = self.root[key]
        return out


class _RefinedSource:
    """The fields of a refined frame: the skin's vertices from the unrefined frame, the new
    ones from the refinement engine's per-muscle data and the frame's values.
    """

    def __init__(self, root: FaceState, engine: RefinedEngine, active, order: np.ndarray):
        self._root, self._engine, self._active, self._order = root, engine, active, order
        self._points: dict[tuple[str, bytes], _RefinedAt] = {}

    @cached_property
    def _dyn(self):
        return self._engine.dynamic(self._root, *self._active)

    def _start(self, muscle: Muscle, key: str):
        """The field's values on the skin's vertices (from the unrefined frame) and where
        the muscle's refined data go: ``(out, levels, positions, kept)``.
        """
        out = np.full(len(self._order), np.nan)
        n0 = self._root.n_points
        out[:n0] = self._root.fields[muscle.name][key]
        lv = self._engine.levels(muscle)
        where = np.full(self._engine.hier.n_points, -1, np.int64)
        where[self._order] = np.arange(len(self._order))
        pos = where[lv.ids] if len(lv.ids) else np.zeros(0, np.int64)
        return out, lv, pos, pos >= 0

    def _at(self, muscle: Muscle, vertices: np.ndarray) -> _RefinedAt:
        """What the muscle's fields at skin vertices ``vertices`` ``(k,)`` are read from."""
        key = (muscle.name, vertices.tobytes())
        if key not in self._points:
            old = vertices < self._root.n_points
            root = self._root.fields[muscle.name].at(vertices[old])
            if old.all():  # no new vertex: the levels have nothing there
                lv, rows, found = None, np.zeros(len(vertices), np.intp), ~old
            else:
                lv = self._engine.levels(muscle)
                rows, found = _rows_of(lv.ids, self._order[vertices])
            self._points[key] = _RefinedAt(old, root, lv, rows[found], found, {})
        return self._points[key]

    def defined_at(self, muscle: Muscle, vertices: np.ndarray) -> bool:
        """Whether one of skin vertices ``vertices`` is in the muscle's AOI."""
        at = self._at(muscle, vertices)
        return bool(at.found.any()) or at.root.defined

    def static_at(self, muscle: Muscle, key: str, attr: str, vertices: np.ndarray
                  ) -> np.ndarray:
        """``(k,)``: :meth:`static` at skin vertices ``vertices``."""
        at = self._at(muscle, vertices)
        out = at.start(key)
        if at.levels is not None:
            out[at.found] = getattr(at.levels, attr)[at.rows]
        return out

    def dynamic_at(self, muscle: Muscle, key: str, vertices: np.ndarray) -> np.ndarray:
        """``(k,)``: :meth:`dynamic` at skin vertices ``vertices``."""
        at = self._at(muscle, vertices)
        out = at.start(key)
        if at.levels is not None and len(at.rows):
            if "eps" not in at.eps:
                at.eps["eps"] = self._dyn.compression(at.levels, at.rows)
            out[at.found] = self._new_values(muscle, key, at.levels, at.rows, at.eps["eps"])
        return out

    def _new_values(self, muscle: Muscle, key: str, lv, rows: np.ndarray,
                    eps: np.ndarray | None = None) -> np.ndarray:
        """Field ``eps``, ``A`` or ``W`` of the frame at the levels' rows ``rows`` (from
        their ``eps`` when known).
        """
        eps = self._dyn.compression(lv, rows) if eps is None else eps
        a = anisotropy(eps)
        if key == "W":  # on the wrinkling region, 0 for a muscle at rest
            active = self._root.activations[muscle.name] > 0.0
            return lv.h[rows] * lv.at[rows] * (a if active else 0.0)
        return eps if key == "eps" else a

    def static(self, muscle: Muscle, key: str, attr: str) -> np.ndarray:
        """Field ``key``, the refined data's ``attr`` on the new vertices."""
        out, lv, pos, keep = self._start(muscle, key)
        out[pos[keep]] = getattr(lv, attr)[keep]
        return out

    def dynamic(self, muscle: Muscle, key: str) -> np.ndarray:
        """Field ``eps``, ``A`` or ``W`` of the frame on the new vertices."""
        out, lv, pos, keep = self._start(muscle, key)
        out[pos[keep]] = self._new_values(muscle, key, lv, np.flatnonzero(keep))
        return out


class _StateFields(Mapping):
    def __init__(self, state: _Frame):
        self._state = state
        self._by_name: dict[str, _MuscleFields] = {}

    def __iter__(self):
        return iter(self._state.face.muscle_names)

    def __len__(self) -> int:
        return len(self._state.face.muscles)

    def __getitem__(self, name: str) -> _MuscleFields:
        if name not in self._by_name:
            self._by_name[name] = _MuscleFields(self._state, self._state.face.muscle(name))
        return self._by_name[name]


class FaceState:
    r"""One evaluated frame of a :class:`FaceModel`.

    Attributes
    ----------
    face : FaceModel
        The model it came from.
    activations : dict of str to float
        Every muscle's activation in this frame.
    rest_points : (n, 3) float
        The rest skin.
    deformed_points : (n, 3) float
        The skin after the muscles' displacement, before wrinkles.
    points : (n, 3) float
        The final skin: deformed points plus :math:`W` along the outward unit normal.
    triangles : (m, 3) int
        The skin's triangles.
    W : (n,) float
        Total wrinkle amplitude, :math:`\sum_m H A(\varepsilon) At`, 0 outside every
        active wrinkling region.
    fields : mapping
        ``fields[muscle][name]`` for ``name`` in :data:`FIELD_NAMES`, each ``(n,)``,
        ``nan`` where the muscle does not define it. ``lambda``, ``gamma``, ``l``, ``At``,
        ``eps`` and ``A`` live on the muscle's AOI; ``w``, ``H`` and ``W`` on its
        wrinkling region. A muscle that is not contracting makes no wrinkles (``W`` = 0 on
        its region) although its compression ``eps`` is still reported. Built on access.
    """

    #: Which skin model made the frame (``"geometric"`` or ``"physical"``).
    skin_model: str = "geometric"
    #: Simulated seconds since the start of a simulation (None for a still frame).
    time: float | None = None
    #: ``(n, 3)``: the skin's velocities (face units per second) in a simulated frame.
    velocities: np.ndarray | None = None
    #: ``(n, 3)``: on a physical frame, the muscles' summed displacement its skin was
    #: solved for (:meth:`FaceModel.muscle_displacement`), which refinement reads instead of
    #: computing it again.
    muscle_pull: np.ndarray | None = None

    def __init__(self, face, activations, deformed, points, total, assembly, compact,
                 source=None):
        self.face = face
        self.activations = dict(activations)
        self.rest_points = face.skin.points
        self.triangles = face.skin.triangles
        self.deformed_points = _readonly(deformed)
        self.points = _readonly(points)
        self.W = _readonly(total)
        self.W_raw = self.W  # the fold guard replaces W and keeps the raw one here
        self.fold_guard = _zeros(len(self.W))  # how much the guard took away, in [0, 1]
        self.fields = _StateFields(_Frame(face, self.deformed_points, assembly, compact,
                                          source))

    @property
    def n_points(self) -> int:
        """Number of skin vertices."""
        return len(self.points)

    @cached_property
    def normals(self) -> np.ndarray:
        """``(n, 3)``: unit vertex normals of the final skin (computed on first access)."""
        return self.face.skin.vertex_normals(self.points)

    def surface(self) -> TriangleSurface:
        """The final skin as a :class:`TriangleSurface`."""
        return TriangleSurface(self.points, self.triangles)

    def field_values(self, key: str, muscle: str | None = None) -> np.ndarray:
        """``(n,)``: field ``key`` of ``muscle``, or its total over the muscles (None; only
        the fields the catalogue gives a total, ``W``: :attr:`W`).

        Raises
        ------
        KeyError
            For an unknown field or muscle, listing them.
        ValueError
            For a field with no total and no muscle.
        """
        spec = check_field(key, muscle)
        if spec.where == "frame":  # a field of the whole frame (fold_guard)
            return getattr(self, key)
        if muscle is None:
            return self.W
        if muscle not in self.face.muscle_names:
            raise KeyError(f"no muscle {muscle!r}; muscles: {', '.join(self.face.muscle_names)}")
        return self.fields[muscle][key]

    def values_at(self, vertices) -> dict[str, Mapping[str, np.ndarray]]:
        """Every field at skin vertices ``vertices`` ``(k,)``: ``{"total": {"W": (k,)},
        muscle: {key: (k,)}}``, the values of :attr:`W` and :attr:`fields` there, for the
        muscles whose AOI holds one of them (every field of the others is ``nan`` there).
        Read from each muscle's compact data: no full-length field is built, but for a
        field whose ``compute`` is not :attr:`~wrinkle_vis.core.fields.FieldSpec.pointwise`.
        """
        vertices = np.asarray(vertices, np.intp)
        out: dict[str, Mapping[str, np.ndarray]] = {"total": {"W": self.W[vertices]}}
        for name in self.face.muscle_names:
            at = self.fields[name].at(vertices)
            if at.defined:
                out[name] = at
        return out

    def summary(self) -> str:
        """A few lines on the frame: activations and the range of each active field."""
        lines = [f"{self.face.name}: {self.n_points} vertices, "
                 f"{len(self.triangles)} triangles"]
        active = {m: a for m, a in self.activations.items() if a > 0}
        lines.append("active muscles: " + (", ".join(f"{m}={a:.2f}" for m, a in active.items())
                                           or "none"))
        unit = face_unit(self.face)
        lines.append(f"W total ({unit}): min {_sig(self.W.min())}  max {_sig(self.W.max())}"
                     f"  nonzero at {np.count_nonzero(self.W)} vertices")
        for m in active:
            f = self.fields[m]
            parts = []
            for key in ("lambda", "gamma", "eps", "At", "H", "A", "W"):
                v = f[key][np.isfinite(f[key])]
                parts.append(f"{key} [{_sig(v.min())}, {_sig(v.max())}]" if len(v) else
                             f"{key} undefined")
            lines.append(f"  {m}: " + "  ".join(parts))
        return "\n".join(lines)


def _sig(value: float) -> str:
    """``value`` with its sign and 4 significant digits, whatever its scale (a face in
    metres has wrinkles of 1e-4): ``+0.0123``, ``-2.5e-05``, ``+0``.
    """
    return f"{float(value):+.4g}"


@lru_cache(maxsize=8)
def _zeros(n: int) -> np.ndarray:
    """``(n,)``: zeros, read-only, shared by the frames of one skin (no allocation a frame)."""
    z = np.zeros(n)
    z.setflags(write=False)
    return z


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.asarray(a)
    a.setflags(write=False)
    return a
