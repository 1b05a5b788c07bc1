"""The main window: three linked views (skin with a field, muscles, skull) and controls.

The window is a thin layer over :class:`~wrinkle_vis.app.session.Session`: each control sets
one session attribute and calls :meth:`MainWindow.refresh`, which redraws from the session.

No Qt connection or VTK observer holds the window strongly (:func:`_weak`), and the
observers are removed on close, so a closed window is freed with everything it drew.
"""

from __future__ import annotations

import ctypes
import dataclasses
import math
import re
import sys
import time
import weakref
from pathlib import Path

import numpy as np
from qtpy import QtCore, QtGui, QtWidgets
from vtkmodules.vtkRenderingCore import vtkPropPicker

from ..core.editing import mirror_name, with_point
from ..core.face import FIELD_NAMES
from ..core.fields import FRAME_FIELDS
from ..core.layout import Layout, LayoutError, load_layout
from ..core.muscle import MuscleParameterError
from ..core.registry import muscle_types
from ..core.skin import SKIN_MODELS, SkinMaterial
from ..core.tracks import TrackError, TrackWarning, default_mapping, performance, read_track
from ..core.units import DEFAULT_UNIT, LENGTH_UNITS, guess_unit
from ..plotting import set_camera
from ..plotting.fields import field_info
from ..plotting.polydata import field_array_name
from ..widgets.panels import MuscleListPanel
from .dialogs import ask_text
from .facemenu import FACE_LABELS, can_pick_again, face_title, mark_face
from .fieldbox import FieldBox
from .mapping import add_mapping_action
from .newface_panel import NewFaceFlow
from .recovery import Recovery
from .session import (
    TIMELINE_STEPS,
    Session,
    SurfacePoint,
    editable,
    load_session,
    playback_position,
)
from .trackplot import TrackPlot, track_curves
from .views import VIEWS, LinkedViews
from .viewwidget import NativeView, View, make_view

__all__ = ["MainWindow"]

TOTAL = "total"
#: What the probe panel says before a point is probed.
PROBE_HINT = "Right-click the skin to probe a point"
#: The probe marker's radius, a fraction of the skin's bounding-box diagonal.
PROBE_MARKER = 0.006
PLAIN = "none"  # the field box's entry for plain skin (no field)
KEEP = object()  # edit(): keep the selection
MAX_RECENT = 8
AUTOSAVE_QUIET_MS = 1000  # autosave after this long without an edit...
AUTOSAVE_MAX_MS = 5000  # ...and at the latest this long after the first unsaved edit
PLAY_TICK_MS = 16  # Play's timer: at most about 60 frames a second
GUIDE = Path(__file__).resolve().parents[2] / "docs" / "guide.md"  # in a source checkout


def guard_none_refcount() -> bool:
    """Keep a long session from dying of "Fatal Python error: deallocating None".

    PySide6 6.12 (an abi3 wheel) on Python 3.11 drops a reference to ``None`` at every call
    of a Qt method that returns nothing (``update()``, ``setText()``...): some ten per frame
    of the app, so that after about 9,000 frames of Play ``None``'s count reaches 0 and the
    interpreter aborts (``benchmarks/bench_soak.py`` found it). Python 3.12 made ``None``
    immortal; where a probe shows the drift here, ``None`` gets 2**40 references more,
    once, which no session spends. Returns whether it did.
    """
    global _NONE_GUARDED
    if _NONE_GUARDED or sys.version_info >= (3, 12) or sys.implementation.name != "cpython":
        return False
    probe = QtCore.QObject()
    before = sys.getrefcount(None)
    for _ in range(16):
        probe.setObjectName("probe")  # returns nothing
    if sys.getrefcount(None) >= before:
        return False
    ctypes.c_ssize_t.from_address(id(None)).value += 1 << 40  # ob_refcnt, first field
    _NONE_GUARDED = True
    return True


_NONE_GUARDED = False


def _weak(method, *args, keep: int = 0):
    """A slot calling ``method(*args, *signal_args[:keep])`` while ``method``'s object lives.

    It holds the object weakly: a Qt connection or a VTK observer made with it keeps no
    window alive (a lambda or a bound method there would, out of the garbage collector's
    sight).
    """
    ref = weakref.WeakMethod(method)

    def slot(*signal_args):
        bound = ref()
        return None if bound is None else bound(*args, *signal_args[:keep])

    return slot


def _render_view(view: View | NativeView) -> None:
    view.render_now()


class MainWindow(QtWidgets.QMainWindow):
    """The wrinkle-vis main window.

    Parameters
    ----------
    session : Session
        What to show.
    settings : QSettings, optional
        Where the recent-files list lives (tests pass a temporary one).
    recovery : Recovery, optional
        Where the layout is autosaved while the user works (default
        :func:`~wrinkle_vis.app.recovery.default_directory`).
    """

    def __init__(self, session: Session, settings: QtCore.QSettings | None = None,
                 recovery: Recovery | None = None):
        super().__init__()
        guard_none_refcount()
        self.session = session
        self.settings = settings or QtCore.QSettings("wrinkle-vis", "wrinkle-vis")
        self.recovery = recovery or Recovery()
        self.undo_stack = QtGui.QUndoStack(self)
        self.undo_stack.cleanChanged.connect(self._on_clean_changed)
        self.undo_stack.indexChanged.connect(self._schedule_autosave)
        # autosave after a second of quiet, and at the latest 5 s after the first unsaved
        # edit however the edits go on (a debounce alone would wait for ever)
        self.autosave_timer = QtCore.QTimer(self)
        self.autosave_timer.setSingleShot(True)
        self.autosave_timer.setInterval(AUTOSAVE_QUIET_MS)
        self.autosave_timer.timeout.connect(self.autosave)
        self.autosave_deadline = QtCore.QTimer(self)
        self.autosave_deadline.setSingleShot(True)
        self.autosave_deadline.setInterval(AUTOSAVE_MAX_MS)
        self.autosave_deadline.timeout.connect(self.autosave)
        self._undo_keys = _UndoKeysToWindow(self)
        self._wheel_guard = _WheelOnlyWhenFocused(self)
        self._ramp = (None, None)  # (what it was computed for, the colour range over the ramp)
        self._drag_before = None
        self._drawn_face = None
        self._press = None
        self.setWindowTitle("wrinkle-vis")
        screen = self.screen() or QtGui.QGuiApplication.primaryScreen()
        self.resize(*fitted_size(screen.availableGeometry().size() if screen else None))
        self._syncing = False
        self._updating_controls = False
        self.plain_skin = False  # the skin view shows no field
        self.plotters: list[View | NativeView] = []
        self.status_label = QtWidgets.QLabel()  # the frame's summary; messages go beside
        self.statusBar().addPermanentWidget(self.status_label)
        self._build_views()
        self._build_controls()
        self.newface = NewFaceFlow(self)
        self.track_plot: TrackPlot | None = None  # made by the first import_performance
        self._build_menus()
        self.timer = QtCore.QTimer(self)  # Play: ticks as fast as 60 a second
        self.timer.setInterval(PLAY_TICK_MS)
        self.timer.timeout.connect(self._tick)
        self._play_start = (0, 0.0)  # timeline position and clock when Play was pressed
        self.clock = time.perf_counter  # the physical skin's wall clock (tests fake it)
        self._populate()
        self.refresh(reset_camera=True)

    # ------------------------------------------------------------------ views
    def _build_views(self) -> None:
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
        self.setCentralWidget(splitter)
        self.skin_view, self.muscle_view, self.skull_view = self.plotters
        self.views = LinkedViews(*self.plotters, on_move=_weak(self._on_handle_moved, keep=3),
                                 on_start=_weak(self._on_handle_start, keep=1),
                                 render_view=_render_view)
        camera = self.skin_view.renderer.camera
        for p in self.plotters[1:]:
            p.renderer.camera = camera
        self._camera_observer = camera.AddObserver("ModifiedEvent", _weak(self._sync_views))
        # PyVista calls back with (point, picker) when use_picker is on
        # a cell picker: the point on the skin drawn and its triangle, exactly (PyVista's
        # tolerance, 2.5 % of the window, can name a triangle beside the one hit; the window
        # draws the probe's own marker, which follows the skin)
        self.skin_view.enable_point_picking(_weak(self._on_pick, keep=2), use_picker=True,
                                            picker="cell", tolerance=1e-4,
                                            show_message=False,
                                            show_point=False, left_clicking=False)
        iren = self.muscle_view.iren
        iren.add_observer("LeftButtonPressEvent", _weak(self._on_muscle_press))
        iren.add_observer("LeftButtonReleaseEvent", _weak(self._on_muscle_release))

    def _on_muscle_press(self, *_) -> None:
        self._press = self.muscle_view.iren.get_event_position()

    def _on_muscle_release(self, *_) -> None:
        """A click (press and release within 3 pixels) on a muscle selects it."""
        x, y = self.muscle_view.iren.get_event_position()
        if self._press is not None and max(abs(x - self._press[0]),
                                           abs(y - self._press[1])) <= 3:
            name = self.muscle_at(x, y)
            if name is not None:
                self.select_muscle(name)
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

    def _sync_views(self, *_) -> None:
        """Render every view at once when the shared camera moves (no timer tick)."""
        if self._syncing:
            return
        self._syncing = True
        try:
            self.views.render()
        finally:
            self._syncing = False

    # ------------------------------------------------------------------ controls
    def _build_controls(self) -> None:
        dock = QtWidgets.QDockWidget("Controls", self)
        dock.setObjectName("controls")
        panel = QtWidgets.QWidget()
        form = QtWidgets.QVBoxLayout(panel)

        view = QtWidgets.QFormLayout()
        self.expression_box = QtWidgets.QComboBox()
        self.expression_box.currentTextChanged.connect(self._on_expression)
        view.addRow("Expression", self.expression_box)
        self.intensity_slider = QtWidgets.QSlider(QtCore.Qt.Horizontal)
        self.intensity_slider.setRange(0, 100)
        self.intensity_slider.valueChanged.connect(self._on_intensity)
        view.addRow("Intensity", self.intensity_slider)
        row = QtWidgets.QHBoxLayout()
        self.play_button = QtWidgets.QPushButton("Play")
        self.play_button.setCheckable(True)
        self.play_button.toggled.connect(self._on_play)
        self.time_slider = QtWidgets.QSlider(QtCore.Qt.Horizontal)
        self.time_slider.setRange(0, TIMELINE_STEPS)
        self.time_slider.valueChanged.connect(self._on_time)
        self.reset_button = QtWidgets.QPushButton("Reset")
        self.reset_button.setToolTip("Physical skin: back to rest at t = 0")
        self.reset_button.clicked.connect(_weak(self.reset_simulation))
        row.addWidget(self.play_button)
        row.addWidget(self.time_slider)
        row.addWidget(self.reset_button)
        view.addRow("Timeline", row)
        # symbols and names (w is not W); the frame's fields (fold_guard) after the muscles'
        self.field_box = FieldBox([*FIELD_NAMES, *FRAME_FIELDS], PLAIN)
        self.field_box.currentTextChanged.connect(self._on_field)
        view.addRow("Field", self.field_box)
        self.muscle_box = QtWidgets.QComboBox()
        self.muscle_box.currentTextChanged.connect(self._on_field)
        view.addRow("Muscle", self.muscle_box)
        row = QtWidgets.QHBoxLayout()
        self.refine_box = QtWidgets.QCheckBox("Refine adaptively")
        self.refine_box.toggled.connect(self._on_refine)
        self.wireframe_box = QtWidgets.QCheckBox("Wireframe")
        self.wireframe_box.toggled.connect(_weak(self.refresh))
        row.addWidget(self.refine_box)
        row.addWidget(self.wireframe_box)
        view.addRow("Mesh", row)
        row = QtWidgets.QHBoxLayout()
        self.range_box = QtWidgets.QComboBox()
        self.range_box.addItems(["automatic", "fixed"])
        self.range_box.setToolTip("Colour range of the field. automatic: each frame's own "
                                  "while paused, the whole ramp's while playing; fixed: "
                                  "min and max")
        self.range_box.currentTextChanged.connect(self._on_range_mode)
        self.range_min = QtWidgets.QDoubleSpinBox()
        self.range_max = QtWidgets.QDoubleSpinBox()
        for box, tip in ((self.range_min, "lowest value of the colour map"),
                         (self.range_max, "highest value of the colour map")):
            box.setRange(-1e9, 1e9)
            box.setDecimals(6)
            box.setKeyboardTracking(False)
            box.setEnabled(False)
            box.setToolTip(tip)
            box.valueChanged.connect(self._on_range_value)
            box.installEventFilter(self._undo_keys)
        row.addWidget(self.range_box)
        row.addWidget(self.range_min)
        row.addWidget(self.range_max)
        view.addRow("Colour range", row)
        self.range_error = _error_label()
        view.addRow(self.range_error)
        form.addLayout(view)
        self._build_skin_controls(view, form)

        self.param_group = QtWidgets.QGroupBox("Parameters of the selected muscle")
        self.param_form = QtWidgets.QFormLayout(self.param_group)
        self.param_error = _error_label()
        self.param_widgets: dict[str, QtWidgets.QAbstractSpinBox] = {}
        self.option_widgets: dict[str, QtWidgets.QWidget] = {}  # a QCheckBox or a QComboBox
        form.addWidget(self.param_group)

        probe = QtWidgets.QGroupBox("Probe (right-click the skin)")
        box = QtWidgets.QVBoxLayout(probe)
        self.probe_label = QtWidgets.QLabel(PROBE_HINT)
        self.probe_label.setWordWrap(True)
        self.probe_label.setTextInteractionFlags(QtCore.Qt.TextSelectableByMouse)
        box.addWidget(self.probe_label)
        self.probe_table = QtWidgets.QTableWidget(len(FIELD_NAMES), 1)
        self.probe_table.setHorizontalHeaderLabels(["total"])
        self.probe_table.setVerticalHeaderLabels(
            [_field_label(f, self.session.unit) for f in FIELD_NAMES])
        self.probe_table.setVerticalScrollBarPolicy(QtCore.Qt.ScrollBarAlwaysOff)
        self.probe_table.setEditTriggers(QtWidgets.QAbstractItemView.NoEditTriggers)
        box.addWidget(self.probe_table)
        form.addWidget(probe)
        form.addStretch(1)
        # scrolled, so that a long parameter panel never makes the window grow
        scroll = QtWidgets.QScrollArea()
        scroll.setWidgetResizable(True)
        scroll.setFrameShape(QtWidgets.QFrame.NoFrame)
        scroll.setHorizontalScrollBarPolicy(QtCore.Qt.ScrollBarAlwaysOff)
        scroll.setWidget(panel)
        self.control_scroll = scroll
        self._guard_wheel(panel)
        scroll.setMinimumWidth(panel.minimumSizeHint().width()
                               + scroll.verticalScrollBar().sizeHint().width())
        dock.setWidget(scroll)
        self.addDockWidget(QtCore.Qt.LeftDockWidgetArea, dock)
        self.probe_point: SurfacePoint | None = None  # on the rest skin
        self._fit_probe_table()
        self._build_muscle_dock()

    def _build_muscle_dock(self) -> None:
        self.add_menu = QtWidgets.QMenu("&Add muscle", self)
        for name in muscle_types():
            self.add_menu.addAction(name).triggered.connect(_weak(self.add_muscle, name))
        add = self.add_menu.menuAction()
        add.setToolTip("Add a muscle of a type, inserted at the probed point (right-click "
                       "the skin first) or at the middle of the skin view")
        self.edit_actions = {"add": add}
        for key, text, shortcut, slot in (
                ("delete", "&Delete", "Del", self.delete_muscle),
                ("duplicate", "D&uplicate", "Ctrl+D", self.duplicate_muscle),
                ("rename", "&Rename...", "F2", self.rename_dialog),
                ("mirror", "&Mirror", "Ctrl+M", self.mirror_muscle),
                ("mirror_pair", "Mirror &pair", "Ctrl+Shift+M", self.mirror_pair)):
            action = QtGui.QAction(text, self)
            action.setShortcut(QtGui.QKeySequence(shortcut))
            action.triggered.connect(_weak(slot))
            self.edit_actions[key] = action
        self.edit_actions["mirror"].setToolTip(
            "Copy the muscle to the other side of the face's symmetry plane, replacing its "
            "twin (_L <-> _R) if there is one")
        self.edit_actions["mirror_pair"].setToolTip(
            "Mirror the muscle and its twin together: each side takes the mirror image of "
            "the other")
        dock = QtWidgets.QDockWidget("Muscles", self)
        dock.setObjectName("muscles")
        self.muscle_panel = MuscleListPanel(list(self.edit_actions.values()))
        self.muscle_panel.selected.connect(self._on_list_selected)
        dock.setWidget(self.muscle_panel)
        self.addDockWidget(QtCore.Qt.LeftDockWidgetArea, dock)

    def _build_menus(self) -> None:
        file_menu = self.menuBar().addMenu("&File")
        self._action(file_menu, "&Open layout...", "Ctrl+O", self.open_dialog)
        self._action(file_menu, "&New face from mesh...", "Ctrl+N",
                     _weak(self.newface.new_face_dialog))
        self._action(file_menu, "&Save layout", "Ctrl+S", self.save)
        self._action(file_menu, "Save layout &as...", "Ctrl+Shift+S", self.save_as_dialog)
        self._action(file_menu, "&Import performance...", "Ctrl+I",
                     self.import_performance_dialog)
        self.recent_menu = file_menu.addMenu("Open &recent")
        self._action(file_menu, "&Export screenshot...", "Ctrl+P", self.screenshot_dialog)
        self._action(file_menu, "Save view &image...", "Ctrl+Shift+P", self.image_dialog)
        file_menu.addSeparator()
        self._action(file_menu, "&Quit", "Ctrl+Q", self.close)
        edit_menu = self.menuBar().addMenu("&Edit")
        undo = self.undo_stack.createUndoAction(self, "&Undo")
        undo.setShortcut(QtGui.QKeySequence.Undo)
        redo = self.undo_stack.createRedoAction(self, "&Redo")
        redo.setShortcut(QtGui.QKeySequence.Redo)
        edit_menu.addActions([undo, redo])
        edit_menu.addSeparator()
        edit_menu.addMenu(self.add_menu)
        edit_menu.addActions([self.edit_actions[k] for k in
                              ("delete", "duplicate", "rename", "mirror", "mirror_pair")])
        add_mapping_action(self, edit_menu)  # Edit > Track mapping... (app/mapping.py)
        self._build_face_menu()
        view_menu = self.menuBar().addMenu("&View")
        for name, key in (("front", "1"), ("three_quarter", "2"), ("side", "3"),
                          ("forehead", "4"), ("upper_face", "5")):
            self._action(view_menu, f"Camera: {name.replace('_', ' ')}", key,
                         _weak(self.set_camera, name))
        self._action(view_menu, "Play / pause", "Space", self.play_button.toggle)
        self.aa_action = view_menu.addAction("&Anti-aliasing (slower drawing)")
        self.aa_action.setCheckable(True)
        self.aa_action.setChecked(self.settings.value("antialiasing", False, type=bool))
        self.aa_action.toggled.connect(self.set_anti_aliasing)
        self.set_anti_aliasing(self.aa_action.isChecked())
        self.raking_action = view_menu.addAction("&Raking light")
        self.raking_action.setShortcut(QtGui.QKeySequence("L"))
        self.raking_action.setToolTip("Light the skin from above and to the side at a grazing "
                                      "angle: shallow furrows show on plain skin")
        self.raking_action.setCheckable(True)
        self.raking_action.setChecked(self.settings.value("raking_light", False, type=bool))
        self.raking_action.toggled.connect(self.set_raking_light)
        self.views.set_raking_light(self.raking_action.isChecked())
        help_menu = self.menuBar().addMenu("&Help")
        self._action(help_menu, "&Guide", "F1", self.show_guide)
        self._action(help_menu, "&Keyboard shortcuts", "Ctrl+/", self.show_shortcuts)
        self._update_recent_menu()

    def _build_face_menu(self) -> None:
        """Face: the built-in faces, a new face from a mesh, its landmarks picked again."""
        from wrinkle_vis.datasets import FACES

        menu = self.menuBar().addMenu("F&ace")
        self.face_actions = {}
        group = QtGui.QActionGroup(menu)  # the face shown is checked (none: a scan's)
        group.setExclusionPolicy(QtGui.QActionGroup.ExclusionPolicy.ExclusiveOptional)
        for name in FACES:
            action = menu.addAction(FACE_LABELS.get(name, name.replace("_", " ").title()))
            action.setCheckable(True)
            group.addAction(action)
            action.setToolTip(f"Show the built-in face load_face({name!r})")
            action.triggered.connect(_weak(self.open_builtin, name))
            self.face_actions[name] = action
        menu.addSeparator()
        self._action(menu, "New face from mesh...", "", _weak(self.newface.new_face_dialog))
        menu.addAction(self.newface.actions["again"])

    def open_builtin(self, name: str) -> bool:
        """Show built-in face ``name`` (:data:`wrinkle_vis.datasets.FACES`), after asking
        about unsaved changes.
        """
        from wrinkle_vis.datasets import load_face

        if not self.may_discard_changes(f"opening the {name} face"):
            self._mark_face()  # the menu's click checked the face not shown
            return False
        try:
            face = load_face(name)
        except (OSError, ValueError, KeyError) as exc:
            QtWidgets.QMessageBox.warning(self, "Cannot open the face", str(exc))
            self._mark_face()
            return False
        named = None if name == "procedural" else name  # the layout records the face
        self._show_session(Session(face, layout=Layout(face=named, unit=face.unit)))
        self.recovery.discard()
        return True

    def _action(self, menu, text, shortcut, slot) -> QtGui.QAction:
        action = menu.addAction(text)
        action.setShortcut(QtGui.QKeySequence(shortcut))
        action.triggered.connect(slot)
        return action

    # ------------------------------------------------------------------ filling
    def _populate(self) -> None:
        s = self.session
        self._updating_controls = True
        try:
            self.expression_box.clear()
            self.expression_box.addItems(list(s.face.expressions) + (
                [s.performance.name] if s.performance is not None else []))
            self.expression_box.setCurrentText(s.expression)
            self.intensity_slider.setValue(round(100 * s.intensity))
            self.time_slider.setValue(self._slider_for_time(s.time_s))
            self.muscle_box.clear()
            self.muscle_box.addItems([TOTAL, *s.face.muscle_names])
            self.muscle_box.setCurrentText(s.muscle or TOTAL)
            self.field_box.setCurrentText(PLAIN if self.plain_skin else s.field)
            self.probe_table.setVerticalHeaderLabels(
                [_field_label(f, s.unit) for f in FIELD_NAMES])
        finally:
            self._updating_controls = False
        self.muscle_panel.set_muscles(s.face.muscle_names, s.muscle)
        self._update_edit_actions()
        self._build_parameter_panel()
        self._sync_skin_controls()

    def _update_edit_actions(self) -> None:
        for key in ("delete", "duplicate", "rename", "mirror"):
            self.edit_actions[key].setEnabled(self.session.muscle is not None)
        self.edit_actions["mirror_pair"].setEnabled(
            self.session.muscle is not None
            and self.session.twin_of(self.session.muscle) is not None)

    def _sync_parameter_panel(self) -> None:
        """Show the selected muscle's values: in place when the panel already shows that
        muscle's type (an undo, a redo or a drag), else built again.
        """
        name = self.session.muscle
        muscle = self.session.face.muscle(name) if name is not None else None
        if muscle is None or self._panel_for != (name, muscle.type_name):
            self._build_parameter_panel()
            return
        for param, widget in self.param_widgets.items():
            widget.blockSignals(True)
            _show_value(widget, muscle.resolved(param))
            widget.blockSignals(False)
        for param, widget in self.option_widgets.items():
            _show_option(widget, getattr(muscle, param))
        self._show_activation()
        self._show_derived()

    def _build_parameter_panel(self) -> None:
        name = self.session.muscle
        self._panel_for = None if name is None else (
            name, self.session.face.muscle(name).type_name)
        while self.param_form.rowCount():
            self.param_form.removeRow(0)  # deletes the rows' widgets, the error label too
        self.param_error = _error_label()
        self.param_widgets = {}
        if name is None:
            self.param_form.addRow(QtWidgets.QLabel("Choose a muscle to edit it."))
            return
        muscle = self.session.face.muscle(name)
        for spec in editable(muscle):  # what the type declares (core.params)
            w = _parameter_box(spec, self.session.unit)
            _show_value(w, muscle.resolved(spec.name))
            w.setKeyboardTracking(False)
            w.valueChanged.connect(_weak(self.set_parameter, spec.name, keep=1))
            w.installEventFilter(self._undo_keys)  # Ctrl+Z undoes the edit, not the typing
            self.param_widgets[spec.name] = w
            self.param_form.addRow(spec.display, w)
        self.option_widgets = {}
        for spec in muscle.options():  # every type has them, declared in core.muscle
            if spec.is_flag:
                w = QtWidgets.QCheckBox()
                w.toggled.connect(_weak(self._on_option, spec.name, keep=1))
            else:
                w = QtWidgets.QComboBox()
                for value, text in spec.labelled_choices.items():
                    w.addItem(text, value)
                w.currentIndexChanged.connect(_weak(self._on_option, spec.name, keep=1))
            w.setToolTip(spec.doc)
            _show_option(w, getattr(muscle, spec.name))
            self.option_widgets[spec.name] = w
            self.param_form.addRow(spec.display, w)
        self.activation_box = QtWidgets.QDoubleSpinBox()
        self.activation_box.setRange(0.0, 1.0)
        self.activation_box.setSingleStep(0.05)
        self.activation_box.setKeyboardTracking(False)
        self.activation_box.setToolTip(
            "The muscle's peak activation in the expression shown: an edit of the layout "
            "(undoable, saved with it); 0 takes the muscle out of the expression")
        self.activation_box.installEventFilter(self._undo_keys)
        self._show_activation()
        self.activation_box.valueChanged.connect(self.set_activation)
        self.param_form.addRow("activation", self.activation_box)
        self.derived_label = QtWidgets.QLabel()
        self.param_form.addRow("derived", self.derived_label)
        self.param_form.addRow(self.param_error)
        self._show_derived()
        self._guard_wheel(self.param_group)

    def _guard_wheel(self, root: QtWidgets.QWidget) -> None:
        """The wheel edits the value controls under ``root`` only once they have the focus
        (a click or Tab gives it; the wheel does not): over an unfocused one it scrolls the
        panel, so scrolling through the controls edits nothing.
        """
        kinds = (QtWidgets.QAbstractSpinBox, QtWidgets.QComboBox, QtWidgets.QAbstractSlider)
        for w in root.findChildren(QtWidgets.QWidget):
            if not isinstance(w, kinds) or isinstance(w, QtWidgets.QScrollBar):
                continue  # a scroll bar (the probe table's) scrolls
            w.setFocusPolicy(QtCore.Qt.StrongFocus)
            w.installEventFilter(self._wheel_guard)

    def _show_derived(self) -> None:
        if self.session.muscle is not None:
            d = self.session.derived(self.session.muscle)
            unit = self.session.unit
            self.derived_label.setText(f"d = {d['d']:.4g} {unit}   u = {d['u']:.4g} {unit}")

    def _show_activation(self) -> None:
        """Show the selected muscle's peak activation in the expression (no signal)."""
        s = self.session
        if s.muscle is None or not hasattr(self, "activation_box"):
            return
        value = s.current_expression().activations.get(s.muscle, 0.0)
        self.activation_box.blockSignals(True)
        self.activation_box.setValue(value)
        self.activation_box.blockSignals(False)

    # ------------------------------------------------------------------ slots
    def _on_expression(self, name: str) -> None:
        if not self._updating_controls and name:
            self.session.set_expression(name)
            self.refresh()

    def _on_intensity(self, value: int) -> None:
        if not self._updating_controls:
            self.session.set_intensity(value / 100)
            self.refresh()

    def _on_time(self, value: int) -> None:
        if not self._updating_controls:
            ex = self.session.current_expression()
            self.session.set_time(value / TIMELINE_STEPS * ex.duration_s)
            if self.track_plot is not None:
                self.track_plot.set_time(self.session.time_s)
            self.refresh()

    def _slider_for_time(self, t: float | None) -> int:
        """Timeline position of ``t`` (None, the peak: the middle of the plateau)."""
        ex = self.session.current_expression()
        if t is None:
            t = ex.onset_s + 0.5 * ex.hold_s
        return round(TIMELINE_STEPS * t / ex.duration_s) if ex.duration_s > 0 else 0

    def _on_refine(self, on: bool) -> None:
        self.session.set_refine(on)
        self.refresh()

    def _on_play(self, playing: bool) -> None:
        self.play_button.setText("Pause" if playing else "Play")
        if playing:
            self._play_start = (self.time_slider.value(), time.perf_counter())
            if self.session.face.skin_model == "physical":
                self.session.play(self.clock())  # the simulation (app.physics)
                self._show_time()
            self.timer.start()
        else:
            self.timer.stop()
            self.session.pause()  # a simulation keeps its state
        self.refresh()  # the colour range: over the ramp while playing, else the frame's

    def _on_range_mode(self, mode: str) -> None:
        """Colour range automatic, or fixed at min and max (which start at the range shown)."""
        fixed = mode == "fixed"
        for box in (self.range_min, self.range_max):
            box.setEnabled(fixed)
        if fixed:
            lo, hi = self.views.scalar_range() or self.session.colour_range()
            for box, value in ((self.range_min, lo), (self.range_max, hi)):
                box.blockSignals(True)
                box.setValue(value)
                box.blockSignals(False)
            self._on_range_value()
        else:
            self.session.set_fixed_range(None)
            self.range_error.setText("")
            self.refresh()

    def _on_range_value(self, _=None) -> None:
        lo, hi = self.range_min.value(), self.range_max.value()
        try:
            self.session.set_fixed_range((lo, hi))
        except ValueError as exc:
            self.range_error.setText(str(exc))  # the range in use stays
            return
        self.range_error.setText("")
        self.refresh()

    def colour_range(self) -> tuple[float, float] | None:
        """The colour range the skin view uses now: the fixed one; while playing, the one
        over the expression's whole ramp (so the ramp shows); else None, each frame's own.
        """
        s = self.session
        if s.fixed_range is not None:
            return s.fixed_range
        if not self.timer.isActive() or self.plain_skin:
            return None
        key = (s.face, s.expression, s.intensity, s.field, s.muscle,
               tuple(sorted(s.overrides.items())))
        if self._ramp[0] != key:
            self._ramp = (key, s.ramp_range())
        return self._ramp[1]

    def _tick(self) -> None:
        """Play: move the timeline to where the expression is now (a frame is drawn when
        the position changes; one that took long skips positions).
        """
        if self.session.face.skin_model == "physical":
            self._tick_physical()
            return
        start, t0 = self._play_start
        ex = self.session.current_expression()
        self.time_slider.setValue(playback_position(start, time.perf_counter() - t0,
                                                    ex.duration_s))

    # ------------------------------------------------------------------ physical skin
    def _build_skin_controls(self, view: QtWidgets.QFormLayout,
                             form: QtWidgets.QVBoxLayout) -> None:
        """The skin-model switch (a row of ``view``) and the physical skin's material, one
        box per parameter that :class:`~wrinkle_vis.core.skin.SkinMaterial` declares (as
        the muscles' boxes are made from their types' declarations).
        """
        self.skin_box = QtWidgets.QComboBox()
        self.skin_box.addItems(list(SKIN_MODELS))
        self.skin_box.setToolTip("geometric: the muscles' pulls, each frame on its own; "
                                 "physical: a simulated mass-spring skin bound to the skull "
                                 "(Play runs it in real time; still frames show its "
                                 "equilibrium)")
        self.skin_box.currentTextChanged.connect(_weak(self.set_skin_model, keep=1))
        view.insertRow(view.rowCount() - 1, "Skin", self.skin_box)  # above the range error
        self.skin_group = QtWidgets.QGroupBox("Physical skin")
        skin_form = QtWidgets.QFormLayout(self.skin_group)
        self.skin_widgets: dict[str, QtWidgets.QAbstractSpinBox] = {}
        for spec in SkinMaterial.parameters():  # what the material declares (core.params)
            w = _parameter_box(spec, self.session.unit)
            w.setKeyboardTracking(False)
            w.valueChanged.connect(_weak(self.set_material, spec.name, keep=1))
            w.installEventFilter(self._undo_keys)  # Ctrl+Z undoes the edit, not the typing
            self.skin_widgets[spec.name] = w
            skin_form.addRow(spec.display, w)
        self.skin_error = _error_label()
        skin_form.addRow(self.skin_error)
        form.addWidget(self.skin_group)

    def _sync_skin_controls(self) -> None:
        """Show the face's skin model and material (no signal); the material and Reset
        only on the physical skin.
        """
        face = self.session.face
        physical = face.skin_model == "physical"
        self.skin_box.blockSignals(True)
        self.skin_box.setCurrentText(face.skin_model)
        self.skin_box.blockSignals(False)
        for name, w in self.skin_widgets.items():
            w.blockSignals(True)
            w.setValue(getattr(face.material, name))
            w.blockSignals(False)
        self.skin_group.setVisible(physical)
        self.reset_button.setEnabled(physical)

    def set_skin_model(self, skin_model: str) -> bool:
        """Evaluate the face with ``skin_model`` ("geometric" or "physical"): an undoable
        edit of the layout (saved as its ``skin_model``).
        """
        if skin_model == self.session.face.skin_model:
            return False
        self.edit(f"Use the {skin_model} skin", self.session.with_skin_model(skin_model))
        return True

    def set_material(self, param: str, value) -> bool:
        """Set one parameter of the physical skin's material (an undoable edit, saved as
        the layout's ``skin_material``); an invalid value is refused with its reason shown
        under the panel, and the box is put back.
        """
        spec = {p.name: p for p in SkinMaterial.parameters()}[param]
        value = int(value) if spec.unit == "count" else float(value)
        try:
            face = self.session.with_material(param, value)
        except ValueError as exc:
            self.skin_error.setText(str(exc))
            self._sync_skin_controls()
            return False
        self.skin_error.setText("")
        self.edit(f"Set {spec.label} of the skin to {value:g}", face)
        return True

    def reset_simulation(self) -> None:
        """Physical skin: back to rest at t = 0 (playing on if playing)."""
        if self.session.face.skin_model != "physical":
            return
        self.session.reset_simulation()
        self._show_time()
        self.refresh()

    def _tick_physical(self) -> None:
        """Play on the physical skin: advance the simulation by the wall-clock time since
        the last tick (:meth:`PhysicalPlayback.tick`) and draw it if it moved.
        """
        s = self.session
        if not s.physics.playing:  # switched to the physical skin, or a layout opened
            s.play(self.clock())
        if s.tick(self.clock()):
            self._show_time()
            self.refresh()

    def _show_time(self) -> None:
        """Put the timeline at the session's time without a scrub."""
        self._updating_controls = True
        try:
            self.time_slider.setValue(self._slider_for_time(self.session.time_s))
        finally:
            self._updating_controls = False
        if self.track_plot is not None:
            self.track_plot.set_time(self.session.time_s)

    def _on_field(self, _=None) -> None:
        if self._updating_controls:
            return
        field = self.field_box.currentText()
        muscle = self.muscle_box.currentText()
        muscle = None if muscle in ("", TOTAL) else muscle
        self.plain_skin = field == PLAIN
        if self.plain_skin:  # the session keeps a field for the probe and a switch back
            field = self.session.field if muscle is not None else "W"
        elif muscle is None and not field_info(field).total:
            self._updating_controls = True
            self.field_box.setCurrentText("W")
            self._updating_controls = False
            self.statusBar().showMessage(
                f"{field} belongs to one muscle: choose the muscle first (in the Muscle box "
                f"or the list); only W has a total", 10000)
            field = "W"
        changed_muscle = muscle != self.session.muscle
        self.session.set_field(field, muscle)
        if changed_muscle:
            self.muscle_panel.set_current(muscle)
            self._update_edit_actions()
            self._build_parameter_panel()
        self.refresh()

    def select_muscle(self, name: str | None) -> None:
        """Select a muscle (None: none): its fields, parameters and placement widget show."""
        self.muscle_box.setCurrentText(name or TOTAL)

    def set_parameter(self, param: str, value) -> bool:
        """Set a parameter of the selected muscle; an invalid value is refused with its
        reason shown under the panel, and the field is put back.
        """
        name = self.session.muscle
        option = param in self.option_widgets
        muscle = self.session.face.muscle(name)
        if not option:
            value = int(value) if muscle.parameter(param).unit == "count" else float(value)
        try:
            face = self.session.with_parameter(name, param, value)
        except (MuscleParameterError, ValueError) as exc:
            self.param_error.setText(self._labelled(str(exc)))
            old = getattr(self.session.face.muscle(name), param)
            if option:
                _show_option(self.option_widgets[param], old)
                return False
            widget = self.param_widgets[param]
            widget.blockSignals(True)
            _show_value(widget, muscle.resolved(param))
            widget.blockSignals(False)
            return False
        self.param_error.setText("")
        shown = ("on" if value else "off") if isinstance(value, bool) else (
            value if isinstance(value, str) else f"{value:g}")
        self.edit(f"Set {self._labels().get(param, param)} of {name} to {shown}", face)
        return True

    def _labels(self) -> dict[str, str]:
        """The selected muscle's parameters as the panel labels them."""
        name = self.session.muscle
        muscle = self.session.face.muscle(name) if name else None
        specs = (*editable(muscle), *muscle.options()) if muscle is not None else ()
        return {p.name: p.display for p in specs}

    def _labelled(self, message: str) -> str:
        """``message`` with the parameters called by the labels the panel shows them under
        (``parameter max_angle_deg = 95`` -> ``Φ (deg) = 95``).
        """
        labels = self._labels()
        message = re.sub(r"\bparameter (\w+) =",
                         lambda m: f"{labels.get(m.group(1), m.group(1))} =", message)
        for param, label in labels.items():
            if "_" in param and param != label:  # a name no word of the prose has
                message = re.sub(rf"\b{param}\b", label, message)
        return message

    def _on_option(self, param: str, value) -> None:
        """An option's check box (bool) or combo box (an index) changed."""
        widget = self.option_widgets[param]
        if isinstance(widget, QtWidgets.QComboBox):
            value = widget.itemData(value)
        self.set_parameter(param, bool(value) if isinstance(
            widget, QtWidgets.QCheckBox) else value)

    def set_activation(self, value: float) -> None:
        """Set the selected muscle's peak activation in the expression shown: one undoable
        edit of the layout (0 takes the muscle out of the expression).
        """
        s = self.session
        if self._updating_controls or s.muscle is None:
            return
        try:
            face = s.with_activation(s.muscle, float(value))
        except ValueError as exc:
            self.param_error.setText(str(exc))
            self._show_activation()
            return
        self.edit(f"Set activation of {s.muscle} in {s.expression} to {value:g}", face)

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
        self.probe_at(self.session.surface_point(point, cell))
        self.views.render_skin()  # the marker where the click was

    def probe_vertex(self, vertex: int) -> dict:
        """Probe skin vertex ``vertex`` of the face (at rest); returns the values shown."""
        return self.probe_at(self.session.vertex_point(vertex))

    def probe_at(self, where: SurfacePoint) -> dict:
        """Probe rest-skin point ``where``: kept there (the frame's values at it, shown
        again every frame, whatever the expression, the edits or the refinement), with a
        marker on the skin view, its coordinates and every field of the total and of each
        muscle that defines anything there (the selected one first); returns the values.
        """
        self.probe_point = where
        s = self.session
        values = s.probe(where)
        rest, now = s.probe_position(where)
        self._show_probe_marker(now)
        unit = s.unit
        frame = "".join(f"\n{k}: {values['total'][k]:.3g}" for k in FRAME_FIELDS)
        self.probe_label.setText(f"at rest ({_xyz(rest)}) {unit}\nnow ({_xyz(now)}) {unit}"
                                 + frame)  # the frame's fields: where the fold guard acted
        muscles = [m for m in values if m != "total"]
        if s.muscle in muscles:
            muscles.remove(s.muscle)
            muscles.insert(0, s.muscle)
        table = self.probe_table
        table.setColumnCount(1 + len(muscles))
        table.setHorizontalHeaderLabels(["total", *muscles])
        table.setVerticalHeaderLabels([_field_label(f, unit) for f in FIELD_NAMES])
        for row, field in enumerate(FIELD_NAMES):
            for col, column in enumerate(["total", *muscles]):
                if column == "total" and field not in values["total"]:
                    text = ""  # no total of this field
                else:
                    v = values[column][field]
                    text = "undefined" if not np.isfinite(v) else f"{v:.5g}"
                table.setItem(row, col, QtWidgets.QTableWidgetItem(text))
        if s.muscle in muscles:
            font = table.horizontalHeaderItem(1).font()
            font.setBold(True)
            table.horizontalHeaderItem(1).setFont(font)
        table.resizeColumnsToContents()
        self._fit_probe_table()
        return values

    def clear_probe(self) -> None:
        """Probe nothing: the marker goes, the table empties."""
        self.probe_point = None
        self.views.show_probe(None, 0.0)
        self.probe_label.setText(PROBE_HINT)
        self.probe_table.setColumnCount(1)
        self.probe_table.setHorizontalHeaderLabels(["total"])
        self.probe_table.clearContents()
        self._fit_probe_table()

    def _show_probe_marker(self, point) -> None:
        lo, hi = self.session.face.skin.bounds()
        self.views.show_probe(point, PROBE_MARKER * float(np.linalg.norm(hi - lo)))

    def _fit_probe_table(self) -> None:
        """Make the probe table as tall as its rows: all of them show, none scrolls."""
        table = self.probe_table
        table.resizeRowsToContents()
        height = (table.horizontalHeader().sizeHint().height() + 2 * table.frameWidth()
                  + sum(table.rowHeight(r) for r in range(table.rowCount())))
        if table.horizontalScrollBar().isVisible() or table.columnCount() > 2:
            height += table.horizontalScrollBar().sizeHint().height()
        table.setFixedHeight(height)

    # ------------------------------------------------------------------ editing
    def edit(self, text: str, face, select=KEEP, before=None) -> None:
        """Show ``face`` as one undoable step called ``text``; ``select`` the muscle to
        select after it (default: keep the selection); ``before`` the face to go back to
        (default: the one shown; a drag has shown its steps already).
        """
        before = self.session.face if before is None else before
        keep = self.session.muscle
        after_select = keep if select is KEEP else select
        self.undo_stack.push(FaceCommand(self, text, before, face, keep, after_select))

    def show_face(self, face, select: str | None = None) -> None:
        """Show a version of the face and select ``select`` (an undo or a redo)."""
        s = self.session
        self.param_error.setText("")  # a refusal is about the version left behind
        if face is s.face and select == s.muscle and self._drawn_face is face:
            return  # a drag's end: already on screen
        names_changed = face.muscle_names != s.face.muscle_names
        field = s.field
        s.set_face(face)
        if select is not None and select in face.muscle_names:
            s.set_field(field, select)
        elif select is None and s.muscle is not None:
            s.set_field("W", None)
        if names_changed or self.muscle_box.currentText() != (s.muscle or TOTAL):
            self._populate()
        else:
            self._sync_parameter_panel()
            self._sync_skin_controls()
        self.refresh()

    def _on_clean_changed(self, clean: bool) -> None:
        self.session.dirty = not clean
        self._update_title()
        self._schedule_autosave()

    def _on_list_selected(self, name: str) -> None:
        self.select_muscle(name or None)

    def _selected_or_warn(self) -> str | None:
        if self.session.muscle is None:
            self.statusBar().showMessage("Select a muscle first (in the list, or click it)")
        return self.session.muscle

    def add_muscle(self, type_name: str) -> str | None:
        """Add a muscle of ``type_name`` at the probed point (or the middle of the skin
        view) and select it; returns its name, or None if the type cannot make one.
        """
        at = self._placement_point()
        try:
            face, name = self.session.added(type_name, at)
        except (NotImplementedError, MuscleParameterError, ValueError, KeyError) as exc:
            QtWidgets.QMessageBox.warning(self, "Cannot add muscle", str(exc))
            return None
        self.edit(f"Add {name}", face, select=name)
        return name

    def _placement_point(self):
        """Where a new muscle goes: the probed vertex (at rest), else the middle of the
        skin view, else the front of the face.
        """
        skin = self.session.face.skin
        if self.probe_point is not None:
            return self.session.probe_position(self.probe_point)[0]
        picker = vtkPropPicker()
        w, h = self.skin_view.render_window.GetSize()
        if picker.Pick(w / 2, h / 2, 0, self.skin_view.renderer):
            return np.array(picker.GetPickPosition())
        return skin.points[np.argmax(skin.points[:, 2])]

    def delete_muscle(self) -> None:
        """Delete the selected muscle."""
        name = self._selected_or_warn()
        if name is not None:
            self.edit(f"Delete {name}", self.session.deleted(name), select=None)

    def duplicate_muscle(self) -> str | None:
        """Copy the selected muscle under a free name and select the copy."""
        name = self._selected_or_warn()
        if name is None:
            return None
        face, copy = self.session.duplicated(name)
        self.edit(f"Duplicate {name}", face, select=copy)
        return copy

    def rename_muscle(self, new_name: str) -> bool:
        """Rename the selected muscle; a bad name is refused with the reason."""
        name = self._selected_or_warn()
        if name is None:
            return False
        try:
            face = self.session.renamed(name, new_name)
        except (ValueError, MuscleParameterError) as exc:
            QtWidgets.QMessageBox.warning(self, "Cannot rename", str(exc))
            return False
        self.edit(f"Rename {name} to {new_name.strip()}", face, select=new_name.strip())
        return True

    def rename_dialog(self) -> None:
        """Ask for a new name for the selected muscle."""
        name = self._selected_or_warn()
        if name is not None:
            text, ok = ask_text(self, "Rename muscle", f"New name for {name}:", name)
            if ok and text != name:
                self.rename_muscle(text)

    def mirror_muscle(self) -> str | None:
        """Mirror the selected muscle across the face's symmetry plane (see
        :meth:`Session.mirrored`); returns the twin's name.
        """
        return self._mirror(self.session.mirrored, "Cannot mirror", "Mirror {} to {}")

    def mirror_pair(self) -> str | None:
        """Mirror the selected muscle and its twin together (see
        :meth:`Session.mirrored_pair`); returns the twin's name.
        """
        return self._mirror(self.session.mirrored_pair, "Cannot mirror the pair",
                            "Mirror the pair {} and {}")

    def _mirror(self, build, title: str, text: str) -> str | None:
        """Apply ``build(name) -> (face, twin)`` to the selected muscle as one undoable step
        called ``text.format(name, twin)``; a refusal is shown under ``title``.
        """
        name = self._selected_or_warn()
        if name is None:
            return None
        try:
            face, twin = build(name)
        except (MuscleParameterError, ValueError) as exc:
            QtWidgets.QMessageBox.warning(self, title, str(exc))
            return None
        if self.session.same_muscles(face):  # already mirror images: nothing to undo
            self.statusBar().showMessage(f"{name} and {twin} are mirror images already; "
                                         "nothing changed", 5000)
            return twin
        if name in face.muscle_names:
            self.edit(text.format(name, twin), face)
        else:  # a muscle without a side was named for its side: X -> X_L, twin X_R
            sided = mirror_name(twin)
            self.edit(f"{text.format(name, twin)} (and name it {sided})", face,
                      select=sided)
        return twin

    # ------------------------------------------------------------------ placement
    @property
    def placement(self):
        """The selected muscle's placement widget (None when no muscle is selected)."""
        return self.views.placement

    def _on_handle_start(self, handle) -> None:
        self._drag_before = self.session.face
        self.views.begin_drag()

    def _on_handle_moved(self, handle, point, finished: bool) -> None:
        """A handle moved to rest position ``point``: move the muscle's point there and
        redraw (an invalid position is refused with the reason, the handle put back); the
        whole drag is one undo step.
        """
        s = self.session
        name = self.placement.muscle.name
        try:
            new = with_point(s.face.muscle(name), handle.param, handle.index, point)
        except MuscleParameterError as exc:
            self.param_error.setText(self._labelled(str(exc)))
            self.statusBar().showMessage(f"Refused: {self._labelled(str(exc))}", 10000)
            self.placement.update(s.face.muscle(name), s.state())
            self._sync_views()
        else:
            self.param_error.setText("")
            s.set_face(s.face.with_muscle(new))
            self._show_derived()
            # the handle's own view is rendered by its widget right after this callback
            self.refresh(skip=() if finished else (self.placement.views[handle.layer],))
        if finished:
            self.views.end_drag()
            self.views.render()
            before, self._drag_before = self._drag_before, None
            if before is not None and before is not s.face:
                self.edit(f"Move {handle.label} of {name}", s.face, before=before)

    # ------------------------------------------------------------------ drawing
    def refresh(self, reset_camera: bool = False, skip=()) -> None:
        """Recompute the frame and redraw the three views (less the plotters in ``skip``)."""
        t0 = time.perf_counter()
        s = self.session
        state = s.state()
        self._syncing = True  # one render per view at the end, not one per change
        try:
            # the drawn meshes can be updated in place only on the same triangles
            if reset_camera:
                self.views.invalidate()
            self.views.draw(s, state, wireframe=self.wireframe_box.isChecked(),
                            plain=self.plain_skin, clim=self.colour_range(), unit=s.unit)
            self._drawn_face = s.face
            if reset_camera:
                set_camera(self.skin_view, "front", s.face)
        finally:
            self._syncing = False
        self._show_activation()
        if self.probe_point is not None:
            if self.probe_point.triangle < s.face.skin.n_triangles:
                self.probe_at(self.probe_point)  # the same rest point, this frame
            else:
                self.clear_probe()
        self.views.render(only_changed=not reset_camera, skip=skip)
        total_ms = 1e3 * (time.perf_counter() - t0)
        self.status_label.setText(
            f"{s.expression} x {s.intensity:.2f}"
            f"{'' if s.time_s is None else f' at {s.time_s:.2f} s'}  |  W in "
            f"[{state.W.min():.3g}, {state.W.max():.3g}] {s.unit}  |  frame "
            f"{s.frame_ms:.2f} ms, drawn in {total_ms:.1f} ms  |  "
            f"{_triangles(len(state.triangles), s.face.skin.n_triangles)}"
            f"{'  |  ⚠ aliased wrinkles: refine' if (note := s.undersampled_note(state)) else ''}"
            + _skin_status(s))
        self.status_label.setToolTip(f"Warning: {note}" if note else "")
        self._update_title()

    def active_array(self) -> str | None:
        """The point array the skin view colours by (None: plain skin)."""
        if self.plain_skin:
            return None
        return field_array_name(self.session.field, self.session.muscle)

    def set_anti_aliasing(self, on: bool) -> None:
        """8x multisampling in the three views, or none (the default: in software rendering
        it costs about 2x per frame, see ``benchmarks/bench_drag.py``).
        """
        self.settings.setValue("antialiasing", bool(on))
        for p in self.plotters:
            if on:
                p.enable_anti_aliasing("msaa", multi_samples=8)
            else:
                p.disable_anti_aliasing()
        self._sync_views()

    def set_raking_light(self, on: bool) -> None:
        """Light the skin view with the raking light (on) or the light kit (off), as
        :func:`~wrinkle_vis.plotting.add_raking_light` describes; remembered in the settings.
        """
        self.settings.setValue("raking_light", bool(on))
        if self.raking_action.isChecked() != bool(on):
            self.raking_action.setChecked(bool(on))  # toggled() comes back here
            return
        self.views.set_raking_light(on)
        self.views.render(only_changed=True)

    def set_camera(self, name: str) -> None:
        """Move the shared camera to a named view."""
        set_camera(self.skin_view, name, self.session.face)
        self._sync_views()

    # ------------------------------------------------------------------ files
    def _update_title(self) -> None:
        self.setWindowTitle(face_title(self.session))
        self._mark_face()

    def _mark_face(self) -> None:
        """The Face menu checks the face shown; Pick landmarks again only on a scan's."""
        mark_face(self.face_actions, self.session)
        self.newface.actions["again"].setEnabled(can_pick_again(self.session))

    def may_discard_changes(self, doing: str = "going on") -> bool:
        """Whether the unsaved changes, if any, may be left behind: asks Save / Discard /
        Cancel (Save saves them first, and a failed or cancelled save is a Cancel). Picking
        a face's landmarks again while it has unsaved changes goes back to that face first.
        """
        self.newface.back_to_unsaved()
        if not self.session.dirty:
            return True
        answer = QtWidgets.QMessageBox.question(
            self, "Unsaved changes",
            f"The layout has unsaved changes. Save them before {doing}?",
            QtWidgets.QMessageBox.Save | QtWidgets.QMessageBox.Discard
            | QtWidgets.QMessageBox.Cancel, QtWidgets.QMessageBox.Save)
        if answer == QtWidgets.QMessageBox.Save:
            return self.save()
        return answer == QtWidgets.QMessageBox.Discard

    def open_layout(self, path: str | Path) -> bool:
        """Open a layout file (after asking about unsaved changes); a bad one is reported
        and the current face kept.
        """
        if not self.may_discard_changes("opening another layout"):
            return False
        current = self.session.layout()
        n = self.session.face.skin.n_triangles if current.skin is None and current.face in (
            None, "procedural") else None
        go_on, unit = self._unit_of_layout_mesh(Path(path))
        if not go_on:
            return False
        try:
            session = load_session(path, n_triangles=n, unit=unit)
            session.state()  # a face that cannot be evaluated is refused here, not later
        except (OSError, LayoutError, ValueError, KeyError) as exc:
            session = self._session_on_chosen_mesh(Path(path), exc)
            if session is None:
                return False
        # the mesh chosen for it is a change of the layout, unsaved
        self._show_session(session, modified=session.dirty)
        self.recovery.discard()  # what it held was saved or discarded just now
        self._remember(path)
        return True

    def _session_on_chosen_mesh(self, path: Path, exc: Exception) -> Session | None:
        """Layout ``path`` could not be opened (``exc``): when it has muscles but names no
        mesh (made for a scan, ``"skin": null``) or names one that is not there (moved),
        offer to choose the mesh it was made for; else report ``exc`` in one line. Returns
        the session on the chosen mesh, or None.
        """
        from wrinkle_vis.core.mesh import MeshError
        from wrinkle_vis.datasets import load_face, read_surface

        from .newface import MESH_FILTER, relative_mesh_path

        try:
            layout = load_layout(path)
        except (OSError, LayoutError, ValueError):
            layout = None
        missing = layout is not None and layout.skin is not None and not (
            layout.resolve("skin", path.parent).is_file())
        if layout is None or not layout.muscles or (layout.skin is not None and not missing):
            QtWidgets.QMessageBox.warning(self, "Cannot open layout", str(exc))
            return None
        why = (f"The layout's mesh {layout.skin} is not there (moved or renamed?)." if missing
               else "The layout names no mesh (\"skin\": null), and its muscles do not fit "
               "the built-in face.")
        box = QtWidgets.QMessageBox(
            QtWidgets.QMessageBox.Question, "Which mesh?",
            f"{exc}\n\n{why} Choose the mesh it was made for?", parent=self)
        choose = box.addButton("Choose mesh...", QtWidgets.QMessageBox.AcceptRole)
        box.addButton(QtWidgets.QMessageBox.Cancel)
        box.exec()
        chosen = box.clickedButton() is choose
        box.deleteLater()
        mesh = QtWidgets.QFileDialog.getOpenFileName(
            self, f"The mesh of {path.name}", str(path.parent), MESH_FILTER)[0] \
            if chosen else ""
        if not mesh:
            return None
        try:
            skin = read_surface(mesh)
        except (OSError, MeshError, ValueError) as err:
            QtWidgets.QMessageBox.warning(self, "Cannot open layout", f"{mesh}: {err}")
            return None
        unit = layout.unit or self.ask_unit(skin, Path(mesh).name)
        if unit is None:
            return None
        named = dataclasses.replace(layout, skin=relative_mesh_path(mesh, path.parent),
                                    unit=unit)
        try:
            session = Session(load_face(layout=layout, skin=skin, unit=unit), path,
                              layout=named)
            session.state()
        except (OSError, LayoutError, ValueError, KeyError) as err:
            QtWidgets.QMessageBox.warning(self, "Cannot open layout", f"{mesh}: {err}")
            return None
        session.dirty = True
        return session

    def _unit_of_layout_mesh(self, path: Path) -> tuple[bool, str | None]:
        """For layout ``path`` naming a mesh but no unit: ``(True, unit)`` with the unit
        guessed or asked (:meth:`ask_unit`), ``(False, None)`` when the question was
        cancelled; ``(True, None)`` for any other layout (or one that cannot be read: the
        opening reports it).
        """
        from wrinkle_vis.core.mesh import MeshError
        from wrinkle_vis.datasets import read_surface

        try:
            layout = load_layout(path)
            mesh = layout.resolve("skin", path.parent)
            if layout.unit is not None or mesh is None or not mesh.is_file():
                return True, None
            skin = read_surface(mesh)
        except (OSError, LayoutError, MeshError, ValueError):
            return True, None
        unit = self.ask_unit(skin, mesh.name)
        return unit is not None, unit

    def ask_unit(self, skin, what: str) -> str | None:
        """The unit of the coordinates of ``skin`` (a :class:`TriangleSurface`; ``what``
        names it): guessed from its height where that is a head's in one of the units
        (:func:`~wrinkle_vis.core.units.guess_unit`), else asked (None: cancelled), so a
        scan is never taken as millimetres without a word.
        """
        lo, hi = skin.bounds()
        height = float(hi[1] - lo[1])
        guess = guess_unit(height)
        if guess is not None:
            return guess
        units = list(LENGTH_UNITS)
        unit, ok = QtWidgets.QInputDialog.getItem(
            self, "Unit of the mesh",
            f"{what} is {height:.3g} units tall, not a head's height in m, cm or mm, so its "
            "unit cannot be guessed. In which unit are its coordinates?",
            units, units.index(DEFAULT_UNIT), False)
        return unit if ok else None

    def open_recent(self, path: str) -> bool:
        """Open a layout of the Open recent menu."""
        return self.open_layout(path)

    def _show_session(self, session: Session, modified: bool = False) -> None:
        """Show another session (a layout opened or restored), with the view's settings;
        ``modified``: it holds a change not saved yet (``*`` in the title, Quit asks).
        """
        session.refine = self.refine_box.isChecked()
        session.fixed_range = self.session.fixed_range
        self.session = session
        self.undo_stack.clear()  # clean again: the new session is not modified (so far)
        if modified:  # after the clear, whose cleanChanged would unmark it
            self.undo_stack.resetClean()
            session.dirty = True
        self.param_error.setText("")
        if self.track_plot is not None:  # the performance stays with the session it was in
            self.track_plot.parentWidget().hide()
        self.clear_probe()  # a point of the skin shown before
        self._populate()
        self.refresh(reset_camera=True)
        self.newface.session_changed(session)

    def save(self) -> bool:
        """Save to the open file, or ask for one. When another program changed the file
        since it was opened or saved, ask first: Overwrite, Save As... or Cancel (which
        writes nothing and keeps the edits); a file deleted meanwhile is written again.
        """
        path = self.session.layout_path
        if path is None:
            return self.save_as_dialog()
        change = self.session.disk_change()
        if change == "changed":
            choice = self._ask_overwrite(path)
            if choice != "overwrite":
                return self.save_as_dialog() if choice == "save as" else False
        if not self.save_as(path):
            return False
        if change == "deleted":
            self.statusBar().showMessage(f"{path} had been deleted meanwhile: saved it again",
                                         10000)
        return True

    def _ask_overwrite(self, path: Path) -> str:
        """Ask what to do with the open file another program changed: ``"overwrite"``,
        ``"save as"`` or ``"cancel"`` (closing the question too).
        """
        box = QtWidgets.QMessageBox(
            QtWidgets.QMessageBox.Warning, "The file changed on disk",
            f"{path} was changed by another program since it was opened or last saved. "
            "Overwrite it with the layout shown here (its changes are lost), save the "
            "layout elsewhere, or cancel (nothing is written, the edits stay)?", parent=self)
        buttons = {box.addButton("Overwrite", QtWidgets.QMessageBox.DestructiveRole):
                   "overwrite",
                   box.addButton("Save As...", QtWidgets.QMessageBox.AcceptRole): "save as"}
        box.setDefaultButton(box.addButton(QtWidgets.QMessageBox.Cancel))
        box.exec()
        choice = buttons.get(box.clickedButton(), "cancel")
        box.deleteLater()
        return choice

    def save_as(self, path: str | Path) -> bool:
        """Save the layout atomically to ``path``."""
        try:
            self.session.save(path)
        except (OSError, ValueError) as exc:
            QtWidgets.QMessageBox.warning(self, "Cannot save layout", str(exc))
            return False
        self.undo_stack.setClean()
        self.recovery.discard()
        self._remember(path)
        self._update_title()
        return True

    def open_dialog(self) -> None:
        """Ask for a layout file and open it."""
        path, _ = QtWidgets.QFileDialog.getOpenFileName(self, "Open layout", "",
                                                        "Layouts (*.json)")
        if path:
            self.open_layout(path)

    def import_performance(self, path: str | Path) -> str:
        """Play a recorded track (File > Import performance...): the timeline follows it,
        Play runs at its clock, its channels are plotted under the views. Returns its name
        in the expression list. ``TrackError`` (one line) for a file that cannot be read.
        """
        import warnings

        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", TrackWarning)
            track = read_track(path)
        s = self.session
        mapping = s.face.mapping or default_mapping()
        perf = performance(track, mapping, s.face.muscle_names,
                           name=f"{Path(path).stem} (track)")
        s.set_performance(perf)
        if self.track_plot is None:
            dock = QtWidgets.QDockWidget("Performance", self)
            dock.setObjectName("performance")
            self.track_plot = TrackPlot(dock)
            dock.setWidget(self.track_plot)
            self.addDockWidget(QtCore.Qt.BottomDockWidgetArea, dock)
        self.track_plot.set_curves(track_curves(track, mapping, s.face.muscle_names),
                                   track.duration_s)
        self.track_plot.parentWidget().show()
        self._populate()
        self.refresh()
        notes = "; ".join(str(w.message) for w in caught)
        self.statusBar().showMessage(
            f"{perf.name}: {track.n_frames} frames, {track.duration_s:.3g} s"
            + (f" ({notes})" if notes else ""), 15000)
        return perf.name

    def import_performance_dialog(self) -> None:
        """Ask for a track file and play it; a bad one is reported in one line."""
        path, _ = QtWidgets.QFileDialog.getOpenFileName(
            self, "Import performance", "", "Tracks (*.csv);;All files (*)")
        if not path:
            return
        try:
            self.import_performance(path)
        except (TrackError, OSError) as exc:
            QtWidgets.QMessageBox.warning(self, "Cannot import the performance", str(exc))

    def save_as_dialog(self) -> bool:
        """Ask for a file and save the layout there."""
        path, _ = QtWidgets.QFileDialog.getSaveFileName(self, "Save layout", "",
                                                        "Layouts (*.json)")
        return self.save_as(path) if path else False

    def screenshot(self, path: str | Path) -> Path:
        """Save the skin view as a PNG (atomically: a failed write keeps the old file)."""
        from wrinkle_vis.plotting.writers import save_image

        save_image(self.skin_view.screenshot(return_img=True), path)
        return Path(path)

    def screenshot_dialog(self) -> None:
        """Ask for a file and save the skin view there."""
        path, _ = QtWidgets.QFileDialog.getSaveFileName(self, "Export screenshot", "",
                                                        "PNG images (*.png)")
        if path:
            self.screenshot(path)

    def save_image(self, view: str, path: str | Path, size: tuple[int, int]) -> Path:
        """Save view ``view`` (``"skin"``, ``"muscles"`` or ``"skull"``) as a PNG of
        ``size`` ``(width, height)`` pixels, without the placement widget's handles and
        outlines or the probe's marker (see :meth:`LinkedViews.save_image`).
        """
        return self.views.save_image(view, path, size)

    def image_dialog(self) -> Path | None:
        """Ask for a view, a size and a file, and save the view's image there."""
        w, h = self.skin_view.window_size
        dialog = ImageDialog(self, (2 * w, 2 * h))
        if dialog.exec() != QtWidgets.QDialog.Accepted:
            return None
        path, _ = QtWidgets.QFileDialog.getSaveFileName(self, "Save view image", "",
                                                        "PNG images (*.png)")
        if not path:
            return None
        if not path.lower().endswith(".png"):
            path += ".png"
        try:
            out = self.save_image(dialog.view(), path, dialog.size())
        except (OSError, ValueError, RuntimeError) as exc:
            QtWidgets.QMessageBox.warning(self, "Cannot save the image", str(exc))
            return None
        self.statusBar().showMessage(f"Saved {out} ({dialog.size()[0]} x "
                                     f"{dialog.size()[1]})", 10000)
        return out

    def recent_files(self) -> list[str]:
        """The recently opened or saved layouts, newest first."""
        value = self.settings.value("recent", [])
        return [value] if isinstance(value, str) else list(value or [])

    def _remember(self, path) -> None:
        path = str(Path(path).resolve())
        recent = [path] + [p for p in self.recent_files() if p != path]
        self.settings.setValue("recent", recent[:MAX_RECENT])
        self._update_recent_menu()

    def _update_recent_menu(self) -> None:
        self.recent_menu.clear()
        for path in self.recent_files():
            self.recent_menu.addAction(path).triggered.connect(_weak(self.open_recent, path))
        self.recent_menu.setEnabled(bool(self.recent_files()))

    # ------------------------------------------------------------------ help
    def show_guide(self) -> QtWidgets.QDialog:
        """Show the user guide (``docs/guide.md``) in a window of its own."""
        if getattr(self, "guide_dialog", None) is None:
            self.guide_dialog = TextDialog(self, "wrinkle-vis guide", _guide_text(),
                                           GUIDE.parent)
        self.guide_dialog.show()
        self.guide_dialog.raise_()
        return self.guide_dialog

    def shortcuts(self) -> list[tuple[str, str, str]]:
        """``(menu, action, shortcut)`` of every action of the menus that has a shortcut,
        read from the actions themselves.
        """
        rows = []

        def walk(menu: QtWidgets.QMenu, where: str) -> None:
            for action in menu.actions():
                text = action.text().replace("&", "").rstrip(".")
                if action.menu() is not None:
                    walk(action.menu(), f"{where} > {text}")
                elif not action.isSeparator() and not action.shortcut().isEmpty():
                    rows.append((where, text, action.shortcut().toString(
                        QtGui.QKeySequence.NativeText)))

        for top in self.menuBar().actions():
            if top.menu() is not None:
                walk(top.menu(), top.text().replace("&", ""))
        return rows

    def show_shortcuts(self) -> QtWidgets.QDialog:
        """Show every action's shortcut (:meth:`shortcuts`) in a table."""
        dialog = getattr(self, "shortcuts_dialog", None)
        if dialog is None:
            dialog = self.shortcuts_dialog = QtWidgets.QDialog(self)
            dialog.setWindowTitle("Keyboard shortcuts")
            box = QtWidgets.QVBoxLayout(dialog)
            dialog.table = QtWidgets.QTableWidget(0, 3)
            dialog.table.setHorizontalHeaderLabels(["menu", "action", "shortcut"])
            dialog.table.verticalHeader().setVisible(False)
            dialog.table.setEditTriggers(QtWidgets.QAbstractItemView.NoEditTriggers)
            box.addWidget(dialog.table)
            note = QtWidgets.QLabel("Mouse: drag to rotate, wheel to zoom, right-click the "
                                    "skin to probe, click a muscle to select it, drag a "
                                    "handle to move it.")
            note.setWordWrap(True)
            box.addWidget(note)
            dialog.resize(560, 520)
        rows = self.shortcuts()  # built afresh: the recent files and plug-ins may change
        dialog.table.setRowCount(len(rows))
        for i, row in enumerate(rows):
            for j, text in enumerate(row):
                dialog.table.setItem(i, j, QtWidgets.QTableWidgetItem(text))
        dialog.table.resizeColumnsToContents()
        dialog.show()
        dialog.raise_()
        return dialog

    # ------------------------------------------------------------------ recovery
    def _schedule_autosave(self, *_) -> None:
        """An edit: autosave after a second of quiet, and at the latest 5 s after the
        first edit not autosaved yet.
        """
        self.autosave_timer.start()
        if not self.autosave_deadline.isActive():
            self.autosave_deadline.start()

    def autosave(self) -> None:
        """Write the layout to the recovery file while it has unsaved changes (remove the
        file when it has none).
        """
        self.autosave_timer.stop()
        self.autosave_deadline.stop()
        if not self.session.dirty:
            self.recovery.discard()
            return
        s = self.session
        try:  # mesh paths relative to the source's folder, else absolute
            self.recovery.save(s.layout(s.layout_path.parent if s.layout_path else None),
                               s.layout_path, s.face.skin.n_triangles)
        except (OSError, ValueError) as exc:  # a full disk; a folder or link refused
            self.statusBar().showMessage(f"Autosave failed: {exc}")

    def offer_recovery(self) -> bool:
        """Offer each layout that an earlier session autosaved and did not get to save
        (newest first): Restore, Discard, or Keep it for the next start. Only the files
        the user answers Discard about are deleted, and one restored becomes this
        session's own. Returns whether one was restored.
        """
        restored = False
        try:
            orphans = self.recovery.orphans()
        except OSError as exc:  # an unreadable recovery folder: start without offering
            self.statusBar().showMessage(f"Cannot look for autosaved work: {exc}", 10000)
            return False
        for path in orphans:
            try:
                rec = Recovery.load(path)
                answer = self._ask_recovery(rec, can_restore=not restored)
            except Exception as exc:  # whatever the file holds, the app starts
                self._keep_aside(path, exc)
                continue
            if answer == "restore":
                restored = self.restore(path) or restored
            elif answer == "discard":
                path.unlink(missing_ok=True)
        return restored

    def _ask_recovery(self, rec, can_restore: bool) -> str:
        """Ask what to do with recovery file ``rec``: "restore", "discard" or "keep"."""
        box = QtWidgets.QMessageBox(self)
        box.setIcon(QtWidgets.QMessageBox.Question)
        box.setWindowTitle("Recover unsaved work?")
        source = rec.source if rec.source else "the built-in face"
        box.setText(
            f"wrinkle-vis did not close cleanly and autosaved unsaved work on {source} "
            f"({len(rec.layout.muscles)} muscles) at {time.ctime(rec.saved_at)} in\n"
            f"{rec.path}\n\n" + (
                "Restore it? Discard deletes the file; Keep leaves it for the next start."
                if can_restore else
                "Another one was restored already. Discard deletes this file; Keep leaves "
                "it for the next start."))
        buttons = {}
        if can_restore:
            buttons[box.addButton("Restore", QtWidgets.QMessageBox.AcceptRole)] = "restore"
        buttons[box.addButton("Discard", QtWidgets.QMessageBox.DestructiveRole)] = "discard"
        keep = box.addButton("Keep", QtWidgets.QMessageBox.RejectRole)
        buttons[keep] = "keep"
        box.setEscapeButton(keep)  # closing the question keeps the file
        box.setDefaultButton(next(iter(buttons)))
        box.exec()
        answer = buttons.get(box.clickedButton(), "keep")
        box.deleteLater()
        return answer

    def _keep_aside(self, path: Path, exc: Exception) -> None:
        """A recovery file that cannot be read is renamed ``.bad`` (never thrown away)."""
        bad = path.with_suffix(".bad")
        try:
            path.replace(bad)
        except OSError:
            bad = path
        QtWidgets.QMessageBox.warning(
            self, "Cannot recover", f"{exc}\n\nThe file was kept as {bad}.")

    def restore(self, path) -> bool:
        """Restore the layout of recovery file ``path`` as unsaved changes (asking first
        about unsaved changes of this session); a file that cannot be read is kept beside
        as ``.bad`` and reported. Only ``path`` is removed, once this session's own
        recovery file holds its layout.
        """
        from wrinkle_vis.datasets import load_face

        if not self.may_discard_changes("restoring autosaved work"):
            return False
        path = Path(path)
        try:
            rec = Recovery.load(path)
            base = rec.source.parent if rec.source else Path.cwd()
            n = rec.layout.n_triangles if rec.layout.n_triangles is not None \
                else rec.n_triangles
            face = load_face(n, layout=rec.layout, skin=rec.layout.resolve("skin", base),
                             skull=rec.layout.resolve("skull", base))
        except (OSError, LayoutError, ValueError, KeyError) as exc:
            self._keep_aside(path, exc)
            return False
        source = rec.source if rec.source and rec.source.exists() else None
        self._show_session(Session(face, source, layout=rec.layout, folder=base))
        self.undo_stack.resetClean()  # the restored edits are unsaved
        self.session.dirty = True
        self._update_title()
        if path == self.recovery.path:  # a dead process's of our pid: out of our file's way
            path = path.replace(path.with_name(f"{path.stem}-restored.json"))
        self.autosave()  # ours now holds them: the orphan can go
        if self.recovery.path.exists():
            path.unlink(missing_ok=True)
        self.statusBar().showMessage(f"Restored the layout autosaved at "
                                     f"{time.ctime(rec.saved_at)}", 10000)
        return True

    # ------------------------------------------------------------------ closing
    def closeEvent(self, event) -> None:  # noqa: N802 (Qt's name)
        """Ask about unsaved changes, then close every plotter and let go of everything
        that could keep the window alive.
        """
        if not self.may_discard_changes("closing"):
            event.ignore()
            return
        self.timer.stop()
        self.autosave_timer.stop()
        self.autosave_deadline.stop()
        self.views.close_placement()
        self.newface.close()
        self.undo_stack.clear()
        self.recovery.discard()  # a clean exit leaves nothing to recover
        # VTK holds observers strongly, out of Python's sight: remove them
        self.skin_view.renderer.GetActiveCamera().RemoveObserver(self._camera_observer)
        self.skin_view.disable_picking()
        self.muscle_view.iren.remove_observers("LeftButtonPressEvent")
        self.muscle_view.iren.remove_observers("LeftButtonReleaseEvent")
        for p in self.plotters:
            p.close()
        for dialog in ("guide_dialog", "shortcuts_dialog"):
            if getattr(self, dialog, None) is not None:
                getattr(self, dialog).close()
        event.accept()


class _UndoKeysToWindow(QtCore.QObject):
    """An event filter that lets Undo and Redo reach the window's actions from a spin box
    (whose line edit would take Ctrl+Z for its own text).
    """

    def eventFilter(self, obj, event) -> bool:  # noqa: N802 (Qt's name)
        if event.type() == QtCore.QEvent.ShortcutOverride and (
                event.matches(QtGui.QKeySequence.Undo)
                or event.matches(QtGui.QKeySequence.Redo)):
            event.ignore()  # not the box's: the shortcut goes to the window
            return True
        return False


class _WheelOnlyWhenFocused(QtCore.QObject):
    """An event filter that keeps the wheel from a value control without the focus: the
    event goes on, unhandled, to the control's parents (the scrolled panel scrolls).
    """

    def eventFilter(self, obj, event) -> bool:  # noqa: N802 (Qt's name)
        if event.type() == QtCore.QEvent.Wheel and not obj.hasFocus():
            event.ignore()  # not the control's: Qt passes it on to its parent
            return True
        return False


class ImageDialog(QtWidgets.QDialog):
    """Which view to save as an image, and at what size in pixels."""

    def __init__(self, parent, size: tuple[int, int]):
        super().__init__(parent)
        self.setWindowTitle("Save view image")
        form = QtWidgets.QFormLayout(self)
        self.view_box = QtWidgets.QComboBox()
        self.view_box.addItems(list(VIEWS))
        form.addRow("View", self.view_box)
        self.width_box, self.height_box = QtWidgets.QSpinBox(), QtWidgets.QSpinBox()
        for box, value in ((self.width_box, size[0]), (self.height_box, size[1])):
            box.setRange(16, 8192)
            box.setSuffix(" px")
            box.setValue(int(value))
        form.addRow("Width", self.width_box)
        form.addRow("Height", self.height_box)
        form.addRow(QtWidgets.QLabel("Without the handles, the outlines and the probe."))
        buttons = QtWidgets.QDialogButtonBox(
            QtWidgets.QDialogButtonBox.Ok | QtWidgets.QDialogButtonBox.Cancel)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        form.addRow(buttons)

    def view(self) -> str:
        """The chosen view."""
        return self.view_box.currentText()

    def size(self) -> tuple[int, int]:  # noqa: D102 (shadows QWidget.size on purpose)
        return self.width_box.value(), self.height_box.value()


class TextDialog(QtWidgets.QDialog):
    """A window showing Markdown text (the guide), images found beside it."""

    def __init__(self, parent, title: str, markdown: str, folder: Path):
        super().__init__(parent)
        self.setWindowTitle(title)
        box = QtWidgets.QVBoxLayout(self)
        self.browser = QtWidgets.QTextBrowser()
        self.browser.setSearchPaths([str(folder)])
        self.browser.setOpenExternalLinks(True)
        self.browser.setMarkdown(markdown)
        box.addWidget(self.browser)
        self.resize(820, 760)


def _guide_text() -> str:
    """The user guide, or where to find it when this install has no copy."""
    try:
        return GUIDE.read_text(encoding="utf-8")
    except OSError:
        return ("# wrinkle-vis guide\n\nThe guide is `docs/guide.md` in the wrinkle-vis "
                "source; this installation has no copy. Help > Keyboard shortcuts lists "
                "every action.")


def _skin_status(session: Session) -> str:
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


def _xyz(point) -> str:
    """``(3,)`` as ``x, y, z`` with 4 significant digits."""
    return ", ".join(f"{float(x):.4g}" for x in point)


def _field_label(field: str, unit: str) -> str:
    """A field's symbol with its unit: ``W (mm)``, ``λ``."""
    return field_info(field).display_label(unit)


def _error_label() -> QtWidgets.QLabel:
    """A red, wrapping label for the reason a value was refused."""
    label = QtWidgets.QLabel()
    label.setStyleSheet("color: #b00020")
    label.setWordWrap(True)
    return label


def _show_option(widget: QtWidgets.QWidget, value) -> None:
    """Show an option's ``value`` in its check box or combo box without emitting."""
    widget.blockSignals(True)
    if isinstance(widget, QtWidgets.QCheckBox):
        widget.setChecked(bool(value))
    else:
        widget.setCurrentIndex(widget.findData(value))
    widget.blockSignals(False)


def _parameter_box(spec, unit: str) -> QtWidgets.QAbstractSpinBox:
    """A spin box for one declared parameter (:class:`~wrinkle_vis.core.params.Parameter`):
    whole numbers for a count, else three decimals (more for an SI unit with a small step,
    as the physical skin's thickness); its step from the metadata, and a
    tooltip with its symbol, meaning, unit and range. The box takes any value, so that one
    out of range is refused by the core with its reason, not clipped silently.
    """
    if spec.unit == "count":
        box = QtWidgets.QSpinBox()
        box.setRange(-999, 999)
        box.setSingleStep(max(1, int(spec.step)))
    elif spec.unit == "length":  # the step is in mm: steps and digits follow the unit
        mm = LENGTH_UNITS["mm"] / LENGTH_UNITS.get(unit, LENGTH_UNITS["mm"])
        box = QtWidgets.QDoubleSpinBox()
        box.setDecimals(3 + max(0, round(-np.log10(mm))))
        box.setRange(-1e6, 1e6)
        box.setSingleStep(spec.step * mm)
    elif spec.unit in ("1", "deg"):
        box = QtWidgets.QDoubleSpinBox()
        box.setDecimals(3)
        box.setRange(-1e6, 1e6)
        box.setSingleStep(spec.step)
    else:  # an SI unit (the physical skin's material): digits from the step
        box = QtWidgets.QDoubleSpinBox()
        box.setDecimals(max(3, 2 - math.floor(math.log10(spec.step))) if spec.step > 0
                        else 6)
        box.setRange(-1e12, 1e12)
        box.setSingleStep(spec.step)
    if isinstance(box, QtWidgets.QDoubleSpinBox):
        box.setProperty("base_decimals", box.decimals())
    shown = {"length": unit, "deg": "deg", "1": "", "count": ""}.get(spec.unit, spec.unit)
    derived = "; left out, derived from the others" if spec.optional else ""
    box.setToolTip(f"{spec.symbol}: {spec.doc}" + (f" ({shown})" if shown else "")
                   + f"; allowed {spec.range_text()}{derived}")
    return box


#: The window's size where the screen has room (pixels).
WINDOW_SIZE = (1500, 800)


def fitted_size(available: QtCore.QSize | None, wanted=WINDOW_SIZE) -> tuple[int, int]:
    """The window's first size: ``wanted``, shrunk to the screen's ``available`` area (a
    1366 x 768 laptop screen less its panels), so that the window opens whole.
    """
    if available is None or available.isEmpty():
        return wanted
    return min(wanted[0], available.width()), min(wanted[1], available.height())


def _show_value(box: QtWidgets.QAbstractSpinBox, value) -> None:
    """Show ``value`` in a parameter box whole: the box's own decimals, or as many more
    (up to 10) as the value needs not to be rounded, as the box rounds what it holds to
    its decimals (k0 = 0.02152 would read, and be, 0.022).
    """
    if isinstance(box, QtWidgets.QDoubleSpinBox):
        base = box.property("base_decimals")
        decimals = box.decimals() if base is None else int(base)
        while decimals < 10 and not np.isclose(round(value, decimals), value, rtol=1e-9,
                                                 atol=0.0):
            decimals += 1
        box.setDecimals(decimals)
    box.setValue(value)


def run(argv=None, layout: str | Path | None = None) -> int:
    """Start the app on the layout file ``layout`` (default: the built-in face); returns
    the exit code.

    ``argv`` is Qt's command line (default ``sys.argv[:1]``). A layout that cannot be
    opened is reported in one line on stderr, exit code 2, before any window opens.
    """
    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication(
        list(argv) if argv else sys.argv[:1])
    try:
        session = load_session(layout)
    except (OSError, LayoutError, ValueError, KeyError) as exc:
        print(f"wrinkle-vis: cannot open layout {layout}: {exc}", file=sys.stderr)
        return 2
    window = MainWindow(session)
    window.show()
    if layout is not None:
        window._remember(layout)
    window.offer_recovery()
    return app.exec()


class FaceCommand(QtGui.QUndoCommand):
    """One undoable edit: the face before and after, and the selection with each.

    It holds the window weakly (the window owns the stack that owns the command).
    """

    def __init__(self, window: MainWindow, text: str, before, after, select_before,
                 select_after):
        super().__init__(text)
        self._window = weakref.ref(window)
        self.before, self.after = before, after
        self.select_before, self.select_after = select_before, select_after

    def redo(self) -> None:
        window = self._window()
        if window is not None:
            window.show_face(self.after, self.select_after)

    def undo(self) -> None:
        window = self._window()
        if window is not None:
            window.show_face(self.before, self.select_before)
