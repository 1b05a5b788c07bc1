"""Another program changes the open layout file (issue 33 M11): Save compares the file with
what the app read or last saved (time, size, SHA-256, kept in the Qt-free session) and asks
before overwriting a change; a deleted file is written again. In a real window (Xvfb,
pytest-qt), the dialogs answered by clicking their buttons (fixtures in conftest.py).
"""

import json
import os

import pytest
from qtpy import QtWidgets
from test_app_safety import menu_action, saved_k0, type_into, with_k0

import wrinkle_vis as wv
from wrinkle_vis.app.session import FileStamp, Session, load_session

pytestmark = pytest.mark.usefixtures("no_leaked_plotters")


@pytest.fixture
def opened(make_window, wv_face, tmp_path):
    """A window on the layout file ``mine.json`` as the app opens one, k0 of corrugator_L
    edited to 4.5 (unsaved); returns the window and the path.
    """
    path = tmp_path / "mine.json"
    wv.save_layout(Session(wv_face).layout(), path)
    w = make_window(load_session(path))
    w.select_muscle("corrugator_L")
    type_into(w.param_widgets["k0"], "4.5")
    assert w.session.dirty
    return w, path


def ctrl_s(window) -> None:
    """Trigger Save layout, the action of Ctrl+S."""
    action = menu_action(window, "File", "Save layout")
    assert action.shortcut().toString() == "Ctrl+S"
    action.trigger()


def another_writer(path) -> bytes:
    """Another program saves a change to the layout at ``path``; returns the file's bytes."""
    wv.save_layout(with_k0(wv.load_layout(path), "corrugator_R", 2.25), path)
    return path.read_bytes()


@pytest.mark.parametrize("choice", ["Cancel", "Overwrite", "Save As..."])
def test_save_asks_before_overwriting_a_change_made_by_another_program(
        opened, tmp_path, monkeypatch, answer, choice):
    w, path = opened
    theirs = another_writer(path)
    elsewhere = tmp_path / "elsewhere.json"
    monkeypatch.setattr(QtWidgets.QFileDialog, "getSaveFileName",
                        lambda *a, **k: (str(elsewhere), "Layouts (*.json)"))
    answer(choice)
    ctrl_s(w)
    assert len(answer.asked) == 1 and "changed by another program" in answer.asked[0]
    assert str(path) in answer.asked[0]
    if choice == "Cancel":  # nothing written, the edits and the modified mark stay
        assert path.read_bytes() == theirs and not elsewhere.exists()
        assert w.session.dirty and w.windowTitle().endswith("mine.json *")
        assert w.session.face.muscle("corrugator_L").k0 == 4.5
        assert w.session.layout_path == path
        return
    mine = w.session.face.muscle("corrugator_R").k0
    written = path if choice == "Overwrite" else elsewhere
    assert saved_k0(written, "corrugator_L") == 4.5
    assert saved_k0(written, "corrugator_R") == mine != 2.25
    assert not w.session.dirty and w.session.layout_path == written
    if choice == "Save As...":
        assert path.read_bytes() == theirs
    # the file as just saved is the new reference: the next Save does not ask
    type_into(w.param_widgets["k0"], "4.25")
    ctrl_s(w)
    assert len(answer.asked) == 1 and saved_k0(written, "corrugator_L") == 4.25


def test_save_does_not_ask_when_only_the_time_changed(opened, answer):
    """Same bytes with a new time (touched, or copied back): nothing to ask about."""
    w, path = opened
    st = path.stat()
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns + 5_000_000_000))
    ctrl_s(w)
    assert not answer.asked and not w.session.dirty
    assert saved_k0(path, "corrugator_L") == 4.5
    assert w.session.disk == FileStamp.of(path)  # what the app wrote, remembered


def test_a_file_deleted_meanwhile_is_written_again_and_said_so(opened, answer):
    w, path = opened
    path.unlink()
    ctrl_s(w)
    assert not answer.asked and not w.session.dirty
    assert saved_k0(path, "corrugator_L") == 4.5
    message = w.statusBar().currentMessage()
    assert "deleted" in message and str(path) in message


def test_saving_before_opening_another_layout_asks_too(opened, tmp_path, monkeypatch,
                                                       answer):
    """Save of the unsaved-changes question meets the changed file: Cancel there cancels
    the opening as well.
    """
    w, path = opened
    theirs = another_writer(path)
    answer("Save", "Cancel")
    assert not w.open_layout(tmp_path / "other.json")
    assert "unsaved changes" in answer.asked[0] and "another program" in answer.asked[1]
    assert path.read_bytes() == theirs and w.session.dirty and w.session.layout_path == path


def test_the_session_tells_a_change_by_the_bytes_not_the_time(wv_face, tmp_path):
    """Qt-free: the session's stamp sees another writer's same-size change made within the
    same clock tick (time set back), ignores a new time on the same bytes, and a save
    becomes the new reference.
    """
    path = tmp_path / "mine.json"
    wv.save_layout(Session(wv_face).layout(), path)
    s = load_session(path)
    stamp = s.disk
    assert stamp == FileStamp.of(path) and s.disk_change() is None
    text = path.read_text()
    data = json.loads(text)
    data["name"] = data["name"][:-1] + ("x" if data["name"][-1] != "x" else "y")
    path.write_text(json.dumps(data, indent=2) + "\n")
    assert path.stat().st_size == stamp.size  # the same size...
    os.utime(path, ns=(stamp.mtime_ns, stamp.mtime_ns))  # ...and the same time
    assert s.disk_change() == "changed"
    path.write_text(text)
    os.utime(path, ns=(stamp.mtime_ns + 10**9, stamp.mtime_ns + 10**9))
    assert s.disk_change() is None
    path.write_text(text + " ")
    assert s.disk_change() == "changed"
    s.save()
    assert s.disk_change() is None and s.disk == FileStamp.of(path) != stamp
    path.unlink()
    assert s.disk_change() == "deleted"
    assert Session(wv_face).disk_change() is None  # the built-in face: no file
