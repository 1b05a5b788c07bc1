"""The editing workflows: undoable edits of the face, and the placement handles' drags.

- :class:`EditController`: the undo stack (its clean flag is the document's ``dirty``,
  through :meth:`~.models.Document.set_dirty` only), :class:`FaceCommand`, the edits of
  a muscle's parameters and activation and of the skin, and the add, delete, duplicate,
  rename, mirror and mirror-pair actions;
- :class:`PlacementController`: a drag of a placement handle, shown at every move and
  one undo step at its end.

They change the :class:`~.models.Document`; what is drawn follows its events.
"""

from __future__ import annotations

import weakref

import numpy as np
from qtpy import QtGui, QtWidgets
from vtkmodules.vtkRenderingCore import vtkPropPicker

from ..core.editing import mirror_name, with_point
from ..core.muscle import MuscleParameterError
from ..core.registry import muscle_types
from ..core.skin import SkinMaterial
from .binding import weak
from .dialogs import ask_text

__all__ = ["KEEP", "EditController", "FaceCommand", "PlacementController"]

KEEP = object()  # edit(): keep the selection


class EditController:
    """Undoable edits of the window's document.

    Parameters
    ----------
    window : MainWindow
        Its ``document``, its parameter panel (``window.parameters``) for refusals, its
        status bar and dialogs' parent.
    """

    def __init__(self, window):
        self.window = window
        self.undo_stack = QtGui.QUndoStack(window)
        self.undo_stack.cleanChanged.connect(weak(self._on_clean_changed, keep=1))
        window.document.changed.connect(self._on_document)
        self.actions = self._make_actions()

    # ------------------------------------------------------------------ the stack
    def edit(self, text: str, face, select=KEEP, before=None) -> None:
        """Show ``face`` as one undoable step called ``text``; ``select`` the muscle to
        select after it (default: keep the selection); ``before`` the face to go back to
        (default: the one shown; a drag has shown its steps already).
        """
        s = self.window.document.session
        before = s.face if before is None else before
        after_select = s.muscle if select is KEEP else select
        self.undo_stack.push(FaceCommand(self, text, before, face, s.muscle, after_select))

    def show_face(self, face, select: str | None = None) -> None:
        """Show a version of the face and select ``select`` (an undo or a redo)."""
        w = self.window
        s = w.document.session
        w.parameters.panel.error.setText("")  # a refusal is about the version left behind
        if face is s.face and select == s.muscle and w.frames.drawn_face is face:
            return  # a drag's end: already on screen
        w.document.show_face(face, select)

    def _on_clean_changed(self, clean: bool) -> None:
        self.window.document.set_dirty(not clean)

    def _on_document(self, what: str) -> None:
        """Another session: a new history. Unsaved changes with no step to undo (a mesh
        chosen, work restored): the stack is not clean, so undoing to it is not a save.
        """
        if what == "session":
            self.undo_stack.clear()
        elif what == "dirty" and self.window.document.session.dirty \
                and self.undo_stack.isClean():
            self.undo_stack.resetClean()

    # ------------------------------------------------------------------ parameters
    def set_parameter(self, param: str, value) -> bool:
        """Set a parameter of the selected muscle; an invalid value is refused with its
        reason shown under the panel, and the field is put back.
        """
        s = self.window.document.session
        panel = self.window.parameters.panel
        name = s.muscle
        muscle = s.face.muscle(name)
        if param not in panel.option_widgets:
            value = int(value) if muscle.parameter(param).unit == "count" else float(value)
        try:
            face = s.with_parameter(name, param, value)
        except (MuscleParameterError, ValueError) as exc:
            panel.error.setText(panel.labelled(str(exc)))
            panel.put_back(param)
            return False
        panel.error.setText("")
        shown = ("on" if value else "off") if isinstance(value, bool) else (
            value if isinstance(value, str) else f"{value:g}")
        self.edit(f"Set {panel.labels().get(param, param)} of {name} to {shown}", face)
        return True

    def set_activation(self, value: float) -> None:
        """Set the selected muscle's peak activation in the expression shown: one undoable
        edit of the layout (0 takes the muscle out of the expression).
        """
        s = self.window.document.session
        if s.muscle is None:
            return
        try:
            face = s.with_activation(s.muscle, float(value))
        except ValueError as exc:
            self.window.parameters.panel.error.setText(str(exc))
            self.window.parameters.show_activation()
            return
        self.edit(f"Set activation of {s.muscle} in {s.expression} to {value:g}", face)

    def set_skin_model(self, skin_model: str) -> bool:
        """Evaluate the face with ``skin_model`` ("geometric" or "physical"): an undoable
        edit of the layout (saved as its ``skin_model``).
        """
        s = self.window.document.session
        if skin_model == s.face.skin_model:
            return False
        self.edit(f"Use the {skin_model} skin", s.with_skin_model(skin_model))
        return True

    def set_material(self, param: str, value) -> bool:
        """Set one parameter of the physical skin's material (an undoable edit, saved as
        the layout's ``skin_material``); an invalid value is refused with its reason shown
        under the panel, and the box is put back.
        """
        controls = self.window.controls
        spec = {p.name: p for p in SkinMaterial.parameters()}[param]
        value = int(value) if spec.unit == "count" else float(value)
        try:
            face = self.window.document.session.with_material(param, value)
        except ValueError as exc:
            controls.skin_error.setText(str(exc))
            controls.show_material()
            return False
        controls.skin_error.setText("")
        self.edit(f"Set {spec.label} of the skin to {value:g}", face)
        return True

    # ------------------------------------------------------------------ muscles
    def _make_actions(self) -> dict[str, QtGui.QAction]:
        """The Add muscle menu's action and the actions on the selected muscle."""
        w = self.window
        self.add_menu = QtWidgets.QMenu("&Add muscle", w)
        for name in muscle_types():
            self.add_menu.addAction(name).triggered.connect(weak(self.add_muscle, name))
        add = self.add_menu.menuAction()
        add.setToolTip("Add a muscle of a type, inserted at the probed point (right-click "
                       "the skin first) or at the middle of the skin view")
        actions = {"add": add}
        for key, text, shortcut, slot in (
                ("delete", "&Delete", "Del", self.delete_muscle),
                ("duplicate", "D&uplicate", "Ctrl+D", self.duplicate_muscle),
                ("rename", "&Rename...", "F2", self.rename_dialog),
                ("mirror", "&Mirror", "Ctrl+M", self.mirror_muscle),
                ("mirror_pair", "Mirror &pair", "Ctrl+Shift+M", self.mirror_pair)):
            action = QtGui.QAction(text, w)
            action.setShortcut(QtGui.QKeySequence(shortcut))
            action.triggered.connect(weak(slot))
            actions[key] = action
        actions["mirror"].setToolTip(
            "Copy the muscle to the other side of the face's symmetry plane, replacing its "
            "twin (_L <-> _R) if there is one")
        actions["mirror_pair"].setToolTip(
            "Mirror the muscle and its twin together: each side takes the mirror image of "
            "the other")
        w.document.changed.connect(self._enable_actions)
        self.actions = actions
        self._enable_actions()
        return actions

    def _enable_actions(self, what: str = "session") -> None:
        if what not in ("session", "muscles", "selection"):
            return
        s = self.window.document.session
        for key in ("delete", "duplicate", "rename", "mirror"):
            self.actions[key].setEnabled(s.muscle is not None)
        self.actions["mirror_pair"].setEnabled(
            s.muscle is not None and s.twin_of(s.muscle) is not None)

    def _selected_or_warn(self) -> str | None:
        s = self.window.document.session
        if s.muscle is None:
            self.window.statusBar().showMessage(
                "Select a muscle first (in the list, or click it)")
        return s.muscle

    def add_muscle(self, type_name: str) -> str | None:
        """Add a muscle of ``type_name`` at the probed point (or the middle of the skin
        view) and select it; returns its name, or None if the type cannot make one.
        """
        at = self._placement_point()
        try:
            face, name = self.window.document.session.added(type_name, at)
        except (NotImplementedError, MuscleParameterError, ValueError, KeyError) as exc:
            QtWidgets.QMessageBox.warning(self.window, "Cannot add muscle", str(exc))
            return None
        self.edit(f"Add {name}", face, select=name)
        return name

    def _placement_point(self):
        """Where a new muscle goes: the probed point (at rest), else the middle of the
        skin view, else the front of the face.
        """
        w = self.window
        s = w.document.session
        if w.probe.point is not None:
            return s.probe_position(w.probe.point)[0]
        picker = vtkPropPicker()
        width, height = w.skin_view.render_window.GetSize()
        if picker.Pick(width / 2, height / 2, 0, w.skin_view.renderer):
            return np.array(picker.GetPickPosition())
        return s.face.skin.points[np.argmax(s.face.skin.points[:, 2])]

    def delete_muscle(self) -> None:
        """Delete the selected muscle."""
        name = self._selected_or_warn()
        if name is not None:
            self.edit(f"Delete {name}", self.window.document.session.deleted(name),
                      select=None)

    def duplicate_muscle(self) -> str | None:
        """Copy the selected muscle under a free name and select the copy."""
        name = self._selected_or_warn()
        if name is None:
            return None
        face, copy = self.window.document.session.duplicated(name)
        self.edit(f"Duplicate {name}", face, select=copy)
        return copy

    def rename_muscle(self, new_name: str) -> bool:
        """Rename the selected muscle; a bad name is refused with the reason."""
        name = self._selected_or_warn()
        if name is None:
            return False
        try:
            face = self.window.document.session.renamed(name, new_name)
        except (ValueError, MuscleParameterError) as exc:
            QtWidgets.QMessageBox.warning(self.window, "Cannot rename", str(exc))
            return False
        self.edit(f"Rename {name} to {new_name.strip()}", face, select=new_name.strip())
        return True

    def rename_dialog(self) -> None:
        """Ask for a new name for the selected muscle."""
        name = self._selected_or_warn()
        if name is not None:
            text, ok = ask_text(self.window, "Rename muscle", f"New name for {name}:", name)
            if ok and text != name:
                self.rename_muscle(text)

    def mirror_muscle(self) -> str | None:
        """Mirror the selected muscle across the face's symmetry plane (see
        :meth:`Session.mirrored`); returns the twin's name.
        """
        return self._mirror(self.window.document.session.mirrored, "Cannot mirror",
                            "Mirror {} to {}")

    def mirror_pair(self) -> str | None:
        """Mirror the selected muscle and its twin together (see
        :meth:`Session.mirrored_pair`); returns the twin's name.
        """
        return self._mirror(self.window.document.session.mirrored_pair,
                            "Cannot mirror the pair", "Mirror the pair {} and {}")

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
            QtWidgets.QMessageBox.warning(self.window, title, str(exc))
            return None
        if self.window.document.session.same_muscles(face):  # nothing to undo
            self.window.statusBar().showMessage(
                f"{name} and {twin} are mirror images already; nothing changed", 5000)
            return twin
        if name in face.muscle_names:
            self.edit(text.format(name, twin), face)
        else:  # a muscle without a side was named for its side: X -> X_L, twin X_R
            sided = mirror_name(twin)
            self.edit(f"{text.format(name, twin)} (and name it {sided})", face,
                      select=sided)
        return twin


class PlacementController:
    """A drag of the selected muscle's placement handles: each move shows the muscle with
    the point moved (an invalid position is refused with the reason, the handle put back),
    and the whole drag is one undo step.
    """

    def __init__(self, window):
        self.window = window
        self._before = None  # the face when the drag started

    def on_start(self, handle) -> None:
        """A handle was grabbed."""
        self._before = self.window.document.session.face
        self.window.views.begin_drag()

    def on_move(self, handle, point, finished: bool) -> None:
        """Handle ``handle`` moved to rest position ``point`` (``finished``: let go)."""
        w = self.window
        s = w.document.session
        views = w.views
        name = views.placement.muscle.name
        panel = w.parameters.panel
        try:
            new = with_point(s.face.muscle(name), handle.param, handle.index, point)
        except MuscleParameterError as exc:
            panel.error.setText(panel.labelled(str(exc)))
            w.statusBar().showMessage(f"Refused: {panel.labelled(str(exc))}", 10000)
            views.placement.update(s.face.muscle(name), s.state())
            w.frames.sync_views()
        else:
            panel.error.setText("")
            s.dragging = not finished  # the frame let go on is solved cold (bit for bit)
            w.document.set_face(s.face.with_muscle(new))
            # the handle's own view is rendered by its widget right after this callback:
            # the frame must be in its meshes before that
            w.frames.flush(skip=() if finished else (views.placement.views[handle.layer],))
        if finished:
            if s.dragging:  # let go on a refused move: the last frame solved cold again
                s.dragging = False
                s._changed()
                w.frames.request()
                w.frames.flush()
            views.end_drag()
            views.render()
            before, self._before = self._before, None
            if before is not None and before is not s.face:
                w.edits.edit(f"Move {handle.label} of {name}", s.face, before=before)


class FaceCommand(QtGui.QUndoCommand):
    """One undoable edit: the face before and after, and the selection with each.

    It holds its controller weakly (the window owns the stack that owns the command).
    """

    def __init__(self, edits: EditController, text: str, before, after, select_before,
                 select_after):
        super().__init__(text)
        self._edits = weakref.ref(edits)
        self.before, self.after = before, after
        self.select_before, self.select_after = select_before, select_after

    def redo(self) -> None:
        """Show the face after the edit."""
        edits = self._edits()
        if edits is not None:
            edits.show_face(self.after, self.select_after)

    def undo(self) -> None:
        """Show the face before the edit."""
        edits = self._edits()
        if edits is not None:
            edits.show_face(self.before, self.select_before)
