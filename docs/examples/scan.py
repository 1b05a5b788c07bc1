"""Wrinkles on your own scan: the built-in muscles moved onto it from nine landmarks.

Usage (from the repository root):

    .venv/bin/python docs/examples/scan.py ../shared/realmeshes/lee_perry_smith_head.obj
        [--landmarks marks.json] [--unit m] [--png surprise.png] [--figure fig9.png]

Any OBJ, PLY, STL, VTP or VTK surface works with a landmarks file (``{"nasion": [x, y, z],
...}``, at least 4 of ``wv.datasets.LANDMARKS``, in the scan's coordinates; the app's
File > New face from mesh... picks them by clicking and saves a layout naming the scan).
Without ``--landmarks`` the landmarks recorded in
``wrinkle_vis/datasets/examples/lee_perry_smith.json`` are used: they were picked on the Lee
Perry-Smith head scan, which is not shipped in this form (CC BY 3.0, Lee Perry-Smith /
Infinite Realities; the package ships a derived form as ``load_face("lee_perry_smith")``).
The skull is built under the scan (a closed level set at the regional tissue depth) and the
unit is guessed from the scan's size unless ``--unit`` says it.
"""

import argparse
from pathlib import Path

import numpy as np

import wrinkle_vis as wv

EXAMPLE = Path(wv.datasets.__file__).with_name("examples") / "lee_perry_smith.json"

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("mesh", help="the scan (OBJ, PLY, STL, VTP, VTK)")
parser.add_argument("--landmarks", help="a JSON file of landmarks on the scan (default: "
                                        "those of the example layout, for the head scan)")
parser.add_argument("--unit", help="the scan's length unit (default: guessed from its size)")
parser.add_argument("--png", help="render W of surprise to this PNG")
parser.add_argument("--figure", help="write the paper's Fig. 9 (refined) to this PNG")
args = parser.parse_args()

landmarks = wv.datasets.read_landmarks(args.landmarks or EXAMPLE)
face = wv.datasets.load_face(skin=args.mesh, landmarks=landmarks, unit=args.unit)
print(f"{face.name}: {face.skin.n_points} vertices, {len(face.muscles)} muscles, "
      f"skull {face.skull.n_triangles} triangles, unit {face.unit}")
for name in ("surprise", "frown", "fear"):
    state = face.evaluate(name)
    print(f"{name:9s} W != 0 at {np.count_nonzero(state.W):4d} vertices, "
          f"|W| <= {np.abs(state.W).max():.3g} {face.unit}")
if args.png:
    from wrinkle_vis.plotting import render_field

    render_field(face, "surprise", "W", camera="forehead", size=(600, 600), filename=args.png)
    print(f"wrote {args.png}")
if args.figure:
    from wrinkle_vis.plotting.figures import figure_expressions

    figure_expressions(face, refine=True, filename=args.figure)
    print(f"wrote {args.figure}")
