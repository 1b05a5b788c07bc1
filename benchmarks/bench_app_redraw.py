"""Redraw time of the app's three views, on the built-in face (needs a display or Xvfb).

Run:  xvfb-run -a .venv/bin/python benchmarks/bench_app_redraw.py [--triangles 4500]

Measures, as medians of 20 changes each: an intensity change (activations only: the drawn
meshes are updated in place) and a field change (the scenes are rebuilt). Both include the
evaluation and the rendering of all three views.
"""

import argparse

from _timing import median_seconds
from qtpy import QtCore, QtWidgets

import wrinkle_vis as wv
from wrinkle_vis.app.session import Session
from wrinkle_vis.app.window import MainWindow


def timed(app, change, n=20):
    """Median milliseconds of ``n`` changes, each with the redraw it causes."""
    calls = iter(range(n))

    def one():
        change(next(calls))
        app.processEvents()

    return 1e3 * median_seconds(one, n, 1)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--triangles", type=int, default=4500)
    args = parser.parse_args()
    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication([])
    settings = QtCore.QSettings(QtCore.QSettings.IniFormat, QtCore.QSettings.UserScope,
                                "wrinkle-vis-bench", "redraw")
    window = MainWindow(Session(wv.datasets.load_face(args.triangles)), settings)
    window.resize(1500, 800)
    window.show()
    for _ in range(10):
        app.processEvents()
    window.muscle_box.setCurrentText("frontalis_major_L")
    fields = ["eps", "W", "gamma", "At"]
    in_place = timed(app, lambda i: window.intensity_slider.setValue(40 + i))
    rebuild = timed(app, lambda i: window.field_box.setCurrentText(fields[i % len(fields)]))
    print(f"{window.session.face.skin.n_triangles} triangles: intensity change "
          f"{in_place:.1f} ms (in place), field change {rebuild:.1f} ms (rebuild)")
    window.session.dirty = False
    window.close()


if __name__ == "__main__":
    main()
