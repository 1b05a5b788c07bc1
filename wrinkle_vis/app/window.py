"""The main window: three linked views (skin with a field, muscles, skull) and controls.

The window only composes (a newcomer's map of the app):

- the models, Qt-free, each emitting an event when it changes (:mod:`.models`): the
  :class:`~.models.Document` (the session and its unsaved changes), the
  :class:`~.models.Playback`, the :class:`~.models.Display` options and the
  :class:`~.models.Probe`;
- the controls, each bound to one model attribute both ways (:mod:`.controls`,
  :mod:`.parameters`, :mod:`.binding`);
- the controllers of the workflows: :class:`~.frames.FrameController` (the views, drawn
  once per event-loop turn after a change), :class:`~.editing.EditController` (the undo
  stack and the edits), :class:`~.editing.PlacementController` (the handles' drags),
  :class:`~.files.FileController` (open, save, recent files, performances, images),
  :class:`~.autosave.RecoveryController`, :class:`~.playback.PlaybackController` and
  :class:`~.dialogs.HelpController`.

The names the tests and the benchmarks use (``w.field_box``, ``w.open_layout``...) are
forwarded to the part that owns them (:func:`_forward`).
"""

from __future__ import annotations

import sys
from pathlib import Path

from qtpy import QtCore, QtGui, QtWidgets

from ..core.layout import LayoutError
from ..plotting.polydata import field_array_name
from ..widgets.panels import MuscleListPanel
from ._pyside_fixes import guard_none_refcount
from .autosave import RecoveryController
from .binding import UndoKeysToWindow, bind, guard_wheel, weak
from .controls import TOTAL, ControlPanel, ProbePanel
from .dialogs import HelpController
from .editing import EditController, PlacementController
from .facemenu import FACE_LABELS, can_pick_again, face_title, mark_face
from .files import FileController
from .frames import FrameController
from .mapping import add_mapping_action
from .models import Display, DisplayOptions, Document, Playback, Probe
from .newface_panel import NewFaceFlow
from .parameters import ParameterGroup
from .playback import PlaybackController
from .recovery import Recovery
from .session import Session, SurfacePoint, load_session

__all__ = ["MainWindow"]

#: The window's size where the screen has room (pixels).
WINDOW_SIZE = (1500, 800)


class MainWindow(QtWidgets.QMainWindow):
    """The wrinkle-vis main window.

    Parameters
    ----------
    session : Session
        What to show.
    settings : QSettings, optional
        Where the recent-files list and the view's switches live (tests pass a temporary
        one).
    recovery : Recovery, optional
        Where the layout is autosaved while the user works (default
        :func:`~wrinkle_vis.app.recovery.default_directory`).
    """

    def __init__(self, session: Session, settings: QtCore.QSettings | None = None,
                 recovery: Recovery | None = None):
        super().__init__()
        guard_none_refcount()
        self.settings = settings or QtCore.QSettings("wrinkle-vis", "wrinkle-vis")
        self.recovery = recovery or Recovery()
        self.document, self.playback, self.probe = Document(session), Playback(), Probe()
        self.display = Display(DisplayOptions(
            anti_aliasing=self.settings.value("antialiasing", False, type=bool),
            raking_light=self.settings.value("raking_light", False, type=bool)))
        self.undo_keys = UndoKeysToWindow(self)
        self.setWindowTitle("wrinkle-vis")
        screen = self.screen() or QtGui.QGuiApplication.primaryScreen()
        self.resize(*fitted_size(screen.availableGeometry().size() if screen else None))
        self.placements = PlacementController(self)
        self.edits = EditController(self)
        self.frames = FrameController(self)
        self.setCentralWidget(self.frames.splitter)
        self.statusBar().addPermanentWidget(self.frames.status_label)
        self.files = FileController(self)
        self._build_docks()
        self.newface = NewFaceFlow(self)
        self.autosaves = RecoveryController(self, self.recovery)
        self.player = PlaybackController(self)
        self.controls.reset_button.clicked.connect(weak(self.player.reset_simulation))
        self.help = HelpController(self)
        self._build_menus()
        self.document.changed.connect(self._on_document)
        self.display.changed.connect(self._remember_display)
        self.frames.draw(reset_camera=True)  # with the raking light and multisampling kept

    # ------------------------------------------------------------------ composing
    def _build_docks(self) -> None:
        """The controls (scrolled, so a long parameter panel never makes the window
        grow) and the list of muscles, docked on the left.
        """
        panel = QtWidgets.QWidget()
        form = QtWidgets.QVBoxLayout(panel)
        self.controls = ControlPanel(self)
        self.parameters = ParameterGroup(self)
        self.probe_panel = ProbePanel(self.document.session.unit)
        for widget in (self.controls, self.parameters, self.probe_panel):
            form.addWidget(widget)
        form.addStretch(1)
        scroll = self.control_scroll = QtWidgets.QScrollArea()
        scroll.setWidgetResizable(True)
        scroll.setFrameShape(QtWidgets.QFrame.NoFrame)
        scroll.setHorizontalScrollBarPolicy(QtCore.Qt.ScrollBarAlwaysOff)
        scroll.setWidget(panel)
        guard_wheel(panel)
        scroll.setMinimumWidth(panel.minimumSizeHint().width()
                               + scroll.verticalScrollBar().sizeHint().width())
        self._dock("Controls", "controls", scroll)
        self.muscle_panel = MuscleListPanel(list(self.edits.actions.values()))
        self.muscle_panel.selected.connect(weak(self.select_muscle, keep=1))
        self._dock("Muscles", "muscles", self.muscle_panel)
        self._show_muscles("session")

    def _dock(self, title: str, name: str, widget: QtWidgets.QWidget) -> None:
        dock = QtWidgets.QDockWidget(title, self)
        dock.setObjectName(name)
        dock.setWidget(widget)
        self.addDockWidget(QtCore.Qt.LeftDockWidgetArea, dock)

    def _build_menus(self) -> None:
        f, e, v = self.files, self.edits, self.frames
        menu = self.menuBar().addMenu("&File")
        for text, key, slot in (
                ("&Open layout...", "Ctrl+O", f.open_dialog),
                ("&New face from mesh...", "Ctrl+N", self.newface.new_face_dialog),
                ("&Save layout", "Ctrl+S", f.save),
                ("Save layout &as...", "Ctrl+Shift+S", f.save_as_dialog),
                ("&Import performance...", "Ctrl+I", f.import_performance_dialog)):
            self._action(menu, text, key, weak(slot))
        f.recent_menu = menu.addMenu("Open &recent")
        self._action(menu, "&Export screenshot...", "Ctrl+P", weak(f.screenshot_dialog))
        self._action(menu, "Save view &image...", "Ctrl+Shift+P", weak(f.image_dialog))
        menu.addSeparator()
        self._action(menu, "&Quit", "Ctrl+Q", self.close)
        menu = self.menuBar().addMenu("&Edit")
        undo = e.undo_stack.createUndoAction(self, "&Undo")
        undo.setShortcut(QtGui.QKeySequence.Undo)
        redo = e.undo_stack.createRedoAction(self, "&Redo")
        redo.setShortcut(QtGui.QKeySequence.Redo)
        menu.addActions([undo, redo])
        menu.addSeparator()
        menu.addMenu(e.add_menu)
        menu.addActions([e.actions[k] for k in
                         ("delete", "duplicate", "rename", "mirror", "mirror_pair")])
        add_mapping_action(self, menu)  # Edit > Track mapping... (app/mapping.py)
        self._build_face_menu()
        menu = self.menuBar().addMenu("&View")
        for name, key in (("front", "1"), ("three_quarter", "2"), ("side", "3"),
                          ("forehead", "4"), ("upper_face", "5")):
            self._action(menu, f"Camera: {name.replace('_', ' ')}", key,
                         weak(v.set_camera, name))
        self._action(menu, "Play / pause", "Space", self.controls.play_button.toggle)
        self.aa_action = self._switch(menu, "&Anti-aliasing (slower drawing)", "",
                                      "anti_aliasing")
        self.raking_action = self._switch(menu, "&Raking light", "L", "raking_light")
        self.raking_action.setToolTip("Light the skin from above and to the side at a "
                                      "grazing angle: shallow furrows show on plain skin")
        menu = self.menuBar().addMenu("&Help")
        self._action(menu, "&Guide", "F1", weak(self.help.show_guide))
        self._action(menu, "&Keyboard shortcuts", "Ctrl+/", weak(self.help.show_shortcuts))
        f.update_recent_menu()

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
            action.triggered.connect(weak(self.files.open_builtin, name))
            self.face_actions[name] = action
        menu.addSeparator()
        self._action(menu, "New face from mesh...", "", weak(self.newface.new_face_dialog))
        menu.addAction(self.newface.actions["again"])

    def _action(self, menu, text, shortcut, slot) -> QtGui.QAction:
        action = menu.addAction(text)
        action.setShortcut(QtGui.QKeySequence(shortcut))
        action.triggered.connect(slot)
        return action

    def _switch(self, menu, text: str, shortcut: str, option: str) -> QtGui.QAction:
        """A checkable action bound to display option ``option``."""
        action = self._action(menu, text, shortcut, lambda *_: None)
        action.setCheckable(True)
        display = self.display
        self.controls.bindings.append(bind(
            action, action.toggled, lambda on: display.set(**{option: bool(on)}),
            lambda: getattr(display.options, option), display.changed, (option,)))
        return action

    # ------------------------------------------------------------------ following
    def _on_document(self, what: str) -> None:
        self._show_muscles(what)
        if what in ("session", "dirty"):  # a drawn frame updates it too
            self.update_title()

    def _show_muscles(self, what: str) -> None:
        s = self.document.session
        if what in ("session", "muscles"):
            self.muscle_panel.set_muscles(s.face.muscle_names, s.muscle)
        elif what == "selection":
            self.muscle_panel.set_current(s.muscle)

    def _remember_display(self, what: str) -> None:
        """The view's switches are kept in the settings for the next start."""
        if what in ("antialiasing", "anti_aliasing", "raking_light"):
            key = "antialiasing" if what == "anti_aliasing" else what
            self.settings.setValue(key, bool(getattr(self.display.options, what)))

    def update_title(self) -> None:
        """``wrinkle-vis - file.json *`` (``*``: unsaved changes; a built-in face by its
        name); the Face menu marks the face shown.
        """
        self.setWindowTitle(face_title(self.document.session))
        self.mark_face()

    def mark_face(self) -> None:
        """The Face menu checks the face shown; Pick landmarks again only on a scan's."""
        mark_face(self.face_actions, self.document.session)
        self.newface.actions["again"].setEnabled(can_pick_again(self.document.session))

    # ------------------------------------------------------------------ actions
    @property
    def session(self) -> Session:
        """The session shown (the document's)."""
        return self.document.session

    def select_muscle(self, name: str | None) -> None:
        """Select a muscle (None: none): its fields, parameters and placement widget show."""
        self.controls.muscle_box.setCurrentText(name or TOTAL)

    def refresh(self, reset_camera: bool = False, skip=()) -> None:
        """Draw the frame now (the frame controller calls it once per event-loop turn after
        a change; a test may call it to draw at once).
        """
        self.frames.draw(reset_camera=reset_camera, skip=skip)

    def probe_vertex(self, vertex: int) -> dict:
        """Probe skin vertex ``vertex`` of the face (at rest); returns the values shown."""
        return self.probe_at(self.document.session.vertex_point(vertex))

    def probe_at(self, where: SurfacePoint) -> dict:
        """Probe rest-skin point ``where``: kept there (the frame's values at it, shown
        again every frame, whatever the expression, the edits or the refinement), with a
        marker on the skin view, its coordinates and every field of the total and of each
        muscle that defines anything there (the selected one first); returns the values.
        """
        self.probe.point = where
        return self.frames.show_probe()

    def clear_probe(self) -> None:
        """Probe nothing: the marker goes, the table empties."""
        self.probe.point = None

    def active_array(self) -> str | None:
        """The point array the skin view colours by (None: plain skin)."""
        if self.display.options.plain:
            return None
        return field_array_name(self.document.session.field, self.document.session.muscle)

    def set_anti_aliasing(self, on: bool) -> None:
        """8x multisampling in the three views, or none (the default: in software rendering
        it costs about 2x per frame, see ``benchmarks/bench_drag.py``).
        """
        self.display.set(anti_aliasing=bool(on))

    def set_raking_light(self, on: bool) -> None:
        """Light the skin view with the raking light (on) or the light kit (off), as
        :func:`~wrinkle_vis.plotting.add_raking_light` describes; remembered in the settings.
        """
        self.display.set(raking_light=bool(on))

    def closeEvent(self, event) -> None:  # noqa: N802 (Qt's name)
        """Ask about unsaved changes, then close every plotter and let go of everything
        that could keep the window alive.
        """
        if not self.files.may_discard_changes("closing"):
            event.ignore()
            return
        self.player.timer.stop()
        self.autosaves.stop()
        self.newface.close()
        self.edits.undo_stack.clear()
        self.recovery.discard()  # a clean exit leaves nothing to recover
        self.frames.close()
        self.help.close()
        event.accept()


def _forward(owner: str, name: str, settable: bool = False) -> property:
    """A property of the window reading (and, ``settable``, writing) ``owner.name``. What
    shows the frame (the views, the status line, the probe) is read up to date: a frame
    still to be drawn in this turn of the event loop is drawn first.
    """
    def get(self):
        if name in _DRAWN:
            self.frames.flush()
        return getattr(getattr(self, owner), name)

    def set_(self, value):
        setattr(getattr(self, owner), name, value)

    return property(get, set_ if settable else None, doc=f"``self.{owner}.{name}``")


_DRAWN = {"plotters", "skin_view", "muscle_view", "skull_view", "views", "status_label",
          "table", "label", "placement"}
_FORWARDS = {
    "controls": "expression_box intensity_slider play_button time_slider reset_button "
                "field_box muscle_box refine_box wireframe_box range_box range_min range_max "
                "range_error cmap_box skin_box skin_group skin_widgets skin_error",
    "frames": "plotters skin_view muscle_view skull_view views muscle_at set_camera "
              "status_label _on_pick sync_views:_sync_views colour_range",
    "edits": "undo_stack actions:edit_actions add_menu edit show_face add_muscle "
             "delete_muscle duplicate_muscle rename_muscle rename_dialog mirror_muscle "
             "mirror_pair set_parameter set_activation set_skin_model set_material",
    "placements": "on_start:_on_handle_start on_move:_on_handle_moved",
    "files": "may_discard_changes open_layout open_builtin open_recent open_dialog save "
             "save_as save_as_dialog recent_files remember:_remember recent_menu ask_unit "
             "show_session:_show_session import_performance import_performance_dialog "
             "track_plot screenshot screenshot_dialog save_image image_dialog",
    "autosaves": "autosave offer_recovery restore autosave_timer autosave_deadline",
    "player": "timer tick:_tick reset_simulation",
    "help": "show_guide show_shortcuts shortcuts guide_dialog shortcuts_dialog",
    "probe_panel": "label:probe_label table:probe_table",
    "parameters": "panel",
    "panel": "widgets:param_widgets option_widgets activation_box derived_label "
             "error:param_error form:param_form",
    "views": "placement",
}
for _owner, _names in _FORWARDS.items():
    for _entry in _names.split():
        _name, _, _alias = _entry.partition(":")
        setattr(MainWindow, _alias or _name, _forward(_owner, _name))
MainWindow.clock = _forward("player", "clock", settable=True)
MainWindow._play_start = _forward("playback", "start", settable=True)
MainWindow.probe_point = property(lambda self: self.probe.point, doc="The probed point.")
MainWindow.param_group = property(lambda self: self.parameters, doc="The parameter group.")
MainWindow.plain_skin = property(lambda self: self.display.options.plain,
                                 lambda self, on: self.display.set(plain=bool(on)),
                                 doc="The skin view shows no field.")


def fitted_size(available: QtCore.QSize | None, wanted=WINDOW_SIZE) -> tuple[int, int]:
    """The window's first size: ``wanted``, shrunk to the screen's ``available`` area (a
    1366 x 768 laptop screen less its panels), so that the window opens whole.
    """
    if available is None or available.isEmpty():
        return wanted
    return min(wanted[0], available.width()), min(wanted[1], available.height())


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
        window.files.remember(layout)
    window.offer_recovery()
    return app.exec()
