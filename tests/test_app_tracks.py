"""File > Import performance...: a recorded track plays in the app (a real window under
Xvfb; fixtures: conftest.py), and the Qt-free session side.
"""

import time
from pathlib import Path

import numpy as np
import pytest
from qtpy import QtWidgets

import wrinkle_vis as wv
from wrinkle_vis.app.session import TIMELINE_STEPS, Session
from wrinkle_vis.app.trackplot import track_curves
from wrinkle_vis.core.tracks import Track, default_mapping, performance, write_track

pytestmark = pytest.mark.usefixtures("no_leaked_plotters")

OPENFACE = Path(__file__).resolve().parents[1].parent / "shared" / "tracks" / \
    "openface_test.csv"


def _brows(tmp_path) -> Path:
    t = np.linspace(0.0, 2.0, 21)
    path = tmp_path / "brows.csv"
    write_track(Track(t, ["AU01", "AU04", "AU45"],
                      np.column_stack([np.sin(np.pi * t / 2), 0.5 * t / 2, 0.3 + 0 * t])),
                path, "openface")
    return path


def test_the_session_plays_a_performance_without_saving_it(wv_face, tmp_path):
    s = Session(wv_face)
    track = wv.read_track(_brows(tmp_path))
    perf = performance(track, default_mapping(), wv_face.muscle_names, name="brows (track)")
    s.set_performance(perf)
    assert s.expression == "brows (track)" and s.current_expression() is perf
    s.set_time(1.0)
    assert s.activations()["frontalis_inner_L"] == pytest.approx(1.0)
    assert s.activations()["procerus"] == pytest.approx(0.25)
    assert "brows (track)" not in s.layout().expressions  # not part of the layout
    with pytest.raises(ValueError, match="recorded track"):
        s.with_activation("procerus", 0.5)
    s.set_face(s.face.without_muscle("procerus"))  # an edit after the import
    assert "procerus" not in s.activations() and s.state().W.shape == (wv_face.skin.n_points,)
    s.set_expression("frown")
    assert s.current_expression() is wv_face.expressions["frown"]
    s.set_expression("brows (track)")  # still offered
    lo, hi = s.ramp_range()
    assert hi > 0.1  # over the whole track, not its (empty) onset


def test_track_curves_keep_the_channels_that_drive_muscles(tmp_path):
    track = wv.read_track(_brows(tmp_path))
    curves = track_curves(track, default_mapping(), ["frontalis_inner_L", "procerus"])
    assert [c[0] for c in curves] == ["AU01", "AU04"]  # AU45 drives no muscle


def test_import_performance_in_the_window(window, tmp_path):
    window.skin_box.setCurrentText("geometric")  # its Play: each frame at the track's clock
    name = window.import_performance(_brows(tmp_path))
    s = window.session
    assert name == "brows (track)" and window.expression_box.currentText() == name
    assert [window.expression_box.itemText(i) for i in range(window.expression_box.count())
            ][-1] == name
    plot = window.track_plot
    assert plot is not None and plot.isVisible() and [c[0] for c in plot.curves] == [
        "AU01", "AU04"]
    window.time_slider.setValue(TIMELINE_STEPS // 2)  # the timeline spans the track
    assert s.time_s == pytest.approx(1.0, abs=2.0 / TIMELINE_STEPS)
    assert plot.time_s == s.time_s
    expected = s.face.evaluate(s.current_expression().at(s.time_s))
    np.testing.assert_allclose(s.state().W, expected.W)
    assert np.abs(s.state().W).max() > 0
    window._play_start = (0, time.perf_counter() - 0.5)  # Play runs at the track's clock:
    window._tick()  # half a second into a 2 s track is a quarter of the timeline
    position = window.time_slider.value()  # 0.5 s and the time the call took (< 0.2 s)
    assert TIMELINE_STEPS / 4 <= position <= TIMELINE_STEPS * (0.5 + 0.2) / 2


def test_the_real_track_imports_and_a_bad_file_is_one_line(window, tmp_path, monkeypatch):
    assert window.import_performance(OPENFACE) == "openface_test (track)"
    assert window.session.current_expression().duration_s == pytest.approx(0.099)
    shown = []
    monkeypatch.setattr(QtWidgets.QMessageBox, "warning", lambda *a: shown.append(a[2]))
    bad = tmp_path / "bad.csv"
    bad.write_text("name,score\nada,3\n")
    monkeypatch.setattr(QtWidgets.QFileDialog, "getOpenFileName",
                        lambda *a, **k: (str(bad), ""))
    window.import_performance_dialog()
    assert len(shown) == 1 and "not a track this reads" in shown[0] and "\n" not in shown[0]
    assert window.session.expression == "openface_test (track)"  # kept
    window._show_session(Session(window.session.face))  # another layout opened
    assert not window.track_plot.isVisible() and window.session.performance is None


def _plot(qtbot, tmp_path, t: float):
    from wrinkle_vis.app.trackplot import TrackPlot

    track = wv.read_track(_brows(tmp_path))
    plot = TrackPlot()
    qtbot.addWidget(plot)
    plot.resize(400, 120)
    plot.set_curves(track_curves(track, default_mapping(), ["frontalis_inner_L", "procerus"]),
                    track.duration_s)
    plot.set_time(t)
    plot.show()
    qtbot.waitExposed(plot)
    return plot


def test_a_frame_of_playback_repaints_only_the_time_line(qtbot, tmp_path, monkeypatch):
    from qtpy import QtCore

    plot = _plot(qtbot, tmp_path, 0.5)
    asked = []
    monkeypatch.setattr(plot, "update", lambda *a: asked.append(a))
    old = plot.cursor_x()
    plot.set_time(1.5)  # a frame of playback: the old line's strip and the new one's
    assert len(asked) == 2 and all(len(a) == 1 and a[0].width() <= 5 for a in asked)
    for rect, x in zip((a[0] for a in asked), (old, plot.cursor_x()), strict=True):
        assert rect.contains(QtCore.QPoint(int(x), 60))


def test_the_moved_time_line_draws_as_a_fresh_plot(qtbot, tmp_path):
    moved = _plot(qtbot, tmp_path, 0.5)
    for t in (0.7, 1.2, 1.5):
        moved.set_time(t)
        moved.repaint()
    fresh = _plot(qtbot, tmp_path, 1.5)
    a, b = moved.grab().toImage(), fresh.grab().toImage()
    assert a == b  # the old lines are gone, the curves are whole
    x = round(fresh.cursor_x())
    assert a.pixelColor(x, 60).name() == "#000000"


# ---------------------------------------------------------------------- the mapping
def test_the_mapping_table_round_trips_and_refuses_a_bad_weight():
    from wrinkle_vis.app.mapping import mapping_from_table, mapping_table, parse_weight

    base = default_mapping()
    channels, muscles, weights = mapping_table(base, ["procerus", "corrugator_L"])
    assert weights[channels.index("AU04")].tolist() == [1.0, 1.0]
    again = mapping_from_table(base, channels, muscles, weights)
    assert again == base  # the muscles not shown and the curves are kept
    weights[channels.index("AU04"), 0] = 0.0
    edited = mapping_from_table(base, channels, muscles, weights)
    assert "procerus" not in edited.drives("AU04") and edited.drives("AU04")["corrugator_R"]
    weights[0, 0] = 1.5
    with pytest.raises(ValueError, match=r"^channel AU01: weight of 'procerus' = 1.5 is "):
        mapping_from_table(base, channels, muscles, weights)
    assert parse_weight(" ", "procerus") == 0.0 and parse_weight("0.25", "procerus") == 0.25
    for bad in ("1.5", "nan", "x"):
        with pytest.raises(ValueError, match="give a weight from 0 to 1$"):
            parse_weight(bad, "procerus")


def _cell(dialog, channel: str, muscle: str):
    from qtpy import QtCore

    i, j = dialog.channels.index(channel), dialog.muscles.index(muscle)
    dialog.table.scrollToItem(dialog.table.item(i, j))
    return dialog.table.visualItemRect(dialog.table.item(i, j)).center(), QtCore.Qt


def _editor(dialog):
    """The table's open cell editor, or None."""
    shown = [e for e in dialog.table.viewport().findChildren(QtWidgets.QLineEdit)
             if e.isVisible()]
    return shown[0] if shown else None


def _type_into(qtbot, dialog, pos, text: str) -> None:
    """Click the cell at ``pos``, press F2, type ``text`` in its editor and press Return."""
    from qtpy import QtCore

    qtbot.mouseClick(dialog.table.viewport(), QtCore.Qt.LeftButton, pos=pos)
    qtbot.keyClick(dialog.table, QtCore.Qt.Key_F2)
    qtbot.waitUntil(lambda: _editor(dialog) is not None)
    editor = _editor(dialog)
    editor.selectAll()
    qtbot.keyClicks(editor, text)
    qtbot.keyClick(editor, QtCore.Qt.Key_Return)
    qtbot.waitUntil(lambda: _editor(dialog) is None)


def test_editing_a_weight_in_the_dialog_changes_what_the_track_plays(window, qtbot,
                                                                      tmp_path):
    window.import_performance(_brows(tmp_path))
    s = window.session
    window.time_slider.setValue(TIMELINE_STEPS // 2)  # 1 s: AU04 = 0.25
    assert s.activations()["procerus"] == pytest.approx(0.25)
    assert not s.dirty
    action = next(a for a in window.menuBar().actions()[1].menu().actions()
                  if a.text() == "Track &mapping...")
    action.trigger()
    dialog = window.mapping_dialog
    qtbot.waitExposed(dialog)
    pos, qt = _cell(dialog, "AU04", "procerus")
    _type_into(qtbot, dialog, pos, "1.5")  # refused: the reason under the table, cell kept
    assert "outside [0, 1]" in dialog.error.text() and "\n" not in dialog.error.text()
    assert dialog.table.item(dialog.channels.index("AU04"),
                             dialog.muscles.index("procerus")).text() == "1"
    _type_into(qtbot, dialog, pos, "0.4")
    assert dialog.error.text() == ""
    assert s.activations()["procerus"] == pytest.approx(0.25)  # not before OK
    qtbot.mouseClick(dialog.buttons.button(QtWidgets.QDialogButtonBox.Ok), qt.LeftButton)
    assert s.activations()["procerus"] == pytest.approx(0.1)  # 0.4 x AU04 0.25
    assert s.activations()["corrugator_L"] == pytest.approx(0.25)
    assert s.dirty and window.undo_stack.undoText() == "Edit the track mapping"
    assert s.layout().mapping.drives("AU04")["procerus"] == 0.4  # saved with the layout
    window.undo_stack.undo()  # one step back to the old weights
    assert s.activations()["procerus"] == pytest.approx(0.25) and not s.dirty
    window.undo_stack.redo()
    assert s.activations()["procerus"] == pytest.approx(0.1)
