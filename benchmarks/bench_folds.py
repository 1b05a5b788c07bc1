"""The fold certificate against ``core.mesh.self_intersections``, a frame's report on its
changed region against every pair, and what the fold guard adds to a frame (unrefined and
refined; the rest skin's radii and terms computed once, before timing).

Run:  .venv/bin/python benchmarks/bench_folds.py [--rounds 3] [--json out.json]
      [--baseline main] [--guard-only] [--intensities 0.25,0.5,1] [--faces paper,head]

``--baseline REV``: that revision's ``core/foldguard.py`` guards the same frames, taking turns
call by call with this tree's and with no guard (wall and CPU time; the frames compared).
``--intensities``: the guard's frames at each of these intensities (the certified skips of
``foldguard.certify`` hold at the lower ones); ``--faces``: the procedural face, the head or
both.

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


GUARD_CASES = (  # (face, refine, expressions): idle frames and frames the guard acts on
    (None, False, ("surprise", "frown", "smile", "pucker")),
    (None, True, ("surprise", "frown", "smile", "pucker")),
    ("lee_perry_smith", False, ("surprise", "smile", "duchenne_smile", "pucker")),
    ("lee_perry_smith", True, ("surprise", "smile", "duchenne_smile")),
)


def _baseline_guard(ref: str):
    """``wrinkle_vis.core.foldguard`` as of the git revision ``ref``, imported as its own
    module (its ``guarded`` takes the same face and state)."""
    import importlib.util
    import subprocess
    import tempfile

    root = Path(__file__).resolve().parents[1]
    text = subprocess.run(["git", "-C", str(root), "show", f"{ref}:wrinkle_vis/core/foldguard.py"],
                          check=True, capture_output=True, text=True).stdout
    path = Path(tempfile.mkdtemp()) / "foldguard_baseline.py"
    path.write_text(text)
    spec = importlib.util.spec_from_file_location("foldguard_baseline", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def _interleaved(runs: dict, calls: int, rounds: int) -> dict:
    """``{name: (wall s, CPU s)}``: medians over ``rounds`` of the medians of ``calls`` calls of
    each function in ``runs``, the functions taking turns call by call (so load that comes
    and goes falls on all of them alike)."""
    import statistics
    import time

    out = {k: ([], []) for k in runs}
    for _ in range(rounds):
        per = {k: ([], []) for k in runs}
        for _ in range(calls):
            for k, fn in runs.items():
                t0, c0 = time.perf_counter(), time.process_time()
                fn()
                per[k][0].append(time.perf_counter() - t0)
                per[k][1].append(time.process_time() - c0)
        for k in runs:
            out[k][0].append(statistics.median(per[k][0]))
            out[k][1].append(statistics.median(per[k][1]))
    return {k: (statistics.median(w), statistics.median(c)) for k, (w, c) in out.items()}


def guard(rounds: int, baseline: str | None = None, intensities: tuple[float, ...] = (1.0,),
          faces: tuple[str, ...] = ("paper", "head")) -> dict:
    """The guarded frame against the unguarded one (``evaluate``; the rest skin's radii and
    terms cached by a first call), and, with ``baseline`` (a git revision), against that
    revision's guard on the same frames, the three taking turns call by call. Wall and
    process CPU time (the CPU time is what a shared machine's load disturbs least)."""
    import wrinkle_vis as wv
    from wrinkle_vis.core import foldguard

    old = _baseline_guard(baseline) if baseline else None
    out = {}
    for face_name, refine, exprs in GUARD_CASES:
        if ("paper" if face_name is None else "head") not in faces:
            continue
        face = wv.datasets.load_face() if face_name is None else wv.datasets.load_face(
            face_name)
        host = sys.modules[type(face).guarded.__module__]  # where FaceModel finds `guarded`
        for expr, level in ((e, i) for e in exprs for i in intensities):
            def on(module, e=expr, i=level, r=refine, f=face, h=host, own=host.guarded):
                h.guarded = module.guarded
                try:
                    return f.evaluate(e, i, refine=r, fold_guard=True)
                finally:
                    h.guarded = own

            runs = {"off": lambda e=expr, i=level, r=refine, f=face: f.evaluate(
                        e, i, refine=r, fold_guard=False),
                    "on": lambda: on(foldguard)}
            if old is not None:
                runs["baseline"] = lambda: on(old)
            s = runs["on"]()  # radii, caches, hierarchy: once
            same = None
            if old is not None:
                b = runs["baseline"]()
                same = all(np.array_equal(getattr(s, k), getattr(b, k))
                           for k in ("points", "W", "deformed_points", "fold_guard"))
            t = _interleaved(runs, 3 if refine else 15, rounds)
            key = f"{face.name.split(' (')[0]} {'refined' if refine else 'unrefined'} {expr}"
            if len(intensities) > 1 or level != 1.0:
                key += f" at {level:g}"
            out[key] = {"vertices": int(s.n_points), "acted": int(np.count_nonzero(s.fold_guard)),
                        "same_as_baseline": same,
                        **{f"{k}_s": v[0] for k, v in t.items()},
                        **{f"{k}_cpu_s": v[1] for k, v in t.items()},
                        "overhead": t["on"][0] / t["off"][0] - 1.0,
                        "overhead_cpu": t["on"][1] / t["off"][1] - 1.0}
            print(_guard_line(key, out[key]), flush=True)
    return out


def _guard_line(key: str, v: dict) -> str:
    base = (f", baseline {v['baseline_s'] * 1e3:8.2f} ({v['baseline_cpu_s'] * 1e3:8.2f}) ms"
            f"{'' if v['same_as_baseline'] else ' FRAMES DIFFER'}") if "baseline_s" in v else ""
    return (f"guard {key:42s} {v['vertices']:6d} vertices, acted at {v['acted']:6d}: "
            f"wall (CPU) off {v['off_s'] * 1e3:8.2f} ({v['off_cpu_s'] * 1e3:8.2f}), "
            f"on {v['on_s'] * 1e3:8.2f} ({v['on_cpu_s'] * 1e3:8.2f}) ms "
            f"({v['overhead']:+.0%}, CPU {v['overhead_cpu']:+.0%}){base}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--baseline", help="a git revision whose fold guard runs side by side")
    ap.add_argument("--guard-only", action="store_true", help="only the fold guard's cost")
    ap.add_argument("--intensities", default="1",
                    help="comma-separated intensities of the guard's frames (default 1)")
    ap.add_argument("--faces", default="paper,head",
                    help="the guard's faces: paper, head or both (default both)")
    args = ap.parse_args()
    levels = tuple(float(v) for v in args.intensities.split(","))
    faces = tuple(args.faces.split(","))
    if args.guard_only:
        res = {"certificate": {}, "frame_report": {},
               "guard": guard(args.rounds, args.baseline, levels, faces)}
    else:
        res = {"certificate": certificate(args.rounds), "frame_report": frame_report(args.rounds),
               "guard": guard(args.rounds, args.baseline, levels, faces)}
    for k, v in res["certificate"].items():
        print(f"certificate {k:10s} {v['triangles']:6d} triangles: ours "
              f"{v['certificate_s'] * 1e3:8.1f} ms, self_intersections "
              f"{v['self_intersections_s'] * 1e3:8.1f} ms ({v['pairs']} pairs)")
    for k, v in res["frame_report"].items():
        print(f"fold_report {k:14s}: changed region {v['region_s'] * 1e3:7.1f} ms, every pair "
              f"{v['every_pair_s'] * 1e3:7.1f} ms ({v['added']} pairs added)")
    if args.json:
        args.json.write_text(json.dumps(res, indent=1))
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
