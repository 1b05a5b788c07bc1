"""File > New face from mesh...: landmarks placed by clicks on the skin view, the muscles
moved onto the scan, a layout that names the mesh and reopens bit for bit (a real window
under Xvfb, pytest-qt; fixtures in conftest.py). Also the Face menu and a layout made for a
scan that names no mesh.
"""

import dataclasses
import json
import os
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import assert_same_face
from qtpy import QtCore, QtWidgets
from qtpy.QtTest import QTest

import wrinkle_vis as wv
from wrinkle_vis.app.newface import DESCRIPTIONS, LandmarkPicker, landmark_picture
from wrinkle_vis.app.recovery import Recovery
from wrinkle_vis.core.analysis import crests, section
from wrinkle_vis.core.mesh import TriangleSurface, closest_points
from wrinkle_vis.datasets import LANDMARKS
from wrinkle_vis.plotting import to_surface_polydata

pytestmark = pytest.mark.usefixtures("no_leaked_plotters")

ROOT = Path(__file__).resolve().parents[1]
REAL = ROOT.parent / "shared" / "realmeshes"  # test data beside the checkout
needs_scans = pytest.mark.skipif(not (REAL / "lee_perry_smith_head.obj").exists(),
                                 reason="../shared/realmeshes is not here")
EXAMPLE = Path(wv.datasets.__file__).with_name("examples") / "lee_perry_smith.json"

#: Where the nine landmarks are on the scans, in their own frames (metres for the head;
#: the bust's own unit), found by eye on front views and ray-cast onto the skin.
SCAN_LANDMARKS = {
    "lee_perry_smith_head.obj": {
        "nasion": (-0.000569, 0.006743, 0.029338), "nose_tip": (0.000836, -0.036339, 0.053476),
        "chin": (-0.002425, -0.10469, 0.036819), "eye_inner_L": (0.019274, -0.004529, 0.015423),
        "eye_inner_R": (-0.01987, -0.004581, 0.01552),
        "eye_outer_L": (0.045785, -0.007556, 0.010251),
        "eye_outer_R": (-0.046438, -0.007786, 0.010138),
        "mouth_corner_L": (0.024521, -0.071208, 0.027875),
        "mouth_corner_R": (-0.022226, -0.071205, 0.029395)},
    "demosthenes_bust.obj": {
        "nasion": (0.194, 1.33, 0.8939), "nose_tip": (0.183, 1.0225, 0.9466),
        "chin": (0.189, 0.584, 0.629), "eye_inner_L": (0.256, 1.319, 0.7998),
        "eye_inner_R": (0.131, 1.319, 0.8089), "eye_outer_L": (0.4875, 1.325, 0.7),
        "eye_outer_R": (-0.094, 1.3125, 0.7224), "mouth_corner_L": (0.363, 0.8875, 0.6865),
        "mouth_corner_R": (-0.0025, 0.899, 0.6416)},
}


def display_point(plotter, point) -> np.ndarray:
    r = plotter.renderer
    r.SetWorldPoint(*point, 1.0)
    r.WorldToDisplay()
    return np.array(r.GetDisplayPoint()[:2])


def click(plotter, point) -> None:
    """A left click with Qt's mouse events on the view widget where world ``point`` is drawn
    (through pyvistaqt, VTK's interactor and the window's observers).
    """
    x, y = display_point(plotter, point)
    view = plotter.interactor
    ratio = view.devicePixelRatioF()
    pos = QtCore.QPoint(int(round(x / ratio)), int(round(view.height() - y / ratio)))
    QTest.mouseMove(view, pos)
    QTest.mousePress(view, QtCore.Qt.LeftButton, QtCore.Qt.NoModifier, pos)
    QTest.mouseRelease(view, QtCore.Qt.LeftButton, QtCore.Qt.NoModifier, pos)


def menu_action(window, menu: str, text: str):
    for top in window.menuBar().actions():
        if top.text().replace("&", "") == menu:
            for action in top.menu().actions():
                if action.text().replace("&", "") == text:
                    return action
    raise AssertionError(f"no {menu} > {text}")


def frontalis_crests(state) -> dict[str, tuple[int, int]]:
    """``{sheet: (crests, n_w)}``: crests of each frontalis sheet's own W along its fibre, on
    the section through the sheet's middle (its longest run: the depth bound of the AOI
    can let a sheet's region reach over the crown too).
    """
    rest = TriangleSurface(state.rest_points, state.triangles)
    out = {}
    for m in state.face.muscles:
        if not m.name.startswith("frontalis"):
            continue
        fibre, across, _ = m.frame
        own = state.fields[m.name]["W"]
        inside = np.isfinite(own)
        values = np.nan_to_num(own)
        middle = np.mean(m.attachment_line, axis=0)
        lines = section(rest, values, middle, across, inside, order_axis=fibre)
        line = max(lines, key=lambda ln: ln.length)
        found = crests(line.s, line.values, 0.1 * np.abs(values).max())
        out[m.name] = (len(found), m.n_wrinkles)
    return out


# ---------------------------------------------------------------------- the flow, no Qt
@pytest.fixture(scope="module")
def ply_skin(tmp_path_factory, wv_face):
    path = tmp_path_factory.mktemp("scan") / "face.ply"
    to_surface_polydata(wv_face.skin).save(path)
    return path


def test_the_picker_asks_in_order_snaps_onto_the_skin_and_undoes(wv_face, ply_skin):
    picker = LandmarkPicker(wv_face.skin, ply_skin)
    assert picker.current == LANDMARKS[0] and picker.step == 0 and not picker.done
    marks = wv_face.landmarks
    off = np.array([0.0, 0.0, 1.0])  # 1 mm in front of the skin
    name, where = picker.add(np.asarray(marks["nasion"]) + off)
    assert name == "nasion" and picker.current == "nose_tip"
    assert np.linalg.norm(np.subtract(where, marks["nasion"])) < 1.0
    np.testing.assert_allclose(closest_points(wv_face.skin, np.array([where]))[0], where,
                               atol=1e-9)
    assert picker.undo() == "nasion" and picker.current == "nasion" and picker.step == 0
    assert picker.undo() is None
    for n in LANDMARKS:
        picker.add(marks[n])
    assert picker.done and picker.current is None and list(picker.picked) == list(LANDMARKS)
    with pytest.raises(ValueError, match="every landmark is placed already"):
        picker.add(marks["chin"])
    assert picker.undo() == "mouth_corner_R" and picker.current == "mouth_corner_R"
    with pytest.raises(ValueError, match="'mouth_corner_R' is not placed yet .8 of 9"):
        picker.face()
    with pytest.raises(ValueError, match="finite numbers"):
        picker.add([0.0, np.nan, 1.0])
    with pytest.raises(ValueError, match="no earlier position"):
        picker.keep()


def test_landmarks_that_cannot_be_a_face_are_refused(wv_face, ply_skin):
    marks = wv_face.landmarks
    picker = LandmarkPicker(wv_face.skin, ply_skin, unit="mm")
    for n in LANDMARKS:
        picker.add(marks["nasion"] if n == "nose_tip" else marks[n])
    with pytest.raises(ValueError, match="nasion and nose_tip are at the same place"):
        picker.face()
    swapped = {"eye_inner_L": "eye_inner_R", "eye_inner_R": "eye_inner_L",
               "eye_outer_L": "eye_outer_R", "eye_outer_R": "eye_outer_L",
               "mouth_corner_L": "mouth_corner_R", "mouth_corner_R": "mouth_corner_L"}
    picker = LandmarkPicker(wv_face.skin, ply_skin, unit="mm")
    for n in LANDMARKS:
        picker.add(marks[swapped.get(n, n)])
    with pytest.raises(ValueError, match="do not make a face .misfit 0.[2-9].*subject's left"):
        picker.check()
    picker = LandmarkPicker(wv_face.skin, ply_skin, unit="mm")
    for n in LANDMARKS:
        picker.add(marks[n])
    picker.check()  # the face's own landmarks fit (snapped onto its mesh)


def test_keep_places_a_landmark_where_it_was(wv_face, ply_skin):
    picker = LandmarkPicker(wv_face.skin, ply_skin, previous=wv_face.landmarks)
    name, where = picker.keep()
    assert name == "nasion"
    assert where == wv_face.landmarks["nasion"]


def test_the_layout_names_the_mesh_and_the_landmarks(wv_face, ply_skin):
    picker = LandmarkPicker(wv_face.skin, ply_skin, unit="mm")
    for n in LANDMARKS:
        picker.add(wv_face.landmarks[n])
    layout = picker.layout(wv_face)
    assert layout.skin == "face.ply" and picker.folder == ply_skin.parent
    assert layout.unit == "mm" and list(layout.landmarks) == list(LANDMARKS)
    assert layout.muscles == wv_face.muscles


def test_each_landmark_has_a_picture_with_its_ball_where_it_goes():
    pictures = {n: landmark_picture(n) for n in LANDMARKS}
    for name, image in pictures.items():
        assert image.shape == (180, 180, 3) and image.dtype == np.uint8
        red = (image[:, :, 0] > 150) & (image[:, :, 1] < 80) & (image[:, :, 2] < 80)
        assert red.sum() > 20, name  # the red ball shows
        assert DESCRIPTIONS[name]
    rows = {n: np.argwhere((p[:, :, 0] > 150) & (p[:, :, 1] < 80))[:, 0].mean()
            for n, p in pictures.items()}
    cols = {n: np.argwhere((p[:, :, 0] > 150) & (p[:, :, 1] < 80))[:, 1].mean()
            for n, p in pictures.items()}
    assert rows["nasion"] < rows["nose_tip"] < rows["mouth_corner_L"] < rows["chin"]
    assert cols["eye_outer_R"] < cols["eye_inner_R"] < cols["eye_inner_L"] < cols["eye_outer_L"]
    with pytest.raises(KeyError, match="unknown landmark 'elbow'"):
        landmark_picture("elbow")


# ---------------------------------------------------------------------- the window
def start_flow(window, monkeypatch, path) -> None:
    monkeypatch.setattr(QtWidgets.QFileDialog, "getOpenFileName",
                        lambda *a, **k: (str(path), ""))
    menu_action(window, "File", "New face from mesh...").trigger()


def test_clicks_place_the_landmarks_and_ctrl_z_takes_one_back(make_window, monkeypatch,
                                                             ply_skin, wv_face, qtbot):
    w = make_window()
    w.activateWindow()
    w.raise_()
    qtbot.waitUntil(lambda: QtWidgets.QApplication.activeWindow() is w, timeout=3000)
    before = w.session
    start_flow(w, monkeypatch, ply_skin)
    flow = w.newface
    assert flow.picking and flow.dock.isVisible() and w.session.face.muscles == ()
    assert "Landmark 1 of 9: nasion" in flow.panel.title.text()
    assert not flow.panel.picture.pixmap().isNull()
    w.set_camera("front")
    marks = wv_face.landmarks
    for name in LANDMARKS[:3]:
        click(w.skin_view, marks[name])
    assert list(flow.picker.picked) == list(LANDMARKS[:3])
    for name in LANDMARKS[:3]:  # within a pixel or two of where the click was aimed
        assert np.linalg.norm(np.subtract(flow.picker.picked[name], marks[name])) < 2.0
    assert "Landmark 4 of 9: eye_inner_L" in flow.panel.title.text()
    assert "landmarks:placed" in w.skin_view.actors
    assert not w.add_menu.isEnabled()  # no muscles on a scan without its landmarks
    assert "landmarks:hint" in w.skull_view.actors  # no skull yet: the view says why
    QTest.keyClick(w.skin_view.interactor, QtCore.Qt.Key_Z, QtCore.Qt.ControlModifier)
    assert list(flow.picker.picked) == list(LANDMARKS[:2])
    assert "Landmark 3 of 9: chin" in flow.panel.title.text()
    # a drag turns the head and places nothing
    view = w.skin_view.interactor
    start = QtCore.QPoint(view.width() // 2, view.height() // 2)
    QTest.mousePress(view, QtCore.Qt.LeftButton, QtCore.Qt.NoModifier, start)
    QTest.mouseMove(view, start + QtCore.QPoint(30, 0))
    QTest.mouseRelease(view, QtCore.Qt.LeftButton, QtCore.Qt.NoModifier,
                       start + QtCore.QPoint(30, 0))
    assert flow.picker.step == 2
    flow.actions["cancel"].trigger()
    assert w.session is before and not flow.dock.isVisible() and flow.picker is None
    assert w.add_menu.isEnabled() and flow.actions["undo"].shortcut().isEmpty()
    assert "landmarks:hint" not in w.skull_view.actors
    assert "landmarks:placed" not in w.skin_view.actors


def test_a_mesh_that_cannot_be_read_is_reported_in_one_line(make_window, monkeypatch,
                                                           tmp_path, answer):
    w = make_window()
    before = w.session
    bad = tmp_path / "junk.obj"
    bad.write_text("v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    answer("OK")
    start_flow(w, monkeypatch, bad)
    assert "junk.obj" in answer.asked[0] and "non-finite" in answer.asked[0]
    assert w.session is before and w.newface.picker is None


def test_the_face_menu_shows_the_built_in_faces(make_window):
    w = make_window()
    menu_action(w, "Face", "Procedural").trigger()
    assert w.session.face.skin.n_points == wv.datasets.load_face().skin.n_points
    assert w.session.layout_path is None and not w.session.dirty
    names = [a.text().replace("&", "") for a in w.face_actions.values()]
    assert names[0] == "Procedural" and "Lee Perry-Smith" in names
    assert not w.newface.pick_again()  # not a face from a scan
    assert "face from a scan" in w.statusBar().currentMessage()


def test_a_layout_made_for_a_scan_without_its_mesh_is_refused_cleanly(make_window, answer):
    """The Lee Perry-Smith example names no mesh: the app asks for it (Cancel here), keeps
    the face it showed, and every action goes on working.
    """
    w = make_window()
    before = w.session
    answer("Cancel")
    assert not w.open_layout(EXAMPLE)
    assert "names no mesh" in answer.asked[0] and "Choose the mesh" in answer.asked[0]
    assert len(answer.asked[0].splitlines()[0]) < 400
    assert w.session is before
    w.expression_box.setCurrentText("frown")
    w.select_muscle("corrugator_L")
    assert np.abs(w.session.state().W).max() > 0


@needs_scans
@pytest.mark.slow
def test_the_example_opens_on_the_mesh_chosen_for_it(make_window, answer, monkeypatch):
    w = make_window()
    head = REAL / "lee_perry_smith_head.obj"
    monkeypatch.setattr(QtWidgets.QFileDialog, "getOpenFileName",
                        lambda *a, **k: (str(head), ""))
    answer("Choose mesh...")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the unit of a mesh file
        assert w.open_layout(EXAMPLE)
    assert w.session.face.skin.n_points == 8844
    assert len(w.session.face.muscles) == len(wv.load_layout(EXAMPLE).muscles)
    assert w.session.dirty  # the layout now names its mesh: unsaved
    assert Path(EXAMPLE.parent / w.session.layout().skin).resolve() == head.resolve()
    assert np.abs(w.session.state().W).max() > 0


@needs_scans
@pytest.mark.slow
def test_the_bust_in_millimetres_keeps_its_frontalis_crests_on_the_physical_skin():
    """The Demosthenes bust is 2.69 units tall, a head in no unit: read in millimetres, the
    physical skin's human material (its membrane reaches sqrt(Y / kappa) = 16 mm) smoothed
    the whole 2.7 mm face and kept n_w crests on 3 of the 6 frontalis sheets (the geometric
    skin: 6). It is simulated at human size, as in metres, and keeps them all."""
    from wrinkle_vis.core.skin import vertex_areas
    from wrinkle_vis.core.units import HUMAN_LANDMARK_RADIUS_M, landmark_radius
    from wrinkle_vis.datasets.scans import read_surface

    skin = read_surface(REAL / "demosthenes_bust.obj")
    marks = SCAN_LANDMARKS["demosthenes_bust.obj"]
    snapped = closest_points(skin, np.array(list(marks.values())))
    landmarks = {name: tuple(p) for name, p in zip(marks, snapped, strict=True)}
    face = wv.datasets.load_face(skin=skin, landmarks=landmarks, unit="mm")
    spring = face.physical_skin()  # per-area stiffness kappa * area * s^2: s m per unit
    s = np.sqrt(spring.k_att / (spring.material.attachment_stiffness * vertex_areas(skin)))
    size_m = landmark_radius(face.landmarks) * np.median(s)
    counts = frontalis_crests(face.evaluate("surprise", refine=True, skin="physical"))
    assert all(c == n_w for c, n_w in counts.values()), counts
    assert size_m == pytest.approx(HUMAN_LANDMARK_RADIUS_M, rel=1e-9)  # at human size


@needs_scans
@pytest.mark.slow
@pytest.mark.parametrize("mesh", list(SCAN_LANDMARKS))
def test_a_new_face_from_a_scan_by_clicks_wrinkles_and_reopens_bit_for_bit(
        make_window, monkeypatch, tmp_path, mesh, asked_unit):
    w = make_window()
    asked_unit.reply = "mm"  # the bust's unit cannot be guessed: asked, read as before
    path = REAL / mesh
    start_flow(w, monkeypatch, path)
    flow = w.newface
    marks = SCAN_LANDMARKS[mesh]
    lo, hi = flow.picker.skin.bounds()
    size = float(np.linalg.norm(hi - lo))
    for name in LANDMARKS:
        assert flow.picker.current == name
        click(w.skin_view, marks[name])
        assert flow.picker.step == LANDMARKS.index(name) + 1, f"the click missed {name}"
    face = w.session.face
    built_in = wv.load_layout(wv.datasets.BUILTIN_LAYOUT)
    assert flow.picker.done and len(face.muscles) == len(built_in.muscles) >= 14
    for name in LANDMARKS:
        assert np.linalg.norm(np.subtract(face.landmarks[name], marks[name])) < 0.01 * size
    assert w.session.dirty and "All 9 landmarks placed" in flow.panel.title.text()
    # surprise, refined as the paper renders it: furrows across each frontalis fibre
    w.expression_box.setCurrentText("surprise")
    w.refine_box.setChecked(True)
    counts = frontalis_crests(w.session.state())
    assert len(counts) == 6
    # n_w crests on each, give or take one where a click-placed frame meets a coarse scan
    assert all(n_w - 1 <= c <= n_w + 1 for c, n_w in counts.values()), counts
    assert sum(c == n_w for c, n_w in counts.values()) >= 4, counts
    w.refine_box.setChecked(False)
    # autosaved meanwhile with the mesh's absolute path (no layout file yet)
    w.autosave()
    rec = Recovery.load(w.recovery.path)
    assert Path(rec.layout.skin) == path.resolve() and rec.layout.landmarks == face.landmarks
    # saved from the panel: the mesh is named relative to the layout, with the landmarks
    target = tmp_path / "faces" / "new.json"
    target.parent.mkdir()
    monkeypatch.setattr(QtWidgets.QFileDialog, "getSaveFileName",
                        lambda *a, **k: (str(target), ""))
    flow.actions["save"].trigger()
    assert not flow.dock.isVisible() and not w.session.dirty
    data = json.loads(target.read_text())
    assert data["skin"] == os.path.relpath(path.resolve(), target.parent)
    assert list(data["landmarks"]) == list(LANDMARKS)
    shown = w.session.face
    assert w.open_layout(target)
    again = w.session.face
    assert again is not shown
    assert_same_face(again, shown)


def test_a_gltf_scan_starts_the_flow(make_window, monkeypatch, tmp_path, wv_face):
    import pyvista as pv

    path = tmp_path / "face.gltf"
    pl = pv.Plotter(off_screen=True)
    pl.add_mesh(to_surface_polydata(wv_face.skin))
    pl.export_gltf(path)
    pl.close()
    w = make_window()
    start_flow(w, monkeypatch, path)
    assert w.newface.picking and w.newface.picker.mesh_path == path.resolve()
    assert w.session.face.skin.n_points == wv_face.skin.n_points
    # closed while picking: the leak check sees the window and its flow freed


@pytest.mark.slow
def test_landmarks_picked_again_move_the_edited_muscles_with_them(make_window, monkeypatch,
                                                                  ply_skin, wv_face, answer):
    """Face > Pick landmarks again on a face from a scan: Keep takes a landmark as it was,
    a click moves one; the layout's edits survive, and Cancel leaves the face as it was.
    """
    w = make_window()
    start_flow(w, monkeypatch, ply_skin)
    w.newface.panel.unit_box.setCurrentText("mm")
    w.set_camera("front")
    for name in LANDMARKS:
        click(w.skin_view, wv_face.landmarks[name])
    assert w.newface.picker.done and w.session.face.unit == "mm"
    w.select_muscle("corrugator_L")
    w.param_widgets["k0"].setValue(3.5)  # an edit, to survive the new landmarks
    edited = w.session.face
    # Ctrl+Z is Edit > Undo's again (the button still takes a landmark back)
    assert w.newface.actions["undo"].shortcut().isEmpty() and w.undo_stack.canUndo()
    again = w.newface.actions["again"]
    assert again.isVisible() and again.isEnabled()
    again.trigger()
    flow = w.newface
    assert flow.picking and flow.picker.previous == edited.landmarks
    assert flow.actions["keep"].isVisible() and "landmarks:before" in w.skin_view.actors
    flow.actions["cancel"].trigger()  # back to the edited face, untouched
    assert w.session.face is edited and w.session.dirty
    again.trigger()  # opening another face mid-way asks about the edited one's changes
    answer("Cancel")
    assert not w.open_builtin("procedural")
    assert "unsaved changes" in answer.asked[-1]
    assert w.session.face is edited and w.session.dirty and w.newface.picker is None
    again.trigger()
    for _ in LANDMARKS:
        flow.actions["keep"].trigger()
    face = w.session.face
    assert flow.picker.done and face.landmarks == edited.landmarks
    assert face.muscle("corrugator_L").k0 == pytest.approx(3.5)  # the edit moved along
    for a, b in zip(edited.muscles, face.muscles, strict=True):  # the same landmarks: the
        for p in a.point_parameters:  # muscles stay where they were
            np.testing.assert_allclose(getattr(b, p), getattr(a, p), atol=1e-6)
    flow.actions["cancel"].trigger()  # "Close": the new face stays
    assert w.session.face is face and not flow.dock.isVisible()


def test_a_new_muscle_and_the_parameter_steps_follow_the_face_unit(make_window, wv_face):
    """On a face in metres a new muscle starts as on the built-in face in millimetres, and
    the parameter boxes step and show lengths in metres.
    """
    from wrinkle_vis.app.session import Session
    from wrinkle_vis.core.face import FaceModel

    metres = FaceModel(wv_face.skin.with_points(wv_face.skin.points / 1000),
                       wv_face.skull.with_points(wv_face.skull.points / 1000), (),
                       {"neutral": wv_face.expressions["neutral"]}, unit="m")
    w = make_window(Session(metres))
    w.probe_vertex(int(np.argmax(metres.skin.points[:, 2])))
    name = w.add_muscle("linear")
    assert w.session.face.muscle(name).k0 == pytest.approx(0.0008)  # 0.8 mm
    box = w.param_widgets["k0"]
    assert box.decimals() == 6 and box.value() == pytest.approx(0.0008)
    assert box.singleStep() == pytest.approx(1e-4)
    assert w.param_widgets["alpha"].singleStep() == pytest.approx(0.1)
    assert "(m)" in w.probe_table.verticalHeaderItem(list(wv.FIELD_NAMES).index("W")).text()


@pytest.mark.slow
def test_a_layout_whose_mesh_moved_asks_for_it(make_window, answer, monkeypatch, tmp_path,
                                               ply_skin, wv_face):
    from wrinkle_vis.app.session import Session

    layout = Session(wv_face).layout()
    path = tmp_path / "mine.json"
    wv.save_layout(dataclasses.replace(layout, skin="gone.ply", n_triangles=None), path)
    w = make_window()
    monkeypatch.setattr(QtWidgets.QFileDialog, "getOpenFileName",
                        lambda *a, **k: (str(ply_skin), ""))
    answer("Choose mesh...")
    assert w.open_layout(path)
    assert "gone.ply is not there" in answer.asked[0]
    assert w.session.face.skin.n_points == wv_face.skin.n_points and w.session.dirty
    assert w.session.layout().skin == os.path.relpath(ply_skin, tmp_path)
    assert len(w.session.face.muscles) == len(wv_face.muscles)


def test_a_mesh_chosen_for_a_layout_is_an_unsaved_change_after_other_edits(
        make_window, answer, monkeypatch, tmp_path, ply_skin, wv_face):
    """Issue 32: after edits (discarded), a mesh chosen for the layout opened was no
    unsaved change: no ``*``, Quit did not ask, the pairing was lost. The title marks it
    and Quit asks (Cancel keeps the window)."""
    from wrinkle_vis.app.session import Session

    path = tmp_path / "mine.json"
    wv.save_layout(dataclasses.replace(Session(wv_face).layout(), skin="gone.ply",
                                       n_triangles=None), path)
    w = make_window()
    w.select_muscle("corrugator_L")
    w.param_widgets["k0"].setValue(2.5)  # an edit: the undo stack is not clean
    assert w.session.dirty
    monkeypatch.setattr(QtWidgets.QFileDialog, "getOpenFileName",
                        lambda *a, **k: (str(ply_skin), ""))
    answer("Discard", "Choose mesh...")
    assert w.open_layout(path)
    assert w.session.dirty and w.windowTitle().endswith(" *")
    assert w.session.layout().skin == os.path.relpath(ply_skin, tmp_path)
    answer("Cancel")
    w.close()
    assert "unsaved changes" in answer.asked[-1] and w.isVisible()


@pytest.fixture
def asked_unit(monkeypatch):
    """QInputDialog.getItem answered with ``asked_unit.reply`` (None: Cancel); the prompts
    asked are kept in ``asked_unit.prompts``."""
    class Asked:
        reply, prompts = "m", []

    def get_item(parent, title, label, items, current=0, editable=True, *a, **k):
        Asked.prompts.append(label)
        assert Asked.reply is None or Asked.reply in items
        return (Asked.reply or "", Asked.reply is not None)

    monkeypatch.setattr(QtWidgets.QInputDialog, "getItem", get_item)
    return Asked


@pytest.fixture(scope="module")
def small_ply(tmp_path_factory, wv_face):
    """The built-in skin at 1/100 of its size (2.3 units tall: no unit fits a head)."""
    path = tmp_path_factory.mktemp("small") / "small.ply"
    to_surface_polydata(wv_face.skin.with_points(wv_face.skin.points / 100.0)).save(path)
    return path


def test_a_scan_whose_unit_cannot_be_guessed_asks_for_it(make_window, monkeypatch,
                                                          asked_unit, small_ply, ply_skin):
    """Issue 32: the app took such a scan (the Demosthenes bust, 2.69 units tall) as
    millimetres without a word; it asks, and Cancel starts nothing. A scan of a head's size
    in millimetres is not asked about."""
    w = make_window()
    start_flow(w, monkeypatch, small_ply)
    assert len(asked_unit.prompts) == 1 and "small.ply is 2.3" in asked_unit.prompts[0]
    assert w.newface.picker.unit == "m" and w.session.unit == "m"
    assert w.newface.panel.unit_box.currentText() == "m"
    w.newface.cancel()
    asked_unit.reply = None  # Cancel
    before = w.session
    start_flow(w, monkeypatch, small_ply)
    assert w.newface.picker is None and w.session is before
    start_flow(w, monkeypatch, ply_skin)  # 230 mm tall: guessed, not asked
    assert len(asked_unit.prompts) == 2 and w.newface.picker.unit == "mm"
    w.newface.cancel()


def test_a_layout_on_a_mesh_of_no_guessable_unit_asks_for_it(make_window, asked_unit,
                                                               small_ply, tmp_path):
    """A layout that names such a mesh and no unit: asked when opened."""
    path = tmp_path / "small.json"
    wv.save_layout(wv.Layout(skin=str(small_ply),
                             expressions={"neutral": wv.Expression("neutral")}), path)
    w = make_window()
    asked_unit.reply = "cm"
    with warnings.catch_warnings():
        warnings.simplefilter("error", wv.core.units.UnitWarning)  # no guess behind it
        assert w.open_layout(path)
    assert len(asked_unit.prompts) == 1 and w.session.face.unit == "cm"
    assert w.session.unit == "cm"


@needs_scans
def test_the_demosthenes_bust_asks_for_its_unit(make_window, monkeypatch, asked_unit):
    w = make_window()
    start_flow(w, monkeypatch, REAL / "demosthenes_bust.obj")
    assert "demosthenes_bust.obj is 2.69 units tall" in asked_unit.prompts[0]
    assert w.newface.picker.unit == "m"
    w.newface.cancel()


def test_the_lee_perry_smith_face_from_the_menu_saves_and_reopens_as_itself(make_window,
                                                                           tmp_path):
    w = make_window()
    menu_action(w, "Face", "Lee Perry-Smith").trigger()
    face = w.session.face
    assert face.skin.n_points == wv.datasets.load_face("lee_perry_smith").skin.n_points
    assert len(face.muscles) >= 14 and np.abs(w.session.state().W).max() > 0
    w.select_muscle("corrugator_L")
    w.param_widgets["k0"].setValue(2.5)
    path = tmp_path / "lps.json"
    assert w.save_as(path)
    data = json.loads(path.read_text())
    assert data["face"] == "lee_perry_smith" and data["skin"] is None
    assert "n_triangles" not in data
    assert w.open_layout(path)
    again = w.session.face
    np.testing.assert_array_equal(again.skin.points, face.skin.points)
    assert again.muscle("corrugator_L").k0 == 2.5 and again.unit == face.unit


def test_the_app_started_on_the_example_explains_in_one_line(qapp, capsys):
    from wrinkle_vis.app.window import run

    assert run(layout=EXAMPLE) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "lee_perry_smith.json" in err
    assert "skin" in err  # the way out: name the mesh in the layout's "skin"


def test_landmarks_that_cannot_be_a_face_are_explained_and_the_last_taken_back(
        make_window, monkeypatch, ply_skin, wv_face, answer):
    w = make_window()
    start_flow(w, monkeypatch, ply_skin)
    answer("OK")
    for n in LANDMARKS:
        w.newface.place(wv_face.landmarks["nasion" if n == "nose_tip" else n])
    assert "at the same place" in answer.asked[0] and "Place mouth_corner_R again" in \
        answer.asked[0]
    assert w.newface.picking and w.newface.picker.current == "mouth_corner_R"
    assert w.session.face.muscles == ()
