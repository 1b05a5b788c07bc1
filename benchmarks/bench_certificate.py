"""The fold certificate (``core.certificate.intersecting_pairs``) of this tree against a
baseline commit's, side by side in one process: the same meshes, the two called alternately,
wall-clock and CPU seconds, and whether they find the same pairs.

Run:  .venv/bin/python benchmarks/bench_certificate.py [--baseline main] [--rounds 7]
      [--json out.json]

``--baseline`` is a git revision whose ``wrinkle_vis/core/certificate.py`` (numpy only) is
loaded beside this tree's, or the path of a module with the same ``intersecting_pairs`` (for
example ``tests/certificate_reference.py``, stop 35's certificate kept verbatim). Every
figure is the median over ``--rounds`` rounds; each round calls the baseline and this tree
once each, in alternating order. The load average before and after is printed: on a shared
machine the CPU seconds move less than the wall-clock ones.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))


def _module(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def meshes() -> dict:
    """The benchmark's meshes: the bumped, jittered square of about 50,000 and 200,000
    triangles, the head scan at rest and its unguarded smile (17,684 triangles)."""
    from bench_folds import wavy_surface

    import wrinkle_vis as wv

    head = wv.datasets.load_face("lee_perry_smith")
    smile = head.evaluate("smile", fold_guard=False)
    out = {"wavy 50k": wavy_surface(), "wavy 200k": wavy_surface(317),
           "head at rest": head.skin, "head smile, unguarded": smile}
    return {k: (np.asarray(s.points, float), np.asarray(s.triangles)) for k, s in out.items()}


def _timed(fn) -> tuple[float, float, object]:
    w, c = time.perf_counter(), time.process_time()
    out = fn()
    return time.perf_counter() - w, time.process_time() - c, out


def _same(a, b) -> bool:
    """The same pairs and degenerate flags, whatever their order."""
    (pa, da), (pb, db) = a, b
    oa, ob = np.lexsort((pa[:, 1], pa[:, 0])), np.lexsort((pb[:, 1], pb[:, 0]))
    return bool(np.array_equal(pa[oa], pb[ob]) and np.array_equal(da[oa], db[ob]))


def compare(old, new, pts, tri, rounds: int) -> dict:
    """Median wall and CPU seconds of both certificates on one mesh, and their agreement."""
    fns = {"baseline": lambda: old.intersecting_pairs(pts, tri, with_degenerate=True),
           "this tree": lambda: new.intersecting_pairs(pts, tri, with_degenerate=True)}
    rows = {k: [] for k in fns}
    results = {k: f() for k, f in fns.items()}  # warm up (and the answers)
    for r in range(rounds):
        for name in (list(fns) if r % 2 == 0 else list(fns)[::-1]):
            rows[name].append(_timed(fns[name])[:2])
    out = {name: {"wall_s": statistics.median(w for w, _ in v),
                  "cpu_s": statistics.median(c for _, c in v)} for name, v in rows.items()}
    out["same_pairs"] = _same(results["baseline"], results["this tree"])
    out["pairs"] = int(len(results["this tree"][0]))
    out["triangles"] = int(len(tri))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default="main")
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    load_before = os.getloadavg()
    if args.baseline.endswith(".py"):
        old = _module(ROOT / args.baseline, "certificate_baseline")
    else:
        with tempfile.TemporaryDirectory() as tmp:
            src = Path(tmp) / "certificate_baseline.py"
            src.write_bytes(subprocess.run(
                ["git", "-C", str(ROOT), "show",
                 f"{args.baseline}:wrinkle_vis/core/certificate.py"],
                check=True, capture_output=True).stdout)
            old = _module(src, "certificate_baseline")
    new = _module(ROOT / "wrinkle_vis" / "core" / "certificate.py", "certificate_this_tree")
    res = {name: compare(old, new, pts, tri, args.rounds)
           for name, (pts, tri) in meshes().items()}
    load = {"before": load_before, "after": os.getloadavg()}
    print(f"{'':24}{'triangles':>10}{'baseline wall / cpu ms':>25}{'this wall / cpu ms':>22}"
          f"{'cpu ratio':>10}  same pairs")
    for name, r in res.items():
        b, t = r["baseline"], r["this tree"]
        print(f"{name:24}{r['triangles']:>10}{b['wall_s'] * 1e3:>14.0f} / {b['cpu_s'] * 1e3:6.0f}"
              f"{t['wall_s'] * 1e3:>13.0f} / {t['cpu_s'] * 1e3:5.0f}"
              f"{b['cpu_s'] / t['cpu_s']:>10.1f}  {r['same_pairs']} ({r['pairs']})")
    print(f"load average (1 min) {load['before'][0]:.2f} before, {load['after'][0]:.2f} after "
          f"(baseline {args.baseline})")
    if args.json:
        args.json.write_text(json.dumps({"baseline": args.baseline, "rounds": args.rounds,
                                         "load": load, "meshes": res}, indent=1))


if __name__ == "__main__":
    main()
