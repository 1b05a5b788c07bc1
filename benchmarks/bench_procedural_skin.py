"""The procedural skin's build and its frames with this tree's code and a baseline commit's,
side by side: the two run alternately, each in a fresh process, round after round (stop 37:
the skin graded round the lips).

Run:  .venv/bin/python benchmarks/bench_procedural_skin.py [--baseline REF] [--rounds 3]
      [--triangles 4500] [--json out.json]

``--baseline`` is a git revision extracted into a temporary folder (``git archive``) with its
own ``datasets`` (linked in as ``wrinkle_vis.datasets``, so its skin is the baseline's). A
round times each version once in a fresh process with an empty cache: ``build_skin`` (the
level set, pyacvd, the projections), then ``load_face`` (the skull and layout from the
cache), the first unrefined frame of ``smile``, the median of 5 more (at 0.90-0.98 of
it), and the first refined frames of ``smile``, ``pucker`` and ``surprise`` (with their
refined triangle counts).
Figures are medians over the rounds, wall and CPU (``time.process_time``).
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
import json, sys, time
import numpy as np
import wrinkle_vis as wv
from wrinkle_vis.datasets.face import build_skin
n = int(sys.argv[1])
out = {}
def timed(key, fn):
    w, c = time.perf_counter(), time.process_time()
    value = fn()
    out[key] = (time.perf_counter() - w, time.process_time() - c)
    return value
timed("build_skin", lambda: build_skin(n))
face = timed("load_face", lambda: wv.datasets.load_face(n))
timed("first smile", lambda: face.evaluate("smile"))
walls, cpus = [], []
smile = face.expressions["smile"].activations
for i in range(5):  # other activations each time: no frame is reused
    acts = {m: a * (0.9 + 0.02 * i) for m, a in smile.items()}
    w, c = time.perf_counter(), time.process_time()
    face.evaluate(acts)
    walls.append(time.perf_counter() - w)
    cpus.append(time.process_time() - c)
out["smile (median of 5)"] = (float(np.median(walls)), float(np.median(cpus)))
for name in ("smile", "pucker", "surprise"):
    state = timed(f"refined {name}", lambda name=name: face.evaluate(name, refine=True))
    out[f"refined {name} triangles"] = (state.face.skin.n_triangles, 0)
print(json.dumps({"file": wv.__file__, "times": out}))
"""


def baseline_tree(ref: str, folder: Path) -> Path:
    """``ref``'s tree extracted into ``folder``, its ``datasets`` and ``widgets`` linked
    under ``wrinkle_vis`` (what the editable install maps for this tree).
    """
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", ref], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(folder)], input=archive, check=True)
    for name in ("datasets", "widgets"):
        (folder / "wrinkle_vis" / name).symlink_to(folder / name)
    return folder


def run(tree: Path, n: int) -> dict:
    """One round of one version in a fresh process with an empty face cache."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, PYTHONPATH=str(tree), WRINKLE_VIS_CACHE=cache)
        text = subprocess.run([sys.executable, "-c", CHILD, str(n)], env=env, cwd=tree,
                              check=True, capture_output=True, text=True).stdout
    got = json.loads(text.strip().splitlines()[-1])
    assert Path(got["file"]).resolve().is_relative_to(tree.resolve()), got["file"]
    return got["times"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", default="9514ff2")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--triangles", type=int, default=4500)
    ap.add_argument("--json")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        trees = {"this tree": ROOT, args.baseline: baseline_tree(args.baseline, Path(tmp))}
        rounds: dict[str, list[dict]] = {k: [] for k in trees}
        for _ in range(args.rounds):
            for key, tree in trees.items():
                rounds[key].append(run(tree, args.triangles))
    print(f"load average {os.getloadavg()[0]:.2f}; medians of {args.rounds} rounds, "
          "wall / CPU seconds (triangle counts for the refined frames)")
    result = {}
    for key, runs in rounds.items():
        result[key] = {k: [statistics.median(r[k][i] for r in runs) for i in (0, 1)]
                       for k in runs[0]}
    names = list(trees)
    print(f"{'':32s}" + "".join(f"{k:>24s}" for k in names))
    for k in result[names[0]]:
        cells = []
        for key in names:
            wall, cpu = result[key][k]
            cells.append(f"{int(wall):>24d}" if "triangles" in k
                         else f"{wall:10.3f} / {cpu:<10.3f}")
        print(f"{k:32s}" + "".join(f"{c:>24s}" for c in cells))
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
