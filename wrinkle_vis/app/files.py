"""Files: open a layout, a built-in face or a recent file, save, import a performance,
save images of the views.

Every way of replacing what the window shows goes through
:meth:`FileController.replace_document`: may the unsaved changes be left behind, try the
loader, warn in one line when it fails, show what it made.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable
from pathlib import Path

from qtpy import QtCore, QtWidgets

from ..core.layout import Layout, LayoutError, load_layout
from ..core.tracks import TrackError, TrackWarning, default_mapping, performance, read_track
from ..core.units import DEFAULT_UNIT, LENGTH_UNITS, guess_unit
from .binding import weak
from .dialogs import ImageDialog
from .session import Session, load_session
from .trackplot import TrackPlot, track_curves

__all__ = ["MAX_RECENT", "FileController"]

MAX_RECENT = 8
#: What opening a layout, a face or a recovery file can raise (the domain's errors are
#: ValueErrors).
LOAD_ERRORS = (OSError, LayoutError, ValueError, KeyError)


class FileController:
    """Opening, saving and importing for ``window`` (its ``document``, ``settings``,
    ``recovery`` and ``edits``' undo stack).
    """

    def __init__(self, window):
        self.window = window
        self.settings = window.settings
        self.track_plot: TrackPlot | None = None  # made by the first import_performance
        self.recent_menu: QtWidgets.QMenu | None = None

    # ------------------------------------------------------------------ replacing
    def may_discard_changes(self, doing: str = "going on") -> bool:
        """Whether the unsaved changes, if any, may be left behind: asks Save / Discard /
        Cancel (Save saves them first, and a failed or cancelled save is a Cancel). Picking
        a face's landmarks again while it has unsaved changes goes back to that face first.
        """
        self.window.newface.back_to_unsaved()
        if not self.window.document.session.dirty:
            return True
        answer = QtWidgets.QMessageBox.question(
            self.window, "Unsaved changes",
            f"The layout has unsaved changes. Save them before {doing}?",
            QtWidgets.QMessageBox.Save | QtWidgets.QMessageBox.Discard
            | QtWidgets.QMessageBox.Cancel, QtWidgets.QMessageBox.Save)
        if answer == QtWidgets.QMessageBox.Save:
            return self.save()
        return answer == QtWidgets.QMessageBox.Discard

    def replace_document(self, load: Callable[[], Session | None], doing: str, title: str,
                         errors=LOAD_ERRORS, on_error=None) -> Session | None:
        """Show the session ``load()`` makes, once the unsaved changes may go (asked about
        ``doing``); a failure is warned about under ``title`` in one line (or handed to
        ``on_error(exc)``, which returns a session or None). Returns the session shown.
        """
        if not self.may_discard_changes(doing):
            return None
        try:
            session = load()
            if session is not None:
                session.state()  # a face that cannot be evaluated is refused here
        except errors as exc:
            if on_error is None:
                QtWidgets.QMessageBox.warning(self.window, title, str(exc))
                return None
            session = on_error(exc)
        if session is None:
            return None
        self.show_session(session, modified=session.dirty)
        return session

    def show_session(self, session: Session, modified: bool = False) -> None:
        """Show another session (a layout opened or restored), with the view's settings;
        ``modified``: it holds a change not saved yet (``*`` in the title, Quit asks).
        """
        w = self.window
        if self.track_plot is not None:  # the performance stays with the session it was in
            self.track_plot.parentWidget().hide()
        w.probe.point = None  # a point of the skin shown before
        w.document.replace(session, modified)
        w.newface.session_changed(session)

    def open_builtin(self, name: str) -> bool:
        """Show built-in face ``name`` (:data:`wrinkle_vis.datasets.FACES`), after asking
        about unsaved changes.
        """
        from wrinkle_vis.datasets import load_face

        def load() -> Session:
            face = load_face(name)
            named = None if name == "procedural" else name  # the layout records the face
            return Session(face, layout=Layout(face=named, unit=face.unit))

        if self.replace_document(load, f"opening the {name} face",
                                 "Cannot open the face") is None:
            self.window.mark_face()  # the menu's click checked the face not shown
            return False
        self.window.recovery.discard()
        return True

    def open_layout(self, path: str | Path) -> bool:
        """Open a layout file (after asking about unsaved changes); a bad one is reported
        and the current face kept.
        """
        path = Path(path)

        def load() -> Session | None:
            current = self.window.document.session
            layout = current.layout()
            n = current.face.skin.n_triangles if layout.skin is None and layout.face in (
                None, "procedural") else None
            go_on, unit = self._unit_of_layout_mesh(path)
            return load_session(path, n_triangles=n, unit=unit) if go_on else None

        shown = self.replace_document(
            load, "opening another layout", "Cannot open layout",
            on_error=lambda exc: self._session_on_chosen_mesh(path, exc))
        if shown is None:
            return False
        self.window.recovery.discard()  # what it held was saved or discarded just now
        self.remember(path)
        return True

    def open_recent(self, path: str) -> bool:
        """Open a layout of the Open recent menu."""
        return self.open_layout(path)

    def open_dialog(self) -> None:
        """Ask for a layout file and open it."""
        path, _ = QtWidgets.QFileDialog.getOpenFileName(self.window, "Open layout", "",
                                                        "Layouts (*.json)")
        if path:
            self.open_layout(path)

    def _session_on_chosen_mesh(self, path: Path, exc: Exception) -> Session | None:
        """Layout ``path`` could not be opened (``exc``): when it has muscles but names no
        mesh (made for a scan, ``"skin": null``) or names one that is not there (moved),
        offer to choose the mesh it was made for; else report ``exc`` in one line. Returns
        the session on the chosen mesh, or None.
        """
        try:
            layout = load_layout(path)
        except (OSError, LayoutError, ValueError):
            layout = None
        missing = layout is not None and layout.skin is not None and not (
            layout.resolve("skin", path.parent).is_file())
        if layout is None or not layout.muscles or (layout.skin is not None and not missing):
            QtWidgets.QMessageBox.warning(self.window, "Cannot open layout", str(exc))
            return None
        why = (f"The layout's mesh {layout.skin} is not there (moved or renamed?)." if missing
               else "The layout names no mesh (\"skin\": null), and its muscles do not fit "
               "the built-in face.")
        mesh = self._choose_mesh(path, f"{exc}\n\n{why} Choose the mesh it was made for?")
        return self._session_on_mesh(path, layout, mesh) if mesh else None

    def _choose_mesh(self, path: Path, question: str) -> str:
        """Ask whether to choose the mesh of layout ``path``, then which ("": cancelled)."""
        from .newface import MESH_FILTER

        box = QtWidgets.QMessageBox(QtWidgets.QMessageBox.Question, "Which mesh?", question,
                                    parent=self.window)
        choose = box.addButton("Choose mesh...", QtWidgets.QMessageBox.AcceptRole)
        box.addButton(QtWidgets.QMessageBox.Cancel)
        box.exec()
        chosen = box.clickedButton() is choose
        box.deleteLater()
        return QtWidgets.QFileDialog.getOpenFileName(
            self.window, f"The mesh of {path.name}", str(path.parent), MESH_FILTER)[0] \
            if chosen else ""

    def _session_on_mesh(self, path: Path, layout: Layout, mesh: str) -> Session | None:
        """The session of ``layout`` (of file ``path``) on the skin in file ``mesh``, its
        unit guessed or asked; a failure is warned about (None).
        """
        from wrinkle_vis.core.mesh import MeshError
        from wrinkle_vis.datasets import load_face, read_surface

        from .newface import relative_mesh_path

        try:
            skin = read_surface(mesh)
        except (OSError, MeshError, ValueError) as err:
            QtWidgets.QMessageBox.warning(self.window, "Cannot open layout", f"{mesh}: {err}")
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
        except LOAD_ERRORS as err:
            QtWidgets.QMessageBox.warning(self.window, "Cannot open layout", f"{mesh}: {err}")
            return None
        session.dirty = True  # the mesh chosen is a change of the layout, unsaved
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
            self.window, "Unit of the mesh",
            f"{what} is {height:.3g} units tall, not a head's height in m, cm or mm, so its "
            "unit cannot be guessed. In which unit are its coordinates?",
            units, units.index(DEFAULT_UNIT), False)
        return unit if ok else None

    # ------------------------------------------------------------------ saving
    def save(self) -> bool:
        """Save to the open file, or ask for one. When another program changed the file
        since it was opened or saved, ask first: Overwrite, Save As... or Cancel (which
        writes nothing and keeps the edits); a file deleted meanwhile is written again.
        """
        s = self.window.document.session
        path = s.layout_path
        if path is None:
            return self.save_as_dialog()
        change = s.disk_change()
        if change == "changed":
            choice = self._ask_overwrite(path)
            if choice != "overwrite":
                return self.save_as_dialog() if choice == "save as" else False
        if not self.save_as(path):
            return False
        if change == "deleted":
            self.window.statusBar().showMessage(
                f"{path} had been deleted meanwhile: saved it again", 10000)
        return True

    def _ask_overwrite(self, path: Path) -> str:
        """Ask what to do with the open file another program changed: ``"overwrite"``,
        ``"save as"`` or ``"cancel"`` (closing the question too).
        """
        box = QtWidgets.QMessageBox(
            QtWidgets.QMessageBox.Warning, "The file changed on disk",
            f"{path} was changed by another program since it was opened or last saved. "
            "Overwrite it with the layout shown here (its changes are lost), save the "
            "layout elsewhere, or cancel (nothing is written, the edits stay)?",
            parent=self.window)
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
        w = self.window
        try:
            w.document.session.save(path)
        except (OSError, ValueError) as exc:
            QtWidgets.QMessageBox.warning(w, "Cannot save layout", str(exc))
            return False
        w.edits.undo_stack.setClean()
        w.document.set_dirty(False)
        w.recovery.discard()
        self.remember(path)
        w.update_title()
        return True

    def save_as_dialog(self) -> bool:
        """Ask for a file and save the layout there."""
        path, _ = QtWidgets.QFileDialog.getSaveFileName(self.window, "Save layout", "",
                                                        "Layouts (*.json)")
        return self.save_as(path) if path else False

    # ------------------------------------------------------------------ recent files
    def recent_files(self) -> list[str]:
        """The recently opened or saved layouts, newest first."""
        value = self.settings.value("recent", [])
        return [value] if isinstance(value, str) else list(value or [])

    def remember(self, path) -> None:
        """Put ``path`` first in the recent files."""
        path = str(Path(path).resolve())
        recent = [path] + [p for p in self.recent_files() if p != path]
        self.settings.setValue("recent", recent[:MAX_RECENT])
        self.update_recent_menu()

    def update_recent_menu(self) -> None:
        """The Open recent menu lists the recent files."""
        if self.recent_menu is None:
            return
        self.recent_menu.clear()
        for path in self.recent_files():
            self.recent_menu.addAction(path).triggered.connect(weak(self.open_recent, path))
        self.recent_menu.setEnabled(bool(self.recent_files()))

    # ------------------------------------------------------------------ performances
    def import_performance(self, path: str | Path) -> str:
        """Play a recorded track (File > Import performance...): the timeline follows it,
        Play runs at its clock, its channels are plotted under the views. Returns its name
        in the expression list. ``TrackError`` (one line) for a file that cannot be read.
        """
        w = self.window
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", TrackWarning)
            track = read_track(path)
        s = w.document.session
        mapping = s.face.mapping or default_mapping()
        perf = performance(track, mapping, s.face.muscle_names,
                           name=f"{Path(path).stem} (track)")
        if self.track_plot is None:
            dock = QtWidgets.QDockWidget("Performance", w)
            dock.setObjectName("performance")
            self.track_plot = TrackPlot(dock)
            dock.setWidget(self.track_plot)
            w.addDockWidget(QtCore.Qt.BottomDockWidgetArea, dock)
        self.track_plot.set_curves(track_curves(track, mapping, s.face.muscle_names),
                                   track.duration_s)
        self.track_plot.parentWidget().show()
        w.document.set_performance(perf)
        notes = "; ".join(str(m.message) for m in caught)
        w.statusBar().showMessage(
            f"{perf.name}: {track.n_frames} frames, {track.duration_s:.3g} s"
            + (f" ({notes})" if notes else ""), 15000)
        return perf.name

    def import_performance_dialog(self) -> None:
        """Ask for a track file and play it; a bad one is reported in one line."""
        path, _ = QtWidgets.QFileDialog.getOpenFileName(
            self.window, "Import performance", "", "Tracks (*.csv);;All files (*)")
        if not path:
            return
        try:
            self.import_performance(path)
        except (TrackError, OSError) as exc:
            QtWidgets.QMessageBox.warning(self.window, "Cannot import the performance",
                                          str(exc))

    # ------------------------------------------------------------------ images
    def screenshot(self, path: str | Path) -> Path:
        """Save the skin view as a PNG (atomically: a failed write keeps the old file)."""
        from wrinkle_vis.plotting.writers import save_image

        save_image(self.window.skin_view.screenshot(return_img=True), path)
        return Path(path)

    def screenshot_dialog(self) -> None:
        """Ask for a file and save the skin view there."""
        path, _ = QtWidgets.QFileDialog.getSaveFileName(self.window, "Export screenshot", "",
                                                        "PNG images (*.png)")
        if path:
            self.screenshot(path)

    def save_image(self, view: str, path: str | Path, size: tuple[int, int]) -> Path:
        """Save view ``view`` (``"skin"``, ``"muscles"`` or ``"skull"``) as a PNG of
        ``size`` ``(width, height)`` pixels, without the placement widget's handles and
        outlines or the probe's marker (see :meth:`LinkedViews.save_image`).
        """
        return self.window.views.save_image(view, path, size)

    def image_dialog(self) -> Path | None:
        """Ask for a view, a size and a file, and save the view's image there."""
        w = self.window
        width, height = w.skin_view.window_size
        dialog = ImageDialog(w, (2 * width, 2 * height))
        if dialog.exec() != QtWidgets.QDialog.Accepted:
            return None
        path, _ = QtWidgets.QFileDialog.getSaveFileName(w, "Save view image", "",
                                                        "PNG images (*.png)")
        if not path:
            return None
        if not path.lower().endswith(".png"):
            path += ".png"
        try:
            out = self.save_image(dialog.view(), path, dialog.size())
        except (OSError, ValueError, RuntimeError) as exc:
            QtWidgets.QMessageBox.warning(w, "Cannot save the image", str(exc))
            return None
        w.statusBar().showMessage(f"Saved {out} ({dialog.size()[0]} x "
                                  f"{dialog.size()[1]})", 10000)
        return out
