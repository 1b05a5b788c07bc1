"""A placement handle dragged in the app's main window (needs a display or Xvfb).

Run:  xvfb-run -a .venv/bin/python benchmarks/bench_app_drag.py [--runs 5] [--steps 40]
      [--skin-model geometric,physical]

``bench_drag.py`` times the drag loop on off-screen views with no window; this one drives
the real window: the muscle is selected in it, and each step is a MouseMoveEvent on the
skin view's interactor while the insertion handle is held, which goes through the
window's handler (the muscle moved, the face re-evaluated, the views redrawn and
rendered) and then Qt's event loop until it is idle (a frame the window defers to the
loop is counted). Prints the median over ``--runs`` runs of the median step time, as
updates per second. Works on any version of the app's window (the code before its split
included), so the two can be timed side by side. ``--skin-model``: the skin models to drag
on (the window's *Skin* box), comma-separated, each in the same run (the face shows the
session's expression, surprise at its peak).
"""

import argparse
import os
import statistics
import sys
import time

import numpy as np
from _app import bench_window

MUSCLE = "frontalis_major_L"


def drag_times(app, window, steps: int) -> list[float]:
    """Seconds of each of ``steps`` moves of one drag of the muscle's first skin handle."""
    widget = window.placement
    handle = next(h for h in widget.handles(widget.muscle) if h.layer == "skin")
    view = window.skin_view
    renderer = view.renderer
    renderer.SetWorldPoint(*widget.position(handle), 1.0)
    renderer.WorldToDisplay()
    x0, y0, _ = renderer.GetDisplayPoint()
    iren = view.iren.interactor

    def event(name, x, y):
        iren.SetEventInformation(int(round(x)), int(round(y)))
        iren.InvokeEvent(name)

    event("MouseMoveEvent", x0, y0)
    event("LeftButtonPressEvent", x0, y0)
    times = []
    for k in range(steps):  # a slow circle of 12 pixels around the start
        t = 2 * np.pi * k / steps
        t0 = time.perf_counter()
        event("MouseMoveEvent", x0 + 12 * np.sin(t), y0 + 12 * (1 - np.cos(t)))
        app.processEvents()
        times.append(time.perf_counter() - t0)
    event("LeftButtonReleaseEvent", x0, y0)
    app.processEvents()
    return times


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--steps", type=int, default=40)
    parser.add_argument("--triangles", type=int, default=4500)
    parser.add_argument("--skin-model", default="geometric",
                        help="comma-separated skin models, each dragged in the same run")
    args = parser.parse_args()
    app, window = bench_window(args.triangles, "drag")
    face = window.session.face
    window.select_muscle(MUSCLE)
    window.set_camera("forehead")
    for _ in range(5):
        app.processEvents()
    for skin in args.skin_model.split(","):
        if skin != window.session.face.skin_model:
            window.skin_box.setCurrentText(skin)
            for _ in range(5):
                app.processEvents()
            if window.session.face.skin_model != skin:
                parser.error(f"unknown skin model {skin!r}; choose geometric or physical")
        undo_before = window.undo_stack.count()
        before = window.session.face.muscle(MUSCLE)
        drag_times(app, window, 5)  # warm-up
        cpu0 = time.process_time()
        medians = [statistics.median(drag_times(app, window, args.steps))
                   for _ in range(args.runs)]
        cpu = (time.process_time() - cpu0) / (args.runs * args.steps)
        moved = window.session.face.muscle(MUSCLE) != before
        undo_steps = window.undo_stack.count() - undo_before
        if not moved:
            raise RuntimeError("the drag did not move the muscle: the benchmark is broken")
        ms = 1e3 * statistics.median(medians)
        print(f"window drag, {face.skin.n_triangles} triangles, {skin} skin: "
              f"{1e3 / ms:.1f} updates/s ({ms:.1f} ms a move, {1e3 * cpu:.1f} ms CPU; runs "
              f"{', '.join(f'{1e3 * m:.1f}' for m in medians)} ms; {undo_steps} undo steps "
              f"for {args.runs + 1} drags); load average {os.getloadavg()[0]:.2f} on "
              f"{os.cpu_count()} cores")
    window.session.dirty = False
    window.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
