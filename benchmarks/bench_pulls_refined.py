"""The pull guard (``foldguard.skin_scale``) on refined animation frames, this tree against
a baseline revision's, on the very same inputs.

The frames' guard runs once (this tree's) over ramps of new activations (refined paper
face and head, each skin model), and every call of ``skin_scale`` from the frame guard is
kept with its inputs, grouped by frame (the calls that share the refined skin's terms: the
pulls' step and the wrinkles' own step). Each frame is then timed with this tree's module
and the baseline's, interleaved (the order swapped every round), from fresh terms
(``pull_terms`` of the refined rest skin, as a refined frame's new skin starts: its edges,
their graph and the rounds all paid within the frame), and the factors they return are
checked equal bit for bit. The figures are the pull guard's share of a frame alone (the
whole frame: ``bench_folds.py --animation``).

Usage: python benchmarks/bench_pulls_refined.py [--baseline b7a9361] [--frames 8]
       [--rounds 5] [--faces paper,head] [--skin-model both]
"""

from __future__ import annotations

import time

import numpy as np
from _timing import alternating, alternating_line, refined_parser

CASES = {"paper": (None, ("surprise", "pucker")),
         "head": ("lee_perry_smith", ("surprise", "smile"))}


def _captured(face_name: str | None, expr: str, skin: str, frames: int) -> list[list]:
    """The pull guard's calls of a ramp of ``frames`` refined frames (intensity 0 to 1),
    one list per frame: each call's rest, deformed, triangles, positional and keyword
    arguments (its terms left out: each frame starts from fresh ones)."""
    import wrinkle_vis as wv
    from wrinkle_vis.core import foldguard

    calls: list[tuple] = []
    own = foldguard.frame.skin_scale

    def keep(rest, deformed, triangles, *args, terms=None, **kw):
        calls.append((id(terms), np.array(rest), np.array(deformed), np.array(triangles),
                      args, kw))
        return own(rest, deformed, triangles, *args, terms=terms, **kw)

    foldguard.frame.skin_scale = keep
    try:
        face = wv.datasets.load_face(*(() if face_name is None else (face_name,)))
        for i in np.linspace(0.0, 1.0, frames)[1:]:
            calls.append(("frame",))
            face.evaluate(expr, float(i), refine=True, skin=skin, fold_guard=True)
    finally:
        foldguard.frame.skin_scale = own
    out: list[list] = []
    for c in calls:
        if c[0] == "frame":
            out.append([])
        else:
            out[-1].append(c[1:])
    return [f for f in out if f]


def _timed(module, frame: list) -> tuple[float, float, tuple]:
    w, c = time.perf_counter(), time.process_time()
    terms = module.pull_terms(frame[0][0], frame[0][2])
    out = tuple(module.skin_scale(r, d, t, *a, terms=terms, **k) for r, d, t, a, k in frame)
    return time.perf_counter() - w, time.process_time() - c, out


def _same(a: tuple, b: tuple) -> bool:
    """Whether two frames' factors are bit for bit the same."""
    return len(a) == len(b) and all(x.tobytes() == y.tobytes() for x, y in zip(a, b, strict=True))


def main() -> None:
    from _foldguard_at import foldguard_at

    from wrinkle_vis.core import foldguard

    ap = refined_parser(__doc__, "b7a9361")
    ap.add_argument("--faces", default="paper,head")
    args = ap.parse_args()
    runs = {"new": foldguard, "old": foldguard_at(args.baseline, "foldguard_pulls_baseline")}
    skins = ("geometric", "physical") if args.skin_model == "both" else (args.skin_model,)
    for name in args.faces.split(","):
        face_name, exprs = CASES[name]
        for skin in skins:
            for expr in exprs:
                frames = _captured(face_name, expr, skin, args.frames)
                v = alternating(runs, frames, args.rounds, _timed, _same)
                print(alternating_line(f"{name} refined {expr:9s} ({skin:9s})",
                                       "frames pulled: a frame's pull guard", v,
                                       args.baseline), flush=True)


if __name__ == "__main__":
    main()
