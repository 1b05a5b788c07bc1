"""Autosave and recovery: the layout is written to a recovery file while it has unsaved
changes, and work an earlier session autosaved and did not save is offered at the start.
"""

from __future__ import annotations

import time
from pathlib import Path

from qtpy import QtCore, QtWidgets

from .binding import weak
from .recovery import Recovery
from .session import Session

__all__ = ["AUTOSAVE_MAX_MS", "AUTOSAVE_QUIET_MS", "RecoveryController"]

AUTOSAVE_QUIET_MS = 1000  # autosave after this long without an edit...
AUTOSAVE_MAX_MS = 5000  # ...and at the latest this long after the first unsaved edit


class RecoveryController:
    """Autosave of ``window``'s document to ``recovery``, and the offer to restore.

    Autosave comes after a second of quiet, and at the latest 5 s after the first
    unsaved edit however the edits go on (a debounce alone would wait for ever).
    """

    def __init__(self, window, recovery: Recovery):
        self.window = window
        self.recovery = recovery
        self.autosave_timer = self._timer(AUTOSAVE_QUIET_MS)
        self.autosave_deadline = self._timer(AUTOSAVE_MAX_MS)
        window.edits.undo_stack.indexChanged.connect(weak(self._schedule_autosave))
        window.document.changed.connect(self._on_document)

    def _timer(self, ms: int) -> QtCore.QTimer:
        timer = QtCore.QTimer(self.window)
        timer.setSingleShot(True)
        timer.setInterval(ms)
        timer.timeout.connect(weak(self.autosave))
        return timer

    def _on_document(self, what: str) -> None:
        if what == "dirty":
            self._schedule_autosave()

    def stop(self) -> None:
        """No more autosaves (the window closes)."""
        self.autosave_timer.stop()
        self.autosave_deadline.stop()

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
        if not self.window.document.session.dirty:
            self.recovery.discard()
            return
        s = self.window.document.session
        try:  # mesh paths relative to the source's folder, else absolute
            self.recovery.save(s.layout(s.layout_path.parent if s.layout_path else None),
                               s.layout_path, s.face.skin.n_triangles)
        except (OSError, ValueError) as exc:  # a full disk; a folder or link refused
            self.window.statusBar().showMessage(f"Autosave failed: {exc}")

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
            self.window.statusBar().showMessage(f"Cannot look for autosaved work: {exc}", 10000)
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
        box = QtWidgets.QMessageBox(self.window)
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
            self.window, "Cannot recover", f"{exc}\n\nThe file was kept as {bad}.")

    def restore(self, path) -> bool:
        """Restore the layout of recovery file ``path`` as unsaved changes (asking first
        about unsaved changes of this session); a file that cannot be read is kept beside
        as ``.bad`` and reported. Only ``path`` is removed, once this session's own
        recovery file holds its layout.
        """
        from wrinkle_vis.datasets import load_face

        path = Path(path)
        saved = []

        def load() -> Session:
            rec = Recovery.load(path)
            base = rec.source.parent if rec.source else Path.cwd()
            n = rec.layout.n_triangles if rec.layout.n_triangles is not None \
                else rec.n_triangles
            face = load_face(n, layout=rec.layout, skin=rec.layout.resolve("skin", base),
                             skull=rec.layout.resolve("skull", base))
            source = rec.source if rec.source and rec.source.exists() else None
            saved.append(rec.saved_at)
            session = Session(face, source, layout=rec.layout, folder=base)
            session.dirty = True  # the restored edits are unsaved
            return session

        if self.window.files.replace_document(
                load, "restoring autosaved work", "Cannot recover",
                on_error=lambda exc: self._keep_aside(path, exc)) is None:
            return False
        if path == self.recovery.path:  # a dead process's of our pid: out of our file's way
            path = path.replace(path.with_name(f"{path.stem}-restored.json"))
        self.autosave()  # ours now holds them: the orphan can go
        if self.recovery.path.exists():
            path.unlink(missing_ok=True)
        self.window.statusBar().showMessage(f"Restored the layout autosaved at "
                                            f"{time.ctime(saved[0])}", 10000)
        return True

