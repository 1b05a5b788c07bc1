"""Render the action-unit figures of docs/model.md: AU4, AU9 and AU17 through the default
track mapping on both built-in faces, plain skin under a raking light, refined, without
(top row) and with (bottom row) the wrinkles (no Qt; off-screen).

Usage:  .venv/bin/python docs/make_au_images.py
"""

from pathlib import Path

import numpy as np
import pyvista as pv

import wrinkle_vis as wv
from wrinkle_vis.plotting import add_raking_light, add_skin
from wrinkle_vis.plotting.writers import save_image

#: (action unit, landmark the view centres on, offset from it (mm), distance (mm), light
#: elevation, azimuth): the glabella above the nasion, the nose, the chin.
VIEWS = (
    ("AU04", "nasion", (0.0, 10.0, 0.0), 95.0, 35.0, 0.0),
    ("AU09", "nose_tip", (0.0, 12.0, 0.0), 100.0, 30.0, 0.0),
    ("AU17", "chin", (0.0, 6.0, 0.0), 95.0, 30.0, 0.0),
)


def au_figure(face, size=(340, 340)) -> np.ndarray:
    """``(h, w, 3)``: each of :data:`VIEWS`, without (top) and with (bottom) wrinkles."""
    mapping = face.mapping or wv.default_mapping()
    plotter = pv.Plotter(off_screen=True, shape=(2, len(VIEWS)), border=False,
                         window_size=[len(VIEWS) * size[0], 2 * size[1]])
    try:
        plotter.set_background("white")
        for col, (au, mark, offset, distance, elevation, azimuth) in enumerate(VIEWS):
            track = wv.Track([0.0], [au], [[1.0]])
            acts = mapping.activations(track, face.muscle_names)[0]
            state = face.evaluate(dict(zip(face.muscle_names, acts, strict=True)), refine=True)
            focal = np.asarray(face.landmarks[mark]) + offset
            for row, (what, points) in enumerate((("without", state.deformed_points),
                                                  ("with wrinkles", state.points))):
                plotter.subplot(row, col)
                add_skin(plotter, state, None, points=points)
                add_raking_light(plotter, elevation, azimuth)
                plotter.add_text(f"{au} {what}", font_size=10, color="black")
                plotter.camera.focal_point = focal
                plotter.camera.position = focal + np.array([0.0, 0.0, distance])
                plotter.camera.up = (0.0, 1.0, 0.0)
                plotter.reset_camera_clipping_range()
        return plotter.screenshot(None, return_img=True)
    finally:
        plotter.close()


def main() -> None:
    """Write ``docs/images/au_procedural.png`` and ``docs/images/au_lee_perry_smith.png``."""
    out = Path(__file__).with_name("images")
    for name in ("procedural", "lee_perry_smith"):
        path = out / f"au_{name}.png"
        save_image(au_figure(wv.datasets.load_face(name)), path)
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
