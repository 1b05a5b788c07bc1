"""The level-set skull of a scan (``datasets/skull.py``) with this tree's code and with a
baseline commit's, side by side: the two run alternately, each in a fresh process, round
after round (issue 33 M12).

Run:  .venv/bin/python benchmarks/bench_scan_skull.py [--baseline REF] [--levels 1]
      [--rounds 2] [--json out.json]

The skin is Lee Perry-Smith's head from ``../shared/realmeshes`` (17,684 triangles)
subdivided ``--levels`` times (1: 70,736 triangles), its landmarks those of
``datasets/examples/lee_perry_smith.json``. ``--baseline``'s ``datasets/skull.py`` is
extracted with ``git show`` and loaded as a module of this tree's ``wrinkle_vis.datasets``
(its helpers, ``sdf`` and ``landmarks``, are this tree's for both). A round times each
version's skull built without its cache (``_build_skull``) and, apart, its cavity test
(``exterior`` on the triangles near the face, as ``skull_field`` calls it); figures are
medians over the rounds. The two skulls are compared at the end.
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
import importlib.util, resource, sys, time
from pathlib import Path
import numpy as np
import wrinkle_vis as wv
from wrinkle_vis.datasets import read_surface
source, levels, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
spec = importlib.util.spec_from_file_location("wrinkle_vis.datasets._bench_skull", source)
skull = importlib.util.module_from_spec(spec)
skull.__package__ = "wrinkle_vis.datasets"
spec.loader.exec_module(skull)
head = Path(sys.argv[4]) / "lee_perry_smith_head.obj"
skin = wv.subdivide(read_surface(head), levels)
marks = wv.load_layout(Path(wv.datasets.__file__).with_name("examples")
                       / "lee_perry_smith.json").landmarks
rot, scale, shift = skull._frame(marks)
q = (skin.points - shift) @ rot / scale
near = (q[:, 2] > skull.EAR_PLANE_Z - 30.0) & (q[:, 1] > skull.NECK_PLANE_Y - 30.0)
t0 = time.perf_counter()
outer = skull.exterior(skin, near[skin.triangles].any(axis=1))
t1 = time.perf_counter()
surf = skull._build_skull(skin, marks)
t2 = time.perf_counter()
rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
np.savez(out, points=surf.points, triangles=surf.triangles, outer=outer.triangles)
print(skin.n_triangles, t2 - t1, t1 - t0, rss)
"""


def run(source: Path, levels: int, out: Path) -> dict:
    """One skull in a fresh process with the skull module at ``source``."""
    real = ROOT.parent / "shared" / "realmeshes"
    text = subprocess.run([sys.executable, "-c", CHILD, str(source), str(levels), str(out),
                           str(real)], cwd=ROOT, check=True, capture_output=True, text=True,
                          env=dict(os.environ)).stdout
    tris, seconds, exterior, rss = text.split()[-4:]
    return {"triangles": int(tris), "skull_s": float(seconds), "exterior_s": float(exterior),
            "rss_MiB": float(rss)}


def main() -> None:
    import numpy as np

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--baseline", default="HEAD")
    parser.add_argument("--levels", type=int, default=1)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--json")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        old = Path(tmp) / "skull_baseline.py"
        old.write_bytes(subprocess.run(["git", "-C", str(ROOT), "show",
                                        f"{args.baseline}:datasets/skull.py"], check=True,
                                       capture_output=True).stdout)
        sources = {"baseline": old, "this tree": ROOT / "datasets" / "skull.py"}
        rows = {k: [] for k in sources}
        for r in range(args.rounds):
            for name, src in (sources.items() if r % 2 == 0 else reversed(sources.items())):
                rows[name].append(run(src, args.levels, Path(tmp) / f"{name}.npz"))
                print(f"round {r + 1} {name}: {rows[name][-1]}", flush=True)
        a, b = (np.load(Path(tmp) / f"{k}.npz") for k in sources)
        same = {k: bool(a[k].shape == b[k].shape and np.array_equal(a[k], b[k]))
                for k in ("points", "triangles", "outer")}
    summary = {name: {k: statistics.median(x[k] for x in runs)
                      for k in ("triangles", "skull_s", "exterior_s", "rss_MiB")}
               for name, runs in rows.items()}
    print(f"{'':>12}{'triangles':>12}{'skull s':>10}{'exterior s':>12}{'RSS MiB':>10}")
    for name, s in summary.items():
        print(f"{name:>12}{s['triangles']:>12.0f}{s['skull_s']:>10.2f}{s['exterior_s']:>12.2f}"
              f"{s['rss_MiB']:>10.0f}")
    print(f"equal to the bit (baseline {args.baseline}): {same}")
    if args.json:
        Path(args.json).write_text(json.dumps({"baseline": args.baseline, "levels":
                                               args.levels, "rounds": rows,
                                               "median": summary, "equal": same}, indent=2))


if __name__ == "__main__":
    main()
