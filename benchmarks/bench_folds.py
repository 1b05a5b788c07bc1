"""The fold certificate against ``core.mesh.self_intersections``, a frame's report on its
changed region against every pair, and what the fold guard adds to a frame (unrefined and
refined; the rest skin's radii and terms computed once, before timing).

Run:  .venv/bin/python benchmarks/bench_folds.py [--rounds 3] [--json out.json]

Every figure is the median over ``--rounds`` rounds of the median of several calls.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np
from _timing import median_seconds

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))


def wavy_surface(n_side: int = 159):
    """A bumped square of about 50,000 triangles, jittered (no exactly planar quads)."""
    from meshes import grid

    g = grid(n_side, n_side, bump=20.0)
    rng = np.random.default_rng(0)
    return g.with_points(g.points + rng.normal(scale=0.05, size=g.points.shape))


def certificate(rounds: int) -> dict:
    import wrinkle_vis as wv
    from wrinkle_vis.core.certificate import intersecting_pairs
    from wrinkle_vis.core.mesh import self_intersections

    out = {}
    head = wv.datasets.load_face("lee_perry_smith").skin
    for label, surf in (("wavy 50k", wavy_surface()), ("head scan", head)):
        ours = median_seconds(lambda s=surf: intersecting_pairs(s.points, s.triangles), 3,
                              rounds)
        old = median_seconds(lambda s=surf: self_intersections(s), 3, rounds)
        out[label] = {"triangles": int(surf.n_triangles), "certificate_s": ours,
                      "self_intersections_s": old,
                      "pairs": int(len(intersecting_pairs(surf.points, surf.triangles)))}
    return out


def frame_report(rounds: int) -> dict:
    """``fold_report`` (only the triangles a frame moved and those their boxes reach)
    against testing every pair of the frame, on the head's unguarded frames."""
    import wrinkle_vis as wv
    from wrinkle_vis.core.certificate import _pair_keys, fold_report, intersecting_pairs

    face = wv.datasets.load_face("lee_perry_smith")
    rest_pairs = intersecting_pairs(face.skin.points, face.skin.triangles)
    out = {}
    for expr in ("surprise", "smile", "pucker"):
        s = face.evaluate(expr, fold_guard=False)

        def every(s=s):
            pairs = intersecting_pairs(s.points, s.triangles)
            m = len(s.triangles)
            return pairs[~np.isin(_pair_keys(pairs, m), _pair_keys(rest_pairs, m))]

        region = median_seconds(lambda s=s: fold_report(s.rest_points, s.points, s.triangles,
                                                        rest_pairs), 3, rounds)
        full = median_seconds(every, 3, rounds)
        rep = fold_report(s.rest_points, s.points, s.triangles, rest_pairs)
        assert len(rep.added) == len(every())
        out[f"head {expr}"] = {"region_s": region, "every_pair_s": full,
                               "added": int(len(rep.added))}
    return out


def guard(rounds: int) -> dict:
    import wrinkle_vis as wv

    out = {}
    for face_name in (None, "lee_perry_smith"):
        face = wv.datasets.load_face() if face_name is None else wv.datasets.load_face(
            face_name)
        for refine in (False, True):
            for expr in ("surprise", "smile", "pucker"):
                face.evaluate(expr, refine=refine)  # radii, caches, hierarchy: once
                off = median_seconds(lambda e=expr, r=refine, f=face: f.evaluate(
                    e, refine=r, fold_guard=False), 5, rounds)
                on = median_seconds(lambda e=expr, r=refine, f=face: f.evaluate(
                    e, refine=r, fold_guard=True), 5, rounds)
                s = face.evaluate(expr, refine=refine)
                key = f"{face.name.split(' (')[0]} {'refined' if refine else 'unrefined'} {expr}"
                out[key] = {"vertices": int(s.n_points), "off_s": off, "on_s": on,
                            "overhead": on / off - 1.0,
                            "acted": int(np.count_nonzero(s.fold_guard))}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    res = {"certificate": certificate(args.rounds), "frame_report": frame_report(args.rounds),
           "guard": guard(args.rounds)}
    for k, v in res["certificate"].items():
        print(f"certificate {k:10s} {v['triangles']:6d} triangles: ours "
              f"{v['certificate_s'] * 1e3:8.1f} ms, self_intersections "
              f"{v['self_intersections_s'] * 1e3:8.1f} ms ({v['pairs']} pairs)")
    for k, v in res["frame_report"].items():
        print(f"fold_report {k:14s}: changed region {v['region_s'] * 1e3:7.1f} ms, every pair "
              f"{v['every_pair_s'] * 1e3:7.1f} ms ({v['added']} pairs added)")
    for k, v in res["guard"].items():
        print(f"guard {k:40s} {v['vertices']:6d} vertices: off {v['off_s'] * 1e3:7.2f} ms, "
              f"on {v['on_s'] * 1e3:7.2f} ms ({v['overhead']:+.0%}), acted at {v['acted']}")
    if args.json:
        args.json.write_text(json.dumps(res, indent=1))
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
