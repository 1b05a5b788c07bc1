"""The app's probe per frame (``Session.probe``: every field at the probed point of the rest
skin, read from the compact per-muscle data, and ``Session.probe_position``, where its
marker goes: what the probe panel asks each frame), with this tree's code and a baseline
tree's, side by side in one run.

Run:  .venv/bin/python benchmarks/bench_probe.py [--baseline /tmp/base] [--triangles 4500]
      [--expressions surprise frown] [--frames 15] [--rounds 3]

``--baseline``: a checkout of the code to compare with (``git worktree add /tmp/base main``);
its ``wrinkle_vis`` is imported through ``PYTHONPATH`` (``wrinkle_vis.datasets``, which the
editable install maps to this tree's ``datasets``, is this tree's for both). The two trees
run alternately, each round in a fresh process of its own (the order swapped every round).

In a round, for each expression, unrefined and refined: a point inside a triangle of the
expression's first muscle's wrinkling region is probed while ``--frames`` intensities play
round and round as Play does (a first pass, not timed, lets the refinement's hierarchy grow
to what they need); each probe gets a frame of its own, evaluated before the clock starts.
Wall clock and CPU time (``time.process_time``: on a machine busy with other work a wall
time also counts the waits for a core); medians of the frames, median over the rounds.
Both trees' probes at the same frames must be equal, bit for bit (checked).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _probe_point(face, expression: str):
    """A point inside a triangle of the wrinkling region of ``expression``'s first muscle."""
    import numpy as np

    from wrinkle_vis.app.session import SurfacePoint

    muscle = next(iter(face.expressions[expression].activations))
    region = face.muscle_data(face.muscle(muscle)).region
    tri = int(np.flatnonzero((face.skin.triangles == region[len(region) // 2]).any(1))[0])
    return SurfacePoint(tri, (0.2, 0.3, 0.5))


def _plain(values: dict) -> dict:
    """The probe's values with NaN as None (JSON)."""
    return {k: {f: None if math.isnan(v) else v for f, v in d.items()}
            for k, d in values.items()}


def one_round(triangles: int, expressions: list[str], frames: int) -> dict:
    """One round in this process: ``{"ms": {"<expr> <refined|unrefined> <probe|evaluate>
    <cpu|wall>": median ms}, "values": {"<expr> <refined|unrefined> <i>": probe}}``.
    """
    import numpy as np

    import wrinkle_vis as wv
    from wrinkle_vis.app.session import Session

    face = wv.datasets.load_face(n_triangles=triangles)
    intensities = np.linspace(0.4, 1.0, frames)
    ms: dict[str, float] = {}
    values: dict[str, dict] = {}
    for expression in expressions:
        where = _probe_point(face, expression)
        for refine in (False, True):
            session = Session(face)
            session.set_expression(expression)
            session.set_refine(refine)
            label = f"{expression} {'refined' if refine else 'unrefined'}"
            per: dict[str, list[float]] = {}
            for timed in (False, True):
                for i, intensity in enumerate(intensities):
                    session.set_intensity(float(intensity))
                    session._state = None  # a new frame: nothing built in it
                    t0, c0 = time.perf_counter(), time.process_time()
                    session.state()
                    t1, c1 = time.perf_counter(), time.process_time()
                    got = session.probe(where)
                    session.probe_position(where)  # the marker's: the panel asks both
                    t2, c2 = time.perf_counter(), time.process_time()
                    if not timed:
                        continue
                    for key, value in (("probe wall", t2 - t1), ("probe cpu", c2 - c1),
                                       ("evaluate wall", t1 - t0),
                                       ("evaluate cpu", c1 - c0)):
                        per.setdefault(f"{label} {key}", []).append(1e3 * value)
                    values[f"{label} {i}"] = _plain(got)
            ms.update({k: statistics.median(v) for k, v in per.items()})
    return {"ms": ms, "values": values}


def _run(tree: Path, args) -> dict:
    """One round in a fresh process importing ``wrinkle_vis`` from ``tree``."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", "--triangles",
           str(args.triangles), "--frames", str(args.frames), "--expressions",
           *args.expressions]
    out = subprocess.run(cmd, env=env, cwd=tree, check=True, capture_output=True, text=True)
    return json.loads(out.stdout.splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, default=None)
    parser.add_argument("--triangles", type=int, default=4500)
    parser.add_argument("--expressions", nargs="+", default=["surprise", "frown"])
    parser.add_argument("--frames", type=int, default=15)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(one_round(args.triangles, args.expressions, args.frames)))
        return
    trees = {"this tree": ROOT}
    if args.baseline is not None:
        trees = {"baseline": args.baseline.resolve(), **trees}
    print(f"{args.triangles} triangles, {args.frames} frames, {args.rounds} rounds; "
          f"load average {os.getloadavg()[0]:.2f}")
    rounds: dict[str, list[dict]] = {name: [] for name in trees}
    for r in range(args.rounds):
        order = list(trees.items()) if r % 2 == 0 else list(trees.items())[::-1]
        for name, tree in order:
            rounds[name].append(_run(tree, args))
    results = {name: {k: statistics.median(rd["ms"][k] for rd in rs) for k in rs[0]["ms"]}
               for name, rs in rounds.items()}
    if "baseline" in rounds:
        same = rounds["baseline"][0]["values"] == rounds["this tree"][0]["values"]
        print(f"probe values of the two trees equal at every frame: {same}")
    for key in results["this tree"]:
        row = "  ".join(f"{name} {ms[key]:7.3f}" for name, ms in results.items())
        ratio = (f"  ({results['baseline'][key] / results['this tree'][key]:.1f}x)"
                 if "baseline" in results else "")
        print(f"{key:40s} {row} ms{ratio}")
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
