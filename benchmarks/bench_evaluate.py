"""Per-frame cost of ``FaceModel.evaluate`` against a memory-stream floor, and our vertex
normals against VTK's ``vtkPolyDataNormals``, on the paper's size and on ~1.3 M triangles.

Run:  .venv/bin/python benchmarks/bench_evaluate.py [--rounds 5] [--json out.json]

Every figure is the median over ``--rounds`` rounds of the median of several calls.
"""

from __future__ import annotations

import argparse
import json
import resource
import time
import tracemalloc

import numpy as np
from _timing import median_seconds


def stream_floor(face, acts):
    """The memory-stream floor of a frame: copy, once each with numpy, every array the frame
    reads (the rest points and the cached operators of the active muscles) and write arrays
    the size of its outputs (deformed points, final points, W)."""
    rest = face.skin.points
    asm = face._assembly(tuple(m for m, a in acts.items() if a > 0))
    inputs = [rest, *asm.arrays()]

    def run():
        copies = [a.copy() for a in inputs]
        out = (np.empty_like(rest), np.empty_like(rest), np.empty(len(rest)))
        for o in out:
            o.fill(0.0)
        return copies, out

    return run


def frame_bytes(face, acts) -> int:
    asm = face._assembly(tuple(m for m, a in acts.items() if a > 0))
    return face.skin.points.nbytes * 3 + sum(a.nbytes for a in asm.arrays()) + \
        face.skin.n_points * 8


def vtk_normals(skin):
    import vtk

    from wrinkle_vis.plotting import to_surface_polydata

    poly = to_surface_polydata(skin)
    filt = vtk.vtkPolyDataNormals()
    filt.SetInputData(poly)
    filt.ComputePointNormalsOn()
    filt.ComputeCellNormalsOff()
    filt.SplittingOff()
    filt.ConsistencyOff()
    filt.AutoOrientNormalsOff()

    def run():
        filt.Modified()
        filt.Update()
        return filt.GetOutput()

    return run


def measure(label: str, face, calls: int, rounds: int) -> dict:
    acts = {m: 0.7 for m in face.muscle_names}
    skin = face.skin
    _ = skin.edges, skin.incidence  # topology is part of loading the mesh
    tracemalloc.start()
    t0 = time.perf_counter()
    face.evaluate(acts)
    setup = time.perf_counter() - t0
    face.evaluate(acts)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    frame = median_seconds(lambda: face.evaluate(acts), calls, rounds)
    floor = median_seconds(stream_floor(face, acts), calls, rounds)
    ours = median_seconds(lambda: skin.vertex_normals(), max(3, calls // 4), rounds)
    theirs = median_seconds(vtk_normals(skin), max(3, calls // 4), rounds)
    return {
        "mesh": label, "triangles": skin.n_triangles, "vertices": skin.n_points,
        "muscles_active": len(acts), "first_frame_s": setup, "frame_ms": 1e3 * frame,
        "floor_ms": 1e3 * floor, "frame_over_floor": frame / floor,
        "frame_MiB_streamed": frame_bytes(face, acts) / 2**20,
        "normals_ours_ms": 1e3 * ours, "normals_vtk_ms": 1e3 * theirs,
        "normals_ours_over_vtk": ours / theirs,
        "peak_traced_MiB_setup_and_frame": peak / 2**20,
    }


def main() -> None:
    import wrinkle_vis as wv

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--large-levels", type=int, default=4,
                        help="midpoint subdivisions of a 5,100-triangle face (4: ~1.3 M)")
    parser.add_argument("--json")
    args = parser.parse_args()

    geometric = wv.datasets.load_face().with_skin_model("geometric")  # the pulls' frame
    rows = [measure("paper size", geometric, 200, args.rounds)]
    base = wv.datasets.load_face(5100)
    skin = wv.subdivide(base.skin, args.large_levels)
    big = wv.FaceModel(skin, base.skull, base.muscles, base.expressions, skin_model="geometric")
    rows.append(measure("subdivided", big, 7, args.rounds))
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024

    keys = ["triangles", "frame_ms", "floor_ms", "frame_over_floor", "frame_MiB_streamed",
            "normals_ours_ms",
            "normals_vtk_ms", "normals_ours_over_vtk", "first_frame_s",
            "peak_traced_MiB_setup_and_frame"]
    print(f"{'':>28}" + "".join(f"{r['mesh']:>16}" for r in rows))
    for k in keys:
        print(f"{k:>28}" + "".join(f"{r[k]:>16.3f}" if isinstance(r[k], float)
                                   else f"{r[k]:>16}" for r in rows))
    print(f"process max RSS: {rss:.0f} MiB (Python, numpy, VTK and both meshes)")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"rows": rows, "max_rss_MiB": rss}, fh, indent=2)


if __name__ == "__main__":
    main()
