"""The three views and the frame they draw.

:class:`FrameController` builds the skin, muscles and skull views (one shared camera,
picking on the skin, clicks on the muscles) and draws the document's frame in them. No
code asks for a redraw: it listens to the models (:mod:`.models`), and a change marks the
frame out of date; the frame is then drawn once, at the next turn of the event loop
(a zero-time single-shot timer), however many changes came in that turn.

No Qt connection or VTK observer holds the window strongly (:func:`~.binding.weak`), and
the observers are removed on :meth:`FrameController.close`, so a closed window is freed
with everything it drew.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np
from qtpy import QtCore, QtWidgets
from vtkmodules.vtkRenderingCore import vtkPropPicker

from ..plotting import set_camera
from .binding import weak
from .models import DisplayOptions
from .views import LinkedViews
from .viewwidget import NativeView, View, make_view

__all__ = ["PROBE_MARKER", "FrameController"]

#: The probe marker's radius, a fraction of the skin's bounding-box diagonal.
PROBE_MARKER = 0.006


def _render_view(view: View | NativeView) -> None:
    view.render_now()


class FrameController:
    """The views of ``window``, drawn from its ``document``, ``display``, ``playback`` and
    ``probe`` once per event-loop turn after any of them changed.
    """

    def __init__(self, window):
        self.window = window
        self.plotters: list[View | NativeView] = []
        self.drawn_face = None  # the face of the frame on screen
        self._ramp = (None, None)  # (what it was computed for, the colour range over it)
        self._pending: dict | None = None  # what the next frame must do (None: nothing)
        self._syncing = False
        self._press = None
        self._closed = False
        self.splitter = self._build_views()
        self.status_label = QtWidgets.QLabel()  # the frame's summary; messages go beside
        window.document.changed.connect(self._on_document)
        window.display.changed.connect(self._on_display)
        window.playback.changed.connect(self.request)
        window.probe.changed.connect(self._on_probe)

    # ------------------------------------------------------------------ the views
    def _build_views(self) -> QtWidgets.QSplitter:
        splitter = QtWidgets.QSplitter(QtCore.Qt.Horizontal)
        for title in ("Skin", "Muscles", "Skull"):
            frame = QtWidgets.QWidget()
            box = QtWidgets.QVBoxLayout(frame)
            box.setContentsMargins(0, 0, 0, 0)
            box.addWidget(QtWidgets.QLabel(f"<b>{title}</b>"))
            plotter = make_view(frame)
            box.addWidget(plotter.interactor)
            splitter.addWidget(frame)
            self.plotters.append(plotter)
        self.skin_view, self.muscle_view, self.skull_view = self.plotters
        drags = self.window.placements
        self.views = LinkedViews(*self.plotters, on_move=weak(drags.on_move, keep=3),
                                 on_start=weak(drags.on_start, keep=1),
                                 render_view=_render_view)
        camera = self.skin_view.renderer.camera
        for p in self.plotters[1:]:
            p.renderer.camera = camera
        self._camera_observer = camera.AddObserver("ModifiedEvent", weak(self.sync_views))
        # a cell picker: the point on the skin drawn and its triangle, exactly (PyVista's
        # tolerance, 2.5 % of the window, can name a triangle beside the one hit; the window
        # draws the probe's own marker, which follows the skin); PyVista calls back with
        # (point, picker) when use_picker is on
        self.skin_view.enable_point_picking(weak(self._on_pick, keep=2), use_picker=True,
                                            picker="cell", tolerance=1e-4,
                                            show_message=False,
                                            show_point=False, left_clicking=False)
        iren = self.muscle_view.iren
        iren.add_observer("LeftButtonPressEvent", weak(self._on_muscle_press))
        iren.add_observer("LeftButtonReleaseEvent", weak(self._on_muscle_release))
        return splitter

    def _on_muscle_press(self, *_) -> None:
        self._press = self.muscle_view.iren.get_event_position()

    def _on_muscle_release(self, *_) -> None:
        """A click (press and release within 3 pixels) on a muscle selects it."""
        x, y = self.muscle_view.iren.get_event_position()
        if self._press is not None and max(abs(x - self._press[0]),
                                           abs(y - self._press[1])) <= 3:
            name = self.muscle_at(x, y)
            if name is not None:
                self.window.select_muscle(name)
        self._press = None

    def muscle_at(self, x: int, y: int) -> str | None:
        """The muscle drawn at display position ``(x, y)`` of the muscles view, if any."""
        picker = vtkPropPicker()
        if not picker.Pick(x, y, 0, self.muscle_view.renderer):
            return None
        actor = picker.GetViewProp()
        for name, a in self.muscle_view.actors.items():
            if a is actor and name.startswith("muscle:"):
                return name.removeprefix("muscle:")
        return None

    def sync_views(self, *_) -> None:
        """Render every view at once when the shared camera moves (no timer tick)."""
        if self._syncing:
            return
        self._syncing = True
        try:
            self.views.render()
        finally:
            self._syncing = False

    def set_camera(self, name: str) -> None:
        """Move the shared camera to a named view (again, when it is the preset chosen
        last: the user may have turned it since).
        """
        if self.window.display.options.camera == name:
            self._show_camera()
        else:
            self.window.display.set(camera=name)

    def _show_camera(self) -> None:
        set_camera(self.skin_view, self.window.display.options.camera,
                   self.window.document.session.face)
        self.sync_views()

    # ------------------------------------------------------------------ picking
    def _on_pick(self, point, picker=None) -> None:
        """A right-click on the skin view picked ``point``: probe the skin there (in the
        triangle the picker names, else at the closest point of the skin shown).
        """
        if point is None:
            return
        skin = self.views.skin_mesh
        cell = None
        if picker is not None and skin is not None and picker.GetDataSet() is skin \
                and hasattr(picker, "GetCellId"):
            cell = int(picker.GetCellId())
        self.window.probe_at(self.window.document.session.surface_point(point, cell))
        self.views.render_skin()  # the marker where the click was

    def show_probe(self) -> dict | None:
        """Show the probe's values in this frame, and its marker; returns the values."""
        w = self.window
        s = w.document.session
        point = w.probe.point
        if point is None or point.triangle >= s.face.skin.n_triangles:
            w.probe_panel.clear(s.unit)
            self.views.show_probe(None, 0.0)
            return None
        values = w.probe_panel.show_values(s, point)
        lo, hi = s.face.skin.bounds()
        self.views.show_probe(s.probe_position(point)[1],
                              PROBE_MARKER * float(np.linalg.norm(hi - lo)))
        return values

    def _on_probe(self, _=None) -> None:
        self.show_probe()

    # ------------------------------------------------------------------ drawing
    def _on_document(self, what: str) -> None:
        if what == "session":  # drawn at once: the camera it sets is there for the caller
            self.show_probe()
            self.request(reset_camera=True)
            self.flush()
        elif what != "dirty":
            self.request()

    def _on_display(self, what: str) -> None:
        if what == "camera":
            self._show_camera()
        elif what in ("raking_light", "anti_aliasing"):  # the scenes as they are, at once
            self.views.apply_switches(self.window.display.options)
            self.sync_views()
        else:
            self.request()

    def request(self, _=None, reset_camera: bool = False) -> None:
        """Mark the frame out of date: it is drawn at the next turn of the event loop."""
        if self._closed:
            return
        if self._pending is None:
            self._pending = {"reset_camera": False}
            QtCore.QTimer.singleShot(0, weak(self.flush))
        self._pending["reset_camera"] |= reset_camera

    def flush(self, skip=()) -> None:
        """Draw the frame now if it is out of date (less the plotters in ``skip``)."""
        if self._pending is None or self._closed:
            return
        pending, self._pending = self._pending, None
        self.window.refresh(reset_camera=pending["reset_camera"], skip=skip)

    def draw(self, reset_camera: bool = False, skip=()) -> None:
        """Recompute the frame and redraw the three views (less the plotters in ``skip``)."""
        self._pending = None
        t0 = time.perf_counter()
        w = self.window
        s = w.document.session
        state = s.state()
        options = w.display.options
        self._syncing = True  # one render per view at the end, not one per change
        try:
            # the drawn meshes can be updated in place only on the same triangles
            if reset_camera:
                self.views.invalidate()
            self.views.draw(state, self.options(), s.face)
            self.drawn_face = s.face
            if reset_camera:
                set_camera(self.skin_view, options.camera, s.face)
        finally:
            self._syncing = False
        if w.probe.point is not None:
            if w.probe.point.triangle >= s.face.skin.n_triangles:
                w.probe.point = None
            else:
                self.show_probe()
        self.views.render(only_changed=not reset_camera, skip=skip)
        self.show_status(state, 1e3 * (time.perf_counter() - t0))
        w.update_title()

    def show_status(self, state, total_ms: float) -> None:
        """The frame's summary in the status bar: expression, W's range, timings."""
        s = self.window.document.session
        note = s.undersampled_note(state)
        self.status_label.setText(
            f"{s.expression} x {s.intensity:.2f}"
            f"{'' if s.time_s is None else f' at {s.time_s:.2f} s'}  |  W in "
            f"[{state.W.min():.3g}, {state.W.max():.3g}] {s.unit}  |  frame "
            f"{s.frame_ms:.2f} ms, drawn in {total_ms:.1f} ms  |  "
            f"{_triangles(len(state.triangles), s.face.skin.n_triangles)}"
            f"{'  |  ⚠ aliased wrinkles: refine' if note else ''}" + _skin_status(s))
        self.status_label.setToolTip(f"Warning: {note}" if note else "")

    def options(self) -> DisplayOptions:
        """What the views are given beside the frame: the display's options, with the
        document's field and muscle (the selection) and the colour range in use
        (:meth:`colour_range`).
        """
        s = self.window.document.session
        return dataclasses.replace(self.window.display.options, field=s.field,
                                   muscle=s.muscle, clim=self.colour_range())

    def colour_range(self) -> tuple[float, float] | None:
        """The colour range the skin view uses now: the fixed one (the display's); while
        playing, the one over the expression's whole ramp (so the ramp shows); else None,
        each frame's own.
        """
        w = self.window
        s = w.document.session
        options = w.display.options
        if options.clim is not None:
            return options.clim
        if not w.playback.playing or options.plain:
            return None
        key = (s.face, s.expression, s.intensity, s.field, s.muscle,
               tuple(sorted(s.overrides.items())))
        if self._ramp[0] != key:
            self._ramp = (key, s.ramp_range())
        return self._ramp[1]

    def close(self) -> None:
        """Remove the observers (VTK holds them strongly, out of Python's sight) and close
        the views.
        """
        self._closed = True
        self.views.close_placement()
        self.skin_view.renderer.GetActiveCamera().RemoveObserver(self._camera_observer)
        self.skin_view.disable_picking()
        self.muscle_view.iren.remove_observers("LeftButtonPressEvent")
        self.muscle_view.iren.remove_observers("LeftButtonReleaseEvent")
        for p in self.plotters:
            p.close()


def _skin_status(session) -> str:
    """The status line's word on the physical skin ("" on the geometric one)."""
    if session.face.skin_model != "physical":
        return ""
    if session.simulating:
        return f"  |  physical skin, simulated to {session.physics.time:.3f} s"
    return "  |  physical skin, equilibrium"


def _triangles(drawn: int, skin: int) -> str:
    """The status bar's triangle count: ``4500 triangles``, ``34162 triangles (refined
    from 4500)``.
    """
    return f"{drawn} triangles" + (f" (refined from {skin})" if drawn != skin else "")
