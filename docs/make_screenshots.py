"""Regenerate the screenshots of the user guide and README (needs a display, or Xvfb).

Usage:  xvfb-run -a .venv/bin/python docs/make_screenshots.py
"""

from pathlib import Path

from qtpy import QtCore, QtWidgets

import wrinkle_vis as wv
from wrinkle_vis.app.recovery import Recovery
from wrinkle_vis.app.session import Session
from wrinkle_vis.app.window import MainWindow
from wrinkle_vis.plotting import render_field

OUT = Path(__file__).with_name("images")
OUT.mkdir(exist_ok=True)


def settle(app, n=20):
    """Let Qt draw."""
    for _ in range(n):
        app.processEvents()


def main():
    """Write the app and field-map screenshots."""
    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication([])
    settings = QtCore.QSettings(str(OUT / ".screenshots.ini"), QtCore.QSettings.IniFormat)
    face = wv.datasets.load_face(20000)
    window = MainWindow(Session(face), settings, Recovery(OUT / ".recovery"))
    window.resize(1600, 820)
    window.show()
    settle(app)
    window.set_camera("three_quarter")
    settle(app)
    window.grab().save(str(OUT / "app_surprise.png"))
    window.expression_box.setCurrentText("frown")
    window.muscle_box.setCurrentText("corrugator_L")
    window.field_box.setCurrentText("gamma")
    window.set_camera("forehead")
    window.probe_vertex(int(window.session.state().W.argmin()))
    settle(app)
    window.grab().save(str(OUT / "app_frown_gamma.png"))
    window.expression_box.setCurrentText("smile")
    window.field_box.setCurrentText("W")
    window.select_muscle("zygomaticus_major_L")
    window.set_camera("three_quarter")
    settle(app)
    window.grab().save(str(OUT / "app_placement.png"))
    window.session.dirty = False
    window.close()
    (OUT / ".screenshots.ini").unlink(missing_ok=True)
    for expression in ("surprise", "frown", "fear"):
        render_field(face, expression, "W", camera="forehead", size=(500, 500),
                     filename=str(OUT / f"W_{expression}.png"))
    print(f"wrote screenshots to {OUT}")


if __name__ == "__main__":
    main()
