"""The forehead's plateau edge (issue 27): the shading crease that the skin deformation alone
adds to a frame as it is shown (:func:`wrinkle_vis.core.analysis.plateau_edge`), beside the
old crease measure, and what the shading normals cost.

Run:  .venv/bin/python benchmarks/bench_plateau.py [--faces procedural lee_perry_smith]
      [--old] [--json FILE]

For each face, skin model (geometric, physical), refinement (off, on) and expression
(surprise, fear, frown) it prints:

- ``plateau p99 / max``: the 99th percentile and the maximum of ``plateau_edge(state)``
  (degrees), on the edges with an end the muscles moved;
- ``old p99``: the 99th percentile of the old measure, the change of the dihedral angles
  from the frame's rest skin (the refined rest on a refined frame) to its skin without
  wrinkles (tests/test_realism.py's ``crease``, moved edges).

``--old`` measures the frame as the code before stop 37 showed it: shaded with its own
vertex normals (``skin.vertex_normals(points)``) instead of
:meth:`~wrinkle_vis.core.state.FaceState.shading_normals`. The timing compares the two on
the refined head's surprise in one run: the old normals (``vertex_normals``) and the new
ones (``shading_normals``), median of 5 rounds of 20 calls.
"""

import argparse
import json
import os

import numpy as np
from _timing import median_seconds

import wrinkle_vis as wv
from wrinkle_vis.core.analysis import dihedral_change, plateau_edge
from wrinkle_vis.core.state import FaceState

EXPRESSIONS = ("surprise", "fear", "frown")


def old_crease(state) -> np.ndarray:
    """tests/test_realism.py's ``crease``: dihedral change rest -> deformed, moved edges."""
    surface, rest = state.face.skin, state.rest_points
    moved = (state.deformed_points != rest).any(axis=1)[surface.edges].any(axis=1)
    change = dihedral_change(surface, rest, state.deformed_points)[moved]
    return change[np.isfinite(change)]


def rows(face_name: str) -> list[dict]:
    face = wv.datasets.load_face(face_name) if face_name != "procedural" \
        else wv.datasets.load_face()
    out = []
    for skin in ("geometric", "physical"):
        for refine in (False, True):
            for name in EXPRESSIONS:
                state = face.evaluate(name, skin=skin, refine=refine)
                p = plateau_edge(state)
                out.append({"face": face_name, "skin": skin, "refine": refine,
                            "expression": name, "edges": int(len(p)),
                            "plateau_p99": float(np.percentile(p, 99)),
                            "plateau_max": float(p.max()),
                            "old_p99": float(np.percentile(old_crease(state), 99))})
    return out


def timing() -> dict:
    face = wv.datasets.load_face("lee_perry_smith")
    state = face.evaluate("surprise", refine=True)
    skin, points = state.face.skin, state.deformed_points
    old = median_seconds(lambda: skin.vertex_normals(points), 20, 5)
    new = median_seconds(lambda: state.shading_normals(points), 20, 5)
    return {"vertices": int(skin.n_points), "old_ms": 1e3 * old, "new_ms": 1e3 * new,
            "ratio": new / old, "load": os.getloadavg()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--faces", nargs="+", default=["procedural", "lee_perry_smith"])
    parser.add_argument("--old", action="store_true",
                        help="shade frames with their own vertex normals (before stop 37)")
    parser.add_argument("--json")
    args = parser.parse_args()
    if args.old:
        FaceState.shading_normals = lambda self, points=None: self.face.skin.vertex_normals(
            self.points if points is None else points)
    table = [r for f in args.faces for r in rows(f)]
    print(f"{'face':16s} {'skin':9s} {'refine':6s} {'expression':10s} {'edges':>6s} "
          f"{'plateau p99':>11s} {'max':>6s} {'old p99':>7s}")
    for r in table:
        print(f"{r['face']:16s} {r['skin']:9s} {r['refine']!s:6s} {r['expression']:10s} "
              f"{r['edges']:6d} {r['plateau_p99']:11.2f} {r['plateau_max']:6.2f} "
              f"{r['old_p99']:7.2f}")
    result = {"rows": table}
    if not args.old:
        t = timing()
        result["timing"] = t
        print(f"refined head surprise, {t['vertices']} vertices: vertex_normals "
              f"{t['old_ms']:.2f} ms, shading_normals {t['new_ms']:.2f} ms "
              f"(x{t['ratio']:.2f}); load {t['load'][0]:.2f}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=1)


if __name__ == "__main__":
    main()
