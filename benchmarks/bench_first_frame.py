"""The first frame of a large face with this tree's code and with a baseline commit's, side
by side: the two run alternately, each in a fresh process, round after round (issue 33 M12).

Run:  .venv/bin/python benchmarks/bench_first_frame.py [--baseline REF] [--levels 4]
      [--rounds 3] [--fold-guard on|off] [--json out.json]

``--baseline`` is a git revision whose ``wrinkle_vis`` is extracted into a
temporary folder (``git archive``; ``wrinkle_vis.datasets``, which the editable install maps
to this tree's ``datasets``, is this tree's for both: only the procedural face is loaded,
from its cache); ``--levels`` midpoint subdivisions of the 5,100-triangle
procedural face (3: 326 k triangles, 4: 1.3 M). A round times each version once: a fresh
``FaceModel`` on the subdivided skin (its edges and incidence built beforehand, as loading a
mesh does), its first ``evaluate`` with every muscle at 0.7 (the fold guard on, or off with
``--fold-guard off``), with tracemalloc running (its
peak: numpy and SciPy arrays); the process's peak RSS is reported too. Figures are medians
over the rounds. The two versions' frames are compared at the end (largest difference of
the final points and of W).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import resource, sys, time, tracemalloc
import numpy as np
import wrinkle_vis as wv
levels, out, guard = int(sys.argv[1]), sys.argv[2], sys.argv[3] == "on"
base = wv.datasets.load_face(5100)
skin = wv.subdivide(base.skin, levels)
_ = skin.edges, skin.incidence
face = wv.FaceModel(skin, base.skull, base.muscles, base.expressions, skin_model="geometric")
acts = {m: 0.7 for m in face.muscle_names}
tracemalloc.start()
t0 = time.perf_counter()
state = face.evaluate(acts, fold_guard=guard)
seconds = time.perf_counter() - t0
peak = tracemalloc.get_traced_memory()[1] / 2**20
tracemalloc.stop()
rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
np.savez(out, points=state.points, W=state.W)
print(skin.n_triangles, seconds, peak, rss, wv.__file__)
"""


def run(tree: Path, levels: int, out: Path, guard: str = "on") -> dict:
    """One first frame in a fresh process importing ``wrinkle_vis`` from ``tree``."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    text = subprocess.run([sys.executable, "-c", CHILD, str(levels), str(out), guard], env=env,
                          cwd=tree, check=True, capture_output=True, text=True).stdout
    tris, seconds, peak, rss, where = text.split()[-5:]
    if not where.startswith(str(tree)):
        raise RuntimeError(f"imported {where}, not the tree {tree}")
    return {"triangles": int(tris), "seconds": float(seconds), "peak_MiB": float(peak),
            "rss_MiB": float(rss)}


def main() -> None:
    import numpy as np

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--baseline", default="HEAD")
    parser.add_argument("--levels", type=int, default=4)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--fold-guard", choices=("on", "off"), default="on")
    parser.add_argument("--json")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        old = Path(tmp) / "baseline"
        old.mkdir()
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", args.baseline,
                                  "wrinkle_vis"], check=True,
                                 capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(old)], input=archive, check=True)
        trees = {"baseline": old, "this tree": ROOT}
        rows = {k: [] for k in trees}
        for r in range(args.rounds):
            for name, tree in (trees.items() if r % 2 == 0 else reversed(trees.items())):
                rows[name].append(run(tree, args.levels, Path(tmp) / f"{name}.npz",
                                     args.fold_guard))
                print(f"round {r + 1} {name}: {rows[name][-1]}", flush=True)
        a, b = (np.load(Path(tmp) / f"{k}.npz") for k in trees)
        diff = {k: float(np.abs(a[k] - b[k]).max()) for k in ("points", "W")}
    summary = {name: {k: statistics.median(x[k] for x in runs)
                      for k in ("triangles", "seconds", "peak_MiB", "rss_MiB")}
               for name, runs in rows.items()}
    print(f"{'':>12}{'triangles':>12}{'first frame s':>15}{'traced MiB':>12}{'RSS MiB':>10}")
    for name, s in summary.items():
        print(f"{name:>12}{s['triangles']:>12.0f}{s['seconds']:>15.2f}{s['peak_MiB']:>12.0f}"
              f"{s['rss_MiB']:>10.0f}")
    print(f"largest difference, final points: {diff['points']:.3g}, W: {diff['W']:.3g} "
          f"(baseline {args.baseline})")
    if args.json:
        Path(args.json).write_text(json.dumps({"baseline": args.baseline, "levels":
                                               args.levels, "rounds": rows,
                                               "median": summary, "max_diff": diff},
                                              indent=2))


if __name__ == "__main__":
    main()
