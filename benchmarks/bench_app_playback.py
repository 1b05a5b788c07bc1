"""Timeline playback of the app (the Play button) with refinement off and on (needs a display
or Xvfb).

Run:  xvfb-run -a .venv/bin/python benchmarks/bench_app_playback.py [--triangles 4500]
      [--runs 5] [--seconds 3] [--expression surprise] [--modes off,on]
      [--skin-model geometric,physical]

A main window on the built-in face (three views, 1500x800, software rendering under Xvfb)
plays the expression's timeline with the real Play button, in Qt's event loop, for
``--seconds`` a run: the timer ticks, the timeline moves, the frame is evaluated and the
views redraw. Each redraw is a frame; frames per second = frames / wall seconds. The
first run of each mode is a warm-up (not counted). Per frame, the time splits into
evaluate (``Session.state``), redraw (``LinkedViews.draw``: writing the frame into the
drawn meshes, or rebuilding them), render (``LinkedViews.render``: the views that changed)
and the rest (the status line, the probe, Qt's own event handling between frames).
Medians over ``--runs`` runs; the targets are 30 frames a second unrefined and 20 refined.

``--skin-model``: the skin models to play, comma-separated, each in the same run and the
same window (default geometric). On the physical skin Play runs the simulation in real
time (:mod:`wrinkle_vis.app.physics`): a timer tick advances it by the wall-clock time
elapsed, in steps of the material's h = 1/30 s, so a new frame comes at most every 1/30 s;
its time splits into simulate (``Session.tick``: the steps), evaluate (the fields of the
simulated skin), redraw, render and the rest; "real time" is the simulated seconds over the
wall seconds (1: the simulation keeps up with the clock; less: the lag a tick could not
catch up, capped, was dropped). The target on the physical skin is 20 frames a second.
"""

import argparse
import os
import statistics
import sys
import time

from qtpy import QtCore, QtWidgets

import wrinkle_vis as wv
from wrinkle_vis.app.session import Session
from wrinkle_vis.app.window import MainWindow

TARGETS = {False: 30.0, True: 20.0}
PHYSICAL_TARGET = 20.0


class FrameClock:
    """Wraps a window's evaluate, redraw and render calls and sums their times per frame."""

    def __init__(self, window: MainWindow):
        self.window = window
        self.reset()
        for owner, name, slot in ((window.session, "state", "evaluate"),
                                  (window.session, "tick", "simulate"),
                                  (window.views, "draw", "redraw"),
                                  (window, "refresh", "frame")):
            setattr(owner, name, self._timed(getattr(owner, name), slot))
        self._started = {}
        for i, p in enumerate(window.plotters):  # however a render comes (a paint event)
            p.render_window.AddObserver("StartEvent", self._start(i))
            p.render_window.AddObserver("EndEvent", self._end(i))

    def _start(self, i):
        def start(*_):
            self._started[i] = time.perf_counter()
        return start

    def _end(self, i):
        def end(*_):
            seconds = time.perf_counter() - self._started.pop(i)
            self.sums["render"] += seconds
            self.view_seconds[i] += seconds
            self.renders[i] += 1
        return end

    def reset(self) -> None:
        self.sums = dict.fromkeys(("evaluate", "simulate", "redraw", "render", "frame"), 0.0)
        self.frames = self.rebuilds = self.remeshes = 0
        self.renders = [0, 0, 0]
        self.view_seconds = [0.0, 0.0, 0.0]

    def _timed(self, fn, slot):
        def timed(*args, **kwargs):
            cached = slot == "evaluate" and self.window.session._state is not None
            t0 = time.perf_counter()
            out = fn(*args, **kwargs)
            if not cached:
                self.sums[slot] += time.perf_counter() - t0
            if slot == "frame":
                self.frames += 1
            elif slot == "redraw":
                kind = getattr(self.window.views, "last_redraw", None)
                self.rebuilds += kind == "scene"
                self.remeshes += kind == "mesh"
            return out
        return timed


def play(app, window: MainWindow, clock: FrameClock, seconds: float) -> dict:
    """Play for ``seconds`` in Qt's event loop; the run's fps and ms per frame."""
    window.time_slider.setValue(0)
    app.processEvents()
    clock.reset()
    loop = QtCore.QEventLoop()
    QtCore.QTimer.singleShot(round(1e3 * seconds), loop.quit)
    t0, cpu0 = time.perf_counter(), time.process_time()
    window.play_button.setChecked(True)
    sim0 = window.session.physics.time
    loop.exec()
    wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
    window.play_button.setChecked(False)
    physics = window.session.physics
    simulated = (physics.time - sim0) if physics.live and sim0 is not None else 0.0
    if simulated < 0.0:  # went round the timeline
        simulated += window.session.current_expression().duration_s
    n = max(clock.frames, 1)
    ms = {k: 1e3 * v / n for k, v in clock.sums.items()}
    frame = ms.pop("frame")
    ms["other"] = 1e3 * wall / n - sum(ms.values())  # the rest of refresh and Qt's loop
    return {"fps": clock.frames / wall, "frame": frame, "frames": clock.frames,
            "real time": simulated / wall,
            "cpu": 1e3 * cpu / n,
            "rebuilds": clock.rebuilds, "remeshes": clock.remeshes,
            "renders": sum(clock.renders) / n,
            **{f"render {v}": 1e3 * t / max(r, 1) for v, t, r in
               zip(("skin", "muscles", "skull"), clock.view_seconds, clock.renders,
                   strict=True)},
            **ms}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--triangles", type=int, default=4500)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--expression", default="surprise")
    parser.add_argument("--modes", default="off,on",
                        help="refinement modes to play, comma-separated (off, on)")
    parser.add_argument("--skin-model", default="geometric",
                        help="skin models to play, comma-separated (geometric, physical)")
    args = parser.parse_args()
    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication(sys.argv[:1])
    settings = QtCore.QSettings(QtCore.QSettings.IniFormat, QtCore.QSettings.UserScope,
                                "wrinkle-vis-bench", "playback")
    face = wv.datasets.load_face(args.triangles)
    window = MainWindow(Session(face), settings)
    window.resize(1500, 800)
    window.show()
    for _ in range(10):
        app.processEvents()
    window.expression_box.setCurrentText(args.expression)
    clock = FrameClock(window)
    sizes = [tuple(p.window_size) for p in window.plotters]
    print(f"{face.skin.n_triangles} triangles, {args.expression}, views {sizes} px, "
          f"{args.runs} runs of {args.seconds:g} s after a warm-up run; load average "
          f"{os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    met = True
    for skin in args.skin_model.split(","):
        window.skin_box.setCurrentText(skin)
        if window.session.face.skin_model != skin:
            parser.error(f"unknown skin model {skin!r}; choose geometric or physical")
        for mode in args.modes.split(","):
            met &= _play_mode(app, window, clock, args, skin, mode)
    window.session.dirty = False
    window.close()
    print("targets met" if met else "TARGETS NOT MET")
    return 0 if met else 1


def _play_mode(app, window, clock, args, skin: str, mode: str) -> bool:
    """Play one skin model with refinement ``mode``; print the medians; the target met?"""
    refine = mode == "on"
    physical = skin == "physical"
    target = PHYSICAL_TARGET if physical else TARGETS[refine]
    window.refine_box.setChecked(refine)
    play(app, window, clock, args.seconds)  # warm-up
    runs = [play(app, window, clock, args.seconds) for _ in range(args.runs)]
    med = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
    fps = [f"{r['fps']:.1f}" for r in runs]
    sim = (f"simulate {med['simulate']:.1f}, " if physical else "")
    real = (f"; simulated time {med['real time']:.2f} x the wall clock" if physical else "")
    print(f"{skin} skin, refinement {mode:3s}: {med['fps']:5.1f} fps (runs {', '.join(fps)}; "
          f"target {target:g}), {1e3 / med['fps']:.1f} ms a frame (this process's "
          f"CPU time {med['cpu']:.1f} ms): {sim}evaluate "
          f"{med['evaluate']:.1f}, redraw {med['redraw']:.1f}, render {med['render']:.1f}, "
          f"other {med['other']:.1f} ms; {med['renders']:.1f} view renders a frame "
          f"(one of the skin view {med['render skin']:.1f} ms, the muscles view "
          f"{med['render muscles']:.1f} ms); "
          f"{med['frames']:.0f} frames a run, "
          f"{med['remeshes']:.0f} with new triangles, {med['rebuilds']:.0f} scenes rebuilt"
          f"{real}")
    return med["fps"] >= target


if __name__ == "__main__":
    sys.exit(main())
