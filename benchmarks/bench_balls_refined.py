"""The deformed balls' search (``foldguard._deformed_lows``) on refined animation frames,
this tree against a baseline revision's, on the very same inputs.

The frames' guard runs once (this tree's) over ramps of new activations (refined paper face,
each skin model), and every call of the balls' search is kept with its inputs; then each
call is timed with this tree's function and the baseline's, interleaved, and the results
are checked equal bit for bit. The figures are the balls' share of a frame alone (the rest
of the guard, the fans' above all, is timed by ``bench_folds.py --animation``).

Usage: python benchmarks/bench_balls_refined.py [--baseline 574c064] [--frames 8]
       [--rounds 5] [--cases surprise,pucker] [--face paper|head]
"""

from __future__ import annotations

import time

import numpy as np
from _timing import alternating, alternating_line, refined_parser


def _module_at(ref: str):
    """``wrinkle_vis.core.foldguard`` as of ``ref``, imported inside the package."""
    from _foldguard_at import foldguard_at

    return foldguard_at(ref, "foldguard_balls_baseline")


def _captured(expr: str, skin: str, frames: int, face_name: str = "paper") -> list[tuple]:
    """The balls' searches of a ramp of ``frames`` refined frames (intensity 0 to 1) of the
    paper's face or the real head (``face_name``): each call's arguments, its terms copied
    as they were when it was called."""
    import wrinkle_vis as wv
    from wrinkle_vis.core import foldguard

    calls, own = [], foldguard._deformed_lows  # (the wrinkle step's search, foldguard.frame)

    def keep(deformed, tri, W, terms, guard, step=None, empty=None, clear=None):
        calls.append((deformed.copy(), tri, W.copy(), dict(terms), guard, step, empty, clear))
        return own(deformed, tri, W, terms, guard, step, empty, clear)

    foldguard.frame._deformed_lows = keep
    try:
        face = wv.datasets.load_face(*(() if face_name == "paper" else ("lee_perry_smith",)))
        for i in np.linspace(0.0, 1.0, frames)[1:]:
            face.evaluate(expr, float(i), refine=True, skin=skin, fold_guard=True)
    finally:
        foldguard.frame._deformed_lows = own
    return calls


def _same(a, b) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])


def _timed(fn, call) -> tuple[float, float, object]:
    args = (*call[:3], dict(call[3]), *call[4:])
    w, c = time.perf_counter(), time.process_time()
    out = fn(*args)
    return time.perf_counter() - w, time.process_time() - c, out


def case(expr: str, skin: str, frames: int, rounds: int, old, face_name: str = "paper"
         ) -> dict:
    """One ramp's balls: per-frame medians over ``rounds`` (wall, CPU) for both trees."""
    from wrinkle_vis.core import foldguard

    calls = _captured(expr, skin, frames, face_name)
    runs = {"new": foldguard._deformed_lows, "old": old._deformed_lows}
    return alternating(runs, calls, rounds, _timed, _same)


def main() -> None:
    ap = refined_parser(__doc__, "574c064")
    ap.add_argument("--cases", default="surprise,pucker")
    ap.add_argument("--face", default="paper", choices=("paper", "head"),
                    help="the paper's procedural face or the real head (Lee Perry-Smith)")
    args = ap.parse_args()
    old = _module_at(args.baseline)
    skins = ("geometric", "physical") if args.skin_model == "both" else (args.skin_model,)
    for skin in skins:
        for expr in args.cases.split(","):
            v = case(expr, skin, args.frames, args.rounds, old, args.face)
            print(alternating_line(f"{args.face} refined {expr:9s} ({skin:9s})",
                                   "searches: a frame's balls", v, args.baseline), flush=True)


if __name__ == "__main__":
    main()
