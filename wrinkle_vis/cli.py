"""The ``wrinkle-vis`` command: summary, render, export, animate and figure."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

FIELD_CHOICES = ("lambda", "gamma", "l", "w", "H", "At", "eps", "A", "W", "none")
CAMERA_CHOICES = ("front", "three_quarter", "side", "forehead", "upper_face")
FIGURE_CHOICES = ("fig9", "fig11")
FIG9_EXPRESSIONS = ("surprise", "frown", "fear")
LAYER_CHOICES = ("skin", "muscles", "skull")


class CliError(Exception):
    """A bad argument the parser could not see; printed without a traceback."""


def _common(p: argparse.ArgumentParser, *, expression_many: bool = False,
            expression_default: str = "every expression") -> None:
    if expression_many:
        p.add_argument("--expression", "-e", action="append",
                       help=f"expression name (repeatable; default: {expression_default})")
    else:
        p.add_argument("--expression", "-e", default="surprise",
                       help="expression name (default: surprise)")
    p.add_argument("--intensity", type=float, default=1.0,
                   help="scale of every activation, in [0, 1] (default 1)")
    p.add_argument("--triangles", type=int, default=4500,
                   help="built-in skin resolution in triangles (default 4500)")
    p.add_argument("--layout", type=Path, help="a layout file (default: the built-in face)")


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="wrinkle-vis",
        description="The muscle-driven facial wrinkle model of Zhang, Sim and Tan on an "
                    "anatomy-based face.",
        epilog="Run 'wrinkle-vis COMMAND --help' for a command's options.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("summary", help="evaluate expressions and print their fields")
    _common(p, expression_many=True)

    p = sub.add_parser("render", help="render a field map to a PNG, off screen")
    _common(p)
    p.add_argument("--field", "-f", default="W", choices=FIELD_CHOICES,
                   help="field to colour the skin by (default W; 'none' for plain skin)")
    p.add_argument("--muscle", "-m", help="whose field (default: the total, W only)")
    p.add_argument("--layers", nargs="+", default=["skin"], choices=LAYER_CHOICES,
                   help="layers to draw (default: skin)")
    p.add_argument("--camera", default="front", choices=CAMERA_CHOICES)
    p.add_argument("--size", type=int, nargs=2, default=(800, 800), metavar=("W", "H"))
    p.add_argument("--output", "-o", type=Path, required=True, help="the PNG to write")

    p = sub.add_parser("export", help="write the skin with every field as point arrays")
    _common(p)
    p.add_argument("--output", "-o", type=Path, required=True,
                   help="a .vtp (ParaView), .vtk or .ply file for the skin, or .vtm for "
                        "skin, skull and muscles")

    p = sub.add_parser("animate", help="render the expression's ramp to a GIF or MP4")
    _common(p)
    p.add_argument("--field", "-f", default="W", choices=FIELD_CHOICES)
    p.add_argument("--camera", default="front", choices=CAMERA_CHOICES)
    p.add_argument("--fps", type=int, default=12)
    p.add_argument("--size", type=int, nargs=2, default=(480, 480), metavar=("W", "H"))
    p.add_argument("--output", "-o", type=Path, required=True, help="a .gif or .mp4 file")

    p = sub.add_parser(
        "figure", help="render one of the paper's figures to a PNG, off screen",
        description="fig9: each expression without and with wrinkles (paper Fig. 9); "
                    "fig11: the adaptively refined mesh over the forehead during surprise "
                    "(paper Fig. 11). Plain skin under a raking light.")
    p.add_argument("figure", choices=FIGURE_CHOICES, help="which figure")
    _common(p, expression_many=True, expression_default=(
        f"fig9: one row each, {', '.join(FIG9_EXPRESSIONS)}; fig11: one, surprise"))
    p.add_argument("--refine", action="store_true",
                   help="fig9: evaluate with adaptive refinement (fig11 always refines)")
    p.add_argument("--size", type=int, nargs=2, metavar=("W", "H"),
                   help="image size in pixels (default: 880 by 400 per row for fig9, "
                        "800 by 800 for fig11)")
    p.add_argument("--output", "-o", type=Path, required=True, help="the PNG to write")
    return parser


def _load(args):
    from wrinkle_vis.datasets import load_face

    face = load_face(args.triangles, layout=args.layout)
    names = getattr(args, "expression", None)
    for name in names if isinstance(names, list) else [names] if names else []:
        if name not in face.expressions:
            raise CliError(f"unknown expression {name!r}; choose from: "
                           f"{', '.join(face.expressions)}")
    muscle = getattr(args, "muscle", None)
    if muscle is not None and muscle not in face.muscle_names:
        raise CliError(f"unknown muscle {muscle!r}; choose from: {', '.join(face.muscle_names)}")
    return face


def _summary(args) -> int:
    t0 = time.perf_counter()
    face = _load(args)
    print(f"loaded {face.name} in {time.perf_counter() - t0:.2f} s: "
          f"{face.skin.n_triangles} skin triangles, "
          f"{face.skull.n_triangles if face.skull else 0} skull triangles, "
          f"{len(face.muscles)} muscles")
    for name in args.expression or list(face.expressions):
        t0 = time.perf_counter()
        state = face.evaluate(name, intensity=args.intensity)
        ms = 1e3 * (time.perf_counter() - t0)
        print(f"\n== {name} (intensity {args.intensity:g}, {ms:.2f} ms) ==")
        print(state.summary())
    return 0


def _field(args):
    field = None if args.field == "none" else args.field
    if field not in (None, "W") and args.__dict__.get("muscle") is None:
        raise CliError(f"--field {field} belongs to one muscle: add --muscle NAME")
    return field


def _render(args) -> int:
    from wrinkle_vis.plotting import render_field

    field = _field(args)
    face = _load(args)
    render_field(face, args.expression, field, args.muscle, layers=tuple(args.layers),
                 camera=args.camera, size=tuple(args.size), intensity=args.intensity,
                 filename=str(args.output))
    print(f"wrote {args.output}")
    return 0


def _export(args) -> int:
    suffix = args.output.suffix.lower()
    if suffix not in (".vtp", ".vtk", ".ply", ".vtm"):
        raise CliError(f"--output must end in .vtp, .vtk, .ply or .vtm; got "
                       f"{args.output.name!r}")
    face = _load(args)
    state = face.evaluate(args.expression, args.intensity)
    if suffix == ".vtm":
        from wrinkle_vis.plotting import to_multiblock

        blocks = to_multiblock(state)
        blocks.save(args.output)
        print(f"wrote {args.output}: {', '.join(blocks.keys())}")
        return 0
    mesh = state.to_polydata()
    mesh.save(args.output)
    print(f"wrote {args.output}: {mesh.n_points} points, {len(mesh.point_data)} point arrays")
    return 0


def _animate(args) -> int:
    import imageio.v3 as iio
    import numpy as np
    import pyvista as pv
    from tqdm import tqdm

    from wrinkle_vis.plotting import add_skin, clear_scene, field_range, set_camera
    from wrinkle_vis.plotting.fields import field_info

    suffix = args.output.suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise CliError(f"--output must end in .gif or .mp4; got {args.output.name!r}")
    field = _field(args)
    face = _load(args)
    expression = face.expressions[args.expression]
    times = np.arange(0.0, expression.duration_s + 1e-9, 1.0 / args.fps)
    peak = face.evaluate(expression, args.intensity)
    clim = field_range(field_info(field), peak.W) if field == "W" else None
    frames = []
    plotter = pv.Plotter(off_screen=True, window_size=list(args.size))
    try:
        for t in tqdm(times, desc=f"rendering {args.output.name}", unit="frame"):
            state = face.evaluate(expression.at(t, args.intensity))
            clear_scene(plotter)
            add_skin(plotter, state, field)
            if clim is not None:
                plotter.update_scalar_bar_range(clim)
            plotter.add_title(f"{args.expression}  t = {t:.2f} s", font_size=10)
            set_camera(plotter, args.camera, face)
            frames.append(plotter.screenshot(return_img=True))
    finally:
        plotter.close()
    if suffix == ".gif":
        iio.imwrite(args.output, np.stack(frames), duration=1000 / args.fps, loop=0)
    else:
        import imageio.v2 as iio2  # imageio-ffmpeg: closes its pipes on leaving the block

        with iio2.get_writer(args.output, fps=args.fps, codec="libx264",
                             macro_block_size=1) as writer:
            for frame in frames:
                writer.append_data(frame)
    print(f"wrote {args.output}: {len(frames)} frames")
    return 0


def _figure(args) -> int:
    from wrinkle_vis.plotting import figure_expressions, figure_refinement

    if args.output.suffix.lower() != ".png":
        raise CliError(f"--output must end in .png; got {args.output.name!r}")
    if args.size is not None and min(args.size) < 16:
        raise CliError(f"--size {args.size[0]} {args.size[1]} is too small (16 pixels at "
                       "least each way)")
    if args.figure == "fig11" and args.expression and len(args.expression) > 1:
        raise CliError(f"fig11 shows one expression; got {len(args.expression)}")
    if not args.expression:
        args.expression = list(FIG9_EXPRESSIONS) if args.figure == "fig9" else ["surprise"]
    face = _load(args)
    size = None if args.size is None else tuple(args.size)
    if args.figure == "fig9":
        figure_expressions(face, args.expression, args.output, size=size,
                           intensity=args.intensity, refine=args.refine)
    else:
        figure_refinement(face, args.output, expression=args.expression[0],
                          size=size or (800, 800), intensity=args.intensity)
    print(f"wrote {args.output}")
    return 0


def _app_or_summary(parser) -> int:
    import os

    if os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY") or sys.platform in (
            "darwin", "win32"):
        from wrinkle_vis.app.window import run

        return run(sys.argv[:1])
    print("wrinkle-vis: no display, so no window; printing the summary instead "
          "(run under a desktop or Xvfb for the app)", file=sys.stderr)
    return _summary(parser.parse_args(["summary"]))


COMMANDS = {"summary": _summary, "render": _render, "export": _export, "animate": _animate,
            "figure": _figure}


def main(argv=None) -> int:
    """Entry point of the ``wrinkle-vis`` command."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command is None:
        return _app_or_summary(parser)
    if not (0.0 <= args.intensity <= 1.0):
        parser.error(f"--intensity {args.intensity:g} is outside [0, 1]")
    if getattr(args, "layout", None) is not None and not args.layout.is_file():
        parser.error(f"--layout {args.layout}: no such file")
    try:
        return COMMANDS[args.command](args)
    except CliError as exc:
        print(f"wrinkle-vis {args.command}: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
