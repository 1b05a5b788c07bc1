"""The ``wrinkle-vis`` command: summary, render, export, animate and figure.

Every error is one line on stderr that names the problem and the way out, with exit status
2 and no traceback; outputs are checked (extension, folder) before any work and written
atomically, so a failed write leaves the old file as it was.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

FIELD_CHOICES = ("lambda", "gamma", "l", "w", "H", "At", "eps", "A", "W", "none")
CAMERA_CHOICES = ("front", "three_quarter", "side", "forehead", "upper_face")
FIGURE_CHOICES = ("fig9", "fig11")
FIG9_EXPRESSIONS = ("surprise", "frown", "fear")
LAYER_CHOICES = ("skin", "muscles", "skull")


#: Image sizes: at least this many pixels a side (smaller is unreadable) ...
MIN_PIXELS = 16
#: ... at most this many a side (OpenGL's usual limit; a 100,000-pixel side aborted with
#: std::bad_alloc) ...
MAX_PIXELS = 16384
#: ... and at most this many in all (8192 by 8192 renders in about 2.5 GB; 16384 by 16384
#: took 9 GB).
MAX_AREA = 8192 * 8192
_SIZES = f"{MIN_PIXELS} to {MAX_PIXELS} a side, 8192 by 8192 in all"
MAX_FPS = 120


class CliError(Exception):
    """A bad argument the parser could not see; printed without a traceback."""


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (no usage block), exit status 2."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


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
    p.add_argument("--triangles", type=int, default=None,
                   help="built-in skin resolution in triangles, exactly (500 to 250000; "
                        "default: the layout's, else 4500)")
    p.add_argument("--layout", type=Path, help="a layout file (default: the built-in face)")


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="wrinkle-vis",
        description="The muscle-driven facial wrinkle model of Zhang, Sim and Tan on an "
                    "anatomy-based face. With no COMMAND, the app opens (it needs a "
                    "display; the commands work headless).",
        epilog="Run 'wrinkle-vis COMMAND --help' for a command's options.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
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
    p.add_argument("--size", type=int, nargs=2, default=(800, 800), metavar=("W", "H"),
                   help=f"image size in pixels ({_SIZES}; "
                        "default 800 800)")
    p.add_argument("--output", "-o", type=Path, required=True,
                   help="the PNG to write (must end in .png)")

    p = sub.add_parser("export", help="write the skin with every field as point arrays")
    _common(p)
    p.add_argument("--output", "-o", type=Path, required=True,
                   help="a .vtp (ParaView), .vtk or .ply file for the skin, or .vtm for "
                        "skin, skull and muscles")

    p = sub.add_parser("animate", help="render the expression's ramp to a GIF or MP4",
                       description="Render the expression's onset, hold and release, frame "
                                   "by frame (streamed to the file), with the colour range "
                                   "fixed at the peak's.")
    _common(p)
    p.add_argument("--field", "-f", default="W", choices=FIELD_CHOICES,
                   help="field to colour the skin by (default W; 'none' for plain skin)")
    p.add_argument("--muscle", "-m", help="whose field (default: the total, W only)")
    p.add_argument("--layers", nargs="+", default=["skin"], choices=LAYER_CHOICES,
                   help="layers to draw (default: skin)")
    p.add_argument("--camera", default="front", choices=CAMERA_CHOICES)
    p.add_argument("--fps", type=int, default=12,
                   help=f"frames per second (1 to {MAX_FPS}; default 12; at most "
                        f"{_max_frames():,} frames in all)")
    p.add_argument("--size", type=int, nargs=2, default=(480, 480), metavar=("W", "H"),
                   help=f"frame size in pixels ({_SIZES}; "
                        "default 480 480)")
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
                   help=f"image size in pixels ({_SIZES}; "
                        "default: 880 by 400 per row for fig9, 800 by 800 for fig11)")
    p.add_argument("--output", "-o", type=Path, required=True, help="the PNG to write")
    return parser


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("wrinkle-vis")
    except PackageNotFoundError:  # run from a source tree
        from wrinkle_vis import __version__

        return __version__


def _max_frames() -> int:
    return 10_000  # wrinkle_vis.plotting.animation.MAX_FRAMES, without importing VTK here


def _check_common(args) -> None:
    """Check the arguments every command shares (before any work)."""
    from wrinkle_vis.datasets.face import MAX_TRIANGLES, MIN_TRIANGLES

    if args.triangles is not None and not MIN_TRIANGLES <= args.triangles <= MAX_TRIANGLES:
        raise CliError(f"--triangles {args.triangles} is outside {MIN_TRIANGLES}.."
                       f"{MAX_TRIANGLES}; choose a number in that range (default 4500)")
    size = getattr(args, "size", None)
    if size is not None:
        w, h = size
        if min(w, h) < MIN_PIXELS:
            raise CliError(f"--size {w} {h} is too small ({MIN_PIXELS} pixels at least each "
                           "way)")
        if max(w, h) > MAX_PIXELS or w * h > MAX_AREA:
            raise CliError(f"--size {w} {h} is too large (at most {MAX_PIXELS} pixels each "
                           f"way and {MAX_AREA:,} in all, e.g. 8192 8192); ask for a "
                           "smaller image")
    fps = getattr(args, "fps", None)
    if fps is not None and not 1 <= fps <= MAX_FPS:
        raise CliError(f"--fps {fps} is outside 1..{MAX_FPS}; choose a frame rate in that "
                       "range (default 12)")


def _output(args, suffixes: tuple[str, ...]) -> Path:
    """Check ``--output`` before any work: its extension, then that it can be written."""
    from wrinkle_vis.core.files import OutputPathError, check_output

    out = args.output
    if not out.is_dir() and out.suffix.lower() not in suffixes:
        names = ", ".join(suffixes[:-1]) + f" or {suffixes[-1]}" if len(suffixes) > 1 \
            else suffixes[0]
        like = out.with_suffix(suffixes[0]) if out.suffix else Path(f"{out}{suffixes[0]}")
        raise CliError(f"--output must end in {names}; got {out.name!r} (e.g. "
                       f"{str(like)!r})")
    try:
        real = check_output(out, suffixes)
        if out.suffix.lower() == ".vtm":
            from wrinkle_vis.plotting.writers import check_target

            check_target(out, suffixes)
    except OutputPathError as exc:
        raise CliError(f"--output {exc}") from None
    return real


def _wrote(args, written) -> str:
    """``args.output``, and where a symbolic link led."""
    out = args.output
    if Path(written.path) != out.absolute():
        try:
            if out.is_symlink():
                return f"{out} (through the link, to {written.path})"
        except OSError:
            pass
    return str(out)


def _load(args, *, refine: bool = False):
    from wrinkle_vis.core.layout import load_layout
    from wrinkle_vis.datasets import load_face

    layout = None
    if args.layout is not None:
        layout = load_layout(args.layout)
        for key in ("skin", "skull"):
            path = layout.resolve(key, args.layout.parent)
            if path is not None and not path.is_file():
                raise CliError(
                    f"--layout {args.layout}: its {key} file {str(path)!r} does not exist; "
                    f"fix \"{key}\" in the layout (a path relative to the layout's folder, "
                    "or null for the built-in face)")
    try:
        face = load_face(args.triangles, layout=layout, **_layout_meshes(layout, args.layout))
    except ValueError as exc:  # a face the layout's meshes and landmarks cannot make
        if args.layout is None:
            raise
        raise CliError(f"--layout {args.layout}: {exc}") from None
    names = getattr(args, "expression", None)
    for name in names if isinstance(names, list) else [names] if names else []:
        if name not in face.expressions:
            raise CliError(f"unknown expression {name!r}; choose from: "
                           f"{', '.join(face.expressions)}")
    muscle = getattr(args, "muscle", None)
    if muscle is not None and muscle not in face.muscle_names:
        raise CliError(f"unknown muscle {muscle!r}; choose from: {', '.join(face.muscle_names)}")
    if not refine:
        _warn_undersampled(args, face, names)
    return face


def _layout_meshes(layout, path) -> dict:
    """A layout's own skin and skull, resolved against its file's folder (a Layout object
    given to load_face has no folder).
    """
    if layout is None:
        return {}
    return {key: layout.resolve(key, path.parent) for key in ("skin", "skull")
            if getattr(layout, key) is not None}


def _warn_undersampled(args, face, expressions) -> None:
    """One line for the muscles at work whose wrinkles the skin cannot resolve (n_w too
    large for the mesh): those the expressions activate, and ``--muscle``.
    """
    from wrinkle_vis.core.sampling import UndersampledWrinklesWarning, warn_undersampled

    if isinstance(expressions, str):
        expressions = [expressions]
    active = {m for e in expressions or face.expressions
              for m, a in face.expressions[e].activations.items() if a > 0}
    if getattr(args, "muscle", None):
        active.add(args.muscle)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UndersampledWrinklesWarning)
        found = warn_undersampled(face.skin, [m for m in face.muscles if m.name in active])
    for w in caught:
        if not issubclass(w.category, UndersampledWrinklesWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    groups: dict[str, list[str]] = {}  # twins share a line
    for item in found:
        text = item.message().split(": ", 1)[1]
        groups.setdefault(text, []).append(item.muscle)
    for text, names in groups.items():
        who = "muscle" if len(names) == 1 else "muscles"
        print(f"wrinkle-vis {args.command}: warning: {who} "
              f"{', '.join(repr(n) for n in names)}: {text}", file=sys.stderr)


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
    from wrinkle_vis.plotting.offscreen import headless_rendering
    from wrinkle_vis.plotting.writers import save_image

    _output(args, (".png",))
    field = _field(args)
    face = _load(args)
    with headless_rendering():
        image = render_field(face, args.expression, field, args.muscle,
                             layers=tuple(args.layers), camera=args.camera,
                             size=tuple(args.size), intensity=args.intensity)
    written = save_image(image, args.output)
    print(f"wrote {_wrote(args, written)}")
    return 0


def _export(args) -> int:
    from wrinkle_vis.plotting.writers import MESH_SUFFIXES, save_mesh

    _output(args, MESH_SUFFIXES)
    face = _load(args)
    state = face.evaluate(args.expression, args.intensity)
    if args.output.suffix.lower() == ".vtm":
        from wrinkle_vis.plotting import to_multiblock

        written = save_mesh(to_multiblock(state), args.output)
    else:
        written = save_mesh(state.to_polydata(), args.output)
    print(f"wrote {_wrote(args, written)}: {written.summary}")
    return 0


def _animate(args) -> int:
    from tqdm import tqdm

    from wrinkle_vis.plotting.animation import animation_frames, frame_times
    from wrinkle_vis.plotting.offscreen import headless_rendering
    from wrinkle_vis.plotting.writers import ANIMATION_SUFFIXES, save_animation

    _output(args, ANIMATION_SUFFIXES)
    field = _field(args)
    face = _load(args)
    expression = face.expressions[args.expression]
    try:
        times = frame_times(expression, args.fps)
    except ValueError as exc:
        raise CliError(str(exc)) from None
    with headless_rendering():
        frames = animation_frames(face, expression, times, field=field, muscle=args.muscle,
                                  layers=tuple(args.layers), camera=args.camera,
                                  size=tuple(args.size), intensity=args.intensity,
                                  label=args.expression)
        progress = tqdm(frames, total=len(times), desc=f"rendering {args.output.name}",
                        unit="frame")
        try:
            written = save_animation(progress, args.output, args.fps)
        finally:
            progress.close()
            frames.close()
    print(f"wrote {_wrote(args, written)}: {written.summary}")
    return 0


def _figure(args) -> int:
    from wrinkle_vis.plotting import figure_expressions, figure_refinement
    from wrinkle_vis.plotting.offscreen import headless_rendering
    from wrinkle_vis.plotting.writers import save_image

    _output(args, (".png",))
    if args.figure == "fig11" and args.expression and len(args.expression) > 1:
        raise CliError(f"fig11 shows one expression; got {len(args.expression)}")
    if not args.expression:
        args.expression = list(FIG9_EXPRESSIONS) if args.figure == "fig9" else ["surprise"]
    face = _load(args, refine=args.refine or args.figure == "fig11")
    size = None if args.size is None else tuple(args.size)
    with headless_rendering():
        if args.figure == "fig9":
            image = figure_expressions(face, args.expression, size=size,
                                       intensity=args.intensity, refine=args.refine)
        else:
            image = figure_refinement(face, expression=args.expression[0],
                                      size=size or (800, 800), intensity=args.intensity)
    written = save_image(image, args.output)
    print(f"wrote {_wrote(args, written)}")
    return 0


def _app(parser) -> int:
    import os

    from wrinkle_vis.plotting.offscreen import display_available

    if not display_available():
        where = os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
        why = f"the display {where!r} cannot be opened" if where else "there is no display"
        print(f"wrinkle-vis: {why}, so the app cannot open; work headless with "
              "'wrinkle-vis summary', 'wrinkle-vis render -o out.png', 'wrinkle-vis export -o "
              "out.vtp' (see 'wrinkle-vis --help'), or run the app on a desktop or under "
              "xvfb-run", file=sys.stderr)
        return 2
    from wrinkle_vis.app.window import run

    return run(sys.argv[:1])


COMMANDS = {"summary": _summary, "render": _render, "export": _export, "animate": _animate,
            "figure": _figure}


def main(argv=None) -> int:
    """Entry point of the ``wrinkle-vis`` command."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command is None:
        return _app(parser)
    if not (0.0 <= args.intensity <= 1.0):
        parser.error(f"--intensity {args.intensity:g} is outside [0, 1]")
    if getattr(args, "layout", None) is not None and not args.layout.is_file():
        what = "is a folder, not a file" if args.layout.is_dir() else "no such file"
        parser.error(f"--layout {args.layout}: {what}; check the path")
    from wrinkle_vis.core.files import OutputPathError, WriteError
    from wrinkle_vis.core.layout import LayoutError
    from wrinkle_vis.core.mesh import MeshError

    try:
        _check_common(args)
        return COMMANDS[args.command](args)
    except (CliError, LayoutError, MeshError, OutputPathError, WriteError) as exc:
        message = " ".join(str(exc).split())  # one line, whatever the message holds
        print(f"wrinkle-vis {args.command}: {message}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
