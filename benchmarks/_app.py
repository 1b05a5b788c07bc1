"""A main window for the app benchmarks: the built-in face at a size, shown at 1500x800
with its own settings file (the user's settings are not touched)."""

from __future__ import annotations

import sys

from qtpy import QtCore, QtWidgets

import wrinkle_vis as wv
from wrinkle_vis.app.session import Session
from wrinkle_vis.app.window import MainWindow


def bench_window(triangles: int, name: str) -> tuple[QtWidgets.QApplication, MainWindow]:
    """``(app, window)``: a shown :class:`MainWindow` on the built-in face of ``triangles``
    triangles on the geometric skin (the figures in docs/benchmarks.md were taken on it; a
    benchmark switches to the physical one itself), its settings under
    ``wrinkle-vis-bench/name``, after ten event-loop turns.
    """
    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication(sys.argv[:1])
    settings = QtCore.QSettings(QtCore.QSettings.IniFormat, QtCore.QSettings.UserScope,
                                "wrinkle-vis-bench", name)
    face = wv.datasets.load_face(triangles).with_skin_model("geometric")
    window = MainWindow(Session(face), settings)
    window.resize(1500, 800)
    window.show()
    for _ in range(10):
        app.processEvents()
    return app, window
