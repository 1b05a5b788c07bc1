"""Redraw time of the app's three views, on the built-in face (needs a display or Xvfb).

Run:  xvfb-run -a .venv/bin/python benchmarks/bench_app_redraw.py [--triangles 4500]

Measures, as medians of 20 changes each: an intensity change (activations only: the drawn
meshes are updated in place) and a field change (the scenes are rebuilt). Both include the
evaluation and the rendering of all three views.

``--overlays R``: also the intensity change with the muscle selected, its placement
overlays (the AOI and region outlines, the AOI volumes) kept and moved with the skin as the
app does, beside the peer that rebuilds them every frame (the code before issue 28), in
``R`` interleaved rounds: the whole change and ``LinkedViews.draw`` alone (medians; the
latter also in CPU time, which a loaded machine's waits for a core do not inflate).
"""

import argparse
import os
import statistics
import time

import numpy as np
from _timing import median_seconds
from qtpy import QtCore, QtWidgets

import wrinkle_vis as wv
from wrinkle_vis.app.session import Session
from wrinkle_vis.app.window import MainWindow
from wrinkle_vis.widgets import PlacementWidget, boundary_lines
from wrinkle_vis.widgets.placement import COLORS


def timed(app, change, n=20):
    """Median milliseconds of ``n`` changes, each with the redraw it causes."""
    calls = iter(range(n))

    def one():
        change(next(calls))
        app.processEvents()

    return 1e3 * median_seconds(one, n, 1)


def rebuilt_overlays(self) -> None:
    """The peer: the placement overlays found anew every frame (before issue 28)."""
    face = self.state.face
    data = face.muscle_data(self.muscle)
    lines = {}
    lift = self.state.points + 0.4 * self.state.normals
    for kind, ids in (("aoi", data.aoi), ("region", data.region)):
        mask = np.zeros(self.state.n_points, dtype=bool)
        mask[ids] = True
        lines[kind] = boundary_lines(face.skin, mask, lift)
    for view in ("skin", "muscles"):
        for kind, mesh in lines.items():
            self._overlay(view, f"widget:{kind}", mesh, color=COLORS[kind], line_width=3)
    for name, mesh in self.aoi_meshes(self.muscle).items():
        self._overlay("muscles", f"widget:{name}", mesh, color=COLORS["aoi"],
                      style="wireframe", line_width=1.5)


def overlays(app, window, rounds: int) -> None:
    """The intensity change with the muscle selected, overlays kept vs rebuilt."""
    kept = PlacementWidget._draw_overlays
    draw = window.views.draw
    spent: list[float] = []
    cpu: list[float] = []

    def timed_draw(*args, **kwargs):
        t0, c0 = time.perf_counter(), time.process_time()
        draw(*args, **kwargs)
        spent.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)

    window.views.draw = timed_draw
    results: dict[str, dict[str, list[float]]] = {w: {"change": [], "draw": [], "cpu": []}
                                                  for w in ("kept", "rebuilt")}
    step = 0
    for _ in range(rounds):
        for way, method in (("kept", kept), ("rebuilt", rebuilt_overlays)):
            PlacementWidget._draw_overlays = method
            spent.clear()
            cpu.clear()
            results[way]["change"].append(timed(
                app, lambda i, s=step: window.intensity_slider.setValue(30 + (s + i) % 60)))
            results[way]["draw"].append(1e3 * statistics.median(spent))
            results[way]["cpu"].append(1e3 * statistics.median(cpu))
            step += 20
    PlacementWidget._draw_overlays = kept
    window.views.draw = draw
    for way, r in results.items():
        print(f"  overlays {way:7s}: intensity change {statistics.median(r['change']):.1f} ms,"
              f" LinkedViews.draw {statistics.median(r['draw']):.2f} ms "
              f"({statistics.median(r['cpu']):.2f} ms CPU)")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--triangles", type=int, default=4500)
    parser.add_argument("--overlays", type=int, default=0, metavar="ROUNDS")
    args = parser.parse_args()
    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication([])
    settings = QtCore.QSettings(QtCore.QSettings.IniFormat, QtCore.QSettings.UserScope,
                                "wrinkle-vis-bench", "redraw")
    face = wv.datasets.load_face(args.triangles).with_skin_model("geometric")
    window = MainWindow(Session(face), settings)
    window.resize(1500, 800)
    window.show()
    for _ in range(10):
        app.processEvents()
    window.muscle_box.setCurrentText("frontalis_major_L")
    fields = ["eps", "W", "gamma", "At"]
    in_place = timed(app, lambda i: window.intensity_slider.setValue(40 + i))
    rebuild = timed(app, lambda i: window.field_box.setCurrentText(fields[i % len(fields)]))
    print(f"{window.session.face.skin.n_triangles} triangles: intensity change "
          f"{in_place:.1f} ms (in place), field change {rebuild:.1f} ms (rebuild); "
          f"load average {os.getloadavg()[0]:.2f}")
    if args.overlays:
        overlays(app, window, args.overlays)
    window.session.dirty = False
    window.close()


if __name__ == "__main__":
    main()
