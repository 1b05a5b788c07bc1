"""The fans' guard (``foldguard.guard_fans``) on refined animation frames, this tree
against a baseline revision's, on the very same inputs.

The frames' guard runs once (this tree's) over ramps of new activations (refined paper
face and head, each skin model), and every call of the fans' guard is kept with its inputs
(its terms copied as they were, the fans' own caches left out: each refined frame is a new
skin); then each call is timed with this tree's function and the baseline's, interleaved
(the order swapped every round), and the points and W they return are checked equal bit
for bit. The figures are the fans' share of a frame alone (the whole frame:
``bench_folds.py --animation --light``, the fans' cost being on minus light).

Usage: python benchmarks/bench_fans_refined.py [--baseline 1136608] [--frames 8]
       [--rounds 5] [--faces paper,head] [--skin-model both]
"""

from __future__ import annotations

import copy
import time

import numpy as np
from _timing import alternating, alternating_line, refined_parser

CASES = {"paper": (None, ("surprise", "pucker")),
         "head": ("lee_perry_smith", ("surprise", "smile"))}


def _module_at(ref: str):
    """``wrinkle_vis.core.foldguard`` as of ``ref``, imported inside the package."""
    from _foldguard_at import foldguard_at

    return foldguard_at(ref, "foldguard_fans_baseline")


def _captured(face_name: str | None, expr: str, skin: str, frames: int) -> list[tuple]:
    """The fans' guards of a ramp of ``frames`` refined frames (intensity 0 to 1): each
    call's arguments, its terms deep-copied as they were when it was called."""
    import wrinkle_vis as wv
    from wrinkle_vis.core import foldguard

    calls, own = [], foldguard.frame.guard_fans

    def keep(deformed, points, W, tri, terms=None, rest=None):
        kept = {k: v for k, v in (terms or {}).items() if not k.startswith("fan")}
        calls.append((np.array(deformed), np.array(points), np.array(W), np.array(tri),
                      copy.deepcopy(kept), None if rest is None else np.array(rest)))
        return own(deformed, points, W, tri, terms, rest)

    foldguard.frame.guard_fans = keep
    try:
        face = wv.datasets.load_face(*(() if face_name is None else (face_name,)))
        for i in np.linspace(0.0, 1.0, frames)[1:]:
            face.evaluate(expr, float(i), refine=True, skin=skin, fold_guard=True)
    finally:
        foldguard.frame.guard_fans = own
    return calls


def _same(a: tuple, b: tuple) -> bool:
    """Whether two calls' outputs are bit for bit the same."""
    return all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


def _timed(fn, call) -> tuple[float, float, tuple]:
    args = (*call[:4], copy.deepcopy(call[4]), call[5])
    w, c = time.perf_counter(), time.process_time()
    out = fn(*args)
    return time.perf_counter() - w, time.process_time() - c, out


def case(face_name: str | None, expr: str, skin: str, frames: int, rounds: int,
         old) -> dict:
    """One ramp's fans: per-frame medians over ``rounds`` (wall, CPU) for both trees."""
    from wrinkle_vis.core import foldguard

    calls = _captured(face_name, expr, skin, frames)
    runs = {"new": foldguard.guard_fans, "old": old.guard_fans}
    return alternating(runs, calls, rounds, _timed, _same)


def main() -> None:
    ap = refined_parser(__doc__, "1136608")
    ap.add_argument("--faces", default="paper,head")
    args = ap.parse_args()
    old = _module_at(args.baseline)
    skins = ("geometric", "physical") if args.skin_model == "both" else (args.skin_model,)
    for name in args.faces.split(","):
        face_name, exprs = CASES[name]
        for skin in skins:
            for expr in exprs:
                v = case(face_name, expr, skin, args.frames, args.rounds, old)
                print(alternating_line(f"{name} refined {expr:9s} ({skin:9s})",
                                       "calls: a frame's fans", v, args.baseline),
                      flush=True)


if __name__ == "__main__":
    main()
