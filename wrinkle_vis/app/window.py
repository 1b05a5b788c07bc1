"""The main window: three linked views (skin with a field, muscles, skull) and controls.

The window is a thin layer over :class:`~wrinkle_vis.app.session.Session`: each control sets
one session attribute and calls :meth:`MainWindow.refresh`, which redraws from the session.
"""

from __future__ import annotations

import time
import weakref
from pathlib import Path

import numpy as np
from pyvistaqt import QtInteractor
from qtpy import QtCore, QtGui, QtWidgets
from vtkmodules.vtkRenderingCore import vtkPropPicker

from ..core.editing import with_point
from ..core.face import FIELD_NAMES
from ..core.layout import LayoutError
from ..core.muscle import MuscleParameterError
from ..core.registry import muscle_types
from ..plotting import set_camera
from ..plotting.polydata import field_array_name
from ..widgets.panels import MuscleListPanel
from .recovery import Recovery
from .session import EDITABLE, OPTIONS, Session
from .views import LinkedViews

__all__ = ["MainWindow"]

TOTAL = "total"
PLAIN = "none"  # the field box's entry for plain skin (no field)
KEEP = object()  # edit(): keep the selection
MAX_RECENT = 8


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
        self.session = session
        self.settings = settings or QtCore.QSettings("wrinkle-vis", "wrinkle-vis")
        self.recovery = recovery or Recovery()
        self.undo_stack = QtGui.QUndoStack(self)
        self.undo_stack.cleanChanged.connect(self._on_clean_changed)
        self.undo_stack.indexChanged.connect(lambda _: self.autosave_timer.start())
        self.autosave_timer = QtCore.QTimer(self)
        self.autosave_timer.setSingleShot(True)
        self.autosave_timer.setInterval(1000)
        self.autosave_timer.timeout.connect(self.autosave)
        self._drag_before = None
        self._drawn_face = None
        self._press = None
        self.setWindowTitle("wrinkle-vis")
        self.resize(1500, 800)
        self._syncing = False
        self._updating_controls = False
        self.plain_skin = False  # the skin view shows no field
        self.plotters: list[QtInteractor] = []
        self._build_views()
        self._build_controls()
        self._build_menus()
        self.timer = QtCore.QTimer(self)
        self.timer.setInterval(40)
        self.timer.timeout.connect(self._tick)
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
            plotter = QtInteractor(frame, auto_update=False)
            box.addWidget(plotter.interactor)
            splitter.addWidget(frame)
            self.plotters.append(plotter)
        self.setCentralWidget(splitter)
        self.skin_view, self.muscle_view, self.skull_view = self.plotters
        self.views = LinkedViews(*self.plotters, on_move=self._on_handle_moved,
                                 on_start=self._on_handle_start)
        camera = self.skin_view.renderer.camera
        for p in self.plotters[1:]:
            p.renderer.camera = camera
        self._camera_observer = camera.AddObserver("ModifiedEvent", self._sync_views)
        self.skin_view.enable_point_picking(self._on_pick, use_picker=True, show_message=False,
                                            show_point=True, left_clicking=False)
        iren = self.muscle_view.iren
        iren.add_observer("LeftButtonPressEvent", self._on_muscle_press)
        iren.add_observer("LeftButtonReleaseEvent", self._on_muscle_release)

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
        self.time_slider.setRange(0, 300)
        self.time_slider.valueChanged.connect(self._on_time)
        row.addWidget(self.play_button)
        row.addWidget(self.time_slider)
        view.addRow("Timeline", row)
        self.field_box = QtWidgets.QComboBox()
        self.field_box.addItems([*FIELD_NAMES, PLAIN])
        self.field_box.setItemData(len(FIELD_NAMES), "Plain skin, no field (try View > Raking "
                                   "light)", QtCore.Qt.ToolTipRole)
        self.field_box.currentTextChanged.connect(self._on_field)
        view.addRow("Field", self.field_box)
        self.muscle_box = QtWidgets.QComboBox()
        self.muscle_box.currentTextChanged.connect(self._on_field)
        view.addRow("Muscle", self.muscle_box)
        row = QtWidgets.QHBoxLayout()
        self.refine_box = QtWidgets.QCheckBox("Refine adaptively")
        self.refine_box.toggled.connect(self._on_refine)
        self.wireframe_box = QtWidgets.QCheckBox("Wireframe")
        self.wireframe_box.toggled.connect(lambda _: self.refresh())
        row.addWidget(self.refine_box)
        row.addWidget(self.wireframe_box)
        view.addRow("Mesh", row)
        form.addLayout(view)

        self.param_group = QtWidgets.QGroupBox("Parameters of the selected muscle")
        self.param_form = QtWidgets.QFormLayout(self.param_group)
        self.param_error = _error_label()
        self.param_widgets: dict[str, QtWidgets.QAbstractSpinBox] = {}
        self.option_widgets: dict[str, QtWidgets.QWidget] = {}  # a QCheckBox or a QComboBox
        form.addWidget(self.param_group)

        probe = QtWidgets.QGroupBox("Probe (right-click the skin)")
        box = QtWidgets.QVBoxLayout(probe)
        self.probe_table = QtWidgets.QTableWidget(len(FIELD_NAMES), 2)
        self.probe_table.setHorizontalHeaderLabels(["selected muscle", "total"])
        self.probe_table.setVerticalHeaderLabels(FIELD_NAMES)
        box.addWidget(self.probe_table)
        form.addWidget(probe)
        form.addStretch(1)
        # scrolled, so that a long parameter panel never makes the window grow
        scroll = QtWidgets.QScrollArea()
        scroll.setWidgetResizable(True)
        scroll.setFrameShape(QtWidgets.QFrame.NoFrame)
        scroll.setHorizontalScrollBarPolicy(QtCore.Qt.ScrollBarAlwaysOff)
        scroll.setWidget(panel)
        scroll.setMinimumWidth(panel.minimumSizeHint().width()
                               + scroll.verticalScrollBar().sizeHint().width())
        dock.setWidget(scroll)
        self.addDockWidget(QtCore.Qt.LeftDockWidgetArea, dock)
        self.probed_vertex: int | None = None
        self._build_muscle_dock()

    def _build_muscle_dock(self) -> None:
        self.add_menu = QtWidgets.QMenu("&Add muscle", self)
        for name in muscle_types():
            self.add_menu.addAction(name).triggered.connect(
                lambda checked=False, n=name: self.add_muscle(n))
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
            action.triggered.connect(lambda checked=False, f=slot: f())
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
        self.muscle_panel.selected.connect(lambda name: self.select_muscle(name or None))
        dock.setWidget(self.muscle_panel)
        self.addDockWidget(QtCore.Qt.LeftDockWidgetArea, dock)

    def _build_menus(self) -> None:
        file_menu = self.menuBar().addMenu("&File")
        self._action(file_menu, "&Open layout...", "Ctrl+O", self.open_dialog)
        self._action(file_menu, "&Save layout", "Ctrl+S", self.save)
        self._action(file_menu, "Save layout &as...", "Ctrl+Shift+S", self.save_as_dialog)
        self.recent_menu = file_menu.addMenu("Open &recent")
        self._action(file_menu, "&Export screenshot...", "Ctrl+P", self.screenshot_dialog)
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
        view_menu = self.menuBar().addMenu("&View")
        for name, key in (("front", "1"), ("three_quarter", "2"), ("side", "3"),
                          ("forehead", "4")):
            self._action(view_menu, f"Camera: {name}", key,
                         lambda checked=False, n=name: self.set_camera(n))
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
        self._update_recent_menu()

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
            self.expression_box.addItems(list(s.face.expressions))
            self.expression_box.setCurrentText(s.expression)
            self.intensity_slider.setValue(round(100 * s.intensity))
            self.time_slider.setValue(self._slider_for_time(s.time_s))
            self.muscle_box.clear()
            self.muscle_box.addItems([TOTAL, *s.face.muscle_names])
            self.muscle_box.setCurrentText(s.muscle or TOTAL)
            self.field_box.setCurrentText(PLAIN if self.plain_skin else s.field)
        finally:
            self._updating_controls = False
        self.muscle_panel.set_muscles(s.face.muscle_names, s.muscle)
        self._update_edit_actions()
        self._build_parameter_panel()

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
            value = getattr(muscle, param)
            widget.blockSignals(True)
            widget.setValue(value if value is not None else _resolved(muscle, param))
            widget.blockSignals(False)
        for param, widget in self.option_widgets.items():
            _show_option(widget, getattr(muscle, param))
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
        for param, label, step in EDITABLE.get(muscle.type_name, ()):
            value = getattr(muscle, param)
            if param == "n_wrinkles":
                w = QtWidgets.QSpinBox()
                w.setRange(0, 99)
            else:
                w = QtWidgets.QDoubleSpinBox()
                w.setDecimals(3)
                w.setRange(-1e6, 1e6)
                w.setSingleStep(step)
            w.setValue(value if value is not None else _resolved(muscle, param))
            w.setKeyboardTracking(False)
            w.valueChanged.connect(lambda v, p=param: self.set_parameter(p, v))
            self.param_widgets[param] = w
            self.param_form.addRow(label, w)
        self.option_widgets = {}
        for param, label, choices in OPTIONS:  # every type has them (core.muscle.OPTIONS)
            if choices is None:
                w = QtWidgets.QCheckBox()
                w.toggled.connect(lambda on, p=param: self.set_parameter(p, bool(on)))
            else:
                w = QtWidgets.QComboBox()
                for value, text in choices.items():
                    w.addItem(text, value)
                w.currentIndexChanged.connect(
                    lambda i, p=param, box=w: self.set_parameter(p, box.itemData(i)))
            w.setToolTip(_OPTION_TIPS.get(param, ""))
            _show_option(w, getattr(muscle, param))
            self.option_widgets[param] = w
            self.param_form.addRow(label, w)
        self.activation_box = QtWidgets.QDoubleSpinBox()
        self.activation_box.setRange(0.0, 1.0)
        self.activation_box.setSingleStep(0.05)
        self.activation_box.setValue(self.session.activations().get(name, 0.0))
        self.activation_box.setKeyboardTracking(False)
        self.activation_box.setToolTip("Set by hand over the expression; choosing an "
                                       "expression again resets it")
        self.activation_box.valueChanged.connect(self.set_activation)
        self.param_form.addRow("activation", self.activation_box)
        self.derived_label = QtWidgets.QLabel()
        self.param_form.addRow("derived", self.derived_label)
        self.param_form.addRow(self.param_error)
        self._show_derived()

    def _show_derived(self) -> None:
        if self.session.muscle is not None:
            d = self.session.derived(self.session.muscle)
            self.derived_label.setText(f"d = {d['d']:.4g}   u = {d['u']:.4g}")

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
            ex = self.session.face.expressions[self.session.expression]
            self.session.set_time(value / 300 * ex.duration_s)
            self.refresh()

    def _slider_for_time(self, t: float | None) -> int:
        """Timeline position of ``t`` (None, the peak: the middle of the plateau)."""
        ex = self.session.face.expressions[self.session.expression]
        if t is None:
            t = ex.onset_s + 0.5 * ex.hold_s
        return round(300 * t / ex.duration_s) if ex.duration_s > 0 else 0

    def _on_refine(self, on: bool) -> None:
        self.session.set_refine(on)
        self.refresh()

    def _on_play(self, playing: bool) -> None:
        self.play_button.setText("Pause" if playing else "Play")
        if playing:
            self.timer.start()
        else:
            self.timer.stop()

    def _tick(self) -> None:
        self.time_slider.setValue((self.time_slider.value() + 4) % 301)

    def _on_field(self, _=None) -> None:
        if self._updating_controls:
            return
        field = self.field_box.currentText()
        muscle = self.muscle_box.currentText()
        muscle = None if muscle in ("", TOTAL) else muscle
        self.plain_skin = field == PLAIN
        if self.plain_skin:  # the session keeps a field for the probe and a switch back
            field = self.session.field if muscle is not None else "W"
        elif muscle is None and field != "W":
            self._updating_controls = True
            self.field_box.setCurrentText("W")
            self._updating_controls = False
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
        if not option:
            value = int(value) if param == "n_wrinkles" else float(value)
        try:
            face = self.session.with_parameter(name, param, value)
        except (MuscleParameterError, ValueError) as exc:
            self.param_error.setText(str(exc))
            old = getattr(self.session.face.muscle(name), param)
            if option:
                _show_option(self.option_widgets[param], old)
                return False
            widget = self.param_widgets[param]
            widget.blockSignals(True)
            widget.setValue(old if old is not None else _resolved(
                self.session.face.muscle(name), param))
            widget.blockSignals(False)
            return False
        self.param_error.setText("")
        labels = {p: lbl for p, lbl, _ in (*EDITABLE.get(
            self.session.face.muscle(name).type_name, ()), *OPTIONS)}
        shown = ("on" if value else "off") if isinstance(value, bool) else (
            value if isinstance(value, str) else f"{value:g}")
        self.edit(f"Set {labels.get(param, param)} of {name} to {shown}", face)
        return True

    def set_activation(self, value: float) -> None:
        """Set the selected muscle's activation by hand."""
        if self._updating_controls or self.session.muscle is None:
            return
        self.session.set_activation(self.session.muscle, float(value))
        self.refresh()

    def _on_pick(self, point) -> None:
        if point is None:
            return
        points = self.session.state().points
        self.probe_vertex(int(np.argmin(np.linalg.norm(points - np.asarray(point), axis=1))))

    def probe_vertex(self, vertex: int) -> dict:
        """Show every field's value at ``vertex`` in the probe table; returns them."""
        self.probed_vertex = vertex
        values = self.session.probe(vertex)
        muscle = self.session.muscle
        for row, field in enumerate(FIELD_NAMES):
            own = values.get(muscle, {}).get(field, np.nan) if muscle else np.nan
            total = values["total"].get(field, np.nan)
            for col, v in enumerate((own, total)):
                text = "undefined" if not np.isfinite(v) else f"{v:.5g}"
                self.probe_table.setItem(row, col, QtWidgets.QTableWidgetItem(text))
        return values

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
        self.refresh()

    def _on_clean_changed(self, clean: bool) -> None:
        self.session.dirty = not clean
        self._update_title()
        self.autosave_timer.start()

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
        if self.probed_vertex is not None and self.probed_vertex < skin.n_points:
            return skin.points[self.probed_vertex]
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
            text, ok = QtWidgets.QInputDialog.getText(self, "Rename muscle", "New name:",
                                                      text=name)
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
        self.edit(text.format(name, twin), face)
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
            self.param_error.setText(str(exc))
            self.statusBar().showMessage(f"Refused: {exc}")
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
                            plain=self.plain_skin)
            self._drawn_face = s.face
            if reset_camera:
                set_camera(self.skin_view, "front", s.face)
        finally:
            self._syncing = False
        if self.session.muscle is not None and hasattr(self, "activation_box"):
            self._updating_controls = True
            self.activation_box.setValue(state.activations.get(self.session.muscle, 0.0))
            self._updating_controls = False
        if self.probed_vertex is not None and self.probed_vertex >= len(state.points):
            self.probed_vertex = None  # a vertex of a refinement that is gone
        if self.probed_vertex is not None:
            self.probe_vertex(self.probed_vertex)
        self.views.render(only_changed=not reset_camera, skip=skip)
        total_ms = 1e3 * (time.perf_counter() - t0)
        self.statusBar().showMessage(
            f"{s.expression} x {s.intensity:.2f}"
            f"{'' if s.time_s is None else f' at {s.time_s:.2f} s'}  |  frame "
            f"{s.frame_ms:.2f} ms, drawn in {total_ms:.1f} ms  |  "
            f"{s.face.skin.n_triangles} triangles")
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
        path = self.session.layout_path
        self.setWindowTitle(f"wrinkle-vis - {path.name if path else 'built-in face'}"
                            f"{' *' if self.session.dirty else ''}")

    def open_layout(self, path: str | Path) -> bool:
        """Open a layout file; a bad one is reported and the current face kept."""
        from wrinkle_vis.datasets import load_face

        try:
            face = load_face(self.session.face.skin.n_triangles, layout=path)
        except (OSError, LayoutError, ValueError, KeyError) as exc:
            QtWidgets.QMessageBox.warning(self, "Cannot open layout", str(exc))
            return False
        self.session = Session(face, path)
        self.undo_stack.clear()
        self.recovery.discard()
        self._remember(path)
        self._populate()
        self.refresh(reset_camera=True)
        return True

    def save(self) -> bool:
        """Save to the open file, or ask for one."""
        if self.session.layout_path is None:
            return self.save_as_dialog()
        return self.save_as(self.session.layout_path)

    def save_as(self, path: str | Path) -> bool:
        """Save the layout atomically to ``path``."""
        try:
            self.session.save(path)
        except OSError as exc:
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

    def save_as_dialog(self) -> bool:
        """Ask for a file and save the layout there."""
        path, _ = QtWidgets.QFileDialog.getSaveFileName(self, "Save layout", "",
                                                        "Layouts (*.json)")
        return self.save_as(path) if path else False

    def screenshot(self, path: str | Path) -> Path:
        """Save the skin view as a PNG."""
        self.skin_view.screenshot(str(path))
        return Path(path)

    def screenshot_dialog(self) -> None:
        """Ask for a file and save the skin view there."""
        path, _ = QtWidgets.QFileDialog.getSaveFileName(self, "Export screenshot", "",
                                                        "PNG images (*.png)")
        if path:
            self.screenshot(path)

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
            action = self.recent_menu.addAction(path)
            action.triggered.connect(lambda checked=False, p=path: self.open_layout(p))
        self.recent_menu.setEnabled(bool(self.recent_files()))

    # ------------------------------------------------------------------ recovery
    def autosave(self) -> None:
        """Write the layout to the recovery file while it has unsaved changes (remove the
        file when it has none).
        """
        if not self.session.dirty:
            self.recovery.discard()
            return
        try:
            self.recovery.save(self.session.layout(), self.session.layout_path,
                               self.session.face.skin.n_triangles)
        except OSError as exc:
            self.statusBar().showMessage(f"Autosave failed: {exc}")

    def offer_recovery(self) -> bool:
        """If an earlier session did not exit cleanly, offer to restore its autosaved
        layout; returns whether one was restored.
        """
        orphans = self.recovery.orphans()
        if not orphans:
            return False
        answer = QtWidgets.QMessageBox.question(
            self, "Recover unsaved work?",
            f"wrinkle-vis did not close cleanly last time and autosaved its layout in\n"
            f"{orphans[0]}\n\nRestore it? (No discards it.)",
            QtWidgets.QMessageBox.Yes | QtWidgets.QMessageBox.No,
            QtWidgets.QMessageBox.Yes)
        if answer != QtWidgets.QMessageBox.Yes:
            for path in orphans:
                path.unlink(missing_ok=True)
            return False
        return self.restore(orphans[0], others=orphans[1:])

    def restore(self, path, others=()) -> bool:
        """Restore the layout of recovery file ``path`` as unsaved changes; a file that
        cannot be read is kept beside as ``.bad`` and reported.
        """
        from wrinkle_vis.datasets import load_face

        path = Path(path)
        try:
            rec = Recovery.load(path)
            base = rec.source.parent if rec.source else Path.cwd()
            face = load_face(rec.n_triangles, layout=rec.layout,
                             skin=rec.layout.resolve("skin", base),
                             skull=rec.layout.resolve("skull", base))
        except (OSError, LayoutError, ValueError, KeyError) as exc:
            path.replace(path.with_suffix(".bad"))
            QtWidgets.QMessageBox.warning(
                self, "Cannot recover", f"{exc}\n\nThe file was kept as "
                f"{path.with_suffix('.bad')}.")
            return False
        self.session = Session(face, rec.source if rec.source and rec.source.exists()
                               else None)
        self.undo_stack.clear()
        self.undo_stack.resetClean()  # the restored edits are unsaved
        self._populate()
        self.refresh(reset_camera=True)
        self.autosave()  # ours now holds them: the orphans can go
        for p in (path, *others):
            p.unlink(missing_ok=True)
        self.statusBar().showMessage(f"Restored the layout autosaved at "
                                     f"{time.ctime(rec.saved_at)}")
        return True

    # ------------------------------------------------------------------ closing
    def closeEvent(self, event) -> None:  # noqa: N802 (Qt's name)
        """Ask about unsaved changes, then close every plotter cleanly."""
        if self.session.dirty:
            answer = QtWidgets.QMessageBox.question(
                self, "Unsaved changes", "The layout has unsaved changes. Save them?",
                QtWidgets.QMessageBox.Save | QtWidgets.QMessageBox.Discard
                | QtWidgets.QMessageBox.Cancel)
            if answer == QtWidgets.QMessageBox.Cancel or (
                    answer == QtWidgets.QMessageBox.Save and not self.save()):
                event.ignore()
                return
        self.timer.stop()
        self.autosave_timer.stop()
        self.views.close_placement()
        self.undo_stack.clear()
        self.recovery.discard()  # a clean exit leaves nothing to recover
        # VTK holds these callbacks strongly, out of Python's sight: drop them, or the
        # window and its plotters could never be collected
        self.skin_view.renderer.GetActiveCamera().RemoveObserver(self._camera_observer)
        self.skin_view.disable_picking()
        self.muscle_view.iren.remove_observers("LeftButtonPressEvent")
        self.muscle_view.iren.remove_observers("LeftButtonReleaseEvent")
        for p in self.plotters:
            p.close()
        event.accept()


def _error_label() -> QtWidgets.QLabel:
    """A red, wrapping label for the reason a value was refused."""
    label = QtWidgets.QLabel()
    label.setStyleSheet("color: #b00020")
    label.setWordWrap(True)
    return label


_OPTION_TIPS = {
    "taper": "Taper H to 0, C1, over the first and last half period of the wrinkling region "
             "(off: the paper's Eq. 5, which jumps to the furrow bottom there)",
    "compression": "How eps is measured: the paper's Eq. 10 over the edges, or the "
                   "deformation gradient's stretch along the contraction direction (exact "
                   "for a uniform strain)",
}


def _show_option(widget: QtWidgets.QWidget, value) -> None:
    """Show an option's ``value`` in its check box or combo box without emitting."""
    widget.blockSignals(True)
    if isinstance(widget, QtWidgets.QCheckBox):
        widget.setChecked(bool(value))
    else:
        widget.setCurrentIndex(widget.findData(value))
    widget.blockSignals(False)


def _resolved(muscle, param: str) -> float:
    """The value a defaulted (None) parameter actually takes."""
    if param == "attenuation_start_deg" or param == "attenuation_start":
        return muscle.attenuation_range[0]
    return getattr(muscle, f"{param}_value")


def run(argv=None) -> int:
    """Start the app on the built-in face; returns the exit code."""
    from wrinkle_vis.datasets import load_face

    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication(argv or [])
    window = MainWindow(Session(load_face()))
    window.show()
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
