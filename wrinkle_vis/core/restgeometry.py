"""The rest skin's geometry, shared by every face on the same skin: its normals, the
normals and shape operators of the surface the skin slides along, and its refinement
engines (:class:`_RestGeometry`).
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from .hierarchy import Hierarchy
from .mesh import TriangleSurface, shape_operators, smoothed_normals
from .muscledata import tangential
from .refined import RefinedEngine

#: The scale the skin slides at, as a fraction of the square root of the skin's area (about
#: 7.5 mm on the built-in face): features narrower than that move with the skin.
SLIDE_SCALE = 0.029

#: The most bytes the refinement engine of one skin keeps cached (the muscles' data on its
#: subdivision hierarchy and the stacked rows of each set of active muscles), however long an
#: animation runs; the least recently used go first (the latest active set's is kept too).
REFINE_CACHE_BYTES = 160 * 2**20


class _RestGeometry:
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
        #: Whether :attr:`normals` were given (a refined skin's Phong normals) rather than
        #: the skin's own vertex normals.
        self.interpolated = normals is not None
        if normals is not None:
            self.normals = np.asarray(normals, dtype=float)
        if radius is None:  # invariant under rigid motions
            radius = SLIDE_SCALE * float(np.sqrt(skin.triangle_areas().sum()))
        self.radius = radius
        self.shape6: np.ndarray | None = None  # (n, 6): set on a refined skin
        #: A refined skin's hierarchy and its rows in it (``FaceModel._refined_face``; the
        #: fold guard keeps per-row data with the coarse face).
        self.refined_from: tuple | None = None
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
    def vertex_normals(self) -> np.ndarray:
        """``(n, 3)``: the rest skin's own unit vertex normals (:attr:`normals` itself unless
        those were given).
        """
        return self._skin.vertex_normals() if self.interpolated else self.normals

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



def _from_six(six: np.ndarray) -> np.ndarray:
    """``(n, 3, 3)`` symmetric matrices from their xx, yy, zz, xy, xz, yz entries."""
    xx, yy, zz, xy, xz, yz = six.T
    return np.stack([np.stack([xx, xy, xz], 1), np.stack([xy, yy, yz], 1),
                     np.stack([xz, yz, zz], 1)], axis=1)
