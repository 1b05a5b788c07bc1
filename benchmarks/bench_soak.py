"""Soak test of the app's memory: open/close cycles of the main window and a long animation.

Run:  xvfb-run -a .venv/bin/python benchmarks/bench_soak.py [--cycles 30] [--frames 10000]

1. ``--cycles`` times: a main window on the built-in face is opened, used (a muscle selected,
   a parameter edited and undone, a vertex probed, the timeline played a few frames, the
   shortcuts shown) and closed, with no deferred delete; the resident memory (RSS) after
   each close.
2. ``--frames`` frames of the expression's ramp in one window: the session's timeline ticks
   as Play does and the three views redraw each frame; the RSS every 500 frames.

Resident memory should stay flat after a warm-up (the first 5 cycles, the first 1,000
frames): the growth after it is printed and must be at most ``--limit-mb`` (50 MB), or the
script exits with status 1.
"""

import argparse
import gc
import os
import sys
import tempfile
import time
import weakref

from qtpy import QtCore, QtWidgets

import wrinkle_vis as wv
from wrinkle_vis.app.recovery import Recovery
from wrinkle_vis.app.session import Session
from wrinkle_vis.app.window import MainWindow

WARM_CYCLES, WARM_FRAMES, EVERY = 5, 1000, 500


def rss_mb() -> float:
    """This process's resident memory, MB."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def spin(app, n: int = 3) -> None:
    for _ in range(n):
        app.processEvents()


def one_cycle(app, face, settings, recovery) -> bool:
    """Open a window, use it, close it; returns whether it was freed."""
    window = MainWindow(Session(face), settings, recovery)
    window.show()
    spin(app)
    window.select_muscle("zygomaticus_major_L")
    window.param_widgets["k0"].setValue(2.5)
    window.undo_stack.undo()
    window.probe_vertex(100)
    for _ in range(5):
        window._tick()
        spin(app, 1)
    window.show_shortcuts()
    ref = weakref.ref(window)
    window.close()
    del window
    spin(app)
    gc.collect()
    return ref() is None


def growth(samples: list[float], warm: int) -> float:
    """How far the RSS rose after the warm-up: the largest sample after it minus the one
    at its end.
    """
    return max(samples[warm:]) - samples[warm - 1]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=30)
    parser.add_argument("--frames", type=int, default=10000)
    parser.add_argument("--limit-mb", type=float, default=50.0)
    args = parser.parse_args()
    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication(sys.argv[:1])
    face = wv.datasets.load_face()
    ok = True
    with tempfile.TemporaryDirectory() as tmp:
        settings = QtCore.QSettings(os.path.join(tmp, "settings.ini"),
                                    QtCore.QSettings.IniFormat)
        recovery = Recovery(os.path.join(tmp, "recovery"))
        print(f"start: RSS {rss_mb():.0f} MB")

        rss, freed = [], 0
        t0 = time.perf_counter()
        for i in range(args.cycles):
            freed += one_cycle(app, face, settings, recovery)
            rss.append(rss_mb())
            print(f"cycle {i + 1:3d}: RSS {rss[-1]:7.1f} MB", flush=True)
        if args.cycles > WARM_CYCLES:
            up = growth(rss, WARM_CYCLES)
            ok &= up <= args.limit_mb and freed == args.cycles
            print(f"{args.cycles} open/close cycles in {time.perf_counter() - t0:.0f} s: "
                  f"{freed} windows freed; RSS {rss[0]:.1f} MB after the first, "
                  f"{rss[WARM_CYCLES - 1]:.1f} MB after the warm-up, {rss[-1]:.1f} MB "
                  f"after the last; growth after the warm-up {up:+.1f} MB "
                  f"(limit {args.limit_mb:g})")

        if args.frames:
            window = MainWindow(Session(face), settings, recovery)
            window.show()
            spin(app)
            samples = []
            t0 = time.perf_counter()
            for frame in range(1, args.frames + 1):
                window._tick()  # what the Play timer does: the timeline moves, all redraw
                app.processEvents()
                if frame % EVERY == 0:
                    samples.append(rss_mb())
                    print(f"frame {frame:6d}: RSS {samples[-1]:7.1f} MB, "
                          f"{1e3 * (time.perf_counter() - t0) / frame:.1f} ms a frame",
                          flush=True)
            seconds = time.perf_counter() - t0
            window.close()
            del window
            gc.collect()
            warm = WARM_FRAMES // EVERY
            if len(samples) > warm:
                up = growth(samples, warm)
                ok &= up <= args.limit_mb
                print(f"{args.frames} frames in {seconds:.0f} s "
                      f"({1e3 * seconds / args.frames:.1f} ms a frame): RSS "
                      f"{samples[warm - 1]:.1f} MB after {WARM_FRAMES} frames, "
                      f"{samples[-1]:.1f} MB at the end; growth after the warm-up "
                      f"{up:+.1f} MB (limit {args.limit_mb:g})")
    print("flat" if ok else "NOT FLAT")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
