"""Nothing lost, nothing silent (issue 13), in a real window (Xvfb, pytest-qt): unsaved edits
and recovery files, the layout held in memory, autosave, the probe through a real click,
the colour range and the scalar bar, units, view images, help, and the small defects a new
user meets. Each test drives the widgets: clicks, keys, the menus' actions, the dialogs'
own buttons (fixtures in conftest.py).
"""

import dataclasses
import json
import os
import sys
import time

import numpy as np
import pytest
from conftest import skin_mesh
from PIL import Image
from qtpy import QtCore, QtGui, QtWidgets
from qtpy.QtTest import QTest

import wrinkle_vis as wv
from wrinkle_vis.app.recovery import Recovery
from wrinkle_vis.app.session import Session
from wrinkle_vis.datasets import load_face
from wrinkle_vis.plotting.fields import field_info, field_range

pytestmark = pytest.mark.usefixtures("no_leaked_plotters")


def menu_action(window, *path: str) -> QtGui.QAction:
    """The action at ``path`` of the menu bar, by the texts shown (without the ``&``)."""
    actions = window.menuBar().actions()
    for i, text in enumerate(path):
        action = next(a for a in actions if a.text().replace("&", "") == text)
        if i < len(path) - 1:
            actions = action.menu().actions()
    return action


def activate(window, qtbot) -> None:
    """Make ``window`` the active window (keyboard shortcuts go to the active window)."""
    window.activateWindow()
    window.raise_()
    qtbot.waitUntil(lambda: QtWidgets.QApplication.activeWindow() is window, timeout=3000)


def type_into(box: QtWidgets.QAbstractSpinBox, text: str) -> None:
    """Type ``text`` into a spin box as a user does: select all, type, Enter."""
    box.setFocus()
    QtWidgets.QApplication.processEvents()  # focus moves through the event loop
    box.selectAll()
    QTest.keyClicks(box, text)
    QTest.keyClick(box, QtCore.Qt.Key_Return)


def display_point(plotter, point) -> np.ndarray:
    r = plotter.renderer
    r.SetWorldPoint(*point, 1.0)
    r.WorldToDisplay()
    return np.array(r.GetDisplayPoint()[:2])


def widget_pos(plotter, point) -> QtCore.QPoint:
    """The Qt position on the view's widget of world ``point``."""
    x, y = display_point(plotter, point)
    view = plotter.interactor
    ratio = view.devicePixelRatioF()
    return QtCore.QPoint(int(round(x / ratio)), int(round(view.height() - y / ratio)))


def shown_range(window) -> tuple[float, float]:
    """The colour range the skin view draws with (its mapper's)."""
    return tuple(float(x) for x in window.skin_view.actors["skin"].mapper.scalar_range)


def saved_k0(path, muscle: str) -> float:
    data = json.loads(path.read_text())
    return next(m for m in data["muscles"] if m["name"] == muscle)["k0"]


# ---------------------------------------------------------------------- work that is lost
@pytest.mark.parametrize("how", ["File > Open", "Open recent"])
@pytest.mark.parametrize("choice", ["Cancel", "Discard", "Save"])
def test_opening_a_layout_asks_about_unsaved_changes(window, tmp_path, monkeypatch, answer,
                                                     how, choice):
    current, other = tmp_path / "current.json", tmp_path / "other.json"
    assert window.save_as(current)
    other.write_text(current.read_text())  # the same layout, k0 as built
    k0 = window.session.face.muscle("corrugator_L").k0
    window.select_muscle("corrugator_L")
    type_into(window.param_widgets["k0"], "4.5")
    assert window.session.dirty
    answer(choice)
    if how == "File > Open":
        monkeypatch.setattr(QtWidgets.QFileDialog, "getOpenFileName",
                            lambda *a, **k: (str(other), "Layouts (*.json)"))
        menu_action(window, "File", "Open layout...").trigger()
    else:
        window._remember(other)
        menu_action(window, "File", "Open recent", str(other.resolve())).trigger()
    assert "unsaved changes" in answer.asked[0]
    if choice == "Cancel":  # nothing happened
        assert window.session.layout_path == current and window.session.dirty
        assert window.session.face.muscle("corrugator_L").k0 == 4.5
        assert window.windowTitle().endswith("current.json *")
        return
    assert window.session.layout_path == other and not window.session.dirty
    assert window.session.face.muscle("corrugator_L").k0 == k0
    assert saved_k0(current, "corrugator_L") == (4.5 if choice == "Save" else k0)


def test_restoring_autosaved_work_asks_about_unsaved_changes(window, tmp_path, answer):
    folder = tmp_path / "orphans"
    Recovery(folder).save(window.session.layout(), None, 4500)
    orphan = folder / "recovery-999999990.json"
    Recovery(folder).path.rename(orphan)
    window.select_muscle("corrugator_L")
    type_into(window.param_widgets["k0"], "4.5")
    answer("Cancel")
    assert not window.restore(orphan)
    assert window.session.face.muscle("corrugator_L").k0 == 4.5 and orphan.exists()


@pytest.mark.parametrize("change", ["deleted", "truncated", "replaced"])
def test_the_open_file_changing_on_disk_loses_nothing(make_window, wv_face, tmp_path,
                                                      monkeypatch, qtbot, answer, change):
    """The session holds its layout: Save (after asking to overwrite a changed file), Save
    As and autosave write what it shows.
    """
    path = tmp_path / "mine.json"
    wv.save_layout(Session(wv_face).layout(), path)
    face = load_face(layout=path)
    w = make_window(Session(face, path))
    warnings = []
    monkeypatch.setattr(QtWidgets.QMessageBox, "warning", lambda *a: warnings.append(a[2]))
    skin, points = w.session.face.skin, w.session.face.skin.points.copy()
    if change == "deleted":
        path.unlink()
    elif change == "truncated":
        path.write_text('{"format": "wrinkle-vis-layout", "vers')
    else:  # another layout in its place: another name, skin and no muscles
        path.write_text(json.dumps({"format": "wrinkle-vis-layout", "version": 1,
                                    "name": "someone else's", "skin": "elsewhere.ply",
                                    "muscles": [], "expressions": {}}))
    w.select_muscle("corrugator_L")
    type_into(w.param_widgets["k0"], "3.75")
    if change != "deleted":  # another program changed it: asked (test_app_external_change)
        answer("Overwrite")
    menu_action(w, "File", "Save layout").trigger()
    assert not warnings and not w.session.dirty
    saved = wv.load_layout(path)
    assert saved.skin is None and saved.name == face.name
    assert saved.muscles == w.session.face.muscles
    assert next(m for m in saved.muscles if m.name == "corrugator_L").k0 == 3.75
    assert w.session.face.skin is skin and np.array_equal(w.session.face.skin.points, points)
    # Save As elsewhere, and the autosave of the next edit
    path.unlink()
    elsewhere = tmp_path / "sub" / "copy.json"
    elsewhere.parent.mkdir()
    assert w.save_as(elsewhere) and not warnings
    assert wv.load_layout(elsewhere).muscles == w.session.face.muscles
    elsewhere.write_text("")
    type_into(w.param_widgets["k0"], "3.5")
    qtbot.waitUntil(w.recovery.path.exists, timeout=8000)
    recovered = Recovery.load(w.recovery.path)
    assert next(m for m in recovered.layout.muscles if m.name == "corrugator_L").k0 == 3.5
    assert not warnings


def test_a_layout_with_its_own_skin_saved_elsewhere_keeps_finding_it(make_window, wv_face,
                                                                   tmp_path):
    """Save As into another folder rewrites the layout's relative mesh paths."""
    import dataclasses

    from wrinkle_vis.plotting.polydata import to_surface_polydata

    (tmp_path / "meshes").mkdir()
    to_surface_polydata(wv_face.skin).save(tmp_path / "meshes" / "skin.ply")
    layout = Session(wv_face).layout()
    path = tmp_path / "meshes" / "mine.json"
    wv.save_layout(dataclasses.replace(layout, skin="skin.ply", n_triangles=None), path)
    w = make_window(Session(load_face(layout=path), path))
    other = tmp_path / "elsewhere" / "copy.json"
    other.parent.mkdir()
    assert w.save_as(other)
    saved = wv.load_layout(other)
    assert saved.resolve("skin", other.parent) == (tmp_path / "meshes" / "skin.ply").resolve()


def orphan(folder, pid: int, layout, age_s: float):
    """A recovery file that process ``pid`` left ``age_s`` seconds ago."""
    rec = Recovery(folder)
    rec.save(layout, None, 4500)
    path = folder / f"recovery-{pid}.json"
    rec.path.rename(path)
    t = time.time() - age_s
    os.utime(path, (t, t))
    return path


def with_k0(layout, muscle: str, k0: float):
    import dataclasses

    return dataclasses.replace(layout, muscles=tuple(
        m.replace(k0=k0) if m.name == muscle else m for m in layout.muscles))


def test_each_recovery_file_is_offered_and_only_a_discarded_one_is_deleted(
        make_window, wv_face, tmp_path, answer):
    folder = tmp_path / "recovery"
    base = Session(wv_face).layout()
    older = orphan(folder, 999999991, with_k0(base, "corrugator_L", 2.0), 120)
    newer = orphan(folder, 999999992, with_k0(base, "corrugator_L", 3.0), 60)
    w = make_window(recovery_=Recovery(folder))
    answer("Keep", "Discard")  # newest first
    assert not w.offer_recovery()
    assert len(answer.asked) == 2
    assert str(newer) in answer.asked[0] and str(older) in answer.asked[1]
    assert newer.exists() and not older.exists()
    answer("Restore")  # the next start offers the one kept
    assert w.offer_recovery()
    assert w.session.face.muscle("corrugator_L").k0 == 3.0 and w.session.dirty
    assert not newer.exists() and w.recovery.path.exists()  # ours holds it now


def test_restoring_one_recovery_file_leaves_the_others_to_the_user(make_window, wv_face,
                                                                  tmp_path, answer):
    folder = tmp_path / "recovery"
    base = Session(wv_face).layout()
    older = orphan(folder, 999999993, with_k0(base, "corrugator_L", 2.0), 120)
    newer = orphan(folder, 999999994, with_k0(base, "corrugator_L", 3.0), 60)
    w = make_window(recovery_=Recovery(folder))
    buttons = []

    def keep(dialog):
        buttons.extend(b.text() for b in dialog.buttons())
        next(b for b in dialog.buttons() if b.text() == "Keep").click()

    answer("Restore", keep)
    assert w.offer_recovery()
    assert w.session.face.muscle("corrugator_L").k0 == 3.0
    assert "restored already" in answer.asked[1] and "Restore" not in buttons
    assert older.exists() and not newer.exists()
    assert Recovery(folder).orphans() == [older]


def test_a_recovery_file_of_a_dead_process_with_our_pid_is_offered_not_overwritten(
        make_window, wv_face, tmp_path, answer):
    """A pid comes back (in a container, often): its file is an orphan all the same."""
    folder = tmp_path / "recovery"
    base = Session(wv_face).layout()
    ours = orphan(folder, os.getpid(), with_k0(base, "corrugator_L", 2.5), 3600)
    rec = Recovery(folder)
    assert rec.path == ours and rec.orphans() == [ours]
    rec.discard()  # a clean exit of this process: not its file
    assert ours.exists()
    rec.save(base, None, 4500)  # our autosave sets it aside first
    aside = [p for p in rec.orphans() if p != ours]
    assert len(aside) == 1 and aside[0].name.startswith(f"recovery-{os.getpid()}-")
    assert next(m for m in Recovery.load(aside[0]).layout.muscles
                if m.name == "corrugator_L").k0 == 2.5
    rec.discard()
    w = make_window(recovery_=rec)
    answer("Restore")
    assert w.offer_recovery() and w.session.face.muscle("corrugator_L").k0 == 2.5


def test_restoring_the_file_of_a_dead_process_with_our_pid_keeps_it_as_ours(
        make_window, wv_face, tmp_path, answer):
    folder = tmp_path / "recovery"
    base = Session(wv_face).layout()
    ours = orphan(folder, os.getpid(), with_k0(base, "corrugator_L", 2.5), 3600)
    w = make_window(recovery_=Recovery(folder))
    answer("Restore")
    assert w.offer_recovery() and w.session.face.muscle("corrugator_L").k0 == 2.5
    assert w.recovery.path == ours and ours.exists()  # now ours, holding the restored work
    saved = Recovery.load(ours)
    assert next(m for m in saved.layout.muscles if m.name == "corrugator_L").k0 == 2.5
    assert list(folder.iterdir()) == [ours] and w.recovery.orphans() == []


def test_autosave_comes_within_a_bounded_time_however_the_edits_go_on(window, recovery,
                                                                      qtbot):
    """An edit every quarter second: the debounce alone would never fire; the file must
    appear at most 5 s after the first unsaved edit.
    """
    window.select_muscle("corrugator_L")
    box = window.param_widgets["k0"]
    box.setFocus()
    t0 = time.monotonic()
    key = QtCore.Qt.Key_Up
    while not recovery.path.exists() and time.monotonic() - t0 < 8.0:
        QTest.keyClick(box, key)  # a step: an undoable edit
        key = QtCore.Qt.Key_Down if key == QtCore.Qt.Key_Up else QtCore.Qt.Key_Up
        qtbot.wait(250)
    elapsed = time.monotonic() - t0
    assert recovery.path.exists(), "no autosave in 8 s of continuous edits"
    assert elapsed < 5.0 + 0.75
    assert window.undo_stack.count() >= 10


# ---------------------------------------------------------------------- silently wrong
def test_a_right_click_on_the_skin_probes_the_point_there(window, qtbot):
    """Through Qt's mouse events on the view, pyvistaqt, VTK's picker and PyVista's pick
    callback (which passes the point and the picker): the point under the mouse, marked
    there, its coordinates and every muscle that acts there in the table.
    """
    window.set_camera("front")
    window.select_muscle("frontalis_major_L")
    state = window.session.state()
    fields = state.fields["frontalis_major_L"]
    defined = np.flatnonzero(np.isfinite(fields["W"]) & (state.normals[:, 2] > 0.9))
    target = int(defined[len(defined) // 2])
    pos = widget_pos(window.skin_view, state.points[target])
    _right_click(window, pos)
    where = window.probe_point
    assert where is not None, "the right-click probed nothing"
    rest, now = window.session.probe_position(where)
    clicked = np.array([pos.x(), window.skin_view.interactor.height() - pos.y()]) \
        * window.skin_view.interactor.devicePixelRatioF()
    assert np.linalg.norm(display_point(window.skin_view, now) - clicked) < 2
    marker = window.skin_view.actors["_picked_probe"].mapper.dataset
    np.testing.assert_allclose(np.mean(marker.points, axis=0), now, atol=1e-3)
    radius = np.ptp(marker.points[:, 0]) / 2
    lo, hi = state.face.skin.bounds()
    assert radius > 0.004 * np.linalg.norm(hi - lo)  # a ball one sees, not 3 pixels
    assert f"{rest[0]:.4g}" in window.probe_label.text()
    values = window.session.probe(where)
    acting = [m for m in values if m != "total"]
    assert "frontalis_major_L" in acting
    table = window.probe_table
    assert [table.horizontalHeaderItem(c).text() for c in range(table.columnCount())] == \
        ["total", "frontalis_major_L", *[m for m in acting if m != "frontalis_major_L"]]
    for row, f in enumerate(wv.FIELD_NAMES):
        own = values["frontalis_major_L"][f]
        shown = table.item(row, 1).text()
        assert shown == ("undefined" if not np.isfinite(own) else f"{own:.5g}")
    assert float(table.item(list(wv.FIELD_NAMES).index("W"), 0).text()) == \
        pytest.approx(values["total"]["W"], rel=1e-4, abs=1e-9)
    # every row shows: the table is as tall as its rows
    assert table.viewport().height() >= sum(table.rowHeight(r) for r in range(9))


def _right_click(window, pos: QtCore.QPoint) -> None:
    view = window.skin_view.interactor
    QTest.mouseMove(view, pos)
    QTest.mousePress(view, QtCore.Qt.RightButton, QtCore.Qt.NoModifier, pos)
    QTest.mouseRelease(view, QtCore.Qt.RightButton, QtCore.Qt.NoModifier, pos)


def _rest_point_clicked(window) -> np.ndarray:
    """The rest-skin point that PyVista's pick (the click) found, located apart from the
    app: the closest cell of the drawn skin (VTK's cell locator), the point's barycentric
    coordinates in that triangle of the frame, the same coordinates on the frame's rest
    skin, the closest point of the face's skin."""
    picked = np.asarray(window.skin_view.picked_point, float)
    cell, on = skin_mesh(window).find_closest_cell(picked, return_closest_point=True)
    state = window.session.state()
    corners = state.points[state.triangles[cell]]
    weights = np.linalg.lstsq(np.vstack([corners.T, np.ones(3)]), np.append(on, 1.0),
                              rcond=None)[0]
    rest = weights @ state.rest_points[state.triangles[cell]]
    return wv.core.mesh.closest_points(window.session.face.skin, rest[None])[0]


def _evaluated_at(face, expression: str, rest: np.ndarray) -> dict:
    """The refined frame of ``expression`` evaluated apart from the app, sampled by VTK
    (``vtkProbeFilter``) on its rest skin where the line through ``rest`` along the skin's
    normal there meets it: ``{"W": .., "point": (3,), muscle: {field: ..}}``."""
    import pyvista as pv

    state = face.evaluate(expression, refine=True)
    mesh = pv.PolyData.from_regular_faces(np.array(state.rest_points), state.triangles)
    mesh.point_data["W"] = state.W
    mesh.point_data["final"] = state.points
    for m in face.muscle_names:
        for f in wv.FIELD_NAMES:
            mesh.point_data[f"{m}/{f}"] = state.fields[m][f]
    tri, _ = wv.core.mesh.surface_coordinates(face.skin, rest[None])
    a, b, c = face.skin.points[face.skin.triangles[tri[0]]]
    normal = np.cross(b - a, c - a)
    normal *= 5.0 / np.linalg.norm(normal)
    hits = [mesh.ray_trace(rest, rest + sign * normal, first_point=True)[0]
            for sign in (1.0, -1.0)]
    hit = min((h for h in hits if len(h)), key=lambda h: np.linalg.norm(h - rest))
    sampled = pv.PolyData(hit[None]).sample(mesh, tolerance=1e-6)
    assert sampled["vtkValidPointMask"][0]
    out = {"W": float(sampled["W"][0]), "point": np.array(sampled["final"][0])}
    for m in face.muscle_names:
        out[m] = {f: float(sampled[f"{m}/{f}"][0]) for f in wv.FIELD_NAMES}
    return out


def _probe_column(window, name: str) -> dict[str, str]:
    table = window.probe_table
    cols = [table.horizontalHeaderItem(c).text() for c in range(table.columnCount())]
    col = cols.index(name)
    return {f: table.item(r, col).text() for r, f in enumerate(wv.FIELD_NAMES)}


def test_the_probe_stays_on_its_point_through_expressions_and_edits_when_refined(
        window, wv_face):
    """Issue 32: with refinement on, the probe kept an index into the refined mesh, whose
    numbering changes with each frame: after surprise -> frown the table showed another
    point's W (-0.68 mm on a bare forehead point), surprise -> fear kept surprise's values,
    and after a k0 edit it showed a muscle outside its AOI. A right-click on the forehead,
    then each frame's table and marker are compared with the frame evaluated apart from
    the app at that rest point."""
    window.set_camera("front")
    window.refine_box.setChecked(True)
    state = window.session.state()
    sheet = state.fields["frontalis_major_L"]["W"]
    defined = np.flatnonzero(np.isfinite(sheet) & (state.normals[:, 2] > 0.9))
    target = int(defined[len(defined) // 3])
    pos = widget_pos(window.skin_view, state.points[target])
    _right_click(window, pos)
    rest = _rest_point_clicked(window)
    face = window.session.face
    for expression in ("surprise", "frown", "fear", "surprise"):
        window.expression_box.setCurrentText(expression)
        want = _evaluated_at(face, expression, rest)
        total = _probe_column(window, "total")
        assert float(total["W"]) == pytest.approx(want["W"], rel=1e-4, abs=1e-6), expression
        marker = window.skin_view.actors["_picked_probe"].mapper.dataset
        np.testing.assert_allclose(np.mean(marker.points, axis=0), want["point"], atol=0.05)
        acting = {m for m in face.muscle_names if np.isfinite(want[m]["lambda"])}
        table = window.probe_table
        shown = {table.horizontalHeaderItem(c).text() for c in range(table.columnCount())}
        assert acting <= shown - {"total"}, expression
        for m in acting:
            column = _probe_column(window, m)
            for f in ("lambda", "gamma", "l"):  # smooth on the AOI: interpolated alike
                assert float(column[f]) == pytest.approx(want[m][f], rel=1e-4, abs=1e-6)
    # an edit: k0 of the sheet; the probe shows the edited frame at its point
    window.select_muscle("frontalis_major_L")
    window.param_widgets["k0"].setValue(2.0 * window.param_widgets["k0"].value())
    face = window.session.face
    want = _evaluated_at(face, "surprise", rest)
    assert float(_probe_column(window, "total")["W"]) == pytest.approx(
        want["W"], rel=1e-4, abs=1e-6)
    column = _probe_column(window, "frontalis_major_L")
    assert float(column["W"]) == pytest.approx(want["frontalis_major_L"]["W"], rel=1e-4,
                                               abs=1e-6)


def test_a_long_session_cannot_run_none_out_of_references(window):
    """PySide6 6.12 on Python 3.11 takes a reference to None from every Qt call that
    returns nothing: the soak benchmark's app aborted after about 9,000 frames ("Fatal
    Python error: deallocating None"). A window guards against it.
    """
    label = QtWidgets.QLabel()
    before = sys.getrefcount(None)
    for _ in range(1000):
        label.setText("x")  # returns nothing
    drifts = sys.getrefcount(None) < before
    assert not drifts or sys.getrefcount(None) > 1 << 39


# ---------------------------------------------------------------------- usability
def test_a_fixed_colour_range_holds_and_automatic_follows_the_frame(window):
    window.range_box.setCurrentText("fixed")
    assert window.range_min.isEnabled() and window.range_max.isEnabled()
    type_into(window.range_min, "-0.5")
    type_into(window.range_max, "0.25")
    assert shown_range(window) == (-0.5, 0.25)
    bar = window.skin_view.scalar_bars["W (mm), total"]
    assert tuple(bar.GetLookupTable().GetRange()) == (-0.5, 0.25)
    window.intensity_slider.setValue(30)  # in place
    assert shown_range(window) == (-0.5, 0.25)
    window.muscle_box.setCurrentText("frontalis_major_L")  # rebuilt
    window.field_box.setCurrentText("eps")
    assert shown_range(window) == (-0.5, 0.25)
    type_into(window.range_min, "0.5")  # above max: refused, with the reason
    assert "min must be below max" in window.range_error.text()
    assert shown_range(window) == (-0.5, 0.25)
    window.range_box.setCurrentText("automatic")
    assert not window.range_min.isEnabled() and not window.range_error.text()
    values = window.session.state().fields["frontalis_major_L"]["eps"]
    assert shown_range(window) == pytest.approx(field_range(field_info("eps"),
                                                                    values))


def test_while_playing_the_colour_range_holds_the_whole_ramp(window, qtbot):
    window.time_slider.setValue(0)
    window.play_button.click()
    ranges, times = [], []
    for _ in range(6):
        qtbot.wait(150)
        ranges.append(shown_range(window))
        times.append(window.session.time_s)
    window.play_button.click()  # pause
    assert len(set(times)) >= 3  # it played: the frames changed
    peak = field_range(field_info("W"), load_face().evaluate("surprise").W)
    assert all(r == ranges[0] for r in ranges)
    assert ranges[0][1] >= peak[1] * (1 - 1e-9)  # the ramp's peak shows within it
    window.time_slider.setValue(10)  # paused, automatic: the frame's own range
    own = field_range(field_info("W"), window.session.state().W)
    assert shown_range(window) == pytest.approx(own)
    assert own[1] < 0.5 * peak[1]


@pytest.mark.parametrize("width", [1500, 1000, 800])
@pytest.mark.parametrize("lo_hi", [None, (-0.000123456, 0.000123456),
                                   (-123456.0, 98765.4), (0.367, 71.6)])
def test_scalar_bar_labels_never_collide(window, qtbot, width, lo_hi):
    """The labels drawn in magenta, the skin hidden: each label is a run of magenta
    columns (its characters at most 4 columns apart), apart from the next by 7 empty
    columns or more; as many runs as labels drawn.
    """
    window.resize(width, 700)
    qtbot.wait(50)
    if lo_hi is not None:
        window.range_box.setCurrentText("fixed")
        type_into(window.range_min, f"{lo_hi[0]:.6f}")
        type_into(window.range_max, f"{lo_hi[1]:.6f}")
    (bar,) = window.skin_view.scalar_bars.values()
    bar.GetLabelTextProperty().SetColor(1.0, 0.0, 1.0)
    window.skin_view.actors["skin"].SetVisibility(False)
    window.skin_view.render()
    image = window.skin_view.screenshot(return_img=True).astype(int)
    r, g, b = image[..., 0], image[..., 1], image[..., 2]
    magenta = (r - g > 60) & (b - g > 60) & (np.abs(r - b) < 60)
    columns = np.flatnonzero(magenta.any(axis=0))
    n = bar.GetNumberOfLabels() if bar.GetDrawTickLabels() else 0
    if n == 0:
        assert columns.size == 0
        assert window.skin_view.window_size[0] < 120  # only a narrow view has none
        return
    runs = 1 + int(np.count_nonzero(np.diff(columns) > 7))  # 7 empty columns or more
    assert runs == n, f"{n} labels drawn as {runs} separate runs of text"


def test_the_unit_is_the_faces_on_bar_probe_status_and_parameters(make_window, wv_face):
    face = wv_face.with_expressions(wv_face.expressions)
    face.unit = "cm"  # a face that knows its unit
    w = make_window(Session(face))
    assert w.session.unit == "cm"
    assert "W (cm), total" in w.skin_view.scalar_bars
    w.muscle_box.setCurrentText("frontalis_major_L")
    w.field_box.setCurrentText("l")
    assert "l (cm), frontalis_major_L" in w.skin_view.scalar_bars
    w.probe_vertex(10)
    header = [w.probe_table.verticalHeaderItem(i).text() for i in range(len(wv.FIELD_NAMES))]
    assert "W (cm)" in header and "l (cm)" in header and "λ" in header
    assert " cm" in w.status_label.text() and " cm" in w.derived_label.text()
    plain = Session(wv_face)
    assert plain.unit == "mm"  # a face that does not say: millimetres


def test_save_view_image_at_a_chosen_size_without_handles_and_outlines(window, tmp_path,
                                                                      monkeypatch, answer):
    window.field_box.setCurrentText("none")  # plain skin: the handles' colours stand out
    window.select_muscle("zygomaticus_major_L")
    window.probe_vertex(10)
    out = tmp_path / "view.png"
    monkeypatch.setattr(QtWidgets.QFileDialog, "getSaveFileName",
                        lambda *a, **k: (str(out.with_suffix("")), "PNG images (*.png)"))

    def choose(dialog):
        dialog.view_box.setCurrentText("skin")
        dialog.width_box.setValue(900)
        dialog.height_box.setValue(700)
        dialog.findChild(QtWidgets.QDialogButtonBox).button(
            QtWidgets.QDialogButtonBox.Ok).click()

    answer(choose)
    menu_action(window, "File", "Save view image...").trigger()
    assert out.is_file()
    saved = np.asarray(Image.open(out).convert("RGB")).astype(int)
    assert saved.shape == (700, 900, 3)

    def count(image, colour):
        rgb = np.array(QtGui.QColor(colour).getRgb()[:3])
        return int(np.count_nonzero(np.abs(image[..., :3] - rgb).max(axis=-1) < 12))

    def bluish(image):  # the skin handle's blue, lit: nothing else on plain skin is
        r, g, b = image[..., 0], image[..., 1], image[..., 2]
        return int(np.count_nonzero((b > r + 60) & (b > g + 30)))

    on_screen = window.skin_view.screenshot(return_img=True).astype(int)
    for colour in ("#2a9d8f", "#e9c46a"):  # the AOI's and the region's outlines
        assert count(on_screen, colour) > 0
        assert count(saved, colour) == 0
    assert bluish(on_screen) > 0 and bluish(saved) == 0
    assert (saved.std(axis=(0, 1)) > 5).all()  # the face is there


def test_help_shows_the_guide_and_every_shortcut(window):
    menu_action(window, "Help", "Guide").trigger()
    assert window.guide_dialog.isVisible()
    text = window.guide_dialog.browser.toPlainText()
    assert "Colour range" in text and "Save view image" in text
    menu_action(window, "Help", "Keyboard shortcuts").trigger()
    table = window.shortcuts_dialog.table
    rows = {(table.item(i, 1).text(), table.item(i, 2).text())
            for i in range(table.rowCount())}
    expected = set()

    def walk(menu):
        for a in menu.actions():
            if a.menu() is not None:
                walk(a.menu())
            elif not a.shortcut().isEmpty():
                expected.add((a.text().replace("&", "").rstrip("."),
                              a.shortcut().toString(QtGui.QKeySequence.NativeText)))

    for top in window.menuBar().actions():
        walk(top.menu())
    assert expected <= rows and ("Undo", "Ctrl+Z") in rows and ("Delete", "Del") in rows
    assert ("Save view image", "Ctrl+Shift+P") in rows
    extra = menu_action(window, "View").menu().addAction("Something new")
    extra.setShortcut(QtGui.QKeySequence("Ctrl+J"))
    menu_action(window, "Help", "Keyboard shortcuts").trigger()  # built from the actions
    assert any(table.item(i, 1).text() == "Something new" and
               table.item(i, 2).text() == "Ctrl+J" for i in range(table.rowCount()))


def test_parameter_errors_use_the_panels_labels_and_an_undo_clears_them(window, qtbot):
    activate(window, qtbot)
    window.select_muscle("zygomaticus_major_L")
    type_into(window.param_widgets["k0"], "2.5")  # a valid edit to undo
    assert window.undo_stack.count() == 1
    type_into(window.param_widgets["max_angle_deg"], "95")
    error = window.param_error.text()
    assert "Φ (deg) = 95" in error and "max_angle_deg" not in error
    type_into(window.param_widgets["radius"], "0.5")
    error = window.param_error.text()
    assert "R = 0.5" in error and "radius" not in error
    assert window.param_widgets["radius"].hasFocus()
    QTest.keyClick(window.param_widgets["radius"], QtCore.Qt.Key_Z,
                   QtCore.Qt.ControlModifier)  # Ctrl+Z with the box focused: undo
    assert window.undo_stack.count() == 1 and window.undo_stack.index() == 0
    assert window.session.face.muscle("zygomaticus_major_L").k0 != 2.5
    assert window.param_error.text() == ""


def test_ctrl_z_in_a_parameter_box_undoes_the_last_edit(window, qtbot):
    activate(window, qtbot)
    window.select_muscle("corrugator_L")
    box = window.param_widgets["k0"]
    before = box.value()
    type_into(box, "3.25")
    assert window.session.face.muscle("corrugator_L").k0 == 3.25
    assert box.hasFocus()
    QTest.keyClick(box, QtCore.Qt.Key_Z, QtCore.Qt.ControlModifier)
    assert window.session.face.muscle("corrugator_L").k0 == before
    assert window.param_widgets["k0"].value() == before
    QTest.keyClick(window.param_widgets["k0"], QtCore.Qt.Key_Z,
                   QtCore.Qt.ControlModifier | QtCore.Qt.ShiftModifier)  # redo
    assert window.session.face.muscle("corrugator_L").k0 == 3.25


def test_a_per_muscle_field_on_the_total_says_why_it_is_refused(window):
    assert window.muscle_box.currentText() == "total"
    window.field_box.setFocus()
    QTest.keyClick(window.field_box, QtCore.Qt.Key_Up)  # from W to A
    assert window.field_box.currentText() == "W"
    message = window.statusBar().currentMessage()
    assert "A belongs to one muscle" in message and "choose the muscle" in message


def test_an_activation_in_an_expression_is_an_undoable_saved_edit(window, tmp_path):
    window.probe_vertex(int(np.argmax(window.session.face.skin.points[:, 2])))
    menu_action(window, "Edit", "Add muscle", "linear").trigger()
    name = window.session.muscle
    assert name == "linear_1"
    assert name not in window.session.face.expressions["surprise"].activations
    type_into(window.activation_box, "0.6")
    assert window.session.face.expressions["surprise"].activations[name] == 0.6
    assert window.undo_stack.undoText() == f"Set activation of {name} in surprise to 0.6"
    assert window.session.state().activations[name] == pytest.approx(0.6)
    path = tmp_path / "joined.json"
    assert window.save_as(path)
    assert wv.load_layout(path).expressions["surprise"].activations[name] == 0.6
    window.undo_stack.undo()
    assert name not in window.session.face.expressions["surprise"].activations
    assert window.activation_box.value() == 0.0 and window.session.dirty


def test_run_opens_the_app_on_a_layout(wv_face, tmp_path, settings, monkeypatch, qtbot):
    from wrinkle_vis.app import window as window_module

    path = tmp_path / "mine.json"
    layout = with_k0(Session(wv_face).layout(), "corrugator_L", 1.75)
    wv.save_layout(layout, path)
    seen = {}
    real = window_module.MainWindow

    def look_and_close():
        w = next(w for w in QtWidgets.QApplication.topLevelWidgets()
                 if isinstance(w, real) and w.isVisible())
        seen["path"] = w.session.layout_path
        seen["k0"] = w.session.face.muscle("corrugator_L").k0
        w.close()

    _run_with_private_settings(window_module, settings, monkeypatch, look_and_close, path)
    assert seen == {"path": path, "k0": 1.75}


def test_run_on_the_physical_skin_opens_one_window_and_closing_it_ends_the_app(
        wv_face, tmp_path, settings, monkeypatch, qtbot):
    """The physical skin's material panel is inside the window: it was a window of its own
    (a group box in no layout, shown), so closing the main window left it open and the app
    never ended (``run`` hung once the physical skin was the default)."""
    from wrinkle_vis.app import window as window_module

    path = tmp_path / "physical.json"
    wv.save_layout(dataclasses.replace(Session(wv_face).layout(), skin_model="physical"), path)
    seen = {}
    real = window_module.MainWindow

    def look_and_close():
        shown = [w for w in QtWidgets.QApplication.topLevelWidgets() if w.isVisible()]
        main = next(w for w in shown if isinstance(w, real))
        seen["windows"] = [type(w).__name__ for w in shown]
        seen["panel"] = (main.skin_group.isVisible(), main.skin_group.window() is main)
        for w in shown[::-1]:  # the main window last: the app ends even where it did not
            if w is not main:
                w.close()
        main.close()

    _run_with_private_settings(window_module, settings, monkeypatch, look_and_close, path)
    assert seen == {"windows": ["Private"], "panel": (True, True)}


def _run_with_private_settings(window_module, settings, monkeypatch, look, path) -> None:
    """``wrinkle-vis --layout path`` with the test's settings (a ``MainWindow`` subclass,
    ``Private``), ``look`` called 300 ms in (it closes the window); the app must end, 0."""
    real = window_module.MainWindow

    class Private(real):  # the test's settings, not the user's
        def __init__(self, session, settings_=None, recovery=None):
            super().__init__(session, settings, recovery)

    monkeypatch.setattr(window_module, "MainWindow", Private)
    QtCore.QTimer.singleShot(300, look)
    assert window_module.run(["wrinkle-vis"], layout=path) == 0


def test_run_reports_a_layout_it_cannot_open_in_one_line(tmp_path, capsys):
    from wrinkle_vis.app.window import run

    bad = tmp_path / "bad.json"
    bad.write_text("{ not json")
    assert run(["wrinkle-vis"], layout=bad) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "bad.json" in err and "line 1" in err


def _wheel(widget: QtWidgets.QWidget, notches: int = 1) -> None:
    """A real QWheelEvent (``notches`` of 15 degrees up) at the middle of ``widget``."""
    centre = QtCore.QPointF(widget.width() / 2, widget.height() / 2)
    event = QtGui.QWheelEvent(centre, QtCore.QPointF(widget.mapToGlobal(centre.toPoint())),
                              QtCore.QPoint(0, 0), QtCore.QPoint(0, 120 * notches),
                              QtCore.Qt.NoButton, QtCore.Qt.NoModifier,
                              QtCore.Qt.NoScrollPhase, False)
    QtWidgets.QApplication.sendEvent(widget, event)


def test_the_wheel_over_an_unfocused_control_edits_nothing(window, qtbot):
    """Issue 32: scrolling the control panel with the wheel edited the parameter under the
    pointer (an undo step each). Unfocused, a spin box, a combo box or a slider takes no
    wheel; focused (clicked, tabbed to), it does."""
    window.select_muscle("frontalis_major_L")
    activate(window, qtbot)
    window.expression_box.setFocus()  # the focus elsewhere
    qtbot.waitUntil(window.expression_box.hasFocus)
    k0 = window.param_widgets["k0"]
    before = (k0.value(), window.session.face, window.undo_stack.count(),
              window.expression_box.currentText(), window.intensity_slider.value(),
              window.field_box.currentText(), window.activation_box.value())
    for box in (k0, window.field_box, window.intensity_slider, window.activation_box):
        assert not box.hasFocus()
        _wheel(box, -1)
    after = (k0.value(), window.session.face, window.undo_stack.count(),
             window.expression_box.currentText(), window.intensity_slider.value(),
             window.field_box.currentText(), window.activation_box.value())
    assert after == before
    k0.setFocus()
    qtbot.waitUntil(k0.hasFocus)
    _wheel(k0, 1)  # the control in use: one step up, an undoable edit
    assert k0.value() == pytest.approx(before[0] + k0.singleStep())
    assert window.undo_stack.count() == before[2] + 1
