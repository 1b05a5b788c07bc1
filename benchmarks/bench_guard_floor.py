"""What the fold guard adds to a refined frame, beside the cost of the least work any sound
guard of its kind must do on that frame (the floor of the 30 % target of issue 29).

Run:  .venv/bin/python benchmarks/bench_guard_floor.py [--frames 8] [--rounds 3]
      [--faces paper,head] [--skin-model geometric,physical] [--json out.json]

Per case (face, skin, expression), over a ramp of ``--frames`` new activations from 0 to 1
(shifted by a few parts in :math:`10^9` per call, so no frame is a cached repeat), the sums
over the ramp of:

* ``off``: ``evaluate(refine=True, fold_guard=False)``, the frame the target is relative to;
* ``on``: the same frame with the default guard;
* ``turned``: the turned-over test of the frame's triangles, one cross product per triangle
  on the skin before W and after (:math:`n_t \\cdot n'_t \\le 0`): the least a guard that
  checks each triangle's fan once must compute;
* ``tree``: a ``cKDTree`` over the frame's skin before W (the skin the empty balls touch);
* ``query``: the two nearest vertices of every vertex W moves, in that tree: one query per
  moved vertex, the least a search for the empty balls on the deformed skin costs.

``tree + query`` is what a guard pays as soon as it must find the balls on the frame's own
skin (the rest skin's radii settle 15-35 % of a refined frame's vertices, stop 40), and
``turned`` what it pays for a local test of the fans. Each is printed as a percentage of
``off``. Every figure is the median over ``--rounds`` rounds.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import numpy as np
from scipy.spatial import cKDTree

CASES = (("paper", ("surprise", "pucker")), ("head", ("surprise", "smile")))


def _timed(fn) -> tuple[float, object]:
    """Seconds one call of ``fn`` took, and what it returned."""
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def _floor(frame) -> dict[str, float]:
    """Seconds of the floor's three parts on one refined frame (see the module's text)."""
    pts, pre = np.asarray(frame.points), np.asarray(frame.deformed_points)
    tri = np.asarray(frame.triangles)
    moved = np.flatnonzero(np.asarray(frame.W) != 0.0)

    def turned() -> int:
        n0, n1 = (np.cross(x[tri[:, 1]] - x[tri[:, 0]], x[tri[:, 2]] - x[tri[:, 0]])
                  for x in (pre, pts))
        return int((np.einsum("ij,ij->i", n0, n1) <= 0.0).sum())

    t_turned = _timed(turned)[0]
    t_tree, tree = _timed(lambda: cKDTree(pre, leafsize=32))
    t_query = _timed(lambda: tree.query(pre[moved], k=2))[0]
    return {"turned": t_turned, "tree": t_tree, "query": t_query}


def ramp_round(face, expr: str, skin: str, frames: int, shift: float) -> dict[str, float]:
    """One round: each frame of the ramp off, on, and its floor; the sums (seconds)."""
    sums = dict.fromkeys(("off", "on", "turned", "tree", "query"), 0.0)
    for level in np.linspace(0.0, 1.0, frames)[1:]:
        for guard, tag in ((False, "off"), (True, "on")):
            at = float(level) * (1.0 - shift * (2 if guard else 1))
            dt, frame = _timed(lambda g=guard, a=at: face.evaluate(
                expr, a, refine=True, skin=skin, fold_guard=g))
            sums[tag] += dt
            if not guard:
                for k, v in _floor(frame).items():
                    sums[k] += v
    return sums


def run(frames: int, rounds: int, faces: tuple[str, ...], skins: tuple[str, ...]) -> dict:
    import wrinkle_vis as wv

    out = {}
    for name, exprs in CASES:
        if name not in faces:
            continue
        face = wv.datasets.load_face(*(() if name == "paper" else ("lee_perry_smith",)))
        for expr in exprs:
            for skin in skins:
                ramp_round(face, expr, skin, frames, 1e-9)  # warm: caches, terms
                per = [ramp_round(face, expr, skin, frames, 1e-9 * (r + 2))
                       for r in range(rounds)]
                med = {k: statistics.median(p[k] for p in per) for k in per[0]}
                out[f"{name} {skin} {expr}"] = med
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--faces", default="paper,head")
    ap.add_argument("--skin-model", default="geometric,physical")
    ap.add_argument("--json")
    a = ap.parse_args()
    res = run(a.frames, a.rounds, tuple(a.faces.split(",")), tuple(a.skin_model.split(",")))
    print(f"{'case':32s} {'off ms':>8s} {'guard %':>8s} {'turned %':>9s} {'tree %':>7s}"
          f" {'query %':>8s} {'tree+query %':>13s}")
    for case, m in res.items():
        pct = {k: 100.0 * v / m["off"] for k, v in m.items()}
        print(f"{case:32s} {1e3 * m['off'] / (a.frames - 1):8.2f} {pct['on'] - 100:8.0f}"
              f" {pct['turned']:9.0f} {pct['tree']:7.0f} {pct['query']:8.0f}"
              f" {pct['tree'] + pct['query']:13.0f}")
    if a.json:
        from pathlib import Path
        Path(a.json).write_text(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
