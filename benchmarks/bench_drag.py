"""Drag-update loop of the placement widget on the built-in face, off screen (no display).

Run:  .venv/bin/python benchmarks/bench_drag.py [--runs 5] [--steps 40] [--size 317 739]

One update is what the app does for each mouse move while a handle is dragged: a
MouseMoveEvent on the skin view's interactor, the handle widget placing the handle on the
skin under the mouse, the muscle's insertion moved there (rest position), the face
re-evaluated (the moved muscle's rest data and the stacked operators rebuilt), the drawn
meshes updated and the changed views rendered. Side by side in one run:

- ours: :class:`~wrinkle_vis.app.views.LinkedViews` updating in place, as the app does (no
  anti-aliasing, the muscles view's translucent skin left out while dragging);
- peer: the same loop rebuilding the three scenes on every move (what a plotter-per-frame
  approach does: ``clear`` and ``add_mesh`` again);
- ours with 8x MSAA (the app's "Anti-aliasing" switch), and ours keeping the muscles
  view's translucent skin while dragging.

Prints medians over ``--runs`` runs of the median update time of ``--steps`` moves, as
updates per second, and the ratio to the target (30 updates/s).
"""

import argparse
import statistics
import time

import numpy as np
import pyvista as pv

import wrinkle_vis as wv
from wrinkle_vis.app.models import DisplayOptions
from wrinkle_vis.app.session import Session
from wrinkle_vis.app.views import LinkedViews
from wrinkle_vis.core.editing import with_point
from wrinkle_vis.plotting import set_camera

MUSCLE = "frontalis_major_L"


def make_views(size, anti_aliasing: bool) -> LinkedViews:
    """Three off-screen views sharing one camera."""
    theme = pv.themes.DocumentTheme()
    theme.anti_aliasing = "msaa" if anti_aliasing else None
    theme.multi_samples = 8 if anti_aliasing else 1
    plotters = [pv.Plotter(off_screen=True, window_size=list(size), theme=theme)
                for _ in range(3)]
    for p in plotters[1:]:
        p.renderer.camera = plotters[0].renderer.camera
    return LinkedViews(*plotters)


def drag_times(face, size, steps: int, rebuild: bool, anti_aliasing: bool,
               hide_skin: bool = True) -> list[float]:
    """Seconds of each of ``steps`` updates of one drag of the muscle's insertion handle."""
    session = Session(face)
    session.set_field("W", MUSCLE)
    options = DisplayOptions(field="W", muscle=MUSCLE, anti_aliasing=anti_aliasing)
    views = make_views(size, anti_aliasing)
    times: list[float] = []

    def on_move(handle, point, finished):
        session.set_face(session.face.with_muscle(
            with_point(session.face.muscle(MUSCLE), handle.param, handle.index, point)))
        if rebuild:
            views.invalidate()
        views.draw(session.state(), options, session.face)
        views.render(only_changed=True, skip=(views.skin_view,))  # the widget renders it

    views.on_move = on_move
    views.on_start = lambda handle: views.begin_drag() if hide_skin else None
    for p in views.plotters:  # the interactors first, then the widgets on them
        p.show(auto_close=False, interactive=False)
    views.draw(session.state(), options, session.face)
    set_camera(views.skin_view, "forehead", face)
    views.render()
    widget = views.placement
    # the first handle on the skin view (a sheet lists its attachment, on the skull, first)
    handle = next(h for h in widget.handles(widget.muscle) if h.layer == "skin")
    renderer = views.skin_view.renderer
    renderer.SetWorldPoint(*widget.position(handle), 1.0)
    renderer.WorldToDisplay()
    x0, y0, _ = renderer.GetDisplayPoint()
    iren = views.skin_view.iren.interactor

    def event(name, x, y):
        iren.SetEventInformation(int(round(x)), int(round(y)))
        iren.InvokeEvent(name)

    event("MouseMoveEvent", x0, y0)
    event("LeftButtonPressEvent", x0, y0)
    for k in range(steps):  # a slow circle of 12 pixels around the start
        t = 2 * np.pi * k / steps
        t0 = time.perf_counter()
        event("MouseMoveEvent", x0 + 12 * np.sin(t), y0 + 12 * (1 - np.cos(t)))
        times.append(time.perf_counter() - t0)
    event("LeftButtonReleaseEvent", x0, y0)
    moved = session.face.muscle(MUSCLE) != face.muscle(MUSCLE)
    views.close_placement()
    for p in views.plotters:
        p.close()
    if not moved:
        raise RuntimeError("the drag did not move the muscle: the benchmark is broken")
    return times


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--steps", type=int, default=40)
    parser.add_argument("--size", type=int, nargs=2, default=(317, 739),
                        help="pixels of each view (the app's in its default 1500 x 800 "
                             "window, beside its panels: bench_app_playback.py prints them)")
    parser.add_argument("--triangles", type=int, default=4500)
    args = parser.parse_args()
    face = wv.datasets.load_face(args.triangles).with_skin_model("geometric")
    face.evaluate("surprise")
    setups = {"ours (in place)": (False, False, True),
              "peer (rebuild each move)": (True, False, True),
              "ours, 8x MSAA": (False, True, True),
              "ours, translucent skin kept": (False, False, False)}
    results = {name: [] for name in setups}
    for _ in range(args.runs):  # interleaved, so drifts hit every setup alike
        for name, (rebuild, aa, hide) in setups.items():
            results[name].append(statistics.median(
                drag_times(face, args.size, args.steps, rebuild, aa, hide)))
    print(f"{face.skin.n_triangles} triangles, views {args.size[0]}x{args.size[1]}, "
          f"{args.runs} runs x {args.steps} moves (medians)")
    ours = statistics.median(results["ours (in place)"])
    for name, per_run in results.items():
        med = statistics.median(per_run)
        print(f"  {name:26s} {1e3 * med:6.1f} ms/update  {1 / med:5.1f} updates/s  "
              f"(x{med / ours:.2f} of ours; runs {', '.join(f'{1e3 * t:.1f}' for t in per_run)})")
    print(f"target 30 updates/s: ours {'meets' if 1 / ours >= 30 else 'MISSES'} it")


if __name__ == "__main__":
    main()
