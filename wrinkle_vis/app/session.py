"""The app's model: what the user is looking at, with no Qt in it (tested on its own)."""

from __future__ import annotations

import dataclasses
import hashlib
import os
import stat
import time
import weakref
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.editing import mirror_name, mirrored, snapped, unique_name
from ..core.expressions import Expression
from ..core.face import FIELD_NAMES, FaceModel, FaceState
from ..core.fields import FRAME_FIELDS, check_field, field_spec
from ..core.layout import Layout, load_layout, save_layout
from ..core.muscle import Muscle
from ..core.params import Parameter
from ..core.registry import get_muscle_type
from ..core.skin import SkinMaterial, default_skin_model
from ..core.tracks import Performance, default_mapping
from ..core.units import face_unit
from ..plotting.fields import field_info, field_range
from .physics import PhysicalPlayback

__all__ = ["OPTIONS", "TIMELINE_STEPS", "FileStamp", "Session", "SurfacePoint", "editable",
           "load_session",
           "playback_position"]

#: Steps of the app's timeline: positions 0 to this many span the expression's duration.
TIMELINE_STEPS = 300

def editable(muscle) -> tuple[Parameter, ...]:
    """The numeric parameters the parameter panel edits for ``muscle`` (a muscle or its
    type), with their metadata (label, symbol, unit, range, step): every number its type
    declares (:meth:`~wrinkle_vis.core.muscle.Muscle.parameters`), so a plug-in type gets
    its controls with no change to the app.
    """
    return tuple(p for p in muscle.parameters() if p.is_number)


#: The options every muscle type has (:meth:`wrinkle_vis.core.muscle.Muscle.options`, off
#: by default), as the parameter panel shows them: (name, label, choices), with choices None
#: for a check box, else ``{value: text}`` for a combo box in the core's order; all from
#: the options' declared metadata.
OPTIONS = tuple((p.name, p.label, None if p.is_flag else p.labelled_choices)
                for p in Muscle.options())


@dataclasses.dataclass(frozen=True)
class FileStamp:
    """What a file was when the app read or wrote it: its modification time (ns), its size
    in bytes and the SHA-256 of its bytes, to tell whether another program changed it since
    (:meth:`change`), as editors do.
    """

    mtime_ns: int
    size: int
    sha256: str

    @classmethod
    def of(cls, path: str | os.PathLike) -> FileStamp | None:
        """The stamp of the file at ``path`` now; None when there is no file there or it
        cannot be read.
        """
        try:
            if not stat.S_ISREG(os.stat(path).st_mode):  # a FIFO would block the open
                return None
            with open(path, "rb") as fh:
                st = os.fstat(fh.fileno())
                digest = hashlib.file_digest(fh, "sha256").hexdigest()
        except OSError:
            return None
        return cls(st.st_mtime_ns, st.st_size, digest)

    def change(self, path: str | os.PathLike) -> str | None:
        """How the file at ``path`` differs from this stamp: None (the same bytes, whatever
        its time), ``"deleted"`` (no file there) or ``"changed"`` (other bytes, or a file
        that cannot be read any more). A file of another size is changed without reading it.
        """
        try:
            st = os.stat(path)
        except FileNotFoundError:
            return "deleted"
        except OSError:
            return "changed"
        if st.st_size != self.size:
            return "changed"
        now = FileStamp.of(path)  # the bytes decide: a time can repeat, or be set back
        return None if now is not None and now.sha256 == self.sha256 else "changed"


class Session:
    """The face, the expression and time, the field on display, and the open layout file.

    The session holds its layout in memory: the file is read once (here, unless ``layout``
    is given) and only written after that, so a file deleted, truncated or replaced on disk
    while the user works changes nothing in the session. It remembers what the file was
    (:attr:`disk`, a :class:`FileStamp`) when it was read or last saved, so that the app
    can ask before Save overwrites a change another program made (:meth:`disk_change`).

    Parameters
    ----------
    face : FaceModel
        The face to show.
    layout_path : path, optional
        The file the face's layout came from (where Save writes).
    layout : Layout, optional
        That file's layout, already read (default: read ``layout_path`` now, or an empty
        layout for the built-in face).
    folder : path, optional
        Where the layout's relative mesh paths start (default: ``layout_path``'s folder).
    disk : FileStamp, optional
        What ``layout_path`` was when ``layout`` was read from it (default: the file as it
        is now; taken before reading when the session reads it itself).
    """

    def __init__(self, face: FaceModel, layout_path: str | Path | None = None, *,
                 layout: Layout | None = None, folder: str | Path | None = None,
                 disk: FileStamp | None = ...):
        self.face = face
        self.layout_path = Path(layout_path) if layout_path else None
        if disk is ...:  # stamped before reading: a change in between is seen, not missed
            disk = FileStamp.of(self.layout_path) if self.layout_path else None
        self.disk: FileStamp | None = disk  # the file as read or last saved (None: unknown)
        if layout is None and self.layout_path is not None:
            layout = load_layout(self.layout_path)  # the only read of the file
        self._layout = layout if layout is not None else Layout()
        self.folder = Path(folder) if folder else (
            self.layout_path.parent if self.layout_path else None)
        self.expression = "surprise" if "surprise" in face.expressions else next(
            iter(face.expressions))
        self.intensity = 1.0
        self.time_s: float | None = None  # None: the expression at its peak
        self.field = "W"
        self.muscle: str | None = None  # None: the total
        self.refine = False  # adaptive refinement (paper Fig. 11)
        # a muscle is being dragged: physical still frames start from the last one
        # (FaceModel.evaluate's warm_start); the drag's last frame is solved from rest again
        self.dragging = False
        self.overrides: dict[str, float] = {}  # activations set by hand, over the expression
        self.dirty = False
        self.frame_ms = 0.0  # how long the last evaluation took
        self.performance: Performance | None = None  # a recorded track, shown by its name
        self._state: FaceState | None = None
        # the probed point's muscles and rest-skin fields (:meth:`_probe_rest`)
        self._probe_memo: tuple | None = None
        self._above_memo: tuple | None = None
        self._located_memo: tuple | None = None  # a refined skin's triangle at the point
        # Play on the physical skin: the simulation (:mod:`wrinkle_vis.app.physics`)
        self.physics = PhysicalPlayback(self.activations_at,
                                        lambda: self.current_expression().duration_s)

    # ------------------------------------------------------------------ what to show
    def activations(self) -> dict[str, float]:
        """The activations of the current expression, intensity and time, with the ones set
        by hand (:meth:`set_activation`) in their place.
        """
        return self.activations_at(self.time_s)

    def activations_at(self, t: float | None) -> dict[str, float]:
        """:meth:`activations` at time ``t`` of the timeline (None: the peak)."""
        return {**self._expression_at(t), **self.overrides}

    def _expression_at(self, t: float | None) -> dict[str, float]:
        """The current expression's activations at ``t`` (None: its peak), intensity
        applied; a muscle removed since a performance's import drives nothing.
        """
        ex = self.current_expression()
        acts = ex.scaled(self.intensity) if t is None else ex.at(t, self.intensity)
        if ex is self.performance:
            acts = {m: a for m, a in acts.items() if m in self.face.muscle_names}
        return acts

    def current_expression(self) -> Expression:
        """The expression shown: the face's, or the imported performance
        (:meth:`set_performance`) when it is the one selected.
        """
        if self.performance is not None and self.expression == self.performance.name:
            return self.performance
        return self.face.expressions[self.expression]

    def set_performance(self, performance: Performance) -> None:
        """Show a recorded track (:func:`~wrinkle_vis.core.tracks.performance`) from its
        first frame; it is not part of the layout (saving leaves it out).
        """
        self.performance = performance
        self.expression = performance.name
        self.time_s = 0.0
        self.overrides.clear()
        self._command_changed()

    def set_activation(self, muscle: str, value: float | None) -> None:
        """Set one muscle's activation by hand (None: back to the expression's)."""
        self.face.muscle(muscle)
        if value is None:
            self.overrides.pop(muscle, None)
        else:
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"activation of {muscle!r} = {value:g} is outside [0, 1]")
            self.overrides[muscle] = float(value)
        self._command_changed()

    def state(self) -> FaceState:
        """The evaluated frame (cached until something changes)."""
        if self._state is None:
            t0 = time.perf_counter()
            if self.simulating:  # refined: guarded on the refined skin, as face.simulate
                state = self.physics.state(guard=not self.refine)
                self._state = self.face._guarded_refined(state, 3.0, 3) if self.refine \
                    else state
            else:  # a still frame: on the physical skin, the equilibrium
                self._state = self.face.evaluate(self.activations(), refine=self.refine,
                                                 warm_start=self.dragging)
            self.frame_ms = 1e3 * (time.perf_counter() - t0)
        return self._state

    def _changed(self) -> None:
        self._state = None

    def _command_changed(self) -> None:
        """The face, expression, intensity or hand-set activations changed: a running
        simulation follows (:meth:`PhysicalPlayback.follow`).
        """
        self.physics.follow(self.face)
        self._changed()

    # ------------------------------------------------------------------ physical skin
    @property
    def simulating(self) -> bool:
        """Whether the frame shown is the physical skin's running simulation (playing or
        paused) rather than a still frame.
        """
        return self.physics.live and self.face.skin_model == "physical"

    def _timeline_time(self) -> float:
        """The timeline's time shown, in seconds (the peak's when :attr:`time_s` is None)."""
        if self.time_s is not None:
            return self.time_s
        ex = self.current_expression()
        return ex.onset_s + 0.5 * ex.hold_s if ex is not self.performance else 0.0

    def play(self, now: float) -> None:
        """Play on the physical skin from wall-clock time ``now`` (seconds): the running
        simulation goes on, else one starts at the timeline's time.
        """
        self.physics.play(self.face, self._timeline_time(), now)
        self.time_s = self.physics.time
        self._changed()

    def pause(self) -> None:
        """Pause the physical skin's simulation (its state stays on display)."""
        self.physics.pause()

    def tick(self, now: float) -> bool:
        """Advance the playing simulation to wall-clock ``now``
        (:meth:`PhysicalPlayback.tick`); returns whether the frame changed.
        """
        moved = self.physics.tick(now)
        if moved:
            self.time_s = self.physics.time
            self._changed()
        return moved

    def reset_simulation(self) -> None:
        """The physical skin back to rest at :math:`t = 0` (a simulation, shown)."""
        self.physics.reset(self.face)
        self.time_s = 0.0
        self._changed()

    def set_skin_model(self, skin_model: str) -> None:
        """Evaluate the face with ``skin_model`` (an edit of the layout)."""
        self.set_face(self.with_skin_model(skin_model))
        self.dirty = True

    def with_skin_model(self, skin_model: str) -> FaceModel:
        """The face with ``skin_model`` (``"geometric"`` or ``"physical"``; raises
        otherwise), its material kept.
        """
        return self.face.with_skin_model(skin_model)

    def with_material(self, param: str, value) -> FaceModel:
        """The face with one parameter of the physical skin's material changed (raises
        ``ValueError`` with the reason if invalid).
        """
        return self.face.with_skin_model(
            self.face.skin_model, dataclasses.replace(self.face.material, **{param: value}))

    def set_expression(self, name: str) -> None:
        """Show expression ``name`` (``KeyError`` lists the face's expressions)."""
        if name not in self.face.expressions and not (
                self.performance is not None and name == self.performance.name):
            raise KeyError(f"unknown expression {name!r}; this face has: "
                           f"{', '.join(self.face.expressions)}")
        self.expression = name
        self.overrides.clear()
        self._command_changed()

    def set_intensity(self, value: float) -> None:
        """Scale every activation by ``value`` in ``[0, 1]``."""
        if not 0.0 <= value <= 1.0:
            raise ValueError(f"intensity = {value:g} is outside [0, 1]")
        self.intensity = float(value)
        self._command_changed()

    def set_time(self, t: float | None) -> None:
        """Show the expression's ramp at ``t`` seconds (None: at its peak); a running
        simulation of the physical skin is re-simulated to it (a scrub,
        :meth:`PhysicalPlayback.scrub`).
        """
        self.time_s = None if t is None else float(t)
        if self.simulating:
            self.physics.scrub(self.face, self._timeline_time())
        self._changed()

    def set_refine(self, on: bool) -> None:
        """Switch adaptive refinement on or off."""
        self.refine = bool(on)
        self._changed()

    def set_field(self, field: str, muscle: str | None = None) -> None:
        """Show ``field`` of ``muscle`` (None: the total, which only W has)."""
        check_field(field, muscle)  # only W has a total
        if muscle is not None:
            self.face.muscle(muscle)
        self.field, self.muscle = field, muscle

    @property
    def unit(self) -> str:
        """The unit of the face's lengths (:func:`~wrinkle_vis.core.units.face_unit`)."""
        return face_unit(self.face)

    def field_values(self, state: FaceState | None = None) -> np.ndarray:
        """``(n,)``: the field on display in ``state`` (default :meth:`state`)."""
        state = self.state() if state is None else state
        return state.field_values(self.field, self.muscle)

    def undersampled_note(self, state: FaceState | None = None) -> str | None:
        """One line (as the command line warns) when the muscles at work in ``state``
        (default :attr:`state`) have wrinkles the skin cannot resolve, else None; None for
        a refined frame, whose refinement resolves them.
        """
        from ..core.sampling import undersampled_line, undersampled_muscles

        state = self.state() if state is None else state
        if state.face.skin is not self.face.skin:
            return None
        active = [m for m in self.face.muscles if state.activations.get(m.name, 0.0) > 0.0]
        return undersampled_line(undersampled_muscles(self.face.skin, active))

    def colour_range(self, state: FaceState | None = None) -> tuple[float, float]:
        """The frame's own colour range of the field on display
        (:func:`~wrinkle_vis.plotting.field_range`; a fixed one is the display's,
        :class:`~wrinkle_vis.app.models.DisplayOptions`).
        """
        return field_range(field_info(self.field), self.field_values(state))

    def ramp_range(self, samples: int = 9) -> tuple[float, float]:
        """The colour range that holds the field over the whole ramp of the expression (at
        the current intensity, without refinement): the union of ``samples`` frames of the
        onset and the peak. The release mirrors the onset.
        """
        info = field_info(self.field)
        if info.limits is not None:
            return info.limits
        ex = self.current_expression()
        lo, hi = np.inf, -np.inf
        times = (*np.linspace(0.0, ex.onset_s, samples)[1:], ex.onset_s + 0.5 * ex.hold_s)
        if ex is self.performance:  # a track has no onset: sample it all
            times = np.linspace(0.0, ex.duration_s, 2 * samples)
        for t in times:
            acts = {**self._expression_at(float(t)), **self.overrides}
            state = self.face.evaluate(acts)
            a, b = field_range(info, self.field_values(state))
            lo, hi = min(lo, a), max(hi, b)
        return (lo, hi)

    # ------------------------------------------------------------------ editing
    # The ``*ed`` methods build the edited face and change nothing, so that the app can
    # wrap each edit in an undoable command; :meth:`set_face` shows one.
    def set_face(self, face: FaceModel) -> None:
        """Show another version of the face (an edit, an undo or a redo)."""
        self.face = face
        if self.muscle is not None and self.muscle not in face.muscle_names:
            self.muscle, self.field = None, "W"
        self.overrides = {k: v for k, v in self.overrides.items() if k in face.muscle_names}
        if self.performance is not None:  # an edited mapping plays the track anew
            self.performance = self.performance.remapped(face.mapping or default_mapping())
        self._command_changed()

    def set_parameter(self, muscle: str, param: str, value) -> None:
        """Change one parameter of a muscle; an invalid value raises and changes nothing."""
        self.set_face(self.with_parameter(muscle, param, value))
        self.dirty = True

    def with_parameter(self, muscle: str, param: str, value) -> FaceModel:
        """The face with one parameter of a muscle changed (raises if invalid)."""
        return self.face.with_muscle(self.face.muscle(muscle).replace(**{param: value}))

    def with_activation(self, muscle: str, value: float) -> FaceModel:
        """The face with ``muscle``'s peak activation in the current expression set to
        ``value`` in ``[0, 1]`` (0 takes it out): an edit of the layout, so a muscle can
        join an expression or leave it.
        """
        self.face.muscle(muscle)
        if self.current_expression() is self.performance:
            raise ValueError(f"{self.expression!r} is a recorded track: its activations come "
                             "from the track and the mapping; choose an expression to edit")
        ex = self.face.expressions[self.expression]
        acts = dict(ex.activations)
        if value:
            acts[muscle] = float(value)
        else:
            acts.pop(muscle, None)
        new = dataclasses.replace(ex, activations=acts)  # validates [0, 1]
        return self.face.with_expressions({**self.face.expressions, self.expression: new})

    def renamed(self, muscle: str, new_name: str) -> FaceModel:
        """The face with ``muscle`` called ``new_name`` (in the expressions too)."""
        new_name = new_name.strip()
        if not new_name:
            raise ValueError("a muscle's name cannot be empty")
        return self.face.with_muscle(self.face.muscle(muscle).replace(name=new_name), muscle)

    def deleted(self, muscle: str) -> FaceModel:
        """The face without ``muscle`` (and without it in the expressions)."""
        return self.face.without_muscle(muscle)

    def duplicated(self, muscle: str) -> tuple[FaceModel, str]:
        """The face with a copy of ``muscle`` under a free name, taking the original's
        activation in every expression; returns it and the name.
        """
        name = unique_name(f"{muscle}_copy", self.face.muscle_names)
        face = self.face.with_muscle(self.face.muscle(muscle).replace(name=name))
        return _sharing_activations(face, muscle, name), name

    def mirrored(self, muscle: str) -> tuple[FaceModel, str]:
        """The face with the twin of ``muscle`` across its symmetry plane, its points snapped
        onto their surfaces; the twin replaces a muscle of its name (``_L`` <-> ``_R``) or is
        added, taking the original's activation in every expression. A muscle whose name
        has no side is renamed for the side it lies on (``X`` to ``X_L`` on the subject's
        left) and its twin named for the other (``X_R``). Returns the face and the twin's
        name.
        """
        face, muscle = self._sided(muscle)
        twin = _mirror_image(face, muscle)
        new = twin.name not in face.muscle_names
        face = face.with_muscle(twin)
        if new:
            face = _sharing_activations(face, muscle, twin.name)
        return face, twin.name

    def _sided(self, muscle: str) -> tuple[FaceModel, str]:
        """The face with ``muscle`` renamed for its side when its name has none
        (:func:`~wrinkle_vis.core.editing.mirror_name` would add ``_mirrored``), and the
        name it has there.
        """
        if mirror_name(muscle) != muscle + "_mirrored":
            return self.face, muscle
        point, normal = self.face.symmetry_plane()
        m = self.face.muscle(muscle)
        points = np.vstack([np.asarray(getattr(m, p), float).reshape(-1, 3)
                            for p in m.point_parameters] or [np.zeros((1, 3))])
        side = "_L" if float(np.mean((points - point) @ normal)) >= 0 else "_R"
        taken = set(self.face.muscle_names) - {muscle}
        if f"{muscle}{side}" in taken or mirror_name(f"{muscle}{side}") in taken:
            return self.face, muscle  # the sided names are taken: keep X_mirrored
        return self.face.with_muscle(m.replace(name=f"{muscle}{side}"), muscle), \
            f"{muscle}{side}"

    def same_muscles(self, face: FaceModel) -> bool:
        """Whether ``face`` has this session's muscles, parameters equal and points within
        2 % of the skin's median edge length: an edit that changes nothing one could see,
        e.g. mirroring a pair that is already symmetric (snapped onto a skin that is not
        quite, the points move by about 1 % of an edge each time).
        """
        if face.muscle_names != self.face.muscle_names:
            return False
        tol = 0.02 * float(np.median(self.face.skin.rest_edge_lengths))
        for a, b in zip(self.face.muscles, face.muscles, strict=True):
            if type(a) is not type(b):
                return False
            for f in dataclasses.fields(a):
                x, y = getattr(a, f.name), getattr(b, f.name)
                if f.name in a.point_parameters:
                    if not np.allclose(np.asarray(x, float), np.asarray(y, float), rtol=0,
                                       atol=tol):
                        return False
                elif not _equal(x, y):
                    return False
        return face.expressions == self.face.expressions

    def twin_of(self, muscle: str) -> str | None:
        """The name of ``muscle``'s twin across the symmetry plane (``_L`` <-> ``_R``,
        ``left`` <-> ``right``) when the face has it, else None.
        """
        twin = mirror_name(muscle)
        return twin if twin != muscle and twin in self.face.muscle_names else None

    def mirrored_pair(self, muscle: str) -> tuple[FaceModel, str]:
        """The face with ``muscle`` and its twin both mirrored across the symmetry plane:
        each side takes the mirror image of the other (snapped onto its surfaces) and keeps
        its own activations. Returns the face and the twin's name; raises ValueError when
        the muscle has no twin (use :meth:`mirrored` to make one).
        """
        twin = self.twin_of(muscle)
        if twin is None:
            raise ValueError(
                f"muscle {muscle!r} has no twin {mirror_name(muscle)!r} on the face; "
                "Mirror (Ctrl+M) makes one")
        face = self.face.with_muscle(self._mirror_image(twin, name=muscle))
        return face.with_muscle(self._mirror_image(muscle, name=twin)), twin

    def _mirror_image(self, muscle: str, name: str | None = None):
        """``muscle`` reflected across the face's symmetry plane and snapped onto its
        surfaces, called ``name`` (default its twin's name).
        """
        return _mirror_image(self.face, muscle, name)

    def added(self, type_name: str, at) -> tuple[FaceModel, str]:
        """The face with a new muscle of type ``type_name``, its insertion on the skin at
        ``at`` ``(3,)``, made by the type itself (:meth:`Muscle.create`) in the face's unit
        (:func:`~wrinkle_vis.core.editing.created`).
        """
        from ..core.editing import created

        cls = get_muscle_type(type_name)
        name = unique_name(f"{type_name}_1", self.face.muscle_names)
        return self.face.with_muscle(created(cls, name, self.face, at)), name

    def derived(self, muscle: str) -> dict[str, float]:
        """The muscle's derived d (Eq. 8) and u (Eq. 6)."""
        m = self.face.muscle(muscle)
        return {"d": m.d, "u": m.u}

    # ------------------------------------------------------------------ probe
    def surface_point(self, point, triangle: int | None = None) -> SurfacePoint:
        """The rest-skin point under ``point`` ``(3,)`` of the frame shown (its final skin,
        as drawn): in its ``triangle`` of :meth:`state` when known (a pick names it), else
        at the closest point of that skin; carried to the rest skin by its barycentric
        coordinates and there onto :attr:`face`'s own (unrefined) skin.
        """
        from ..core.mesh import barycentric_points, closest_on_triangles, surface_coordinates

        state = self.state()
        point = np.asarray(point, float).reshape(1, 3)
        shown = state.surface()
        if triangle is None or not 0 <= triangle < len(state.triangles):
            tri, bary = surface_coordinates(shown, point)
        else:
            t, b = closest_on_triangles(shown, [triangle], point[0])
            tri, bary = np.array([t]), b[None]
        rest = barycentric_points(state.face.skin, tri, bary)
        base = self.face.skin
        if state.face.skin is not base:  # a refined frame: onto the skin's own triangles
            tri, bary = surface_coordinates(base, rest)
        return SurfacePoint(int(tri[0]), tuple(float(b) for b in bary[0]))

    def vertex_point(self, vertex: int) -> SurfacePoint:
        """Skin vertex ``vertex`` of :attr:`face` as a :class:`SurfacePoint`."""
        skin = self.face.skin
        if not 0 <= vertex < skin.n_points:
            raise IndexError(f"vertex {vertex} is not on the skin (0..{skin.n_points - 1})")
        tri, corner = np.argwhere(skin.triangles == vertex)[0]
        bary = [0.0, 0.0, 0.0]
        bary[corner] = 1.0
        return SurfacePoint(int(tri), tuple(bary))

    def _located(self, where: SurfacePoint) -> tuple[FaceState, np.ndarray, np.ndarray]:
        """The frame shown, and the vertices ``(3,)`` and weights ``(3,)`` of its triangle
        that holds ``where``: on the skin's own frame its triangle and coordinates; on a
        refined frame (whose vertices and numbering change with each evaluation) the
        closest point of its rest skin to ``where``'s rest position.
        """
        from ..core.mesh import closest_on_triangles, ray_on_triangles

        state, base = self.state(), self.face.skin
        if not 0 <= where.triangle < base.n_triangles:
            raise IndexError(f"triangle {where.triangle} is not on the skin "
                             f"(0..{base.n_triangles - 1})")
        bary = np.asarray(where.barycentric, float)
        if state.face.skin is base:
            return state, base.triangles[where.triangle], bary
        # a refined frame: its triangles over the base triangle, bent onto the smooth rest
        # surface; the point is the one straight above (or below) ``where`` along the base
        # triangle's normal, as :meth:`surface_point` projects it back down
        # found once for the refinement's skin: the frames of one split set share it (the
        # probe's values and its position ask for it both)
        memo, skin = self._located_memo, state.face.skin
        if memo is not None and memo[0]() is skin and memo[1] == where:
            return state, *memo[2]
        rest, normal, reach = self._above(where)
        candidates = _triangles_near(skin.points, skin.triangles, rest, reach)
        found = ray_on_triangles(skin, candidates, rest, normal)
        tri, weights = found if found is not None else closest_on_triangles(
            skin, candidates, rest)
        self._located_memo = (weakref.ref(skin), where, (skin.triangles[tri], weights))
        return state, skin.triangles[tri], weights

    def _above(self, where: SurfacePoint) -> tuple[np.ndarray, np.ndarray, float]:
        """Where ``where`` is on the skin at rest ``(3,)``, its triangle's normal ``(3,)``
        (not normalized) and how far a refined frame's triangles over it may reach (twice
        its largest distance from a corner to the middle), kept for the face and point.
        """
        from ..core.mesh import barycentric_points

        memo = self._above_memo
        if memo is not None and memo[0] is self.face and memo[1] == where:
            return memo[2]
        base = self.face.skin
        rest = barycentric_points(base, [where.triangle],
                                  np.asarray(where.barycentric, float)[None])[0]
        corners = base.points[base.triangles[where.triangle]]
        reach = 2.0 * float(np.linalg.norm(corners - corners.mean(axis=0), axis=1).max())
        normal = np.cross(corners[1] - corners[0], corners[2] - corners[0])
        self._above_memo = (self.face, where, (rest, normal, reach))
        return rest, normal, reach

    def probe(self, where: SurfacePoint | int) -> dict:
        r"""Every field's value in the frame shown at rest-skin point ``where`` (or at skin
        vertex ``where``): ``{"total": {"W": .., "fold_guard": ..}, muscle: {field: ..}}``
        (the totals: W and the frame's fields) for the muscles
        that define anything there (NaN where one does not define a field).

        The values are the frame's, interpolated linearly in the triangle of the frame's
        skin that holds the point, as the skin view draws them: with weights :math:`b_k`
        on its corners, :math:`v = \sum_k b_k v_k / \sum_k b_k` over the corners where the
        field is defined, undefined when it is not at the nearest corner. At a vertex these
        are its values exactly. The point stays where it is on the rest skin whatever the
        frame (an expression, an edit, the refinement, whose vertices change each frame).
        """
        if not isinstance(where, SurfacePoint):
            where = self.vertex_point(int(where))
        state, corners, weights = self._located(where)
        interpolated = _Interpolated(weights)
        out = {"total": {"W": interpolated(state.W[corners]),
                         **{k: interpolated(np.asarray(state.field_values(k))[corners])
                            for k in FRAME_FIELDS}}}
        for name, kept in self._probe_rest(state, corners, weights).items():
            at = state.fields[name].at(corners)  # from the compact per-muscle data
            values = {f: kept[f] if f in kept else interpolated(at[f]) for f in FIELD_NAMES}
            if any(np.isfinite(v) for v in values.values()):
                out[name] = values
        return out

    def _probe_rest(self, state: FaceState, corners: np.ndarray, weights: np.ndarray
                    ) -> dict[str, dict[str, float]]:
        """The muscles whose AOI holds one of the probed point's ``corners`` ``(3,)`` (the
        others have no value there), each with its fields that depend on the rest skin
        alone (:attr:`~wrinkle_vis.core.fields.FieldSpec.rest`) at the point: read from
        the compact per-muscle data (:meth:`FaceState.values_at`) once, then kept while
        the face, the corners' rest positions and the weights stay the same (Play moves
        the frame, not the point; a refined frame renumbers its vertices, so the corners
        are known by where they are at rest).
        """
        rest = state.face.skin.points[corners]
        key = (rest.tobytes(), weights.tobytes(), tuple(FIELD_NAMES))
        memo = self._probe_memo
        if memo is not None and memo[0] is self.face and memo[1] == key:
            return memo[2]
        at = state.values_at(corners)
        static = [f for f in FIELD_NAMES if field_spec(f).rest]
        interpolated = _Interpolated(weights)
        kept = {name: {f: interpolated(at[name][f]) for f in static}
                for name in self.face.muscle_names if name in at}
        self._probe_memo = (self.face, key, kept)
        return kept

    def probe_position(self, where: SurfacePoint | int) -> tuple[np.ndarray, np.ndarray]:
        """``((3,), (3,))``: rest-skin point ``where`` at rest and in the frame shown (its
        final skin, wrinkles included), in the face's unit.
        """
        if not isinstance(where, SurfacePoint):
            where = self.vertex_point(int(where))
        state, corners, weights = self._located(where)
        rest = weights @ state.face.skin.points[corners]
        return rest, weights @ state.points[corners]

    # ------------------------------------------------------------------ files
    @property
    def base_layout(self) -> Layout:
        """The layout as read or last saved (where its skin comes from, which built-in face,
        its unit), without the current edits: cheap, unlike :meth:`layout`, which builds
        the current one.
        """
        return self._layout

    def layout(self, folder: str | Path | None = ...) -> Layout:
        """The current muscles and expressions as a :class:`Layout`, from the layout held
        in memory (the file is not read again). ``folder``: where its relative mesh paths
        should start (default: where they start now; None: absolute paths).
        """
        base = self._layout
        procedural = base.skin is None and base.face in (None, "procedural")
        extra = {"n_triangles": self.face.skin.n_triangles} if procedural else {}
        layout = dataclasses.replace(base, name=self.face.name, muscles=self.face.muscles,
                                     expressions=self.face.expressions,
                                     landmarks=self.face.landmarks or base.landmarks,
                                     unit=self.face.unit or base.unit, **extra,
                                     mapping=self.face.mapping,
                                     **self._skin_record(base))
        return layout if folder is ... else self._relocated(layout, folder)

    def _skin_record(self, base: Layout) -> dict:
        """The layout's ``skin_model`` (left out, None, for a face on its default skin model,
        :func:`~wrinkle_vis.core.skin.default_skin_model`, whose layout recorded none) and
        ``skin_material`` (the parameters that differ from their defaults).
        """
        model = self.face.skin_model
        default = SkinMaterial()
        material = {p.name: getattr(self.face.material, p.name)
                    for p in SkinMaterial.parameters()
                    if getattr(self.face.material, p.name) != getattr(default, p.name)}
        keep = model == default_skin_model(self.face.skin.n_points) and base.skin_model is None
        return {"skin_model": None if keep else model, "skin_material": material}

    def _relocated(self, layout: Layout, folder: str | Path | None) -> Layout:
        """``layout`` with its relative mesh paths rewritten to start at ``folder`` (None:
        absolute).
        """
        if self.folder is None:
            return layout
        here = self.folder.resolve()
        there = Path(folder).resolve() if folder is not None else None
        if there == here:
            return layout
        moved = {}
        for key in ("skin", "skull"):
            value = getattr(layout, key)
            if value is None or Path(value).is_absolute():
                continue
            target = (here / value).resolve()
            try:
                moved[key] = str(target) if there is None else os.path.relpath(target, there)
            except ValueError:  # another drive
                moved[key] = str(target)
        return dataclasses.replace(layout, **moved) if moved else layout

    def disk_change(self) -> str | None:
        """Whether the open file changed on disk since the session read or last saved it
        (:meth:`FileStamp.change`): None (unchanged, or no file or stamp to compare),
        ``"deleted"`` or ``"changed"``. Save should ask before overwriting a change.
        """
        if self.layout_path is None or self.disk is None:
            return None
        return self.disk.change(self.layout_path)

    def save(self, path: str | Path | None = None) -> Path:
        """Save the layout atomically to ``path`` (default the open file), whatever is
        there (ask first with :meth:`disk_change`); its relative mesh paths are rewritten
        for the new folder. The file written becomes :attr:`disk`.
        """
        path = Path(path or self.layout_path or "")
        if not path.name:
            raise ValueError("no file to save to: choose one")
        layout = self.layout(path.parent)
        save_layout(layout, path)
        self._layout, self.folder = layout, path.parent
        self.layout_path, self.dirty = path, False
        self.disk = FileStamp.of(path)  # read back at once (as editors stat after writing)
        return path


@dataclass(frozen=True)
class SurfacePoint:
    """A point on a face's rest skin: one of its triangles and barycentric coordinates in
    it (the skin's own triangles, not a refinement's, whose numbering changes each frame).
    """

    triangle: int
    barycentric: tuple[float, float, float]


class _Interpolated:
    """Values ``v`` ``(3,)`` on a triangle's corners at the point with ``weights`` ``(3,)``
    there (``interpolated(v)``): the weighted mean over the corners where it is finite;
    NaN where it is not at the corner of the largest weight; at a vertex its value as it
    is. What depends on the weights alone is found once for all the fields.
    """

    def __init__(self, weights: np.ndarray):
        self.weights = weights
        self.nearest = int(np.argmax(weights))
        self.at_vertex = bool(weights[self.nearest] == 1.0)
        self.total = weights.sum()

    def __call__(self, v: np.ndarray) -> float:
        if self.at_vertex:
            return float(v[self.nearest])
        ok = np.isfinite(v)
        if ok.all():  # the same sums as over ``ok`` below, with no copies
            return float(self.weights @ v / self.total)
        if not ok[self.nearest]:
            return float(v[self.nearest])  # undefined
        w = self.weights[ok]
        return float(w @ v[ok] / w.sum())


def _triangles_near(points: np.ndarray, triangles: np.ndarray, centre: np.ndarray,
                    reach: float) -> np.ndarray:
    r"""``(t,)``: the triangles ``(m, 3)`` with a corner of ``points`` ``(n, 3)`` within
    ``reach`` of ``centre`` ``(3,)`` (:math:`|p - c|^2 \le r^2`).
    """
    x, y, z = (points[:, k] - centre[k] for k in range(3))  # no (n, 3) temporary
    near = x * x + y * y + z * z <= reach * reach
    hit = near.take(triangles.ravel()).reshape(-1, 3)
    return np.flatnonzero(hit[:, 0] | hit[:, 1] | hit[:, 2])


def playback_position(start: int, elapsed_s: float, duration_s: float,
                      steps: int = TIMELINE_STEPS) -> int:
    r"""The timeline position ``elapsed_s`` seconds of playback after position ``start``.

    .. math:: p = \left(p_0 + \operatorname{round}\left(s \, t / T\right)\right)
              \bmod (s + 1)

    for ``steps`` :math:`s` spanning the expression's duration :math:`T`: the expression
    plays at its own speed, round and round, however long a frame takes to draw (a slow
    frame skips positions instead of slowing the expression down). A duration of 0 stays
    at ``start``.
    """
    if duration_s <= 0.0:
        return int(start)
    return (int(start) + round(steps * elapsed_s / duration_s)) % (steps + 1)


def load_session(path: str | Path | None = None, n_triangles: int | None = None,
                 unit: str | None = None) -> Session:
    """A session on the layout file ``path``, read once (default: the built-in face).

    ``n_triangles``: the built-in skin's resolution when the layout records none (default
    the loader's); ``unit``: its mesh's unit when the layout records none (default guessed
    from its size). Raises ``FileNotFoundError``, :class:`~wrinkle_vis.core.layout.LayoutError`
    or ``ValueError`` with the reason.
    """
    from wrinkle_vis.datasets import load_face

    if path is None:
        return Session(load_face(n_triangles))
    path = Path(path)
    disk = FileStamp.of(path)  # before reading: a change in between is seen, not missed
    layout = load_layout(path)
    n = layout.n_triangles if layout.n_triangles is not None else n_triangles
    face = load_face(n, layout=layout, skin=layout.resolve("skin", path.parent),
                     skull=layout.resolve("skull", path.parent), unit=layout.unit or unit)
    return Session(face, path, layout=layout, disk=disk)


def _mirror_image(face: FaceModel, muscle: str, name: str | None = None):
    """``muscle`` of ``face`` reflected across its symmetry plane and snapped onto its
    surfaces, called ``name`` (default its twin's name).
    """
    point, normal = face.symmetry_plane()
    source = face.muscle(muscle)
    return snapped(mirrored(source, point, normal, name=name),
                   {"skin": face.skin, "skull": face.skull}, like=source)


def _sharing_activations(face: FaceModel, muscle: str, other: str) -> FaceModel:
    """``face`` with ``other`` activated as ``muscle`` in every expression that has it."""
    return face.with_expressions({
        k: dataclasses.replace(ex, activations={**ex.activations,
                                                other: ex.activations[muscle]})
        if muscle in ex.activations else ex for k, ex in face.expressions.items()})


def _equal(x, y) -> bool:
    """``x == y`` for parameters (arrays compared element-wise)."""
    if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
        return np.array_equal(np.asarray(x), np.asarray(y))
    return bool(x == y)
