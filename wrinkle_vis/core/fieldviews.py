"""The lazy field views of a :class:`~wrinkle_vis.core.face.FaceState`:
``state.fields[muscle][key]``, built on first access from the compact per-muscle
data (:class:`_MuscleFields`), or read at a few vertices without building the full
arrays (:class:`_PointFields`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from .equations import anisotropy
from .fields import FIELD_NAMES, FieldSpec, field_spec
from .muscle import Muscle

if TYPE_CHECKING:
    from .face import FaceModel
    from .refinedfields import _RefinedSource
    from .stacked import _StackedMuscles


@dataclass(frozen=True, eq=False)
class _StateData:
    """What the lazy field views of a state need (not the state: no reference cycle)."""

    face: FaceModel
    deformed_points: np.ndarray
    assembly: _StackedMuscles | None
    compact: dict[str, np.ndarray]  # the frame's eps (K,) and W (R,), stacked
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

    def __init__(self, state: _StateData, muscle: Muscle):
        self._state = state
        self._muscle = muscle
        self._cache: dict[str, np.ndarray] = {}
        self._dynamic: dict[str, np.ndarray] | None = None

    def __getitem__(self, key: str) -> np.ndarray:
        if key not in self._cache:
            spec = field_spec(key)  # KeyError lists the fields
            arr = _compute_field(spec, self)  # a copy: ours to freeze
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


def _compute_field(spec: FieldSpec, fields: Mapping[str, np.ndarray]) -> np.ndarray:
    """``spec.compute(fields)`` as a new float array (``(n,)`` on the whole skin, ``(k,)``
    at a few vertices).
    """
    compute = spec.compute
    if compute is None:  # FieldSpec sets or requires one: a spec made some other way
        raise ValueError(f"field {spec.key!r} has no compute(fields)")
    return np.array(compute(fields), dtype=float)


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
            source = self._state.source
            root = source.old_at(self._muscle, self._vertices) if source is not None else None
            if root is not None:  # the unrefined frame's vertices: its values, as they are
                return root[key].copy()
            arr = _compute_field(spec, self)
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
        if self._fields._dynamic is None and not self._active():
            return self._at_rest(key, where)
        return self._picked(where, lambda: self._fields.dynamic()[key])

    def _active(self) -> bool:
        """Whether the frame's stacked data hold the muscle (it acts in the frame)."""
        asm = self._state.assembly
        return asm is not None and self._muscle.name in asm.names

    def _at_rest(self, key: str, where: str) -> np.ndarray:
        r"""``(k,)``: :meth:`frame_value` of a muscle that does not act in the frame, from
        its compression at the vertices' AOI rows alone (:meth:`_MuscleData.compression_at`,
        not over its whole AOI): :math:`\varepsilon` or :math:`A(\varepsilon)`, or W = 0,
        on the vertices in its ``where``, ``nan`` elsewhere.
        """
        if key == "W":
            value = np.zeros(len(self._vertices))
        else:
            value = self._rest_eps if key == "eps" else anisotropy(self._rest_eps)
        out = np.full(len(self._vertices), np.nan)
        found = self._rows_in(where)[1]
        out[found] = value[found]
        return out

    @cached_property
    def _rest_eps(self) -> np.ndarray:
        """``(k,)``: the muscle's compression at the vertices in its AOI (``nan`` else)."""
        rows, found = self._rows_in("aoi")
        state = self._state
        eps = np.full(len(self._vertices), np.nan)
        eps[found] = state.face.muscle_data(self._muscle).compression_at(
            state.face.skin, state.deformed_points, rows[found])
        return eps

    def _picked(self, where: str, values) -> np.ndarray:
        """``(k,)``: compact ``values()`` (on the muscle's ``where``) at the vertices,
        ``nan`` at those outside it (``values`` is not called when all are).
        """
        rows, found = self._rows_in(where)
        out = np.full(len(self._vertices), np.nan)
        if found.any():
            out[found] = values()[rows[found]]
        return out


class _StateFields(Mapping):
    def __init__(self, state: _StateData):
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
