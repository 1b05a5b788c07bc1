"""Shared test set-up: nothing a test does may write into the user's home, and every
window and plotter a test makes is closed and freed.

Importing this file imports neither Qt nor PyVista nor the app: a test of the model pays for
them only when it uses them (the Qt fixtures import Qt when they are set up). pytest-qt
itself imports Qt, and pytest-pyvista PyVista, when pytest starts; ``pytest -p no:pytest-qt
-p no:pyvista -p no:xvfb`` runs the core's test files without them
(tests/test_layers.py::CORE_TESTS).
"""

import gc
import os
import sys
import tempfile
import weakref
from pathlib import Path

import numpy as np
import pytest


def pytest_configure(config):
    """Built faces and skulls are cached in pytest's cache folder (kept between runs, in the
    repository's ``.pytest_cache``), never in ``~/.cache/wrinkle-vis``: set before any test
    module is imported, and inherited by the processes the tests start. A test that wants
    another folder sets ``WRINKLE_VIS_CACHE`` itself.
    """
    cache = config.cache.mkdir("wrinkle-vis") if getattr(config, "cache", None) else \
        tempfile.mkdtemp(prefix="wrinkle-vis-cache-")
    os.environ["WRINKLE_VIS_CACHE"] = str(cache)


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item, call):
    """Keep each phase's report on the test, for the leak check (skipped after a failure,
    whose traceback holds the test's frames and what they reference).
    """
    report = yield
    setattr(item, f"report_{report.when}", report)
    return report


#: The fixtures through which a test gets a Qt application (and so may build windows).
QT_FIXTURES = {"qapp", "qtbot"}
PLOTTERS = "pyvista.plotting.plotter"


@pytest.fixture(autouse=True)
def no_leaks(request):
    """Every main window and every PyVista plotter a test builds is freed once the test
    is over: closed (by the test, or by pytest-qt for the widgets it was given), its last
    reference gone and the garbage collected, its weak reference is dead, without any
    deferred delete. Set up before every other fixture (it must not use monkeypatch), so
    that it checks after they are all torn down.

    Windows are watched in tests that use a Qt fixture (or when the app's window module is
    loaded already); plotters once PyVista is loaded. A test that loads PyVista itself
    is checked for plotters it left open (a closed one it still holds is not seen).
    """
    made = []
    window_module = None
    if QT_FIXTURES & set(request.fixturenames) or "wrinkle_vis.app.window" in sys.modules:
        from wrinkle_vis.app import window as window_module
    plotter_module = sys.modules.get(PLOTTERS)
    if window_module is not None:
        original_init = window_module.MainWindow.__init__

        def recording_init(self, *args, **kwargs):
            made.append((type(self).__name__, weakref.ref(self)))
            original_init(self, *args, **kwargs)

        window_module.MainWindow.__init__ = recording_init

    class Recording(dict):
        def __setitem__(self, key, plotter):
            made.append((f"{type(plotter).__name__} {key}", weakref.ref(plotter)))
            super().__setitem__(key, plotter)

    if plotter_module is not None:
        original_plotters = plotter_module._ALL_PLOTTERS
        plotter_module._ALL_PLOTTERS = Recording(original_plotters)
    try:
        yield
    finally:
        if window_module is not None:
            window_module.MainWindow.__init__ = original_init
        if plotter_module is not None:
            recorded = plotter_module._ALL_PLOTTERS
            plotter_module._ALL_PLOTTERS = original_plotters
            original_plotters.clear()
            original_plotters.update(recorded)
        elif PLOTTERS in sys.modules:  # loaded by the test: the plotters it made are here
            made += [(f"{type(p).__name__} {key}", weakref.ref(p))
                     for key, p in sys.modules[PLOTTERS]._ALL_PLOTTERS.items()]
    call = getattr(request.node, "report_call", None)
    if made and call is not None and call.passed:
        request.node.funcargs.clear()  # the test's arguments: pytest drops them right after
        gc.collect()
        alive = [name for name, ref in made if ref() is not None]
        assert not alive, (
            f"still alive after the test, closed and collected: {alive} (build windows "
            "with the make_window fixture: qtbot.addWidget's deleteLater would hide a leak)")


@pytest.fixture(autouse=True)
def private_recovery_dir(tmp_path, monkeypatch):
    """The app's autosave folder, private to each test."""
    monkeypatch.setenv("WRINKLE_VIS_RECOVERY_DIR", str(tmp_path / "recovery-default"))


# ---------------------------------------------------------------------- faces
@pytest.fixture(scope="session")
def wv_head():
    """The built-in scanned head (``load_face("lee_perry_smith")``), loaded once for the
    session, as the plug-in's ``wv_face`` is the procedural face. Test modules take their
    own face object from it, ``wv_head.with_skin_model(wv_head.skin_model)``, which shares
    its caches: what the head builds once (the physical skin's factorization and skull
    contact, the fold guard's rest radii and bounds, the refinement hierarchy, the muscles'
    rest data; 5-10 s on 2 cores) is built once per session instead of once per module.
    Every frame is still bit for bit a fresh face's (physical still frames start from the
    rest skin unless ``warm_start``); a test about what a fresh face builds loads its own.
    """
    from wrinkle_vis.datasets import load_face

    return load_face("lee_perry_smith")


@pytest.fixture(scope="session")
def procedural_at():
    """``procedural_at(n_triangles)``: the procedural face at that size (20,000 or 60,000
    triangles, which several modules use), loaded once for the session; each call gives a
    face object sharing its caches (the 60k physical skin's factorization, its muscles'
    rest data), as with :func:`wv_head`.
    """
    from wrinkle_vis.datasets import load_face

    faces: dict = {}

    def get(n_triangles: int):
        if n_triangles not in (20000, 60000):
            raise ValueError("procedural_at keeps the 20k and 60k faces only")
        if n_triangles not in faces:
            faces[n_triangles] = load_face(n_triangles)
        face = faces[n_triangles]
        return face.with_skin_model(face.skin_model)

    return get


#: The head scan (test data beside the checkout: ``../shared/realmeshes``).
SCAN_HEAD = Path(__file__).resolve().parents[2] / "shared" / "realmeshes" / \
    "lee_perry_smith_head.obj"


@pytest.fixture(scope="session")
def example_scan():
    """The head scan with the example layout (``load_face(skin=SCAN_HEAD, layout=<the
    example>)``), loaded once for the session; modules take a face object sharing its
    caches (``example_scan.with_skin_model(example_scan.skin_model)``), as with
    :func:`wv_head`. Skips where the scan is not there.
    """
    if not SCAN_HEAD.exists():
        pytest.skip("../shared/realmeshes is not here")
    import wrinkle_vis as wv

    example = Path(wv.datasets.__file__).with_name("examples") / "lee_perry_smith.json"
    return wv.datasets.load_face(skin=SCAN_HEAD, layout=example)


def assert_same_face(a, b, expression: str = "surprise") -> None:
    """Faces ``a`` and ``b`` are the same: skin, skull, muscles, landmarks, unit and
    expressions equal, and ``expression`` evaluates to the same points and W bit for bit.
    """
    np.testing.assert_array_equal(a.skin.points, b.skin.points)
    np.testing.assert_array_equal(a.skin.triangles, b.skin.triangles)
    assert (a.skull is None) == (b.skull is None)
    if a.skull is not None:
        np.testing.assert_array_equal(a.skull.points, b.skull.points)
        np.testing.assert_array_equal(a.skull.triangles, b.skull.triangles)
    assert [m.to_dict() for m in a.muscles] == [m.to_dict() for m in b.muscles]
    assert a.landmarks == b.landmarks and a.unit == b.unit
    assert {k: e.to_dict() for k, e in a.expressions.items()} == \
        {k: e.to_dict() for k, e in b.expressions.items()}
    sa, sb = a.evaluate(expression), b.evaluate(expression)
    assert np.array_equal(sa.W, sb.W) and np.array_equal(sa.points, sb.points)


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
    from qtpy import QtCore

    return QtCore.QSettings(str(tmp_path / "settings.ini"), QtCore.QSettings.IniFormat)


@pytest.fixture
def recovery(tmp_path):
    """A private recovery folder."""
    from wrinkle_vis.app.recovery import Recovery

    return Recovery(tmp_path / "recovery")


@pytest.fixture
def make_window(qtbot, wv_face, settings, recovery):
    """``make_window(session=None, recovery=None, show=True)``: a main window (default on
    the built-in face, with the test's settings and recovery folder), closed after the
    test with its changes discarded. Closed only, never deleteLater'd (as pytest-qt's
    ``addWidget`` does), so that the leak check sees closing alone free it.
    """
    from wrinkle_vis.app.session import Session
    from wrinkle_vis.app.window import MainWindow

    made = []
    stray = StrayDialogs()

    def make(session=None, recovery_=None, show=True, **kwargs):
        w = MainWindow(session or Session(wv_face), settings, recovery_ or recovery, **kwargs)
        made.append(weakref.ref(w))
        if show:
            w.show()
            qtbot.waitUntil(w.isVisible)
        return w

    yield make
    stray.timer.stop()
    for ref in made:
        w = ref()
        if w is not None and not all(p._closed for p in w.plotters):
            _discard_changes(w)
            w.close()
        del w
    assert not stray.closed, f"unexpected modal dialogs (closed so the test could end): " \
        f"{stray.closed}"


class StrayDialogs:
    """Closes a modal dialog nobody answers (no :func:`answer` queued for it) after about
    three seconds and keeps its text, so a test that meets one fails instead of hanging.
    """

    def __init__(self):
        from qtpy import QtCore

        self.closed: list[str] = []
        self._seen = None
        self._ticks = 0
        self.timer = QtCore.QTimer()
        self.timer.setInterval(1000)
        self.timer.timeout.connect(self._poll)
        self.timer.start()

    def _poll(self) -> None:
        from qtpy import QtWidgets

        dialog = QtWidgets.QApplication.activeModalWidget()
        if dialog is None or not dialog.isVisible():
            self._seen, self._ticks = None, 0
            return
        self._ticks = self._ticks + 1 if dialog is self._seen else 1
        self._seen = dialog
        if self._ticks >= 3:
            self.closed.append(dialog.text() if isinstance(dialog, QtWidgets.QMessageBox)
                               else dialog.windowTitle())
            dialog.reject()
            self._seen, self._ticks = None, 0


@pytest.fixture
def window(make_window):
    """The main window on the built-in face, shown; closed after the test, changes
    discarded.
    """
    return make_window()


def _discard_changes(w):
    w.session.dirty = False


def skin_mesh(window):
    """The mesh the skin view draws (the frame is drawn first if a change is pending: the
    app draws once per event-loop turn).
    """
    window.frames.flush()
    return window.skin_view.actors["skin"].mapper.dataset


class DialogAnswers:
    """Answers the modal dialogs the app opens, in order, by clicking the real button
    with the given text (a timer looks for the active modal dialog), and keeps the text
    of each dialog it answered in :attr:`asked`.
    """

    def __init__(self):
        from qtpy import QtCore

        self.answers: list = []
        self.asked: list[str] = []
        self.timer = QtCore.QTimer()
        self.timer.setInterval(20)
        self.timer.timeout.connect(self._poll)

    def __call__(self, *answers) -> "DialogAnswers":
        """Queue answers: a button's text, or a function of the dialog that answers it."""
        self.answers.extend(answers)
        self.timer.start()
        return self

    def _poll(self) -> None:
        from qtpy import QtWidgets

        dialog = QtWidgets.QApplication.activeModalWidget()
        if dialog is None or not dialog.isVisible() or not self.answers:
            return
        answer = self.answers.pop(0)
        self.asked.append(dialog.text() if isinstance(dialog, QtWidgets.QMessageBox)
                          else dialog.windowTitle())
        if callable(answer):
            answer(dialog)
            return
        buttons = dialog.findChildren(QtWidgets.QAbstractButton)
        matching = [b for b in buttons if b.text().replace("&", "") == answer]
        if not matching:
            dialog.reject()  # or the test would hang on it
            raise AssertionError(f"no button {answer!r} in {self.asked[-1]!r}: "
                                 f"{[b.text() for b in buttons]}")
        matching[0].click()


@pytest.fixture
def answer(qapp):
    """``answer("Discard", "Save", ...)``: click these buttons of the next modal dialogs
    (see :class:`DialogAnswers`); every queued answer must have been used.
    """
    answers = DialogAnswers()
    yield answers
    answers.timer.stop()
    assert not answers.answers, f"dialogs never asked: {answers.answers}"


def bumpy_sheets(n: int, bump: float, gap: float, shift: float = 0.0):
    """Two bumpy ``n`` x ``n`` grid sheets of unit spacing, the second ``gap`` above the
    first (lips, a fold's two sides) and ``shift`` along x and y (its vertices over the
    first's cells: a triangle then comes nearer a vertex across than any vertex does):
    their points and triangles (normals along +z)."""
    i, j = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float), indexing="ij")
    z = bump * np.sin(0.7 * i) * np.cos(0.5 * j)
    one = np.stack([i.ravel(), j.ravel(), z.ravel()], axis=1)
    v = (np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None, :]).ravel()
    tri = np.concatenate([np.stack([v, v + n, v + 1], 1), np.stack([v + 1, v + n, v + n + 1], 1)])
    return np.vstack([one, one + [shift, shift, gap]]), np.vstack([tri, tri + n * n])


def smooth_move(rng, rest, amp: float, k: float, w: float):
    """A random smooth move of the skin ``rest`` ``(n, 3)`` (one sine wave of wave number
    ``k`` along a random direction, amplitude ``amp`` along another) and a random W
    ``(n,)`` in ``[-w, w]``, a fifth of it 0: the deformed skin and W."""
    kv = rng.normal(size=3)
    kv *= k / np.linalg.norm(kv)
    u = amp * rng.normal(size=3)[None, :] * np.sin(rest @ kv + rng.uniform(0, 6.3))[:, None]
    W = rng.uniform(-w, w, len(rest))
    W[rng.uniform(size=len(rest)) < 0.2] = 0.0
    return rest + u, W
