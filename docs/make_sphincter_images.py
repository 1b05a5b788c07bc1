"""Render the sphincter figures of docs/model.md: plain skin under a raking light, each
expression without and with its wrinkles (no Qt; off-screen).

Usage:  .venv/bin/python docs/make_sphincter_images.py [n_triangles] [scan.obj]

With the Lee Perry-Smith head scan (``../shared/realmeshes/lee_perry_smith_head.obj``) it
also renders squint and pucker on the scan, with the built-in layout moved onto it
(``datasets/examples/lee_perry_smith.json``).
"""

import sys
from pathlib import Path

import numpy as np
import pyvista as pv

import wrinkle_vis as wv
from wrinkle_vis.plotting import add_raking_light, add_skin, set_camera
from wrinkle_vis.plotting.writers import save_image

OUT = Path(__file__).with_name("images")

#: (expression, focal point, direction to the eye, distance, light elevation, azimuth), mm
FIGURES = (
    ("duchenne_smile", (30.0, -20.0, 70.0), (0.45, 0.05, 0.9), 260.0, 18.0, 5.0),
    ("squint", (46.0, 0.0, 66.0), (0.7, 0.1, 0.7), 170.0, 15.0, 0.0),
    ("pucker", (0.0, -56.0, 90.0), (0.25, 0.05, 1.0), 150.0, 20.0, 70.0),
)


def figure(face, expression, focal, towards, distance, elevation, azimuth,
           size=(520, 520)) -> np.ndarray:
    """``(h, w, 3)``: the expression without (left) and with (right) its wrinkles."""
    state = face.evaluate(expression)
    plotter = pv.Plotter(off_screen=True, shape=(1, 2), border=False,
                         window_size=[2 * size[0], size[1]])
    try:
        plotter.set_background("white")
        towards = np.asarray(towards) / np.linalg.norm(towards)
        for col, (what, points) in enumerate((("without wrinkles", state.deformed_points),
                                              ("with wrinkles", state.points))):
            plotter.subplot(0, col)
            add_skin(plotter, state, None, points=points)
            add_raking_light(plotter, elevation, azimuth)
            plotter.add_text(f"{expression}: {what}", font_size=11, color="black")
            plotter.camera.focal_point = focal
            plotter.camera.position = np.asarray(focal) + distance * towards
            plotter.camera.up = (0.0, 1.0, 0.0)
            plotter.reset_camera_clipping_range()
        return plotter.screenshot(None, return_img=True)
    finally:
        plotter.close()


def scan_figure(scan, size=(520, 520)) -> np.ndarray:
    """``(h, w, 3)``: squint and pucker on the head scan, refined, as plain skin."""
    example = Path(wv.datasets.__file__).with_name("examples") / "lee_perry_smith.json"
    face = wv.datasets.load_face(skin=scan, layout=example)
    plotter = pv.Plotter(off_screen=True, shape=(1, 2), border=False,
                         window_size=[2 * size[0], size[1]])
    try:
        plotter.set_background("white")
        for col, (expression, azimuth) in enumerate((("squint", 20.0), ("pucker", 60.0))):
            plotter.subplot(0, col)
            add_skin(plotter, face.evaluate(expression, refine=True), None)
            add_raking_light(plotter, 25.0, azimuth)
            plotter.add_text(f"{expression}: the head scan", font_size=11, color="black")
            set_camera(plotter, "front", face)
            plotter.camera.zoom(2.6)
            shift = np.asarray(face.landmarks["nose_tip"]) - plotter.camera.focal_point
            shift[2] = 0.0
            plotter.camera.focal_point = plotter.camera.focal_point + shift
            plotter.camera.position = plotter.camera.position + shift
            plotter.reset_camera_clipping_range()
        return plotter.screenshot(None, return_img=True)
    finally:
        plotter.close()


def main(n_triangles: int = 60000, scan=None) -> None:
    """Write the three figures, rendered on the face with ``n_triangles`` triangles, and
    with a ``scan`` path the head-scan figure.
    """
    face = wv.datasets.load_face(n_triangles)
    for expression, *view in FIGURES:
        path = OUT / f"sphincter_{expression}.png"
        save_image(figure(face, expression, *view), path)
        print(f"wrote {path}")
    if scan is not None:
        path = OUT / "sphincter_lee_perry_smith.png"
        save_image(scan_figure(scan), path)
        print(f"wrote {path}")


if __name__ == "__main__":
    main(*(int(a) if i == 0 else a for i, a in enumerate(sys.argv[1:])))
