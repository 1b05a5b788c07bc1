"""Render the sphincter figures of docs/model.md: plain skin under a raking light, each
expression without and with its wrinkles (no Qt; off-screen).

Usage:  .venv/bin/python docs/make_sphincter_images.py [n_triangles]
"""

import sys
from pathlib import Path

import numpy as np
import pyvista as pv

import wrinkle_vis as wv
from wrinkle_vis.plotting import add_raking_light, add_skin
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


def main(n_triangles: int = 60000) -> None:
    """Write the three figures, rendered on the face with ``n_triangles`` triangles."""
    face = wv.datasets.load_face(n_triangles)
    for expression, *view in FIGURES:
        path = OUT / f"sphincter_{expression}.png"
        save_image(figure(face, expression, *view), path)
        print(f"wrote {path}")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:]))
