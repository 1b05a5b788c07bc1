"""The Qt app in a real window (Xvfb, xcb) driven by pytest-qt (fixtures: conftest.py)."""

import gc
import json

import numpy as np
import pytest
from conftest import _discard_changes, skin_mesh
from qtpy import QtWidgets

import wrinkle_vis as wv
from wrinkle_vis.app.session import Session
from wrinkle_vis.app.window import MainWindow
from wrinkle_vis.plotting.polydata import field_array_name

pytestmark = pytest.mark.usefixtures("no_leaked_plotters")


def test_window_has_three_views_that_close_cleanly(make_window):
    w = make_window()
    assert len(w.plotters) == 3 and all(not p._closed for p in w.plotters)
    assert skin_mesh(w) is not None
    w.close()
    assert all(p._closed for p in w.plotters)


def test_a_camera_change_in_one_view_reaches_the_others_at_once(window):
    cams = [p.renderer.GetActiveCamera() for p in window.plotters]
    assert cams[0] is cams[1] is cams[2]
    renders = []
    window.skull_view.render_window.AddObserver("EndEvent", lambda *a: renders.append(1))
    window.muscle_view.camera.azimuth = 35.0  # move the camera from the middle view
    assert renders, "the skull view did not redraw synchronously"
    assert window.skin_view.camera_position == window.skull_view.camera_position


def test_switching_field_changes_the_active_array_and_scalar_bar(window):
    window.muscle_box.setCurrentText("corrugator_L")
    window.field_box.setCurrentText("gamma")
    assert window.active_array() == "corrugator_L__gamma"
    assert skin_mesh(window).active_scalars_name == "corrugator_L__gamma"
    bars = window.skin_view.scalar_bars
    assert "gamma, corrugator_L" in bars and "W (mm), total" not in bars  # W's bar is gone
    window.muscle_box.setCurrentText("total")  # only W has a total
    assert window.field_box.currentText() == "W"
    assert skin_mesh(window).active_scalars_name == "W"


def test_probe_reports_what_the_core_computes(window, wv_face):
    window.muscle_box.setCurrentText("frontalis_major_L")
    state = wv_face.evaluate("surprise")
    vertex = int(np.flatnonzero(np.isfinite(state.fields["frontalis_major_L"]["W"]))[0])
    values = window.probe_vertex(vertex)
    for f in wv.FIELD_NAMES:
        np.testing.assert_equal(values["frontalis_major_L"][f],
                                state.fields["frontalis_major_L"][f][vertex])
    assert values["total"]["W"] == state.W[vertex]
    row = list(wv.FIELD_NAMES).index("W")
    table = window.probe_table
    assert table.horizontalHeaderItem(1).text() == "frontalis_major_L"  # selected: first
    assert float(table.item(row, 1).text()) == pytest.approx(
        state.fields["frontalis_major_L"]["W"][vertex], rel=1e-4)
    assert float(table.item(row, 0).text()) == pytest.approx(state.W[vertex], rel=1e-4)


def test_pick_callback_probes_the_point_on_the_skin(window):
    """A pick with no triangle probes the closest point of the skin shown: at a vertex,
    that vertex's values exactly, and its rest position."""
    state = window.session.state()
    window._on_pick(state.points[123] + 1e-6)
    rest, now = window.session.probe_position(window.probe_point)
    np.testing.assert_allclose(rest, state.rest_points[123], atol=1e-5)
    np.testing.assert_allclose(now, state.points[123], atol=1e-5)
    assert window.session.probe(window.probe_point)["total"]["W"] == pytest.approx(
        state.W[123], abs=1e-9)


def test_a_parameter_change_updates_the_skin(window):
    window.muscle_box.setCurrentText("corrugator_L")
    before = np.array(skin_mesh(window).points)
    window.expression_box.setCurrentText("frown")
    frown_before = np.array(skin_mesh(window).points)
    assert not np.array_equal(before, frown_before)
    window.param_widgets["k0"].setValue(4.0)
    after = np.array(skin_mesh(window).points)
    assert window.session.face.muscle("corrugator_L").k0 == 4.0
    assert not np.array_equal(after, frown_before)
    assert "d = 3" in window.derived_label.text()  # d = 0.75 k0 at alpha = 1
    assert window.session.dirty and window.windowTitle().endswith("*")


def test_an_invalid_value_is_refused_with_its_reason(window):
    window.muscle_box.setCurrentText("corrugator_L")
    assert not window.set_parameter("lambda_w", 1.5)
    assert "λ_w" in window.param_error.text() and "[0, 1)" in window.param_error.text()
    before = window.session.face.muscle("corrugator_L").lambda_w
    assert window.session.face.muscle("corrugator_L").lambda_w == before == pytest.approx(0.1)
    assert window.param_widgets["lambda_w"].value() == pytest.approx(before)


def test_intensity_and_timeline(window):
    window.intensity_slider.setValue(50)
    assert window.session.intensity == 0.5
    assert max(window.session.state().activations.values()) == pytest.approx(0.5)
    window.time_slider.setValue(0)
    assert not window.session.state().W.any()  # the ramp starts at rest
    window.time_slider.setValue(150)  # half way: the plateau
    assert window.session.state().W.any()
    assert "frame" in window.status_label.text() and "mm" in window.status_label.text()


def test_play_advances_the_timeline(window, qtbot):
    window.time_slider.setValue(0)
    window.play_button.setChecked(True)
    qtbot.waitUntil(lambda: window.time_slider.value() > 8, timeout=3000)
    window.play_button.setChecked(False)
    assert not window.timer.isActive()


def test_save_reopen_gives_the_same_layout(window, tmp_path):
    window.muscle_box.setCurrentText("corrugator_R")
    window.param_widgets["k0"].setValue(3.5)
    path = tmp_path / "mine.json"
    assert window.save_as(path)
    assert not window.session.dirty
    saved = wv.load_layout(path)
    assert saved.muscles == window.session.face.muscles
    assert window.open_layout(path)
    assert window.session.face.muscle("corrugator_R").k0 == 3.5
    assert window.recent_files()[0] == str(path.resolve())
    assert window.recent_menu.actions()[0].text() == str(path.resolve())


def test_a_bad_layout_is_reported_and_the_face_kept(window, tmp_path, monkeypatch):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"format": "wrinkle-vis-layout", "version": 9}))
    shown = []
    monkeypatch.setattr(QtWidgets.QMessageBox, "warning", lambda *a: shown.append(a[2]))
    face = window.session.face
    assert not window.open_layout(bad)
    assert window.session.face is face and "$.version" in shown[0]


def test_screenshot(window, tmp_path):
    out = window.screenshot(tmp_path / "shot.png")
    assert out.is_file() and out.stat().st_size > 1000


def test_closing_with_unsaved_changes_asks(make_window, monkeypatch):
    w = make_window()
    w.session.dirty = True
    monkeypatch.setattr(QtWidgets.QMessageBox, "question",
                        lambda *a: QtWidgets.QMessageBox.Cancel)
    w.close()
    assert w.isVisible() and not any(p._closed for p in w.plotters)
    monkeypatch.setattr(QtWidgets.QMessageBox, "question",
                        lambda *a: QtWidgets.QMessageBox.Discard)
    w.close()
    assert all(p._closed for p in w.plotters)


def test_field_array_name_matches_the_skin_view(window):
    assert window.active_array() == field_array_name("W")


def test_activation_set_by_hand_recomputes_at_once(window):
    window.expression_box.setCurrentText("neutral")
    window.muscle_box.setCurrentText("zygomaticus_major_L")
    assert not window.session.state().W.any()
    rest = np.array(skin_mesh(window).points)
    window.activation_box.setValue(0.8)  # joins "neutral": an edit of the layout
    assert window.session.state().activations["zygomaticus_major_L"] == 0.8
    assert window.session.state().W.any()
    assert not np.array_equal(np.array(skin_mesh(window).points), rest)
    window.expression_box.setCurrentText("frown")  # not in frown
    assert window.session.state().activations["zygomaticus_major_L"] == 0.0
    assert window.activation_box.value() == 0.0
    window.expression_box.setCurrentText("neutral")
    assert window.activation_box.value() == 0.8


def test_closing_prints_no_vtk_warnings(make_window, capfd):
    w = make_window()
    w.close()
    QtWidgets.QApplication.processEvents()
    gc.collect()
    out, err = capfd.readouterr()
    assert "vtk" not in (out + err).lower() and "error" not in (out + err).lower()


def test_in_place_update_draws_what_a_rebuild_draws(window):
    window.muscle_box.setCurrentText("frontalis_major_L")
    window.field_box.setCurrentText("eps")
    window.intensity_slider.setValue(60)  # activations only: updated in place
    _drawn_in_place_as_rebuilt(window, window.skin_view, 100)


def test_a_muscle_is_coloured_by_its_activation_without_sending_its_mesh_again(window):
    import matplotlib

    window.expression_box.setCurrentText("surprise")
    window.intensity_slider.setValue(40)
    actor = window.muscle_view.actors["muscle:frontalis_major_L"]
    mesh = actor.mapper.dataset
    stamp = mesh.GetMTime()
    window.intensity_slider.setValue(90)  # a new activation: only the actor's colour
    window.frames.flush()  # the frame of this event-loop turn, drawn now
    a = window.session.state().activations["frontalis_major_L"]
    assert 0.0 < a < 1.0
    assert mesh.GetMTime() == stamp and actor.mapper.dataset is mesh
    want = matplotlib.colormaps["Reds"](a)[:3]  # the colour map the scalar bar shows
    np.testing.assert_allclose(actor.GetProperty().GetColor(), want, atol=1.5 / 255)
    _drawn_in_place_as_rebuilt(window, window.muscle_view, 20)


def _drawn_in_place_as_rebuilt(window, view, other_intensity: int) -> None:
    """``view`` as drawn in place equals it rebuilt from scratch (within 2 levels), and
    differs at intensity ``other_intensity`` (the comparison can tell frames apart).
    """
    in_place = view.screenshot(return_img=True).astype(int)
    window.views.invalidate()
    window.refresh()  # from scratch
    rebuilt = view.screenshot(return_img=True).astype(int)
    assert np.abs(in_place - rebuilt).max() <= 2
    window.intensity_slider.setValue(other_intensity)
    window.frames.flush()  # the frame of this event-loop turn, drawn now
    assert np.abs(view.screenshot(return_img=True).astype(int) - rebuilt).max() > 20


def test_a_closed_window_and_its_plotters_are_collected(wv_face, settings, recovery, qtbot,
                                                       tmp_path):
    """Quit (the menu's action) frees the window and everything it drew, with no deferred
    delete: no Qt connection or VTK observer holds it, after a session that used them all.
    """
    import weakref

    w = MainWindow(Session(wv_face), settings, recovery)
    w.show()
    qtbot.waitUntil(w.isVisible)
    w.select_muscle("zygomaticus_major_L")  # a placement widget with VTK observers
    w.probe_vertex(100)
    w.param_widgets["k0"].setValue(2.5)
    w.undo_stack.undo()
    w.save_as(tmp_path / "mine.json")  # a recent file: an action of the Open recent menu
    w.show_shortcuts()
    w.play_button.setChecked(True)
    qtbot.wait(100)
    w.play_button.setChecked(False)
    refs = [weakref.ref(w)] + [weakref.ref(p) for p in w.plotters]
    quit_action = next(a for a in w.menuBar().actions()[0].menu().actions()
                       if a.text() == "&Quit")
    quit_action.trigger()
    assert not w.isVisible()
    del w, quit_action
    gc.collect()
    assert [r() for r in refs] == [None] * 4


def test_refinement_toggle_and_wireframe(window, wv_face):
    base = skin_mesh(window).n_cells
    assert base == wv_face.skin.n_triangles
    window.refine_box.setChecked(True)
    refined = skin_mesh(window).n_cells
    assert refined > base
    assert refined == len(wv_face.evaluate("surprise", refine=True).triangles)
    state = window.session.state()
    newest = len(state.points) - 1  # a vertex the refinement made
    assert newest >= wv_face.skin.n_points
    window._on_pick(state.points[newest])
    assert window.session.probe(window.probe_point)["total"]["W"] == pytest.approx(
        state.W[newest], abs=1e-9)
    window.wireframe_box.setChecked(True)
    assert window.skin_view.actors["skin"].prop.show_edges
    window.intensity_slider.setValue(40)  # a new refinement pattern: rebuilt, still right
    assert skin_mesh(window).n_cells == len(window.session.state().triangles)
    window.refine_box.setChecked(False)
    assert skin_mesh(window).n_cells == base
    assert window.probe_point is not None  # a point of the rest skin: it stays


def test_plain_skin_and_the_raking_light(window):
    """Field "none" draws plain skin; View > Raking light swaps the skin view's lights for a
    grazing key light and a weak headlight and back, across rebuilds, and the view changes.
    """
    renderer = window.skin_view.renderer
    kit = len(renderer.lights)
    assert kit == 5 and not window.raking_action.isChecked()  # pyvista's light kit
    window.field_box.setCurrentText("none")
    actor = window.skin_view.actors["skin"]
    assert window.active_array() is None and not actor.mapper.scalar_visibility
    assert not window.skin_view.scalar_bars and "W" not in skin_mesh(window).point_data
    window.set_camera("forehead")
    kit_image = window.skin_view.screenshot(return_img=True).astype(int)

    window.raking_action.trigger()
    assert window.raking_action.isChecked() and window.settings.value("raking_light", type=bool)
    key, fill = renderer.lights
    assert key.is_scene_light and not key.positional and fill.is_headlight
    assert key.intensity > 2 * fill.intensity
    towards = np.subtract(key.position, key.focal_point)
    assert towards[1] > towards[2] > 0 and towards[0] > 0  # above, grazing, from the right
    raking_image = window.skin_view.screenshot(return_img=True).astype(int)
    assert np.abs(raking_image - kit_image).max() > 40

    window.field_box.setCurrentText("W")  # a rebuild keeps the raking light
    assert len(renderer.lights) == 2 and window.active_array() == "W"
    window.field_box.setCurrentText("none")
    window.expression_box.setCurrentText("frown")  # updated in place, still plain
    np.testing.assert_allclose(skin_mesh(window).points, window.session.state().points)
    assert not window.skin_view.actors["skin"].mapper.scalar_visibility

    window.raking_action.trigger()
    assert len(renderer.lights) == kit and not window.raking_action.isChecked()


# ---------------------------------------------------------------------- the view widgets
def test_views_are_native_windows_that_render_once_a_frame(window):
    """On X11 each view is a native child window VTK renders into (Qt composes nothing), and
    a playback frame renders each view it changed once: no paint event renders it again.
    """
    from qtpy import QtCore, QtGui

    from wrinkle_vis.app.viewwidget import NativeView

    assert QtGui.QGuiApplication.platformName() == "xcb"
    assert all(isinstance(p, NativeView) for p in window.plotters)
    assert all(p.testAttribute(QtCore.Qt.WA_NativeWindow) for p in window.plotters)
    renders = [0, 0, 0]
    for i, p in enumerate(window.plotters):
        p.render_window.AddObserver("EndEvent", lambda *a, i=i: renders.__setitem__(
            i, renders[i] + 1))
    window.intensity_slider.setValue(window.intensity_slider.value() // 2)
    QtWidgets.QApplication.processEvents()
    assert renders == [1, 1, 0]  # skin and muscles changed, the skull did not


def test_a_view_initializes_its_plotter_once_with_its_arguments(qapp, monkeypatch):
    """Qt's ``QWidget.__init__`` continues the ``super().__init__`` chain past the Qt classes;
    a view ends it there, so ``BasePlotter.__init__`` runs once, with the view's arguments
    (not first with none, which fails)."""
    from pyvista.plotting.plotter import BasePlotter

    from wrinkle_vis.app.viewwidget import NativeView

    calls = []
    init = BasePlotter.__init__
    monkeypatch.setattr(BasePlotter, "__init__",
                        lambda self, *a, **k: (calls.append((a, k)), init(self, *a, **k))[1])
    view = NativeView(None, border=False)
    try:
        assert calls == [((), {"border": False})]
        assert view.renderer is not None
    finally:
        view.close()


def shown_pixels(view) -> np.ndarray:
    """``(h, w, 3)`` uint8: what the screen shows of a view (a native window: grabbed from
    the X server; a QOpenGLWidget: its framebuffer, which Qt composes as it is)."""
    from qtpy import QtGui

    from wrinkle_vis.app.viewwidget import NativeView

    QtWidgets.QApplication.processEvents()
    if isinstance(view, NativeView):
        image = QtGui.QGuiApplication.primaryScreen().grabWindow(view.winId()).toImage()
    else:
        image = view.grabFramebuffer()
    image = image.convertToFormat(QtGui.QImage.Format_RGB888)
    rows = np.frombuffer(image.constBits(), np.uint8, image.sizeInBytes())
    return rows.reshape(image.height(), image.bytesPerLine())[:, :3 * image.width()].reshape(
        image.height(), image.width(), 3)


def test_both_view_kinds_show_the_same_picture(make_window, monkeypatch):
    """The QOpenGLWidget views (Wayland, offscreen Qt) and the native ones show the same
    frame on screen.
    """
    from wrinkle_vis.app.viewwidget import NativeView, View

    shown = {}
    for kind, cls in (("native", NativeView), ("qopenglwidget", View)):
        monkeypatch.setenv("WRINKLE_VIS_VIEW", kind)
        w = make_window()
        assert all(type(p) is cls for p in w.plotters)
        shown[kind] = shown_pixels(w.skin_view).astype(int)
        _discard_changes(w)
        w.close()
    a, b = shown["native"], shown["qopenglwidget"]
    assert a.shape == b.shape and a.std() > 10  # a picture, not a cleared window
    assert (np.abs(a - b).max(axis=2) > 8).mean() < 0.01


def test_saved_view_image_is_what_the_view_shows(window, tmp_path):
    """File > Save view as image renders the view off screen at its size: the same picture
    as on screen (the camera copied, not reset by PyVista's first render).
    """
    from PIL import Image

    shown = shown_pixels(window.skin_view).astype(int)
    path = window.save_image("skin", tmp_path / "skin.png", window.skin_view.window_size)
    saved = np.asarray(Image.open(path))[..., :3].astype(int)
    assert saved.shape == shown.shape and shown.std() > 10
    assert (np.abs(saved - shown).max(axis=2) > 8).mean() < 0.01


def test_the_view_kind_comes_from_the_platform_or_the_environment(qapp, monkeypatch):
    from wrinkle_vis.app.viewwidget import view_kind

    monkeypatch.delenv("WRINKLE_VIS_VIEW", raising=False)
    assert view_kind() == "native"  # xcb
    monkeypatch.setenv("WRINKLE_VIS_VIEW", "QOpenGLWidget")
    assert view_kind() == "qopenglwidget"
    monkeypatch.setenv("WRINKLE_VIS_VIEW", "opengl")
    with pytest.raises(ValueError, match="WRINKLE_VIS_VIEW='opengl' is not a view kind; use"):
        view_kind()


def test_the_status_bar_warns_of_aliased_wrinkles(window):
    """As the command line does: the frame's muscles whose wrinkles the skin cannot resolve
    (frown's corrugators at 4,500 triangles), in the status bar with the line as tooltip.
    """
    window.expression_box.setCurrentText("frown")
    assert "aliased wrinkles" in window.status_label.text()
    tip = window.status_label.toolTip()
    assert "'corrugator_L', 'corrugator_R'" in tip and "refine the skin" in tip
    window.expression_box.setCurrentText("surprise")  # the frontalis' are resolved
    assert "aliased" not in window.status_label.text()
    assert window.status_label.toolTip() == ""
