"""The fold certificate against ``core.mesh.self_intersections``, a frame's report on its
changed region against every pair, and what the fold guard adds to a frame (unrefined and
refined; the rest skin's radii and terms computed once, before timing).

Run:  .venv/bin/python benchmarks/bench_folds.py [--rounds 3] [--json out.json]
      [--baseline main] [--guard-only] [--intensities 0.25,0.5,1] [--faces paper,head]
      [--skin-model geometric|physical|both] [--animation 12]

``--baseline REV``: that revision's fold guard (``core/foldguard``) guards the same frames,
taking turns call by call with this tree's and with no guard (wall and CPU time; the frames
compared).
``--intensities``: the guard's frames at each of these intensities (the certified skips of
``foldguard.certify`` hold at the lower ones); ``--faces``: the procedural face, the head or
both; ``--skin-model``: the skin the guard's frames are evaluated on (default the geometric;
``both``: each in turn).

The guard's frames above are one frame asked again and again: on the physical skin that is a
cached repeat of the equilibrium, not a frame a user meets. ``--animation N`` times what a
user meets instead: an expression's intensity ramping from 0 to 1 over ``N`` frames, every
frame new activations (as ``FaceModel.play`` and the app's timeline ask for them: one
``evaluate`` a frame), the whole ramp with the guard off, on, and (``--baseline``) on with
that revision's guard, taking turns ramp by ramp; on the physical skin each frame solves its
equilibrium, once from rest and once with ``warm_start=True`` (the app's still frames while
a muscle is dragged). Every timed ramp's intensities are shifted by a few parts in
:math:`10^9` so that no frame of any ramp is a cached repeat of another's (the physical
skin keeps its latest still frame and its warm starts by activations). The frames are
compared bit for bit with the baseline's (and, where the guard does not act, with the
unguarded ones) in an untimed pass first.

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
    module (its ``guarded`` takes the same face and state; :mod:`_foldguard_at`)."""
    from _foldguard_at import foldguard_at

    return foldguard_at(ref)


def _as_baseline(foldguard, old):
    """This tree's ``FoldGuard`` with the baseline module ``old``'s defaults (``fans``,
    opt-in up to stop 40, defaults to ``"refined"`` since: a baseline's guard reading this
    tree's default would run its fans everywhere)."""
    import dataclasses

    base = old.FoldGuard()
    return foldguard.FoldGuard(**{f.name: getattr(base, f.name)
                                  for f in dataclasses.fields(base)})


def _cases(cases: tuple, faces: tuple[str, ...]):
    """Per case of ``cases`` ((face, refine, expressions)) whose face is in ``faces``: the
    face, a twin for the baseline's guard (caches of its own: their layout may differ), the
    module `guarded` is looked up in, refine and the expressions."""
    import wrinkle_vis as wv

    for face_name, refine, exprs in cases:
        if ("paper" if face_name is None else "head") not in faces:
            continue
        face, twin = (wv.datasets.load_face(*(() if face_name is None else (face_name,)))
                      for _ in range(2))
        yield face, twin, sys.modules[type(face).guarded.__module__], refine, exprs


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
          faces: tuple[str, ...] = ("paper", "head"), skin: str = "geometric") -> dict:
    """The guarded frame against the unguarded one (``evaluate``; the rest skin's radii and
    terms cached by a first call), and, with ``baseline`` (a git revision), against that
    revision's guard on the same frames, the three taking turns call by call. Wall and
    process CPU time (the CPU time is what a shared machine's load disturbs least)."""
    from wrinkle_vis.core import foldguard

    old = _baseline_guard(baseline) if baseline else None
    out = {}
    for face, twin, host, refine, exprs in _cases(GUARD_CASES, faces):
        for expr, level in ((e, i) for e in exprs for i in intensities):
            def on(module, e=expr, i=level, r=refine, f=face, h=host, own=host.guarded, g=True):
                h.guarded = module.guarded
                try:
                    return f.evaluate(e, i, refine=r, fold_guard=g, skin=skin)
                finally:
                    h.guarded = own

            runs = {"off": lambda e=expr, i=level, r=refine, f=face: f.evaluate(
                        e, i, refine=r, fold_guard=False, skin=skin),
                    "on": lambda: on(foldguard)}
            if old is not None:
                runs["baseline"] = lambda on=on, t=twin: on(old, f=t,
                                                            g=_as_baseline(foldguard, old))
            s = runs["on"]()  # radii, caches, hierarchy: once
            same = None
            if old is not None:
                b = runs["baseline"]()
                same = all(np.array_equal(getattr(s, k), getattr(b, k))
                           for k in ("points", "W", "deformed_points", "fold_guard"))
            t = _interleaved(runs, 3 if refine else 15, rounds)
            key = f"{face.name.split(' (')[0]} {'refined' if refine else 'unrefined'} {expr}"
            if skin != "geometric":
                key += f" ({skin})"
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


ANIMATION_CASES = (  # (face, refine, expressions) of the animation frames
    (None, False, ("surprise", "frown", "smile", "pucker", "waters_anger")),
    (None, True, ("surprise", "pucker")),
    ("lee_perry_smith", False, ("surprise", "smile", "pucker")),
    ("lee_perry_smith", True, ("surprise", "smile")),
)

_FIELDS = ("points", "W", "deformed_points", "fold_guard")


def _ramp(n: int, shift: float) -> np.ndarray:
    """``(n,)``: intensities from 0 to 1, each times ``1 - shift``."""
    return np.linspace(0.0, 1.0, n) * (1.0 - shift)


def _same(a, b, fields=_FIELDS) -> bool:
    """Whether two frames are bit for bit the same (``fold_guard`` None on unguarded ones)."""
    return all(np.array_equal(np.asarray(getattr(a, k)), np.asarray(getattr(b, k)))
               if getattr(a, k) is not None and getattr(b, k) is not None
               else getattr(a, k) is getattr(b, k) for k in fields)


def _timed_ramps(runs: dict, n: int, passes: int, rounds: int) -> dict:
    """``{name: (wall s, CPU s)}`` a frame: medians over ``rounds`` of the medians over
    ``passes`` ramps of each ramp's mean, the functions in ``runs`` (``intensities ->
    frames``) taking turns ramp by ramp; every ramp's intensities its own (:func:`_ramp`)."""
    import itertools
    import statistics
    import time

    count = itertools.count(1)
    out = {k: ([], []) for k in runs}
    for _ in range(rounds):
        per = {k: ([], []) for k in runs}
        for _ in range(passes):
            for k, fn in runs.items():
                levels = _ramp(n, 3e-9 * next(count))
                t0, c0 = time.perf_counter(), time.process_time()
                fn(levels)
                per[k][0].append((time.perf_counter() - t0) / n)
                per[k][1].append((time.process_time() - c0) / n)
        for k in runs:
            out[k][0].append(statistics.median(per[k][0]))
            out[k][1].append(statistics.median(per[k][1]))
    return {k: (statistics.median(w), statistics.median(c)) for k, (w, c) in out.items()}


def animation(rounds: int, frames: int, baseline: str | None = None,
              faces: tuple[str, ...] = ("paper", "head"),
              skins: tuple[str, ...] = ("geometric", "physical"),
              only: tuple[str, ...] = (), fans: bool = False, light: bool = False) -> dict:
    """The guard's share of animation frames (module notes, ``--animation``): per face,
    refinement, expression, skin and (physical) warm start, the mean frame of a ramp of
    ``frames`` intensities with the guard off, on and (``baseline``) that revision's;
    ``only``: the cases whose name (refined/unrefined, expression) holds all of these words;
    ``fans``: also this tree's guard with ``FoldGuard(fans=True)``; ``light``: with
    ``FoldGuard(fans=False)`` (``--fold-guard light``)."""
    from wrinkle_vis.core import foldguard

    old = _baseline_guard(baseline) if baseline else None
    out = {}
    for face, twin, host, refine, exprs in _cases(ANIMATION_CASES, faces):
        for expr, skin in ((e, k) for e in exprs for k in skins):
            name = f"{'refined' if refine else 'unrefined'} {expr}"
            if not all(w in name.split() for w in only):
                continue
            for warm in ((False, True) if skin == "physical" else (False,)):
                def ramp(levels, module, e=expr, r=refine, f=face, k=skin, w=warm,
                         h=host, own=host.guarded, g=True):
                    if module is None:
                        return [f.evaluate(e, float(i), refine=r, skin=k, warm_start=w,
                                           fold_guard=False) for i in levels]
                    h.guarded = module.guarded
                    try:
                        return [f.evaluate(e, float(i), refine=r, skin=k, warm_start=w,
                                           fold_guard=g) for i in levels]
                    finally:
                        h.guarded = own

                runs = {"off": lambda v, ramp=ramp: ramp(v, None),
                        "on": lambda v, ramp=ramp: ramp(v, foldguard)}
                if old is not None:  # (the baseline's own default guard: its fans default)
                    runs["baseline"] = lambda v, ramp=ramp, t=twin: ramp(
                        v, old, f=t, g=_as_baseline(foldguard, old))
                if fans:
                    runs["fans"] = lambda v, ramp=ramp: ramp(
                        v, foldguard, g=foldguard.FoldGuard(fans=True))
                if light:
                    runs["light"] = lambda v, ramp=ramp: ramp(
                        v, foldguard, g=foldguard.FoldGuard(fans=False))
                out.update(_animation_case(face, refine, expr, skin, warm, runs, frames,
                                           rounds))
    return out


def _animation_case(face, refine: bool, expr: str, skin: str, warm: bool, runs: dict,
                    frames: int, rounds: int) -> dict:
    """One line of :func:`animation`: the untimed check (frames against the baseline's,
    and the unguarded ones where the guard did not act), then the timed ramps."""
    levels = _ramp(frames, 1e-3 if warm else 0.0)  # (warm: none of the cold ramp's starts)
    got = {k: fn(levels) for k, fn in runs.items()}  # caches, hierarchy; compared
    acted = [int(np.count_nonzero(s.fold_guard)) for s in got["on"]]
    idle_same = same = None  # warm starts: each ramp starts from the one before, not bit
    if not warm:  # for bit (the cold ramps stand for them)
        idle_same = all(_same(a, b, ("points", "W", "deformed_points"))
                        for a, b, k in zip(got["on"], got["off"], acted, strict=True) if not k)
        same = (all(_same(a, b) for a, b in zip(got["on"], got["baseline"], strict=True))
                if "baseline" in got else None)
    del got
    heavy = face.skin.n_points > 5000 and (skin == "physical" or refine)
    t = _timed_ramps(runs, frames, 1 if heavy else 3, rounds)
    key = (f"{face.name.split(' (')[0]} {'refined' if refine else 'unrefined'} {expr} "
           f"({skin}{', warm' if warm else ''})")
    v = {"frames": frames, "acting_frames": sum(1 for k in acted if k),
         "idle_same_as_off": idle_same, "same_as_baseline": same,
         **{f"{k}_s": x[0] for k, x in t.items()},
         **{f"{k}_cpu_s": x[1] for k, x in t.items()},
         "share": t["on"][0] / t["off"][0] - 1.0,
         "share_cpu": t["on"][1] / t["off"][1] - 1.0, "load": os.getloadavg()[0]}
    if "baseline" in t:
        v["share_baseline_cpu"] = t["baseline"][1] / t["off"][1] - 1.0
    print(_animation_line(key, v), flush=True)
    return {key: v}


def _animation_line(key: str, v: dict) -> str:
    base = (f", baseline {v['baseline_s'] * 1e3:7.2f} ({v['baseline_cpu_s'] * 1e3:7.2f}) ms "
            f"(CPU {v['share_baseline_cpu']:+.0%})"
            f"{' FRAMES DIFFER' if v['same_as_baseline'] is False else ''}"
            ) if "baseline_s" in v else ""
    idle = " IDLE FRAMES DIFFER FROM UNGUARDED" if v["idle_same_as_off"] is False else ""
    if "fans_s" in v:
        base += f", fans {v['fans_s'] * 1e3:7.2f} ({v['fans_cpu_s'] * 1e3:7.2f}) ms"
    if "light_s" in v:
        base += f", light {v['light_s'] * 1e3:7.2f} ({v['light_cpu_s'] * 1e3:7.2f}) ms"
    return (f"animation {key:46s} {v['acting_frames']:2d}/{v['frames']} acting: a frame, "
            f"wall (CPU) off {v['off_s'] * 1e3:7.2f} ({v['off_cpu_s'] * 1e3:7.2f}), "
            f"on {v['on_s'] * 1e3:7.2f} ({v['on_cpu_s'] * 1e3:7.2f}) ms "
            f"(guard {v['share']:+.0%}, CPU {v['share_cpu']:+.0%}){base}{idle} "
            f"[load {v['load']:.2f}]")


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
    ap.add_argument("--skin-model", default="geometric",
                    choices=("geometric", "physical", "both"),
                    help="the skin of the guard's frames (default geometric)")
    ap.add_argument("--cases", default="",
                    help="only the animation cases named by all these comma-separated words "
                         "(refined or unrefined, an expression: refined,pucker)")
    ap.add_argument("--animation", type=int, default=0, metavar="N",
                    help="time ramps of N frames (intensity 0 to 1) instead of repeats")
    ap.add_argument("--fans", action="store_true",
                    help="--animation: also time the guard with FoldGuard(fans=True)")
    ap.add_argument("--light", action="store_true",
                    help="--animation: also time the guard with FoldGuard(fans=False)")
    args = ap.parse_args()
    levels = tuple(float(v) for v in args.intensities.split(","))
    faces = tuple(args.faces.split(","))
    skins = ("geometric", "physical") if args.skin_model == "both" else (args.skin_model,)
    if args.animation:
        if args.animation < 2:
            ap.error(f"--animation {args.animation}: a ramp needs at least 2 frames")
        print(f"load average {os.getloadavg()[0]:.2f}")
        res = {"animation": animation(args.rounds, args.animation, args.baseline, faces,
                                      skins, tuple(filter(None, args.cases.split(","))),
                                      args.fans, args.light)}
        if args.json:
            args.json.write_text(json.dumps(res, indent=1))
        print(f"load average {os.getloadavg()[0]:.2f}")
        return
    if args.guard_only:
        res = {"certificate": {}, "frame_report": {},
               "guard": {k: v for sk in skins
                         for k, v in guard(args.rounds, args.baseline, levels, faces,
                                           sk).items()}}
    else:
        res = {"certificate": certificate(args.rounds), "frame_report": frame_report(args.rounds),
               "guard": {k: v for sk in skins
                         for k, v in guard(args.rounds, args.baseline, levels, faces,
                                           sk).items()}}
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
