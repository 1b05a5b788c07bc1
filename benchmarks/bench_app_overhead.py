"""The app's own cost per frame, without the renders (needs a display or Xvfb).

Run:  xvfb-run -a .venv/bin/python benchmarks/bench_app_overhead.py [--steps 200] [--runs 5]

A main window on the built-in face moves its timeline one position at a time, as Play
does; the views' renders are replaced by nothing, so what is timed is the window's work
for a frame: the control's signal, the models' events, the evaluation, writing the frame
into the drawn meshes, the status line, and Qt's event loop until it is idle (the app
draws a frame at the next turn of the loop). The renders, 30 to 80 ms a frame in software
under Xvfb and the noisiest part of ``bench_app_playback.py``, are left out so that two
versions of the window can be compared on a loaded machine. Works on any version of the
window (the code before its split included). Prints the median over ``--runs`` runs of
the median step time.
"""

import argparse
import os
import statistics
import sys
import time

from _app import bench_window


def step_times(app, window, steps: int) -> list[float]:
    """Seconds of each of ``steps`` moves of the timeline by one position."""
    slider = window.time_slider
    times = []
    for k in range(steps):
        t0 = time.perf_counter()
        slider.setValue((slider.value() + 1) % (slider.maximum() + 1) if k else 0)
        app.processEvents()
        times.append(time.perf_counter() - t0)
    return times


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--triangles", type=int, default=4500)
    parser.add_argument("--muscle", default="frontalis_major_L",
                        help="the muscle selected (its placement widget follows each frame)")
    args = parser.parse_args()
    app, window = bench_window(args.triangles, "overhead")
    face = window.session.face
    if args.muscle:
        window.select_muscle(args.muscle)
    for _ in range(5):
        app.processEvents()
    views = window.views
    views.render = lambda *a, **k: None  # the renders are not timed
    step_times(app, window, 20)  # warm-up
    medians = [statistics.median(step_times(app, window, args.steps))
               for _ in range(args.runs)]
    window.session.dirty = False
    window.close()
    ms = 1e3 * statistics.median(medians)
    print(f"window frame without renders, {face.skin.n_triangles} triangles, muscle "
          f"{args.muscle or 'none'}: {ms:.2f} ms (runs "
          f"{', '.join(f'{1e3 * m:.2f}' for m in medians)}); load average "
          f"{os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    return 0


if __name__ == "__main__":
    sys.exit(main())
