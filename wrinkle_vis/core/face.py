"""The face model: skin, skull and muscles, evaluated frame by frame (see :doc:`/model`).

:class:`FaceModel` holds the rest skin, the skull, the muscles and the expressions,
and evaluates frames; it is built from these modules:

- :mod:`~wrinkle_vis.core.muscledata`: what one muscle defines on the rest skin;
- :mod:`~wrinkle_vis.core.restgeometry`: the rest skin's normals, shape operators
  and refinement engines;
- :mod:`~wrinkle_vis.core.stacked`: the operators of a set of active muscles,
  stacked, and one frame computed with them;
- :mod:`~wrinkle_vis.core.state`: the evaluated frame, :class:`FaceState`;
- :mod:`~wrinkle_vis.core.fieldviews` and :mod:`~wrinkle_vis.core.refinedfields`:
  its lazy per-muscle fields.
"""

from __future__ import annotations

import dataclasses
from collections import OrderedDict
from collections.abc import Callable, Iterable, Iterator, Mapping
from typing import TYPE_CHECKING, NamedTuple, TypeAlias

import numpy as np

from .expressions import Expression, paper_expressions
from .fields import FIELD_NAMES
from .foldguard import FoldGuard, guarded
from .hierarchy import canonical_order
from .mesh import MeshError, TriangleSurface
from .muscle import Muscle, check_activation
from .muscledata import _MuscleData
from .refined import RefinedEngine
from .refinedfields import _RefinedSource
from .restgeometry import REFINE_CACHE_BYTES as REFINE_CACHE_BYTES
from .restgeometry import SLIDE_SCALE as SLIDE_SCALE
from .restgeometry import _RestGeometry
from .skin import SkinMaterial, SpringRest, SpringSkin, _Skull, check_skin_model, default_skin_model
from .stacked import _StackedMuscles
from .state import FaceState, _readonly
from .tracks import Track, TrackMapping, default_mapping, iter_activations
from .units import check_unit, physical_metres_per_unit

if TYPE_CHECKING:
    from .simulation import Simulation

__all__ = ["FIELD_NAMES", "FaceModel", "FaceState"]

#: What :meth:`FaceModel.evaluate` takes: an expression name, an :class:`Expression`, or
#: muscle name to activation.
Activations: TypeAlias = "str | Expression | Mapping[str, float]"
#: What :meth:`FaceModel.simulator` follows: activations (a step at t = 0) or a callable
#: ``t -> activations``.
Timeline: TypeAlias = "Activations | Callable[[float], Activations]"


class _SharedCaches(NamedTuple):
    """What a face shares with the faces derived from it (:meth:`FaceModel.with_muscle`
    and the like), all on the same rest skin.
    """

    muscle_data: dict[Muscle, _MuscleData]  # each muscle's rest data, by muscle
    stacked: OrderedDict | None  # the stacked operators of the latest active sets (None: new)
    rest: _RestGeometry  # the rest skin's normals, shape operators, refinement engines
    #: the physical skin's layout-free data: "contact" the skull contact, (material, metres
    #: per unit) its SpringRest (springs, factors, warm starts); None: new
    physical: dict | None = None


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
        :meth:`with_skin_model`); default (None) the skin's size policy,
        :func:`~wrinkle_vis.core.skin.default_skin_model`: the physical skin
        (:data:`~wrinkle_vis.core.skin.DEFAULT_SKIN_MODEL`) up to
        :data:`~wrinkle_vis.core.skin.PHYSICAL_DEFAULT_MAX_POINTS` vertices, the geometric
        one above.
    material : SkinMaterial, optional
        The physical skin's parameters (default :class:`SkinMaterial()`).

    Notes
    -----
    The model is immutable. :meth:`with_muscle` and :meth:`without_muscle` return a new
    model that shares the per-muscle caches of the unchanged muscles. One setting is not
    part of the model: :attr:`fold_guard` (default True), the default of :meth:`evaluate`'s
    ``fold_guard`` for this object (the command line's ``--fold-guard``): True for the
    default :class:`~wrinkle_vis.core.foldguard.FoldGuard`, False for none, or a
    :class:`~wrinkle_vis.core.foldguard.FoldGuard` (``FoldGuard(fans=True)``: ``--fold-guard
    fans``).
    """

    fold_guard: bool | FoldGuard = True

    def __init__(self, skin: TriangleSurface, skull: TriangleSurface | None = None,
                 muscles: Iterable[Muscle] = (),
                 expressions: Mapping[str, Expression] | None = None, *, name: str = "face",
                 landmarks: Mapping[str, Iterable[float]] | None = None, unit: str | None = None,
                 mapping: TrackMapping | None = None, skin_model: str | None = None,
                 material: SkinMaterial | None = None,
                 _caches: _SharedCaches | None = None) -> None:
        if not isinstance(skin, TriangleSurface):
            raise TypeError(f"skin must be a TriangleSurface; got {type(skin).__name__}")
        if skull is not None and not isinstance(skull, TriangleSurface):
            raise TypeError(f"skull must be a TriangleSurface or None; got {type(skull).__name__}")
        self.skin = skin
        self.skull = skull
        self.name = name
        self.unit: str | None = None if unit is None else check_unit(unit)
        self.skin_model: str = check_skin_model(
            default_skin_model(skin.n_points) if skin_model is None else skin_model)
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
            _caches = _SharedCaches({}, OrderedDict(), _RestGeometry(skin))
        self._muscle_data: dict[Muscle, _MuscleData] = _caches.muscle_data
        self._assemblies: OrderedDict = (OrderedDict() if _caches.stacked is None
                                         else _caches.stacked)
        self._rest: _RestGeometry = _caches.rest
        self._springs: dict[SkinMaterial, SpringSkin] = {}  # the physical skin, per material
        self._physical: dict = {} if _caches.physical is None else _caches.physical

    # ------------------------------------------------------------------ access
    @property
    def muscle_names(self) -> tuple[str, ...]:
        """Names of the muscles, in order."""
        return tuple(m.name for m in self.muscles)

    @property
    def rest_normals(self) -> np.ndarray:
        """``(n, 3)``: the unit normals the rest skin is shaded with: its vertex normals,
        and on a refined skin the Phong normals that carry the coarse skin's to the new
        vertices (:func:`~wrinkle_vis.core.mesh.phong_midpoints`).
        """
        return self._rest.normals

    @property
    def refined(self) -> bool:
        """Whether this is the refined skin of a frame (:meth:`evaluate` with ``refine``),
        whose :attr:`rest_normals` interpolate the coarse skin's.
        """
        return self._rest.interpolated

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

    def with_expressions(self, expressions: Mapping[str, Expression]) -> FaceModel:
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
                         material=self.material,
                         _caches=_SharedCaches(cache, None, self._rest, self._physical))

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

    def _assembly(self, names: tuple[str, ...]) -> _StackedMuscles:
        return _lru(self._assemblies, names, 32, lambda: _StackedMuscles.build(
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
        material. What does not depend on the muscle layout (springs, masses, skull
        contact, factorized matrices, warm starts: :class:`~wrinkle_vis.core.skin.SpringRest`)
        is shared with every face derived from this one, so a new layout (a muscle drag,
        :meth:`with_muscle`) builds only its zone springs, and factorizes nothing when its
        grip differs from the factorized layout's on few vertices.
        """
        material = material or self.material
        cache = self._springs
        skin = cache.get(material)
        if skin is None:
            if len(cache) > 2:
                cache.clear()
            skin = cache[material] = SpringSkin(self.skin, self.muscle_grip(), material,
                                                shared=self._spring_rest(material))
        return skin

    def _spring_rest(self, material: SkinMaterial) -> SpringRest:
        """The layout-free part of the physical skin for ``material``, shared by this face
        and every face derived from it (built on first use).
        """
        shared = self._physical
        key = (material, physical_metres_per_unit(self))
        rest = shared.get(key)
        if rest is None:
            for old in [k for k in shared if k != "contact"][:-2]:  # a few materials at most
                del shared[old]
            contact = None if self.skull is None else self._skull_contact()
            rest = shared[key] = SpringRest(self.skin, material, key[1], self.skull, contact)
        return rest

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

    def simulator(self, timeline: Timeline | None = None, *,
                  material: SkinMaterial | None = None) -> Simulation:
        """A :class:`~wrinkle_vis.core.simulation.Simulation` of the physically based skin
        for ``timeline`` (an expression name or activations: a step at t = 0; a callable
        ``t -> activations``), with ``step(dt)`` and ``reset()``.
        """
        from .simulation import Simulation

        return Simulation(self, timeline, material)

    def simulate(self, timeline: Timeline, duration: float, dt: float | None = None, *,
                 material: SkinMaterial | None = None, refine: bool = False,
                 refine_angle_deg: float = 3.0, refine_levels: int = 3
                 ) -> Iterator[FaceState]:
        """Yield the physically based skin's states over ``duration`` seconds, one every
        ``dt`` (default the material's ``time_step``), from rest at t = 0, for
        ``timeline`` (see :meth:`simulator`); each :class:`FaceState` has ``time`` and
        ``velocities``; with ``refine``, refined as :meth:`evaluate` does.
        """
        sim = self.simulator(timeline, material=material)
        for state in sim.run(duration, dt, guard=not refine):  # refined: guard the refined
            yield self._guarded_refined(state, refine_angle_deg, refine_levels) if refine \
                else state

    def expression_states(self, expression: Expression, times: Iterable[float],
                          intensity: float = 1.0, *, refine: bool = False,
                          refine_angle_deg: float = 3.0, refine_levels: int = 3
                          ) -> Iterator[FaceState]:
        """Yield the states of ``expression``'s timeline (onset, hold, release:
        :meth:`Expression.at`) at ``times`` (seconds, ascending), one at a time: on the
        geometric skin each evaluated on its own; on the physical skin (the face's
        :attr:`skin_model`) simulated from rest at t = 0, the timeline as the command, at
        the material's time step and landing on each time.
        """
        times = [float(t) for t in times]
        if any(b < a for a, b in zip(times, times[1:], strict=False)):
            raise ValueError("times must be ascending")
        if self.skin_model != "physical":
            for t in times:
                yield self.evaluate(expression.at(t, intensity), refine=refine,
                                    refine_angle_deg=refine_angle_deg,
                                    refine_levels=refine_levels)
            return
        sim = self.simulator(lambda t: expression.at(t, intensity))
        for t in times:
            sim.advance_to(t)  # the fields only at the times asked for
            state = sim.state(guard=not refine)
            yield (self._guarded_refined(state, refine_angle_deg, refine_levels)
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

    def _guarded_refined(self, state: FaceState, angle_deg: float, levels: int) -> FaceState:
        """A simulated state ``state`` (unguarded) refined and then guarded on its refined
        skin (the face's :attr:`fold_guard`), as :meth:`evaluate` guards a refined frame.
        """
        return self.guarded(self._refined_physical(state, angle_deg, levels), None)

    # ------------------------------------------------------------------ evaluation
    def activations_for(self, activations: Activations, intensity: float = 1.0
                        ) -> dict[str, float]:
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
        acts: Mapping[str, float]
        if isinstance(activations, Expression):
            acts = activations.scaled(intensity)
        elif isinstance(activations, Mapping):
            k = float(intensity)
            if not (0.0 <= k <= 1.0):
                raise ValueError(f"intensity = {k:g} is outside [0, 1]")
            acts = {m: check_activation(m, a) * k for m, a in activations.items()}
        else:
            raise TypeError("activations must be an expression name, an Expression or a "
                            f"mapping of muscle name to activation; got {type(activations)}")
        unknown = sorted(set(acts) - set(self.muscle_names))
        if unknown:
            raise KeyError(f"no muscle named {', '.join(map(repr, unknown))} in this face; its "
                           f"muscles are: {', '.join(self.muscle_names) or 'none'}")
        return {n: float(acts.get(n, 0.0)) for n in self.muscle_names}

    def evaluate(self, activations: Activations | None = None, intensity: float = 1.0, *,
                 refine: bool = False,
                 refine_angle_deg: float = 3.0, refine_levels: int = 3,
                 skin: str | None = None, material: SkinMaterial | None = None,
                 fold_guard: bool | FoldGuard | None = None,
                 warm_start: bool = False) -> FaceState:
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
        fold_guard : bool or FoldGuard, optional
            Default: the face's :attr:`fold_guard` (True; a
            :class:`~wrinkle_vis.core.foldguard.FoldGuard`: that guard's parameters, e.g.
            ``FoldGuard(fans=True)``). Keep the skin from passing
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
        warm_start : bool, default False
            Physical skin: start the still frame's solve from the latest still frame of the
            same activations on any layout of this face (a muscle being dragged: a few
            iterations instead of 25-30). Such a frame agrees with a cold one to the solver's
            tolerance (about :math:`1.5 \cdot 10^{-5}` of the face's size), not bit for
            bit; without it every frame starts from the rest skin, so a frame does not depend
            on which frames were asked for before (exports, sweeps, tests compare bit for
            bit).

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
            x = springs.equilibrium(pull, warm=tuple(acts.items()), start_warm=warm_start)
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

    def guarded(self, state: FaceState, fold_guard: bool | FoldGuard | None = None
                ) -> FaceState:
        """``state`` through the fold guard (:func:`~wrinkle_vis.core.foldguard.guarded`)
        when ``fold_guard`` (None: the face's :attr:`fold_guard`) says so, on either skin
        (a :class:`~wrinkle_vis.core.foldguard.FoldGuard`: with its parameters).
        """
        on = self.fold_guard if fold_guard is None else fold_guard
        if not on:
            return state
        solved = state.deformed_points  # on the physical skin: out of the skull already
        state = guarded(self, state, on if isinstance(on, FoldGuard) else FoldGuard())
        if (state.deformed_points is not solved and state.skin_model == "physical"
                and state.face is self and self.skull is not None):
            _keep_out_of_skull(self._skull_contact(), state)
        return state

    def _skull_contact(self) -> _Skull:
        """The skull contact of the physical skin (:class:`~wrinkle_vis.core.skin._Skull`),
        built once and shared with every face derived from this one (it depends on the
        rest skin and the skull only).
        """
        contact = self._physical.get("contact")
        if contact is None:
            assert self.skull is not None
            contact = self._physical["contact"] = _Skull(self.skull, self.skin.points)
        return contact

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

    def _refined_face(self, engine: RefinedEngine, split: np.ndarray, split_ids: np.ndarray,
                      tris: np.ndarray) -> tuple[FaceModel, np.ndarray]:
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
        rest = _RestGeometry(surface, np.take(hier.normal, order, axis=0), self._rest.radius)
        rest.slide_normals = np.take(hier.slide, order, axis=0)
        rest.shape6 = np.take(hier.shape6, order, axis=0)
        rest.refined_from = (hier, order)  # its rows of the hierarchy (the fold guard's)
        face = FaceModel(surface, self.skull, self.muscles, self.expressions, name=self.name,
                         landmarks=self.landmarks, unit=self.unit,
                         _caches=_SharedCaches({}, None, rest))
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


def _renamed(expression: Expression, old: str, new: str | None) -> Expression:
    """``expression`` with muscle ``old`` called ``new`` (None: dropped)."""
    if old not in expression.activations:
        return expression
    acts: dict[str, float] = {}
    for k, v in expression.activations.items():
        if k != old:
            acts[k] = v
        elif new is not None:
            acts[new] = v  # in the old one's place
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


def _keep_out_of_skull(contact: _Skull, state: FaceState) -> None:
    r"""Put the vertices of a guarded physical frame ``state`` that the pull guard's
    scaling took into the skull back on it (:meth:`~wrinkle_vis.core.skin._Skull.project`,
    as the simulation's every step does), in place: ``deformed_points`` and ``points``
    (the wrinkled skin, :math:`x + W n`) move by the same amount there.

    The guard scales a vertex's displacement, :math:`x = r + s\,u` with :math:`s < 1`;
    from a vertex the skin's solve left on the skull's surface that can end a few
    nanometres inside a concave skull.
    """
    deformed = np.array(state.deformed_points)
    moved = contact.project(deformed)
    if not len(moved):
        return
    points = np.array(state.points)
    points[moved] += deformed[moved] - state.deformed_points[moved]
    for name, value in (("deformed_points", deformed), ("points", points)):
        value.setflags(write=False)
        setattr(state, name, value)
