"""The New-face panel: which landmark to click next, a picture of where it goes, the ones
placed, Undo, and once all are placed Save. A thin view of a
:class:`~wrinkle_vis.app.newface.LandmarkPicker`; the window does the work.
"""

from __future__ import annotations

import weakref
from pathlib import Path

import numpy as np
from qtpy import QtCore, QtGui, QtWidgets
from vtkmodules.vtkRenderingCore import vtkCellPicker

from ..core.units import LENGTH_UNITS
from .facemenu import can_pick_again
from .newface import (
    DESCRIPTIONS,
    MESH_FILTER,
    LandmarkPicker,
    landmark_picture,
    scan_only_face,
)

__all__ = ["NewFaceFlow", "NewFacePanel"]


class NewFacePanel(QtWidgets.QWidget):
    """The panel of the New-face dock; :meth:`show_picker` shows a picker's state.

    Its buttons are the window's actions (``undo``, ``keep``, ``cancel``, ``save``,
    ``again``), given as a dict.
    """

    def __init__(self, actions: dict[str, QtGui.QAction], parent=None):
        super().__init__(parent)
        box = QtWidgets.QVBoxLayout(self)
        self.title = QtWidgets.QLabel()
        self.title.setWordWrap(True)
        box.addWidget(self.title)
        self.picture = QtWidgets.QLabel()
        self.picture.setAlignment(QtCore.Qt.AlignCenter)
        self.picture.setMinimumSize(180, 180)
        box.addWidget(self.picture)
        self.hint = QtWidgets.QLabel()
        self.hint.setWordWrap(True)
        box.addWidget(self.hint)
        row = QtWidgets.QHBoxLayout()
        row.addWidget(QtWidgets.QLabel("Unit of the scan"))
        self.unit_box = QtWidgets.QComboBox()
        self.unit_box.addItems(list(LENGTH_UNITS))
        self.unit_box.setToolTip("The unit of the mesh file's coordinates (guessed from the "
                                 "head's height; the layout records it)")
        row.addWidget(self.unit_box)
        box.addLayout(row)
        self.list = QtWidgets.QListWidget()
        self.list.setSelectionMode(QtWidgets.QAbstractItemView.NoSelection)
        box.addWidget(self.list, 1)
        self.buttons = {}
        for key in ("undo", "keep", "cancel", "again", "save"):
            button = QtWidgets.QToolButton()
            button.setDefaultAction(actions[key])
            button.setToolButtonStyle(QtCore.Qt.ToolButtonTextOnly)
            button.setSizePolicy(QtWidgets.QSizePolicy.Expanding,
                                 QtWidgets.QSizePolicy.Fixed)
            self.buttons[key] = button
            box.addWidget(button)

    def show_picker(self, picker: LandmarkPicker, note: str = "") -> None:
        """Show the step ``picker`` is at (or that it is done), and ``note`` under it."""
        name, n = picker.current, len(picker.order)
        if name is None:
            self.title.setText(f"<b>All {n} landmarks placed.</b>")
            self.hint.setText("The muscles are moved onto the scan: the views show them on "
                              "surprise. Save the layout to keep the face; it names the mesh "
                              "file (a path relative to the layout) and the landmarks."
                              + (f"<br>{note}" if note else ""))
            self.picture.clear()
        else:
            self.title.setText(f"<b>Landmark {picker.step + 1} of {n}: {name}</b><br>"
                               "Click it on the skin (drag to turn the head).")
            again = " A grey ball marks where it was; Keep takes that." \
                if name in picker.previous else ""
            self.hint.setText(f"{DESCRIPTIONS.get(name, name)}.{again}"
                              + (f"<br>{note}" if note else ""))
            self.picture.setPixmap(_pixmap(landmark_picture(name)))
        self.unit_box.blockSignals(True)
        self.unit_box.setCurrentText(picker.unit or picker.guessed_unit())
        self.unit_box.blockSignals(False)
        self.list.clear()
        for k in picker.order:
            where = picker.picked.get(k)
            text = f"{k}: " + ("-" if where is None else
                               ", ".join(f"{x:.3g}" for x in where))
            item = QtWidgets.QListWidgetItem(("\u2713 " if where else "   ") + text)
            if k == name:
                font = item.font()
                font.setBold(True)
                item.setFont(font)
            self.list.addItem(item)


def _pixmap(image: np.ndarray) -> QtGui.QPixmap:
    """A pixmap of an ``(h, w, 3)`` uint8 image (copied: Qt does not keep the array)."""
    image = np.ascontiguousarray(image)
    h, w, _ = image.shape
    qimage = QtGui.QImage(image.data, w, h, 3 * w, QtGui.QImage.Format_RGB888)
    return QtGui.QPixmap.fromImage(qimage.copy())


def _weak(method, *args):
    """A slot or VTK observer calling ``method(*args)`` while its object lives (holds it
    weakly, as the window's own ``_weak`` does).
    """
    ref = weakref.WeakMethod(method)

    def slot(*_):
        bound = ref()
        return None if bound is None else bound(*args)

    return slot


def _weak_arg(method):
    """A slot calling ``method(value)`` with the signal's value while its object lives."""
    ref = weakref.WeakMethod(method)

    def slot(value):
        bound = ref()
        return None if bound is None else bound(value)

    return slot


class NewFaceFlow:
    """File > New face from mesh... and Face > Pick landmarks again... in a window: the
    dock, its actions, and the clicks on the skin view that place the landmarks.

    It holds the window weakly (the window owns it), and :meth:`close` removes its VTK
    observers.
    """

    def __init__(self, window):
        self._window = weakref.ref(window)
        self.picker: LandmarkPicker | None = None
        self._before = None  # (session, was dirty) to go back to on Cancel
        self._press = None
        self.actions = {}
        for key, text, shortcut, slot, tip in (
                ("undo", "Undo last landmark", "Ctrl+Z", self.undo,
                 "Take back the last landmark placed (also after the last one)"),
                ("keep", "Keep where it was", "K", self.keep,
                 "Place this landmark where it was before"),
                ("cancel", "Cancel", "Escape", self.cancel,
                 "Leave the new face and go back to the face shown before"),
                ("again", "Pick landmarks again...", "", self.pick_again,
                 "Place the landmarks of this face from a scan again; its muscles move "
                 "with them"),
                ("save", "Save layout as...", "", self.save, "Save the new face's layout")):
            action = QtGui.QAction(text, window)
            if shortcut and key != "undo":  # set while picking (_update_actions)
                action.setShortcut(QtGui.QKeySequence(shortcut))
            action.setToolTip(tip)
            action.triggered.connect(_weak(slot))
            self.actions[key] = action
        window.addActions([self.actions[k] for k in ("undo", "keep", "cancel")])
        self.dock = QtWidgets.QDockWidget("New face", window)
        self.dock.setObjectName("newface")
        self.panel = NewFacePanel(self.actions)
        self.panel.unit_box.currentTextChanged.connect(_weak_arg(self.set_unit))
        self.dock.setWidget(self.panel)
        window.addDockWidget(QtCore.Qt.RightDockWidgetArea, self.dock)
        self.dock.hide()
        iren = window.skin_view.iren
        self._observers = [
            iren.add_observer("LeftButtonPressEvent", _weak(self._on_press)),
            iren.add_observer("LeftButtonReleaseEvent", _weak(self._on_release))]
        self._markers = []
        self._own = None  # the session this flow showed last
        self._update_actions()

    def session_changed(self, session) -> None:
        """The window shows ``session``: one the flow did not show ends the flow (a layout
        opened, a face chosen, autosaved work restored).
        """
        if session is not self._own and self.picker is not None:
            self._clear_markers()
            self._end()

    @property
    def window(self):
        """The window (None once it is gone)."""
        return self._window()

    @property
    def picking(self) -> bool:
        """Whether a landmark is being asked for."""
        return self.picker is not None and not self.picker.done

    # ------------------------------------------------------------------ starting
    def new_face_dialog(self) -> bool:
        """Ask for a mesh file and start the New-face flow on it."""
        path, _ = QtWidgets.QFileDialog.getOpenFileName(
            self.window, "New face from mesh", "", MESH_FILTER)
        return self.start(path) if path else False

    def start(self, path) -> bool:
        """Start the flow on the mesh file ``path`` (after asking about unsaved changes);
        a file that cannot be read is reported in one line and nothing changes.
        """
        from wrinkle_vis.core.mesh import MeshError
        from wrinkle_vis.datasets import read_surface

        w = self.window
        if not self._leave_flow() or not w.may_discard_changes("starting a new face"):
            return False
        try:
            skin = read_surface(path)
        except (OSError, MeshError, ValueError) as exc:
            QtWidgets.QMessageBox.warning(w, "Cannot read the mesh", str(exc))
            return False
        picker = LandmarkPicker(skin, Path(path))
        picker.unit = w.ask_unit(skin, Path(path).name)  # guessed, else asked
        if picker.unit is None:
            return False
        self._begin(picker)
        return True

    def pick_again(self) -> bool:
        """Place the landmarks of the face shown (one from a scan) again: its layout,
        edits and all, moves with them. Refused in one line on a built-in face.
        """
        w = self.window
        s = w.session
        if not can_pick_again(s):
            w.statusBar().showMessage(
                "Pick landmarks again works on a face from a scan (File > New face from "
                "mesh..., or a layout that names its mesh)", 10000)
            return False
        if not self._leave_flow():
            return False
        layout = s.layout()
        mesh = layout.resolve("skin", s.folder)
        self._begin(LandmarkPicker(s.face.skin, mesh, source=layout,
                                   previous=dict(s.face.landmarks), unit=s.unit))
        return True

    def _begin(self, picker: LandmarkPicker) -> None:
        w = self.window
        if self._before is None:
            self._before = (w.session, w.session.dirty)
        self.picker = picker
        self._show_scan(reset_camera=True)
        self.dock.show()
        self.dock.raise_()

    def _show_scan(self, reset_camera: bool) -> None:
        """Show the scan alone, plain, with the landmarks placed so far."""
        from .session import Session

        w = self.window
        camera = w.skin_view.camera_position
        face = scan_only_face(self.picker.skin, name=self.picker.mesh_path.name,
                              unit=self.picker.unit)
        w.display.set(plain=True)
        self._own = Session(face)
        w.files.show_session(self._own)
        if not reset_camera:
            w.skin_view.camera_position = camera
        self._show_step()

    # ------------------------------------------------------------------ clicking
    def _on_press(self) -> None:
        self._press = self.window.skin_view.iren.get_event_position()

    def _on_release(self) -> None:
        """A click (press and release within 3 pixels) on the skin places the landmark."""
        w = self.window
        x, y = w.skin_view.iren.get_event_position()
        press, self._press = self._press, None
        if not self.picking or press is None or max(abs(x - press[0]),
                                                     abs(y - press[1])) > 3:
            return
        point = self.skin_point_at(x, y)
        if point is not None:
            self.place(point)

    def skin_point_at(self, x: int, y: int) -> np.ndarray | None:
        """The point of the skin drawn at display position ``(x, y)`` of the skin view
        (None: no skin there).
        """
        w = self.window
        actor = w.skin_view.actors.get("skin")
        if actor is None:
            return None
        picker = vtkCellPicker()
        picker.SetTolerance(1e-4)
        picker.PickFromListOn()
        picker.AddPickList(actor)
        if not picker.Pick(x, y, 0, w.skin_view.renderer) or picker.GetCellId() < 0:
            return None
        return np.array(picker.GetPickPosition())

    # ------------------------------------------------------------------ the steps
    def place(self, point) -> str:
        """Place the landmark asked for at ``point`` (snapped onto the skin)."""
        name, _ = self.picker.add(point)
        self._after_step()
        return name

    def keep(self) -> None:
        """Place the landmark asked for where it was before (picking again)."""
        if self.picking and self.picker.current in self.picker.previous:
            self.picker.keep()
            self._after_step()

    def undo(self) -> None:
        """Take back the last landmark (after the last one: back to picking it)."""
        if self.picker is None:
            return
        was_done = self.picker.done
        if self.picker.undo() is None:
            return
        if was_done:
            self._show_scan(reset_camera=False)
        else:
            self._show_step()

    def set_unit(self, unit: str) -> None:
        """The scan's coordinates are in ``unit``: the face is built again when done."""
        if self.picker is None or unit == self.picker.unit:
            return
        self.picker.unit = unit
        if self.picker.done:
            self._after_step()
        else:
            self._show_scan(reset_camera=False)

    def _after_step(self) -> None:
        if not self.picker.done:
            self._show_step()
            return
        w = self.window
        try:
            face = self.picker.face()
        except ValueError as exc:
            name = self.picker.undo()
            QtWidgets.QMessageBox.warning(w, "Cannot move the muscles onto the scan",
                                          f"{exc}\n\nPlace {name} again.")
            self._show_step()
            return
        self._show_result(face)

    def _show_result(self, face) -> None:
        """The face with the muscles moved onto it: shown as unsaved work on surprise."""
        from .session import Session

        w = self.window
        camera = w.skin_view.camera_position
        self._clear_markers()
        session = Session(face, None, layout=self.picker.layout(face),
                          folder=self.picker.folder)
        w.display.set(plain=False)
        self._own = session
        w.files.show_session(session, modified=True)  # new work: unsaved until saved
        w.skin_view.camera_position = camera
        self._show_step()

    def _show_step(self) -> None:
        self.panel.show_picker(self.picker)
        self._draw_markers()
        self._update_actions()

    def _update_actions(self) -> None:
        active = self.picker is not None
        done = active and self.picker.done
        self.actions["undo"].setEnabled(active and self.picker.step > 0)
        # Ctrl+Z is the landmarks' only while picking (the face has no edits to undo then);
        # once done it is Edit > Undo's again, the button still takes a landmark back
        self.actions["undo"].setShortcut(QtGui.QKeySequence(
            "Ctrl+Z" if self.picking else ""))
        w = self.window
        if w is not None:
            w.add_menu.setEnabled(not self.picking)  # no muscle on a scan without landmarks
        self.actions["keep"].setEnabled(self.picking
                                        and self.picker.current in self.picker.previous)
        self.actions["keep"].setVisible(active and bool(self.picker.previous))
        self.actions["cancel"].setEnabled(active)
        self.actions["cancel"].setText("Close" if done else "Cancel")
        self.actions["save"].setEnabled(done)
        self.actions["again"].setVisible(not self.picking)

    # ------------------------------------------------------------------ markers
    def _draw_markers(self) -> None:
        """Red balls on the landmarks placed; grey ones where they were before."""
        import pyvista as pv

        self._clear_markers()
        if not self.picking:
            return
        w = self.window
        lo, hi = self.picker.skin.bounds()
        radius = 0.008 * float(np.max(hi - lo))
        for key, points, colour in (
                ("placed", list(self.picker.picked.values()), "#e00000"),
                ("before", [v for k, v in self.picker.previous.items()
                            if k not in self.picker.picked], "#9a9a9a")):
            if not points:
                continue
            balls = pv.PolyData(np.asarray(points, float)).glyph(
                geom=pv.Sphere(radius=radius), scale=False, orient=False)
            actor = w.skin_view.add_mesh(balls, color=colour, name=f"landmarks:{key}",
                                         pickable=False, reset_camera=False, render=False)
            self._markers.append(f"landmarks:{key}")
            del actor
        w.skull_view.add_text("The skull is built under the face\nonce the nine landmarks "
                              "are placed", position="upper_left", font_size=10,
                              color="#555555", name="landmarks:hint", render=False)
        w.skin_view.render()
        w.skull_view.render()

    def _clear_markers(self) -> None:
        w = self.window
        for name in self._markers:
            w.skin_view.remove_actor(name, render=False)
        w.skull_view.remove_actor("landmarks:hint", render=False)
        self._markers = []

    # ------------------------------------------------------------------ leaving
    def cancel(self) -> None:
        """Cancel (while picking): back to the face shown before. Close (once done): the
        new face stays, the panel goes.
        """
        if self.picker is None:
            return
        w = self.window
        if self.picking:
            before, dirty = self._before
            self._clear_markers()
            w.display.set(plain=False)
            w.files.show_session(before, modified=dirty)
        self._end()

    def back_to_unsaved(self) -> None:
        """While picking a face's landmarks again, the face left has unsaved changes: go
        back to it (Cancel), so that the question about them is asked about it.
        """
        if self.picking and self._before is not None and self._before[1]:
            self.cancel()

    def _leave_flow(self) -> bool:
        """Before starting anew: a flow under way is cancelled (a finished one kept)."""
        if self.picker is not None:
            self.cancel()
        return True

    def _end(self) -> None:
        self.picker, self._before = None, None
        self.dock.hide()
        self._update_actions()

    def save(self) -> bool:
        """Save the new face's layout (asks for the file); the panel closes once saved."""
        w = self.window
        if not w.save_as_dialog():
            return False
        self._end()
        return True

    def close(self) -> None:
        """Remove the VTK observers and the markers (the window is closing)."""
        w = self.window
        if w is None:
            return
        for observer in self._observers:
            w.skin_view.iren.remove_observer(observer)
        self._observers = []
        self._markers = []
        self.picker, self._before = None, None
