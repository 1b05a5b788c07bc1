"""
A contact sheet of a sweep's images
===================================

Each run of a sweep can render images (fields, cameras, size and a raking light, from its
spec). They lie in the run's folder, ``runs/<run id>/<field>_<camera>.png``, and the table
says which parameters made them, so a contact sheet is a few lines of numpy. The sweep is
the one of the previous example (run here again, it finds every run finished and only
writes the table): rows :math:`n_w` = 2, 3, 4, columns :math:`k_0` = 1 and 3 mm, plain
skin under the raking light beside the map of :math:`W`.
"""

import tempfile
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pyvista as pv

import wrinkle_vis as wv
import wrinkle_vis.plotting  # noqa: F401 (off screen through EGL where there is no display)

OUT = Path(tempfile.gettempdir()) / "wrinkle-vis-gallery-sweep"
SPEC = {
    "name": "gallery",
    "faces": [{"name": "procedural", "n_triangles": 4500}],
    "expressions": ["surprise"],
    "refine": [True],
    "vary": [
        {"type": "sheet", "parameter": "n_wrinkles", "values": [2, 3, 4]},
        {"type": "sheet", "parameter": "k0", "values": [1.0, 3.0]},
    ],
    "outputs": {"images": {"fields": ["none", "W"], "cameras": ["forehead"],
                           "size": [300, 300], "raking_light": True}},
}

# %%
# One row per n_w, one pair of images per k0.
if __name__ == "__main__":
    table = wv.sweep(SPEC, OUT, workers=2, progress=False)
    rows = []
    for _, group in table.sort_values(["type:sheet.n_wrinkles", "type:sheet.k0"]).groupby(
            "type:sheet.n_wrinkles"):
        tiles = []
        for rid in group["run_id"]:
            for field in ("none", "W"):
                tiles.append(iio.imread(OUT / "runs" / rid / f"{field}_forehead.png")[..., :3])
        rows.append(np.concatenate(tiles, axis=1))
    sheet = np.concatenate(rows, axis=0)
    iio.imwrite(OUT / "contact_sheet.png", sheet)
    print(f"{sheet.shape[1]} by {sheet.shape[0]} pixels: {OUT / 'contact_sheet.png'}")

# %%
# Shown as a texture, flat on the screen.
if __name__ == "__main__":
    h, w = sheet.shape[:2]
    plane = pv.Plane(i_size=w, j_size=h, i_resolution=1, j_resolution=1)
    plotter = pv.Plotter(window_size=(w // 2, h // 2))
    plotter.add_mesh(plane, texture=pv.numpy_to_texture(np.ascontiguousarray(sheet)))
    plotter.view_xy()
    plotter.camera.parallel_projection = True
    plotter.reset_camera(bounds=plane.bounds)
    plotter.camera.parallel_scale = h / 2
    plotter.show()
