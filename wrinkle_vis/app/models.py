"""The app's models, Qt-free: what the window shows, each emitting an event when it changes.

- :class:`Document`: the open :class:`~wrinkle_vis.app.session.Session` (the face, its
  layout and file, the expression and time, the field and the selected muscle) and whether
  it holds unsaved changes (``dirty``: this is its one owner; the undo stack's clean flag
  reaches it through :meth:`Document.set_dirty` only);
- :class:`Playback`: whether Play runs, and where it started;
- :class:`Display`: how the frame is drawn, an immutable :class:`DisplayOptions` snapshot
  (plain skin, colour map and range, camera preset, wireframe, raking light,
  anti-aliasing) handed to the views with the field shown;
- :class:`Probe`: the probed point of the rest skin.

Each has a :class:`Signal` ``changed`` that calls its listeners with the name of what
changed. The controls (:mod:`.binding`) show a model's attribute and set it; the frame
(:class:`~wrinkle_vis.app.frames.FrameController`) listens to them all and redraws once
per event-loop turn. Nothing here imports Qt.
"""

from __future__ import annotations

import dataclasses
import math
import weakref
from collections.abc import Callable
from typing import Any

from .session import Session, SurfacePoint

__all__ = ["Display", "DisplayOptions", "Document", "Playback", "Probe", "Signal"]


class Signal:
    """A list of listeners called in order with the arguments of :meth:`emit`.

    A bound method is held weakly (a listener's object is not kept alive by what it
    listens to); a plain function is held strongly.
    """

    def __init__(self) -> None:
        self._slots: list[Callable[[], Callable | None]] = []

    def connect(self, slot: Callable) -> Callable:
        """Call ``slot`` on every :meth:`emit`; returns ``slot`` (usable as a decorator)."""
        if hasattr(slot, "__self__") and hasattr(slot, "__func__"):
            self._slots.append(weakref.WeakMethod(slot))
        else:
            self._slots.append(lambda: slot)
        return slot

    def disconnect_all(self) -> None:
        """Forget every listener."""
        self._slots.clear()

    def emit(self, *args: Any) -> None:
        """Call each live listener with ``args`` (dead ones are dropped)."""
        live = []
        for ref in list(self._slots):
            slot = ref()
            if slot is not None:
                live.append(ref)
                slot(*args)
        if len(live) != len(self._slots):
            self._slots = [r for r in self._slots if r() is not None]


class _Evented:
    """A model with declared attributes that emits ``changed(name)`` when one changes."""

    _fields: tuple[str, ...] = ()

    def __init__(self) -> None:
        object.__setattr__(self, "changed", Signal())

    def __setattr__(self, name: str, value: Any) -> None:
        old = getattr(self, name, dataclasses.MISSING)
        object.__setattr__(self, name, value)
        if name in self._fields and not _same(old, value):
            self.changed.emit(name)


def _same(a: Any, b: Any) -> bool:
    """Identity or equality, never an array's elementwise answer."""
    if a is b:
        return True
    try:
        return bool(a == b)
    except (TypeError, ValueError):
        return False


class Playback(_Evented):
    """Whether Play runs (``playing``) and where it started: ``start`` is the timeline
    position and the clock (s) when Play was pressed.
    """

    _fields = ("playing",)

    def __init__(self) -> None:
        super().__init__()
        self.playing = False
        self.start: tuple[int, float] = (0, 0.0)


@dataclasses.dataclass(frozen=True)
class DisplayOptions:
    """How the frame is drawn: an immutable snapshot, all the views are given beside the
    frame (:meth:`~wrinkle_vis.app.views.LinkedViews.draw`).

    Attributes
    ----------
    field : str
        The field the skin view shows (:data:`~wrinkle_vis.core.fields.FIELDS`).
    muscle : str or None
        Whose field (None: the total); the selected muscle, whose placement widget shows.
    plain : bool
        The skin view shows plain skin, no field.
    cmap : str or None
        The colour map (a Matplotlib name; None: the field's own,
        :attr:`~wrinkle_vis.core.fields.FieldSpec.cmap`).
    clim : (float, float) or None
        The colour range, ``lo < hi`` (None: automatic, each frame's own; while playing,
        the window hands the views the whole ramp's).
    camera : str
        The camera preset last chosen (:data:`~wrinkle_vis.plotting.scenes.CAMERAS`),
        where a new face is shown from.
    wireframe : bool
        The skin's triangles are outlined.
    raking_light : bool
        The skin view is lit from above at a grazing angle.
    anti_aliasing : bool
        8x multisampling in the three views.
    """

    field: str = "W"
    muscle: str | None = None
    plain: bool = False
    cmap: str | None = None
    clim: tuple[float, float] | None = None
    camera: str = "front"
    wireframe: bool = False
    raking_light: bool = False
    anti_aliasing: bool = False

    def __post_init__(self) -> None:
        if self.clim is not None:
            lo, hi = map(float, self.clim)
            if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
                raise ValueError(f"colour range [{lo:g}, {hi:g}]: min must be below max")
            object.__setattr__(self, "clim", (lo, hi))


class Display(_Evented):
    """The :class:`DisplayOptions` in use (their one owner, but for the field and the
    muscle, which the :class:`Document` holds as the selection: the window adds them to
    the snapshot it hands the views); :meth:`set` replaces them and emits
    ``changed(name)`` for each option that changed.
    """

    def __init__(self, options: DisplayOptions | None = None) -> None:
        super().__init__()
        object.__setattr__(self, "options", options or DisplayOptions())

    def set(self, **changes: Any) -> None:
        """Replace some options (``display.set(plain=True)``); ``ValueError`` for a bad
        colour range (the options stay as they were).
        """
        old = self.options
        object.__setattr__(self, "options", dataclasses.replace(old, **changes))
        for name in changes:
            if getattr(old, name) != getattr(self.options, name):
                self.changed.emit(name)


class Probe(_Evented):
    """The probed point of the rest skin (None: nothing probed)."""

    _fields = ("point",)

    def __init__(self) -> None:
        super().__init__()
        self.point: SurfacePoint | None = None


class Document:
    """The open session, and whether it holds changes not saved yet.

    ``changed`` is emitted with:

    - ``"session"`` when another session replaces it (a layout opened, restored, a new
      face): every control shows it afresh;
    - ``"face"`` when the face is edited (an edit, an undo, a drag's step), ``"muscles"``
      when that edit changed the set of muscles;
    - ``"selection"`` when another muscle (or none) is selected;
    - ``"time"`` when the physical skin's simulation moved the time (the timeline
      follows), then ``"frame"``;
    - ``"frame"`` when what the frame shows changes otherwise (the expression, its
      intensity and time, the field, the refinement);
    - ``"performance"`` when a recorded track is imported (a new entry of the
      expressions);
    - ``"dirty"`` when unsaved changes appear or go.
    """

    def __init__(self, session: Session) -> None:
        self.changed = Signal()
        self.session = session

    # ------------------------------------------------------------------ the session
    def replace(self, session: Session, modified: bool = False) -> None:
        """Show ``session`` (keeping the view's refinement); ``modified``: it holds
        changes not saved yet.
        """
        session.refine = self.session.refine
        self.session = session
        session.dirty = False
        self.changed.emit("session")
        self.set_dirty(modified)

    def set_dirty(self, dirty: bool) -> None:
        """Mark the session as holding unsaved changes or not (the one place it is set)."""
        if self.session.dirty != bool(dirty):
            self.session.dirty = bool(dirty)
            self.changed.emit("dirty")

    # ------------------------------------------------------------------ the face
    def show_face(self, face, select: str | None = None) -> None:
        """Show a version of the face with muscle ``select`` selected (None: none)."""
        s = self.session
        names_changed = face.muscle_names != s.face.muscle_names
        selected = s.muscle
        field = s.field
        s.set_face(face)
        if select is not None and select in face.muscle_names:
            s.set_field(field, select)
        elif select is None and s.muscle is not None:
            s.set_field("W", None)
        self.changed.emit("muscles" if names_changed else "face")
        if s.muscle != selected:
            self.changed.emit("selection")

    def set_face(self, face) -> None:
        """Show another face (a drag's step: no selection change)."""
        self.session.set_face(face)
        self.changed.emit("face")

    # ------------------------------------------------------------------ the frame
    def set_expression(self, name: str) -> None:
        """Show expression ``name``."""
        if name and name != self.session.expression:
            self.session.set_expression(name)
            self.changed.emit("frame")

    def set_intensity(self, value: float) -> None:
        """Scale the expression's activations by ``value`` in [0, 1]."""
        self.session.set_intensity(value)
        self.changed.emit("frame")

    def set_time(self, t: float | None) -> None:
        """Show the expression at time ``t`` (s; None: at its peak)."""
        self.session.set_time(t)
        self.changed.emit("frame")

    def set_refine(self, on: bool) -> None:
        """Refine the skin adaptively, or not."""
        self.session.set_refine(on)
        self.changed.emit("frame")

    def set_field(self, field: str, muscle: str | None) -> None:
        """Show ``field`` of ``muscle`` (None: the total)."""
        selected = self.session.muscle
        self.session.set_field(field, muscle)
        self.changed.emit("frame")
        if muscle != selected:
            self.changed.emit("selection")

    def set_performance(self, performance) -> None:
        """Add a recorded performance to the expressions and show it."""
        self.session.set_performance(performance)
        self.changed.emit("performance")

    def simulation_changed(self) -> None:
        """The physical skin's simulation moved (a tick, a reset): a new time and frame."""
        self.changed.emit("time")
        self.changed.emit("frame")
