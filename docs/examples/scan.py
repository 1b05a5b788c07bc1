"""Wrinkles on a real scan: the built-in muscle layout moved onto the Lee Perry-Smith head.

Usage:  .venv/bin/python docs/examples/scan.py PATH/TO/lee_perry_smith_head.obj
            [--png out.png] [--figure fig9.png]

The scan is not shipped (CC BY 3.0, Lee Perry-Smith / Infinite Realities); in this
repository's workspace it lies at ../shared/realmeshes/. The layout
``wrinkle_vis/datasets/examples/lee_perry_smith.json`` was made from the built-in layout by
``transfer_layout`` with the nine landmarks it records.
"""

import argparse
from pathlib import Path

import numpy as np

import wrinkle_vis as wv

EXAMPLE = Path(wv.datasets.__file__).with_name("examples") / "lee_perry_smith.json"

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("mesh", help="path to lee_perry_smith_head.obj")
parser.add_argument("--png", help="render W of surprise to this PNG")
parser.add_argument("--figure", help="write the paper's Fig. 9 (refined) to this PNG")
args = parser.parse_args()

face = wv.datasets.load_face(skin=args.mesh, layout=EXAMPLE)
print(f"{face.name}: {face.skin.n_points} vertices, {len(face.muscles)} muscles")
for name in ("surprise", "frown", "fear"):
    state = face.evaluate(name)
    print(f"{name:9s} W != 0 at {np.count_nonzero(state.W):4d} vertices, "
          f"|W| <= {np.abs(state.W).max():.2e} (scan units)")
if args.png:
    import pyvista as pv

    state = face.evaluate("surprise")
    lim = float(np.abs(state.W).max())
    plotter = pv.Plotter(off_screen=True, window_size=(600, 600))
    plotter.add_mesh(state.to_polydata(), scalars="W", cmap="RdBu_r", clim=(-lim, lim),
                     smooth_shading=True)
    plotter.camera_position = [(0, 0.02, 0.6), (0, 0.0, 0), (0, 1, 0)]
    plotter.screenshot(args.png)
    plotter.close()
    print(f"wrote {args.png}")
if args.figure:
    from wrinkle_vis.plotting.figures import figure_expressions

    figure_expressions(face, refine=True, filename=args.figure)
    print(f"wrote {args.figure}")
