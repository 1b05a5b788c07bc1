"""The main window: three linked views (skin with a field, muscles, skull) and controls.

The window is a thin layer over :class:`~wrinkle_vis.app.session.Session`: each control sets
one session attribute and calls :meth:`MainWindow.refresh`, which redraws from the session.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from pyvistaqt import QtInteractor
from qtpy import QtCore, QtGui, QtWidgets

from ..core.face import FIELD_NAMES
from ..core.layout import LayoutError
from ..core.muscle import MuscleParameterError
from ..plotting import add_muscles, add_skin, add_skull, clear_scene, field_range, set_camera
from ..plotting.fields import field_info
from ..plotting.polydata import field_array_name
from .session import EDITABLE, Session

__all__ = ["MainWindow"]

TOTAL = "total"
MAX_RECENT = 8


class MainWindow(QtWidgets.QMainWindow):
    """The wrinkle-vis main window.

    Parameters
    ----------
    session : Session
        What to show.
    settings : QSettings, optional
        Where the recent-files list lives (tests pass a temporary one).
    """

    def __init__(self, session: Session, settings: QtCore.QSettings | None = None):
        super().__init__()
        self.session = session
        self.settings = settings or QtCore.QSettings("wrinkle-vis", "wrinkle-vis")
        self.setWindowTitle("wrinkle-vis")
        self.resize(1500, 800)
        self._syncing = False
        self._updating_controls = False
        self._scene_key = None
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
        camera = self.skin_view.renderer.camera
        for p in self.plotters[1:]:
            p.renderer.camera = camera
        self._camera_observer = camera.AddObserver("ModifiedEvent", self._sync_views)
        self.skin_view.enable_point_picking(self._on_pick, use_picker=True, show_message=False,
                                            show_point=True, left_clicking=False)

    def _sync_views(self, *_) -> None:
        """Render every view at once when the shared camera moves (no timer tick)."""
        if self._syncing:
            return
        self._syncing = True
        try:
            for p in self.plotters:
                if not getattr(p, "_closed", False):
                    p.render_window.Render()
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
        self.field_box.addItems(FIELD_NAMES)
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
        self.param_error = QtWidgets.QLabel()
        self.param_error.setStyleSheet("color: #b00020")
        self.param_error.setWordWrap(True)
        self.param_widgets: dict[str, QtWidgets.QAbstractSpinBox] = {}
        form.addWidget(self.param_group)

        probe = QtWidgets.QGroupBox("Probe (right-click the skin)")
        box = QtWidgets.QVBoxLayout(probe)
        self.probe_table = QtWidgets.QTableWidget(len(FIELD_NAMES), 2)
        self.probe_table.setHorizontalHeaderLabels(["selected muscle", "total"])
        self.probe_table.setVerticalHeaderLabels(FIELD_NAMES)
        box.addWidget(self.probe_table)
        form.addWidget(probe)
        form.addStretch(1)
        dock.setWidget(panel)
        self.addDockWidget(QtCore.Qt.LeftDockWidgetArea, dock)
        self.probed_vertex: int | None = None

    def _build_menus(self) -> None:
        file_menu = self.menuBar().addMenu("&File")
        self._action(file_menu, "&Open layout...", "Ctrl+O", self.open_dialog)
        self._action(file_menu, "&Save layout", "Ctrl+S", self.save)
        self._action(file_menu, "Save layout &as...", "Ctrl+Shift+S", self.save_as_dialog)
        self.recent_menu = file_menu.addMenu("Open &recent")
        self._action(file_menu, "&Export screenshot...", "Ctrl+P", self.screenshot_dialog)
        file_menu.addSeparator()
        self._action(file_menu, "&Quit", "Ctrl+Q", self.close)
        view_menu = self.menuBar().addMenu("&View")
        for name, key in (("front", "1"), ("three_quarter", "2"), ("side", "3"),
                          ("forehead", "4")):
            self._action(view_menu, f"Camera: {name}", key,
                         lambda checked=False, n=name: self.set_camera(n))
        self._action(view_menu, "Play / pause", "Space", self.play_button.toggle)
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
            self.field_box.setCurrentText(s.field)
        finally:
            self._updating_controls = False
        self._build_parameter_panel()

    def _build_parameter_panel(self) -> None:
        while self.param_form.rowCount():
            self.param_form.removeRow(0)
        self.param_widgets = {}
        name = self.session.muscle
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
        if muscle is None and field != "W":
            self._updating_controls = True
            self.field_box.setCurrentText("W")
            self._updating_controls = False
            field = "W"
        changed_muscle = muscle != self.session.muscle
        self.session.set_field(field, muscle)
        if changed_muscle:
            self._build_parameter_panel()
        self.refresh()

    def set_parameter(self, param: str, value) -> bool:
        """Set a parameter of the selected muscle; an invalid value is refused with its
        reason shown under the panel, and the field is put back.
        """
        name = self.session.muscle
        value = int(value) if param == "n_wrinkles" else float(value)
        try:
            self.session.set_parameter(name, param, value)
        except (MuscleParameterError, ValueError) as exc:
            self.param_error.setText(str(exc))
            widget = self.param_widgets[param]
            widget.blockSignals(True)
            old = getattr(self.session.face.muscle(name), param)
            widget.setValue(old if old is not None else _resolved(
                self.session.face.muscle(name), param))
            widget.blockSignals(False)
            return False
        self.param_error.setText("")
        self._show_derived()
        self.refresh()
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

    # ------------------------------------------------------------------ drawing
    def refresh(self, reset_camera: bool = False) -> None:
        """Recompute the frame and redraw the three views."""
        t0 = time.perf_counter()
        s = self.session
        state = s.state()
        self._syncing = True  # one render per view at the end, not one per change
        try:
            # the drawn meshes can be updated in place only on the same triangles
            key = (id(s.face), id(state.face), s.field, s.muscle,
                   self.wireframe_box.isChecked())
            if reset_camera or key != self._scene_key:
                self._rebuild(state)
                self._scene_key = key
            else:
                self._update_in_place(state)
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
        self._sync_views()
        total_ms = 1e3 * (time.perf_counter() - t0)
        self.statusBar().showMessage(
            f"{s.expression} x {s.intensity:.2f}"
            f"{'' if s.time_s is None else f' at {s.time_s:.2f} s'}  |  frame "
            f"{s.frame_ms:.2f} ms, drawn in {total_ms:.1f} ms  |  "
            f"{s.face.skin.n_triangles} triangles")
        self._update_title()

    def _rebuild(self, state) -> None:
        """Build the three scenes from scratch (field, muscle or face changed)."""
        s = self.session
        clear_scene(self.skin_view)
        add_skin(self.skin_view, state, s.field, s.muscle,
                 show_edges=self.wireframe_box.isChecked())
        self._skin_mesh = self.skin_view.mesh
        clear_scene(self.muscle_view)
        add_skin(self.muscle_view, state, None, opacity=0.25)
        self._ghost_mesh = self.muscle_view.mesh
        self._muscle_meshes = add_muscles(self.muscle_view, s.face, state.activations)
        clear_scene(self.skull_view)
        add_skull(self.skull_view, s.face)

    def _update_in_place(self, state) -> None:
        """Only activations changed: move the skin and recolour, without new actors.

        ``add_mesh`` renders a shallow copy of each mesh, which shares its VTK arrays, so
        the new values are written into those arrays and the arrays marked modified.
        """
        s = self.session
        array = self.active_array()
        values = state.W if s.muscle is None else state.fields[s.muscle][s.field]
        _write(self._skin_mesh, state.points, array, values)
        self.skin_view.actors["skin"].mapper.scalar_range = field_range(
            field_info(s.field), values)
        _write(self._ghost_mesh, state.points)
        for name, mesh in self._muscle_meshes.items():
            _write(mesh, None, "activation", state.activations[name])

    def active_array(self) -> str:
        """The point array the skin view colours by."""
        return field_array_name(self.session.field, self.session.muscle)

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
        # VTK holds these callbacks strongly, out of Python's sight: drop them, or the
        # window and its plotters could never be collected
        self.skin_view.renderer.GetActiveCamera().RemoveObserver(self._camera_observer)
        self.skin_view.disable_picking()
        for p in self.plotters:
            p.close()
        event.accept()


def _write(mesh, points=None, array: str | None = None, values=None) -> None:
    """Write into a mesh's existing VTK buffers (shared with PyVista's shallow copies)."""
    if points is not None:
        mesh.points[:] = points
        mesh.GetPoints().Modified()
    if array is not None:
        mesh.point_data[array][:] = values
        mesh.GetPointData().GetArray(array).Modified()
    mesh.Modified()


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
    return app.exec()
