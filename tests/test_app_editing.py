"""Placing and editing muscles in the app (Xvfb, pytest-qt): selection, drags through the
real interactors, undo and redo, editing actions, autosave and crash recovery.
"""

import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from conftest import skin_mesh
from qtpy import QtCore, QtWidgets

from wrinkle_vis.app.recovery import Recovery
from wrinkle_vis.core.mesh import closest_points
from wrinkle_vis.widgets import LinearWidget, SheetWidget

pytestmark = pytest.mark.usefixtures("no_leaked_plotters")


def layout_of(window) -> dict:
    return window.session.layout().to_dict()


def display_point(plotter, point) -> np.ndarray:
    r = plotter.renderer
    r.SetWorldPoint(*point, 1.0)
    r.WorldToDisplay()
    return np.array(r.GetDisplayPoint()[:2])


def mouse(plotter, events) -> None:
    """Send ``[(event name, (x, y)), ...]`` to the view's interactor, as the mouse does."""
    iren = plotter.iren.interactor
    for name, (x, y) in events:
        iren.SetEventInformation(int(round(x)), int(round(y)))
        iren.InvokeEvent(name)


def drag_handle(window, layer: str, offset=(-12, 8), steps: int = 4):
    """Drag the selected muscle's first handle on ``layer`` by ``offset`` pixels."""
    widget = window.placement
    handle = next(h for h in widget.handles(widget.muscle) if h.layer == layer)
    plotter = widget.views[layer]
    start = display_point(plotter, widget.position(handle))
    path = [start + t * np.asarray(offset) for t in np.linspace(0, 1, steps + 1)[1:]]
    mouse(plotter, [("MouseMoveEvent", start), ("LeftButtonPressEvent", start),
                    *[("MouseMoveEvent", p) for p in path],
                    ("LeftButtonReleaseEvent", path[-1])])
    return handle


def test_selecting_from_the_list_shows_the_types_widget(window):
    assert window.placement is None
    window.muscle_panel.list.setCurrentRow(window.session.face.muscle_names.index("corrugator_L"))
    assert window.session.muscle == "corrugator_L"
    assert type(window.placement) is LinearWidget
    assert window.muscle_box.currentText() == "corrugator_L"
    window.select_muscle("frontalis_inner_L")
    assert type(window.placement) is SheetWidget
    assert window.muscle_panel.current() == "frontalis_inner_L"
    window.select_muscle(None)
    assert window.placement is None and window.muscle_panel.current() is None


def test_clicking_a_muscle_selects_it(window):
    window.set_camera("front")
    m = window.session.face.muscle("zygomaticus_major_L")
    middle = 0.5 * (np.asarray(m.attachment) + np.asarray(m.insertion))
    xy = display_point(window.muscle_view, middle)
    assert window.muscle_at(*map(int, xy)) == "zygomaticus_major_L"
    mouse(window.muscle_view, [("LeftButtonPressEvent", xy), ("LeftButtonReleaseEvent", xy)])
    assert window.session.muscle == "zygomaticus_major_L"
    assert type(window.placement) is LinearWidget
    corner = (2, 2)  # nothing there: the selection stays
    mouse(window.muscle_view, [("LeftButtonPressEvent", corner),
                               ("LeftButtonReleaseEvent", corner)])
    assert window.session.muscle == "zygomaticus_major_L"


@pytest.mark.parametrize(("expression", "name", "layer"), [
    ("smile", "zygomaticus_major_L", "skin"), ("smile", "zygomaticus_major_L", "skull"),
    ("surprise", "frontalis_major_L", "skin")])
def test_a_drag_moves_the_muscle_redraws_and_is_one_undo_step(window, expression, name, layer):
    window.expression_box.setCurrentText(expression)
    window.select_muscle(name)
    window.set_camera("front" if "zygomaticus" in name else "forehead")
    before_layout = layout_of(window)
    before_points = np.array(skin_mesh(window).points)
    before_image = window.muscle_view.screenshot(return_img=True).astype(int)
    steps_before = window.undo_stack.count()
    camera = window.skin_view.camera_position
    handle = drag_handle(window, layer)
    assert window.skin_view.camera_position == camera  # the handle took the drag, not the camera
    m = window.session.face.muscle(name)
    assert not np.allclose(handle.value(m), _value(before_layout, name, handle))
    surface = window.session.face.skin if layer == "skin" else window.session.face.skull
    p = handle.value(m)
    assert np.linalg.norm(closest_points(surface, p[None])[0] - p) < 1e-6  # on its surface
    assert window.undo_stack.count() == steps_before + 1  # the whole drag: one step
    assert window.undo_stack.undoText().startswith(f"Move {handle.label} of {name}")
    assert window.session.dirty and window.windowTitle().endswith("*")
    after_layout = layout_of(window)
    # the fields changed and every view was redrawn while dragging
    assert not np.array_equal(np.array(skin_mesh(window).points), before_points)
    after_image = window.muscle_view.screenshot(return_img=True).astype(int)
    assert np.abs(after_image - before_image).max() > 50
    window.undo_stack.undo()
    assert layout_of(window) == before_layout  # exactly the previous layout
    assert np.allclose(np.array(skin_mesh(window).points), before_points)
    assert not window.session.dirty
    window.undo_stack.redo()
    assert layout_of(window) == after_layout  # exactly the next


def _value(layout: dict, name: str, handle):
    m = next(m for m in layout["muscles"] if m["name"] == name)
    v = np.asarray(m[handle.param], dtype=float)
    return v if handle.index is None else v[handle.index]


def test_an_invalid_handle_position_is_refused_with_the_reason(window):
    window.select_muscle("zygomaticus_major_L")
    m = window.session.face.muscle("zygomaticus_major_L")
    handle = next(h for h in window.placement.handles(m) if h.layer == "skull")
    before = layout_of(window)
    window._on_handle_start(handle)
    window._on_handle_moved(handle, np.asarray(m.insertion), True)  # zero length
    assert "zygomaticus_major_L" in window.param_error.text()
    assert "length" in window.param_error.text() or "radius" in window.param_error.text()
    assert layout_of(window) == before and window.undo_stack.count() == 0
    assert np.allclose(window.placement.position(handle), m.attachment)  # put back


def test_editing_actions_undo_and_redo(window, monkeypatch):
    original = layout_of(window)
    window.select_muscle("corrugator_L")
    window.edit_actions["duplicate"].trigger()
    assert window.session.muscle == "corrugator_L_copy"
    assert "corrugator_L_copy" in [window.muscle_panel.list.item(i).text()
                                   for i in range(window.muscle_panel.list.count())]
    assert window.rename_muscle("corrugator_extra")
    assert window.session.muscle == "corrugator_extra"
    warnings = []
    monkeypatch.setattr(QtWidgets.QMessageBox, "warning", lambda *a: warnings.append(a[2]))
    assert not window.rename_muscle("corrugator_R")  # taken: refused with the reason
    assert "exists already" in warnings[-1]
    window.select_muscle("corrugator_L")
    window.edit_actions["delete"].trigger()
    assert "corrugator_L" not in window.session.face.muscle_names
    assert window.session.muscle is None and window.placement is None
    texts = [window.undo_stack.text(i) for i in range(window.undo_stack.count())]
    assert texts == ["Duplicate corrugator_L", "Rename corrugator_L_copy to corrugator_extra",
                     "Delete corrugator_L"]
    for _ in texts:
        window.undo_stack.undo()
    assert layout_of(window) == original
    assert window.session.muscle == "corrugator_L"  # selected as it was
    for _ in texts:
        window.undo_stack.redo()
    names = window.session.face.muscle_names
    assert "corrugator_extra" in names and "corrugator_L" not in names


def test_mirror_replaces_the_twin_with_the_mirror_image(window):
    window.select_muscle("zygomaticus_major_L")
    drag_handle(window, "skin", offset=(-10, 10))  # make the pair asymmetric
    left = window.session.face.muscle("zygomaticus_major_L")
    window.edit_actions["mirror"].trigger()
    right = window.session.face.muscle("zygomaticus_major_R")
    flip = np.array([-1.0, 1.0, 1.0])
    assert np.abs(np.asarray(right.insertion) - flip * left.insertion).max() < 2.0
    window.undo_stack.undo()
    assert np.abs(np.asarray(window.session.face.muscle("zygomaticus_major_R").insertion)
                  - flip * left.insertion).max() > 2.0


def test_mirror_pair_swaps_the_sides_in_one_undo_step(window):
    window.select_muscle("zygomaticus_major_L")
    assert window.edit_actions["mirror_pair"].isEnabled()
    drag_handle(window, "skin", offset=(-10, 10))  # make the pair asymmetric
    before = layout_of(window)
    face = window.session.face
    left, right = face.muscle("zygomaticus_major_L"), face.muscle("zygomaticus_major_R")
    window.edit_actions["mirror_pair"].trigger()
    flip = np.array([-1.0, 1.0, 1.0])
    face = window.session.face
    assert np.abs(face.muscle("zygomaticus_major_R").insertion
                  - flip * left.insertion).max() < 2.0
    assert np.abs(face.muscle("zygomaticus_major_L").insertion
                  - flip * right.insertion).max() < 2.0
    assert window.session.muscle == "zygomaticus_major_L"
    window.undo_stack.undo()
    assert layout_of(window) == before
    window.edit_actions["delete"].trigger()  # the right side loses its twin
    window.select_muscle("zygomaticus_major_R")
    assert not window.edit_actions["mirror_pair"].isEnabled()


@pytest.mark.parametrize(("type_name", "widget"), [("linear", "LinearWidget"),
                                                   ("sheet", "SheetWidget"),
                                                   ("ring", "RingWidget")])
def test_add_a_muscle_of_each_type_including_the_plugin(window, type_name, widget):
    window.probe_vertex(int(np.argmax(window.session.face.skin.points[:, 2])))  # nose tip
    action = next(a for a in window.add_menu.actions() if a.text() == type_name)
    action.trigger()
    name = f"{type_name}_1"
    assert window.session.muscle == name
    assert type(window.placement).__name__ == widget  # the plugin brings its own
    if type_name == "ring":
        assert "widget:aoi_disc" in window.muscle_view.actors
        handle = drag_handle(window, "skin", offset=(6, -6))
        assert handle.param == "center"
    window.activation_box.setValue(1.0)  # the new muscle joins the expression
    assert window.session.face.expressions[window.session.expression].activations[name] == 1
    assert np.isfinite(window.session.state().W).all()
    for _ in range(3 if type_name == "ring" else 2):  # (the drag,) the activation, the add
        window.undo_stack.undo()
    assert name not in window.session.face.muscle_names


def test_autosave_writes_a_recovery_file_and_a_clean_exit_removes_it(qtbot, make_window,
                                                                      recovery, monkeypatch):
    w = make_window()
    w.select_muscle("corrugator_L")
    assert w.set_parameter("k0", 3.25)
    qtbot.waitUntil(recovery.path.exists, timeout=5000)
    saved = Recovery.load(recovery.path)
    assert next(m for m in saved.layout.muscles if m.name == "corrugator_L").k0 == 3.25
    w.undo_stack.undo()  # back to the saved state: nothing to recover
    qtbot.waitUntil(lambda: not recovery.path.exists(), timeout=5000)
    w.undo_stack.redo()
    qtbot.waitUntil(recovery.path.exists, timeout=5000)
    monkeypatch.setattr(QtWidgets.QMessageBox, "question",
                        lambda *a: QtWidgets.QMessageBox.Discard)
    w.close()
    assert not recovery.path.exists()


CHILD = textwrap.dedent("""
    import sys, time
    from qtpy import QtCore, QtWidgets
    import wrinkle_vis as wv
    from wrinkle_vis.app.recovery import Recovery
    from wrinkle_vis.app.session import Session
    from wrinkle_vis.app.window import MainWindow

    app = QtWidgets.QApplication([])
    settings = QtCore.QSettings(sys.argv[2], QtCore.QSettings.IniFormat)
    w = MainWindow(Session(wv.datasets.load_face()), settings, Recovery(sys.argv[1]))
    w.show()
    w.select_muscle("corrugator_L")
    w.set_parameter("k0", 3.5)
    w.rename_muscle("corrugator_edited")
    while not w.recovery.path.exists():
        app.processEvents()
        time.sleep(0.02)
    print("autosaved", flush=True)
    while True:  # working on, until killed
        app.processEvents()
        time.sleep(0.02)
""")


def test_killing_the_app_and_restarting_restores_the_edits(make_window, tmp_path, answer):
    folder = tmp_path / "recovery"
    with subprocess.Popen([sys.executable, "-c", CHILD, str(folder),
                           str(tmp_path / "child.ini")], stdout=subprocess.PIPE,
                          text=True) as child:
        try:
            assert child.stdout.readline().strip() == "autosaved"
        finally:
            os.kill(child.pid, signal.SIGKILL)  # a crash: no clean exit
            child.wait(timeout=60)
    assert (folder / f"recovery-{child.pid}.json").exists()
    recovery = Recovery(folder)
    assert recovery.orphans() == [folder / f"recovery-{child.pid}.json"]
    w = make_window(recovery_=recovery)
    answer("Restore")
    assert w.offer_recovery()
    assert "did not close cleanly" in answer.asked[0]
    face = w.session.face
    assert "corrugator_edited" in face.muscle_names and "corrugator_L" not in face.muscle_names
    assert face.muscle("corrugator_edited").k0 == 3.5
    assert "corrugator_edited" in face.expressions["frown"].activations
    assert w.session.dirty  # restored as unsaved work
    assert not (folder / f"recovery-{child.pid}.json").exists()  # taken over by ours
    assert recovery.path.exists() and recovery.orphans() == []


def test_discarding_recovery_deletes_it_and_a_broken_file_is_kept_aside(make_window,
                                                                       tmp_path,
                                                                       monkeypatch, answer):
    folder = tmp_path / "recovery"
    folder.mkdir()
    (folder / "recovery-999999999.json").write_text("{ not json")
    recovery = Recovery(folder)
    warnings = []
    monkeypatch.setattr(QtWidgets.QMessageBox, "warning", lambda *a: warnings.append(a[2]))
    w = make_window(recovery_=recovery, show=False)
    assert not w.offer_recovery()
    assert "recovery-999999999.json" in warnings[0]
    assert (folder / "recovery-999999999.bad").exists()  # never thrown away silently
    Recovery(folder).save(w.session.layout(), None, 4500)
    os.rename(Recovery(folder).path, folder / "recovery-999999998.json")
    answer("Discard")
    assert not w.offer_recovery()
    assert recovery.orphans() == []


BAD_RECOVERY_FIELDS = [("n_triangles", "many"), ("n_triangles", None), ("n_triangles", 1e400),
                       ("n_triangles", 10**400), ("n_triangles", True), ("source", 123),
                       ("source", "a\0b"), ("saved_at", [1]), ("saved_at", 1e400),
                       ("saved_at", 10**400), ("saved_at", "now"), ("saved_at", 1e300)]


def _recovery_file(folder, pid: int, layout: dict, **fields) -> Path:
    data = {"wrinkle_vis_recovery": 1, "pid": pid, "saved_at": 1.0, "source": None,
            "n_triangles": 4500, "layout": layout, **fields}
    path = folder / f"recovery-{pid}.json"
    path.write_text(json.dumps(data))
    return path


@pytest.mark.parametrize(("key", "value"), BAD_RECOVERY_FIELDS,
                         ids=[f"{k}={v!r:.12}" for k, v in BAD_RECOVERY_FIELDS])
def test_a_malformed_recovery_field_is_a_one_line_layout_error(tmp_path, key, value):
    from wrinkle_vis.core.layout import LayoutError
    from wrinkle_vis.datasets import BUILTIN_LAYOUT

    layout = json.loads(BUILTIN_LAYOUT.read_text())
    path = _recovery_file(tmp_path, 999999990, layout, **{key: value})
    with pytest.raises(LayoutError, match=rf"\$\.{key}: expected ") as info:
        Recovery.load(path)
    assert "\n" not in str(info.value) and str(path) in str(info.value)


def test_malformed_recovery_files_are_kept_aside_and_the_app_starts(make_window, tmp_path,
                                                                     monkeypatch):
    """Each malformed file is set aside as .bad with a warning; none stops the start."""
    from wrinkle_vis.datasets import BUILTIN_LAYOUT

    folder = tmp_path / "recovery"
    folder.mkdir()
    layout = json.loads(BUILTIN_LAYOUT.read_text())
    paths = [_recovery_file(folder, 999999900 + i, layout, **{key: value})
             for i, (key, value) in enumerate(BAD_RECOVERY_FIELDS)]
    warnings = []
    monkeypatch.setattr(QtWidgets.QMessageBox, "warning", lambda *a: warnings.append(a[2]))
    w = make_window(recovery_=Recovery(folder), show=False)
    assert not w.offer_recovery()
    assert len(warnings) == len(paths)
    for path in paths:
        assert not path.exists() and path.with_suffix(".bad").exists()
    assert Recovery(folder).orphans() == []


def test_an_unreadable_recovery_folder_does_not_stop_the_start(make_window, monkeypatch):
    """As a user other than root, a recovery folder without read permission makes the
    folder listing raise PermissionError (root reads any folder, so it is simulated).
    """
    def unreadable(self):
        raise PermissionError(13, "Permission denied", str(self.directory))

    monkeypatch.setattr(Recovery, "orphans", unreadable)
    w = make_window(show=False)
    assert not w.offer_recovery()
    assert "Permission denied" in w.statusBar().currentMessage()


def _insertion_on_screen(window):
    """The skin view's Qt widget and the selected muscle's insertion handle on it."""
    widget = window.placement
    handle = next(h for h in widget.handles(widget.muscle) if h.param == "insertion")
    x, y = display_point(window.skin_view, widget.position(handle))
    view = window.skin_view.interactor
    ratio = view.devicePixelRatioF()
    return view, QtCore.QPoint(int(x / ratio), int(view.height() - y / ratio))


def test_a_drag_with_real_qt_mouse_events(window, qtbot):
    """The whole path: Qt mouse events on the view widget, pyvistaqt, VTK, the widget."""
    from qtpy.QtTest import QTest

    window.expression_box.setCurrentText("smile")
    window.select_muscle("zygomaticus_major_L")
    view, start = _insertion_on_screen(window)
    before = np.array(window.session.face.muscle("zygomaticus_major_L").insertion)
    QTest.mouseMove(view, start)
    QTest.mousePress(view, QtCore.Qt.LeftButton, QtCore.Qt.NoModifier, start)
    for k in range(1, 6):
        QTest.mouseMove(view, start + QtCore.QPoint(-2 * k, 2 * k))
    QTest.mouseRelease(view, QtCore.Qt.LeftButton, QtCore.Qt.NoModifier,
                       start + QtCore.QPoint(-10, 10))
    after = np.array(window.session.face.muscle("zygomaticus_major_L").insertion)
    assert np.linalg.norm(after - before) > 1.0
    assert window.undo_stack.count() == 1


def test_a_drag_on_the_physical_skin_starts_warm_and_lets_go_cold(window, qtbot, monkeypatch):
    """While a handle moves, each physical still frame starts from the last one (a few
    iterations); the frame the drag lets go on is solved from the rest skin, so the frame
    shown, saved and exported is the one a fresh evaluation gives, bit for bit."""
    from qtpy.QtTest import QTest

    from wrinkle_vis.core.face import FaceModel

    assert window.session.face.skin_model == "physical"
    asked = []
    evaluate = FaceModel.evaluate

    def spy(self, *args, warm_start=False, **kwargs):
        asked.append(warm_start)
        return evaluate(self, *args, warm_start=warm_start, **kwargs)

    monkeypatch.setattr(FaceModel, "evaluate", spy)
    window.expression_box.setCurrentText("smile")
    window.select_muscle("zygomaticus_major_L")
    view, start = _insertion_on_screen(window)
    QTest.mouseMove(view, start)
    QTest.mousePress(view, QtCore.Qt.LeftButton, QtCore.Qt.NoModifier, start)
    asked.clear()
    for k in range(1, 6):
        QTest.mouseMove(view, start + QtCore.QPoint(-2 * k, 2 * k))
    assert asked and all(asked)  # every move's frame warm
    QTest.mouseRelease(view, QtCore.Qt.LeftButton, QtCore.Qt.NoModifier,
                       start + QtCore.QPoint(-10, 10))
    assert asked[-1] is False  # the last frame cold
    face = window.session.face
    shown = window.session.state()
    cold = evaluate(face, window.session.activations())
    assert np.array_equal(shown.W, cold.W)
    assert np.array_equal(shown.points, cold.points)


# ---------------------------------------------------------------------- polish
def test_duplicate_takes_the_originals_activation(window):
    window.select_muscle("corrugator_L")
    window.edit_actions["duplicate"].trigger()
    face = window.session.face
    for name, ex in face.expressions.items():
        assert ex.activations.get("corrugator_L_copy") == ex.activations.get(
            "corrugator_L"), name
    assert face.expressions["frown"].activations["corrugator_L_copy"] > 0


def test_mirror_names_a_sideless_muscle_for_its_side(window):
    """Mirroring 'zygo' (on the subject's left) gives the pair zygo_L and zygo_R, not
    zygo_mirrored; the copy keeps the original's activations.
    """
    window.select_muscle("zygomaticus_major_L")
    window.rename_muscle("zygo")
    window.edit_actions["mirror"].trigger()
    names = window.session.face.muscle_names
    assert "zygo_L" in names and "zygo_R" in names and "zygo" not in names
    assert not any(n.endswith("_mirrored") for n in names)
    assert window.session.muscle == "zygo_L"
    smile = window.session.face.expressions["smile"].activations
    assert smile["zygo_L"] == smile["zygo_R"] > 0
    assert window.undo_stack.undoText() == "Mirror zygo to zygo_R (and name it zygo_L)"
    window.undo_stack.undo()
    assert "zygo" in window.session.face.muscle_names


def test_mirroring_a_symmetric_pair_changes_nothing(window):
    window.select_muscle("zygomaticus_major_L")
    window.edit_actions["mirror_pair"].trigger()  # the built-in pair is symmetric
    assert window.undo_stack.count() == 0 and not window.session.dirty
    assert "mirror images already" in window.statusBar().currentMessage()


def test_parameter_boxes_show_the_whole_value(window):
    window.select_muscle("corrugator_L")
    assert window.set_parameter("k0", 0.0002152)
    box = window.param_widgets["k0"]
    assert box.value() == pytest.approx(0.0002152, rel=1e-9)
    assert "2152" in box.text()
    assert window.set_parameter("k0", 3.25)
    assert box.text() == "3.250" and box.decimals() == 3  # the box's own decimals


def test_view_menu_names_cameras_without_underscores(window):
    view = next(a.menu() for a in window.menuBar().actions() if a.text() == "&View")
    cameras = [a.text() for a in view.actions() if a.text().startswith("Camera:")]
    assert "Camera: three quarter" in cameras and "Camera: upper face" in cameras
    assert not any("_" in c for c in cameras)


def test_the_window_fits_a_small_screen(window):
    from wrinkle_vis.app.window import fitted_size

    assert fitted_size(QtCore.QSize(1366, 728)) == (1366, 728)
    assert fitted_size(QtCore.QSize(1920, 1040)) == (1500, 800)
    assert fitted_size(None) == (1500, 800)
    hint = window.minimumSizeHint()
    assert hint.width() <= 1366 and hint.height() <= 728


def test_the_field_box_names_each_field_by_its_symbol_and_meaning(window):
    box = window.field_box
    tips = {box.itemText(i): box.itemData(i, QtCore.Qt.ToolTipRole) for i in range(box.count())}
    assert tips["lambda"].startswith("λ: ") and tips["eps"].startswith("ε: ")
    assert tips["w"] != tips["W"] and "Eq. 7" in tips["w"] and "Eq. 4" in tips["W"]
