"""Shared test set-up: nothing a test does may write into the user's home."""

import gc

import pytest
from qtpy import QtCore

from wrinkle_vis.app.recovery import Recovery
from wrinkle_vis.app.session import Session


@pytest.fixture(autouse=True)
def private_recovery_dir(tmp_path, monkeypatch):
    """The app's autosave folder, private to each test."""
    monkeypatch.setenv("WRINKLE_VIS_RECOVERY_DIR", str(tmp_path / "recovery-default"))


# ---------------------------------------------------------------------- the Qt app
@pytest.fixture
def no_leaked_plotters():
    """Like pyvistaqt's leak check: a test must close every plotter it opens."""
    from pyvista.plotting.plotter import _ALL_PLOTTERS

    before = {k for k, p in _ALL_PLOTTERS.items() if not p._closed}
    yield
    gc.collect()
    leaked = [k for k, p in _ALL_PLOTTERS.items() if not p._closed and k not in before]
    assert not leaked, f"plotters left open: {leaked}"


@pytest.fixture
def settings(tmp_path):
    """A private QSettings file (recent files, anti-aliasing)."""
    return QtCore.QSettings(str(tmp_path / "settings.ini"), QtCore.QSettings.IniFormat)


@pytest.fixture
def recovery(tmp_path):
    """A private recovery folder."""
    return Recovery(tmp_path / "recovery")


@pytest.fixture
def window(qtbot, wv_face, settings, recovery):
    """The main window on the built-in face, shown; closed after the test, changes
    discarded.
    """
    from wrinkle_vis.app.window import MainWindow

    w = MainWindow(Session(wv_face), settings, recovery)
    qtbot.addWidget(w, before_close_func=_discard_changes)
    w.show()
    qtbot.waitExposed(w)
    return w


def _discard_changes(w):
    w.session.dirty = False


def skin_mesh(window):
    """The mesh the skin view draws."""
    return window.skin_view.actors["skin"].mapper.dataset
