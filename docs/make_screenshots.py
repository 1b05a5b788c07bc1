"""Regenerate the screenshots of the user guide and README (needs a display, or Xvfb).

Usage:  xvfb-run -a .venv/bin/python docs/make_screenshots.py [--newface | --physical]

``--newface``: only the New-face flow's landmark step (on the Lee Perry-Smith head scan in
``../shared/realmeshes`` beside the checkout). ``--physical``: only the app playing surprise
on the physically based skin (``app_physical.png``). Under Xvfb ``window.grab()`` sees
the views only with ``WRINKLE_VIS_VIEW=qopenglwidget`` (native VTK windows grab black).
"""

import sys
import time
import warnings
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


SCAN = Path(__file__).resolve().parents[2] / "shared" / "realmeshes" / "lee_perry_smith_head.obj"
#: The head scan's landmarks (metres, its own frame), as tests/test_app_newface.py clicks them.
SCAN_MARKS = {"nasion": (-0.000569, 0.006743, 0.029338),
              "nose_tip": (0.000836, -0.036339, 0.053476),
              "chin": (-0.002425, -0.10469, 0.036819),
              "eye_inner_L": (0.019274, -0.004529, 0.015423)}


def newface_screenshot(app, settings):
    """File > New face from mesh... on the head scan, four landmarks placed, the fifth
    asked for: ``app_newface.png``.
    """
    if not SCAN.exists():
        print(f"no {SCAN}: app_newface.png not made")
        return
    window = MainWindow(Session(wv.datasets.load_face()), settings, Recovery(OUT / ".recovery"))
    window.resize(1600, 820)
    window.show()
    settle(app)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        window.newface.start(SCAN)
    window.skin_view.camera.zoom(1.8)  # closer to the face, as one picks
    for point in SCAN_MARKS.values():
        window.newface.place(point)
    settle(app)
    window.grab().save(str(OUT / "app_newface.png"))
    window.newface.cancel()
    window.session.dirty = False
    window.close()


def physical_screenshot(app, settings, at_s: float = 0.8):
    """The physically based skin playing surprise at the paper's size, grabbed while Play
    runs the simulation in real time, once it has simulated ``at_s`` seconds (the forehead
    furrows forming): ``app_physical.png``.
    """
    window = MainWindow(Session(wv.datasets.load_face()), settings,
                        Recovery(OUT / ".recovery"))
    window.resize(1600, 820)
    window.show()
    settle(app)
    window.skin_box.setCurrentText("physical")
    window.set_camera("forehead")
    window.time_slider.setValue(0)
    window.play_button.setChecked(True)
    deadline = time.perf_counter() + 60.0
    while (window.session.physics.time or 0.0) < at_s and time.perf_counter() < deadline:
        app.processEvents(QtCore.QEventLoop.AllEvents, 10)
    app.processEvents()  # still playing
    window.grab().save(str(OUT / "app_physical.png"))
    print(f"app_physical.png: simulated {window.session.physics.time:.3f} s, status "
          f"{window.status_label.text()!r}")
    window.play_button.setChecked(False)
    window.session.dirty = False
    window.close()


def main():
    """Write the app and field-map screenshots."""
    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication([])
    settings = QtCore.QSettings(str(OUT / ".screenshots.ini"), QtCore.QSettings.IniFormat)
    if "--physical" in sys.argv:
        physical_screenshot(app, settings)
        (OUT / ".screenshots.ini").unlink(missing_ok=True)
        return
    newface_screenshot(app, settings)
    if "--newface" in sys.argv:
        (OUT / ".screenshots.ini").unlink(missing_ok=True)
        return
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
    window.clear_probe()  # the frown's probe is not the placement's
    window.expression_box.setCurrentText("smile")
    window.field_box.setCurrentText("W")
    window.select_muscle("zygomaticus_major_L")
    window.set_camera("three_quarter")
    settle(app)
    window.grab().save(str(OUT / "app_placement.png"))
    window.session.dirty = False
    window.close()
    physical_screenshot(app, settings)
    (OUT / ".screenshots.ini").unlink(missing_ok=True)
    for expression in ("surprise", "frown", "fear"):
        render_field(face, expression, "W", camera="forehead", size=(500, 500),
                     filename=str(OUT / f"W_{expression}.png"))
    print(f"wrote screenshots to {OUT}")


if __name__ == "__main__":
    main()
