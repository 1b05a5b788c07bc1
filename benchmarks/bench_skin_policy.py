"""Where the physical skin's first frame outgrows issue 33's budget (10 s, 1 GB): the first
frame of subdivided procedural faces on both skins, each in a fresh process, side by side
(issue 27: the default skin's size policy, ``wrinkle_vis.core.skin.default_skin_model``).

Run:  .venv/bin/python benchmarks/bench_skin_policy.py [--sizes 5100:2 10000:2 15000:2 5100:3]
      [--rounds 1] [--skins geometric physical]

A size ``B:L`` is the procedural face of ``B`` triangles subdivided ``L`` times (midpoints,
4**L times the triangles; 5100:3 is stop 36's 326,400 triangles). A run builds a fresh
``FaceModel`` on the subdivided skin (edges and incidence built beforehand, as loading a mesh
does) and times its first ``evaluate`` with every muscle at 0.7, the fold guard on: wall
clock, CPU time of the process (the steadier figure on a shared machine) and the process's
peak RSS. Figures are medians over the rounds; the load average is printed with them.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import resource, sys, time
import wrinkle_vis as wv
base_n, levels, model = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
base = wv.datasets.load_face(base_n)
skin = wv.subdivide(base.skin, levels)
_ = skin.edges, skin.incidence
face = wv.FaceModel(skin, base.skull, base.muscles, base.expressions, skin_model=model)
acts = {m: 0.7 for m in face.muscle_names}
rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
t0, c0 = time.perf_counter(), time.process_time()
face.evaluate(acts, fold_guard=True)
wall, cpu = time.perf_counter() - t0, time.process_time() - c0
rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(skin.n_triangles, skin.n_points, wall, cpu, rss0, rss)
"""


def run(base: int, levels: int, model: str) -> dict:
    """One first frame in a fresh process."""
    text = subprocess.run([sys.executable, "-c", CHILD, str(base), str(levels), model],
                          cwd=ROOT, check=True, capture_output=True, text=True).stdout
    tris, points, wall, cpu, rss0, rss = text.split()[-6:]
    return {"triangles": int(tris), "points": int(points), "wall_s": float(wall),
            "cpu_s": float(cpu), "rss_before_MiB": float(rss0), "rss_MiB": float(rss)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sizes", nargs="+", default=["5100:2", "10000:2", "15000:2",
                                                        "5100:3"])
    parser.add_argument("--rounds", type=int, default=1)
    parser.add_argument("--skins", nargs="+", default=["geometric", "physical"])
    args = parser.parse_args()
    print(f"load average at the start: {os.getloadavg()}", flush=True)
    print(f"{'triangles':>10}{'points':>9}{'skin':>11}{'wall s':>9}{'CPU s':>8}"
          f"{'RSS MiB':>9}{'fits 10 s, 1 GB':>17}", flush=True)
    for size in args.sizes:
        base, levels = map(int, size.split(":"))
        for model in args.skins:
            rows = [run(base, levels, model) for _ in range(args.rounds)]
            med = {k: statistics.median(r[k] for r in rows) for k in rows[0]}
            fits = med["cpu_s"] <= 10.0 and med["rss_MiB"] <= 1024.0
            print(f"{med['triangles']:>10.0f}{med['points']:>9.0f}{model:>11}"
                  f"{med['wall_s']:>9.2f}{med['cpu_s']:>8.2f}{med['rss_MiB']:>9.0f}"
                  f"{'yes' if fits else 'no':>17}", flush=True)
    print(f"load average at the end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
