"""The fields of a refined frame: the skin's vertices from the unrefined frame, the new
ones from the refinement engine (:class:`_RefinedSource`).
"""

from __future__ import annotations

from functools import cached_property
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from .equations import anisotropy
from .fieldviews import _PointFields
from .hierarchy import MuscleLevels
from .muscle import Muscle
from .refined import RefinedEngine

if TYPE_CHECKING:
    from .state import FaceState


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
        if self.old.any():  # (none: the unrefined frame has nothing to say)
            out[self.old] = self.root[key]
        return out


def _sorted_rows_of(ids: np.ndarray, vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~wrinkle_vis.core.fieldviews._rows_of` for ascending ``ids`` ``(r,)`` (a
    muscle's levels add the hierarchy's vertices in the order it builds them): a binary
    search, not a comparison with every row.
    """
    if not len(ids):
        return np.zeros(len(vertices), np.intp), np.zeros(len(vertices), bool)
    rows = np.minimum(np.searchsorted(ids, vertices), len(ids) - 1)
    return rows, ids.take(rows) == vertices


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

    @cached_property
    def _dyn_at(self):
        return self._engine.dynamic_at(self._root, *self._active)

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
                rows, found = _sorted_rows_of(lv.ids, self._order.take(vertices))
            self._points[key] = _RefinedAt(old, root, lv, rows[found], found, {})
        return self._points[key]

    def old_at(self, muscle: Muscle, vertices: np.ndarray) -> _PointFields | None:
        """The unrefined frame's fields at skin vertices ``vertices`` ``(k,)`` when all of
        them are its vertices (a pointwise field's values there are the unrefined frame's,
        which the refined frame takes as they are), else None.
        """
        at = self._at(muscle, vertices)
        return at.root if at.old.all() else None

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
                at.eps["eps"] = self._dyn_at.compression(at.levels, at.rows)
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
