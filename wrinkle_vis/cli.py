"""The ``wrinkle-vis`` command."""

from __future__ import annotations

import argparse
import sys
import time


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="wrinkle-vis",
        description="The muscle-driven facial wrinkle model of Zhang, Sim and Tan.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    summary = sub.add_parser(
        "summary", help="evaluate expressions on the built-in face and print their fields")
    summary.add_argument("--expression", "-e", action="append",
                         help="expression name (repeatable; default: every expression)")
    summary.add_argument("--intensity", type=float, default=1.0,
                         help="scale of every activation, in [0, 1] (default 1)")
    summary.add_argument("--triangles", type=int, default=4500,
                         help="skin resolution in triangles (default 4500)")
    return parser


def _summary(args) -> int:
    from wrinkle_vis.datasets import load_face

    t0 = time.perf_counter()
    face = load_face(args.triangles)
    print(f"loaded {face.name} in {time.perf_counter() - t0:.2f} s: "
          f"{face.skin.n_triangles} skin triangles, {face.skull.n_triangles} skull "
          f"triangles, {len(face.muscles)} muscles")
    names = args.expression or list(face.expressions)
    for name in names:
        if name not in face.expressions:
            print(f"wrinkle-vis: unknown expression {name!r}; choose from: "
                  f"{', '.join(face.expressions)}", file=sys.stderr)
            return 2
    for name in names:
        t0 = time.perf_counter()
        state = face.evaluate(name, intensity=args.intensity)
        ms = 1e3 * (time.perf_counter() - t0)
        print(f"\n== {name} (intensity {args.intensity:g}, {ms:.2f} ms) ==")
        print(state.summary())
    return 0


def main(argv=None) -> int:
    """Entry point of the ``wrinkle-vis`` command."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command is None:
        args = parser.parse_args(["summary"])
    if not (0.0 <= args.intensity <= 1.0):
        parser.error(f"--intensity {args.intensity:g} is outside [0, 1]")
    return _summary(args)


if __name__ == "__main__":
    sys.exit(main())
