"""The ``wrinkle-vis`` command: summary, render, export, animate, figure, bake, types and sweep.

Every error is one line on stderr that names the problem and the way out, with exit status
2 and no traceback; outputs are checked (extension, folder) before any work and written
atomically, so a failed write leaves the old file as it was. Ctrl-C, SIGTERM and SIGHUP
stop a command with one line, exit status 128 + the signal's number (130, 143, 129), its
temporaries removed and a running ffmpeg stopped.
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
import warnings
from contextlib import contextmanager
from pathlib import Path

from wrinkle_vis.core.files import input_problem
from wrinkle_vis.core.skin import (
    DEFAULT_SKIN_MODEL,
    PHYSICAL_DEFAULT_MAX_POINTS,
    SKIN_MODELS,
    default_skin_notice,
)

CAMERA_CHOICES = ("front", "three_quarter", "side", "forehead", "upper_face")
FIGURE_CHOICES = ("fig9", "fig10", "fig11")
#: ``--skin-model`` choices (core's declaration; the default is core's DEFAULT_SKIN_MODEL).
SKIN_MODEL_CHOICES = SKIN_MODELS
#: The simulated times (seconds after the activation step) fig10 shows by default.
FIG10_TIMES = (0.033, 0.067, 0.1, 0.2, 0.5)
FIG9_EXPRESSIONS = ("surprise", "frown", "fear")
LAYER_CHOICES = ("skin", "muscles", "skull")
#: The built-in faces (wrinkle_vis.datasets.FACES, without importing it here).
FACE_CHOICES = ("procedural", "lee_perry_smith")
UNIT_CHOICES = ("mm", "cm", "m", "um", "in", "ft")
#: wrinkle_vis.core.tracks.TRACK_FORMATS, without importing it here.
TRACK_FORMAT_CHOICES = ("openface", "pyfeat", "arkit", "mediapipe")
#: The frame rate a track is resampled to when --fps is not given.
TRACK_FPS = 30


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
#: The most texels of padding ``bake`` puts around a UV island.
MAX_PADDING = 256
#: The most levels of adaptive refinement ``--refine-levels`` takes (each level can split
#: every triangle the last one made in four).
MAX_REFINE_LEVELS = 5


class CliError(Exception):
    """A bad argument the parser could not see; printed without a traceback."""


@contextmanager
def _signals_raise(received: list[int]):
    """While the block runs, SIGINT raises KeyboardInterrupt and SIGTERM and SIGHUP
    :class:`~wrinkle_vis.core.files.Interrupted`; each signal's number is appended to
    ``received`` and kept by :func:`~wrinkle_vis.core.files.note_interrupt`, so that no
    output is put in place afterwards even if VTK swallowed the exception.
    """
    from wrinkle_vis.core import files

    def stop(signum, frame):
        received.append(signum)
        files.note_interrupt(signum)
        raise files.interrupt_exception(signum)

    old = {}
    for name in ("SIGINT", "SIGTERM", "SIGHUP"):
        sig = getattr(signal, name, None)
        if sig is not None:
            try:
                old[sig] = signal.signal(sig, stop)
            except ValueError:  # not the main thread: the default stays
                pass
    try:
        yield
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)
        files.note_interrupt(None)


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
    p.add_argument("--face", choices=FACE_CHOICES, default=None,
                   help="a built-in face: procedural (default) or lee_perry_smith (a real "
                        "head scan, CC BY 3.0 Lee Perry-Smith / Infinite Realities)")
    p.add_argument("--skin", type=Path,
                   help="a scan of your own (OBJ, PLY, STL, VTP, VTK, ...), with --landmarks "
                        "or a --layout that has them; for bake, an OBJ with UVs")
    p.add_argument("--landmarks", type=Path, metavar="FILE.json",
                   help='where the landmarks lie on --skin: {"nasion": [x, y, z], ...} (at '
                        "least 4 of nasion, nose_tip, chin, eye_inner_L/R, eye_outer_L/R, "
                        "mouth_corner_L/R), or a layout file with them")
    p.add_argument("--skin-model", choices=SKIN_MODEL_CHOICES, default=None,
                   help="geometric: the muscles' summed pulls; physical: the simulated "
                        "mass-spring skin bound to the skull, at equilibrium for a still "
                        "frame, simulated over time for animate, export --sequence and fig10 "
                        f"(default: the layout's, else {DEFAULT_SKIN_MODEL} up to "
                        f"{PHYSICAL_DEFAULT_MAX_POINTS:,} vertices, geometric above)")
    p.add_argument("--unit", choices=UNIT_CHOICES, default=None,
                   help="the unit of the face's lengths (default: the layout's; mm for the "
                        "built-in faces; guessed from a scan's size, with a note)")
    p.add_argument("--taper", action="store_true",
                   help="taper every muscle's wrinkle shape H to 0 at both ends of its "
                        "wrinkling region (C1), removing the seam the paper's Eq. 5 leaves "
                        "there (e.g. across the top of the forehead's wrinkles in surprise "
                        "and fear); default: the paper's model, or the layout's choice")
    p.add_argument("--fold-guard", choices=("on", "off", "fans", "light"), default="on",
                   help="keep the skin from passing through itself: limit the pulls where "
                        "a triangle would turn over and |W| below half the empty-ball "
                        "radius on its side, and on refined frames each vertex's wrinkled "
                        "fan off its two rings (default on; off: the paper's model as is; "
                        "fans: the fans kept off their rings on unrefined frames too; light: "
                        "no fans' guard at all, refined frames a fifth to a third cheaper, a few "
                        "crossings possible where the skin folds sharply under raised k0)")


def _refine_options(p: argparse.ArgumentParser, what: str = "evaluate with adaptive "
                    "refinement where the skin bends (paper Fig. 11)") -> None:
    p.add_argument("--refine", action="store_true", help=what)
    p.add_argument("--refine-angle", type=float, metavar="DEG",
                   help="with --refine: split the triangles whose vertex normals differ by "
                        "more than DEG degrees beyond the rest skin's own bend, or too "
                        "coarse for a furrow that deep; in (0, 180) (default 3)")
    p.add_argument("--refine-levels", type=int, metavar="N",
                   help=f"with --refine: at most N levels of splitting, 0 to "
                        f"{MAX_REFINE_LEVELS} (default 3)")


def _track_options(p: argparse.ArgumentParser, what: str) -> None:
    """``--track`` and its options (a recorded performance instead of an expression)."""
    p.add_argument("--track", type=Path, metavar="FILE",
                   help=f"{what} a recorded track (OpenFace, py-feat, ARKit / Live Link Face "
                        "or MediaPipe CSV) instead of an expression")
    p.add_argument("--format", choices=TRACK_FORMAT_CHOICES, default=None,
                   help="the track's format (default: recognised from its header)")
    p.add_argument("--map", type=Path, metavar="FILE",
                   help="channels to muscles: a layout file with a \"mapping\", or a JSON "
                        "object of that mapping (default: the face's, else the FACS default)")
    p.add_argument("--smooth", type=float, default=0.0, metavar="S",
                   help="smooth the track over a Gaussian of S seconds (default 0)")
    p.add_argument("--fps-in", type=float, default=None, metavar="N",
                   help="the track's frame rate, for py-feat frames and ARKit timecodes")
    p.add_argument("--max-mb", type=float, default=None, metavar="MB",
                   help="read a track file larger than 64 MiB")


def field_choices() -> tuple[str, ...]:
    """``--field`` choices: the core catalogue's fields
    (:data:`wrinkle_vis.core.fields.FIELDS`, read when the parser is built) and ``none``.
    """
    from wrinkle_vis.core.fields import FIELD_NAMES

    return (*FIELD_NAMES, "none")


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="wrinkle-vis",
        description="The muscle-driven facial wrinkle model of Zhang, Sim and Tan on an "
                    "anatomy-based face. With no COMMAND, the app opens (it needs a "
                    "display; the commands work headless); 'wrinkle-vis LAYOUT.json' opens it "
                    "on a layout file.",
        epilog="Run 'wrinkle-vis COMMAND --help' for a command's options.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    fields = field_choices()
    for add in (_summary_parser, _render_parser, _export_parser, _animate_parser,
                _figure_parser, _bake_parser, _types_parser, _sweep_parser):
        add(sub, fields)
    return parser


def _summary_parser(sub, fields: tuple[str, ...]) -> None:
    """The ``summary`` command: evaluate expressions and print their fields."""
    p = sub.add_parser("summary", help="evaluate expressions and print their fields")
    _common(p, expression_many=True)
    _track_options(p, "print the action units or blendshapes of")


def _render_parser(sub, fields: tuple[str, ...]) -> None:
    """The ``render`` command: a field map to a PNG."""
    p = sub.add_parser("render", help="render a field map to a PNG, off screen")
    _common(p)
    _view_options(p, fields)
    p.add_argument("--size", type=int, nargs=2, default=(800, 800), metavar=("W", "H"),
                   help=f"image size in pixels ({_SIZES}; "
                        "default 800 800)")
    _refine_options(p)
    p.add_argument("--output", "-o", type=Path, required=True,
                   help="the PNG to write (must end in .png)")


def _export_parser(sub, fields: tuple[str, ...]) -> None:
    """The ``export`` command: the skin and its fields, a sequence or glTF morph targets."""
    p = sub.add_parser("export", help="write the skin with every field as point arrays, "
                                      "the ramp as a time series, or glTF morph targets")
    _common(p)
    p.set_defaults(expression=None)  # .glb: every expression; otherwise surprise
    p.add_argument("--sequence", action="store_true",
                   help="write the expression's onset, hold and release, one frame every "
                        "1/fps s: NAME.pvd (ParaView time series, frames in NAME/), "
                        "NAME_####.obj or NAME_####.ply (one numbered file per frame, "
                        "in NAME/)")
    p.add_argument("--fps", type=int, default=None,
                   help=f"frames per second of --sequence (1 to {MAX_FPS}; default 12, "
                        f"{TRACK_FPS} with --track; at most {_max_frames():,} frames in all)")
    _track_options(p, "with --sequence, write")
    p.add_argument("--output", "-o", type=Path, required=True,
                   help="a .vtp (ParaView), .vtu (also meshio), .vtk, .ply, .obj or .stl "
                        "file for the skin, .vtm for "
                        "skin, skull and muscles, or .glb (glTF: the neutral skin with one "
                        "morph target per expression, or per --expression); with --sequence "
                        "NAME.pvd, NAME_####.obj or NAME_####.ply")


def _animate_parser(sub, fields: tuple[str, ...]) -> None:
    """The ``animate`` command: the expression's ramp to a GIF or MP4."""
    p = sub.add_parser("animate", help="render the expression's ramp to a GIF or MP4",
                       description="Render the expression's onset, hold and release, frame "
                                   "by frame (streamed to the file), with the colour range "
                                   "fixed at the peak's.")
    _common(p)
    _view_options(p, fields)
    p.add_argument("--fps", type=int, default=None,
                   help=f"frames per second (1 to {MAX_FPS}; default 12, {TRACK_FPS} with "
                        f"--track; at most {_max_frames():,} frames in all)")
    _track_options(p, "render")
    p.add_argument("--size", type=int, nargs=2, default=(480, 480), metavar=("W", "H"),
                   help=f"frame size in pixels ({_SIZES}; "
                        "default 480 480)")
    _refine_options(p, "evaluate every frame with adaptive refinement where the skin bends")
    p.add_argument("--output", "-o", type=Path, required=True, help="a .gif or .mp4 file")


def _figure_parser(sub, fields: tuple[str, ...]) -> None:
    """The ``figure`` command: one of the paper's figures."""
    p = sub.add_parser(
        "figure", help="render one of the paper's figures to a PNG, off screen",
        description="fig9: each expression without and with wrinkles (paper Fig. 9); "
                    "fig10: wrinkles forming on the physical skin after a step to the "
                    "expression, snapshots at --times (paper Fig. 10); "
                    "fig11: the adaptively refined mesh over the forehead during surprise "
                    "(paper Fig. 11). Plain skin under a raking light.")
    p.add_argument("figure", choices=FIGURE_CHOICES, help="which figure")
    _common(p, expression_many=True, expression_default=(
        f"fig9: one row each, {', '.join(FIG9_EXPRESSIONS)}; fig11: one, surprise"))
    _refine_options(p, "fig9: evaluate with adaptive refinement (fig11 always refines; "
                       "--refine-angle and --refine-levels set how for both)")
    p.add_argument("--times", type=float, nargs="+", metavar="S",
                   help="fig10: the simulated seconds after the step to show (default "
                        f"{' '.join(f'{t:g}' for t in FIG10_TIMES)})")
    p.add_argument("--size", type=int, nargs=2, metavar=("W", "H"),
                   help=f"image size in pixels ({_SIZES}; "
                        "default: 880 by 400 per row for fig9, 800 by 800 for fig11)")
    p.add_argument("--output", "-o", type=Path, required=True, help="the PNG to write")


def _bake_parser(sub, fields: tuple[str, ...]) -> None:
    """The ``bake`` command: texture maps of W, its normals and fields."""
    p = sub.add_parser(
        "bake", help="bake W, a normal map and field colour maps into textures (a skin "
                     "with UVs)",
        description="For a skin with UV coordinates (an OBJ with vt, e.g. the Lee "
                    "Perry-Smith head): W as a 16-bit displacement map with its scale and "
                    "offset in displacement.json, a tangent-space normal map of the "
                    "wrinkles, and each --field as a colour map, padded across UV seams. "
                    "W sampled back at the texel centres is reported.")
    _common(p)
    p.add_argument("--field", "-f", action="append", choices=fields[:-1],
                   help="a field to bake as a colour map (repeatable; default W)")
    p.add_argument("--muscle", "-m", help="whose fields (default: the total, W only)")
    p.add_argument("--size", type=int, nargs=2, default=(1024, 1024), metavar=("W", "H"),
                   help=f"map size in texels ({_SIZES}; default 1024 1024)")
    p.add_argument("--padding", type=int, default=8,
                   help=f"texels of padding around each UV island (0 to {MAX_PADDING}; "
                        "default 8)")
    _refine_options(p, "bake the adaptively refined skin (its new vertices get UVs "
                       "interpolated in their triangle of the scan), so that large maps show "
                       "no facets")
    p.add_argument("--output", "-o", type=Path, required=True,
                   help="the folder for the maps (made, or replaced whole if it holds only "
                        "maps)")


def _types_parser(sub, fields: tuple[str, ...]) -> None:
    """The ``types`` command: the installed muscle types."""
    p = sub.add_parser(
        "types", help="list the installed muscle types and their parameters",
        description="Every registered muscle type (built-in and plug-in) with its "
                    "parameters as the type declares them: symbol, unit, allowed range, "
                    "default and meaning.")
    p.add_argument("type", nargs="*", help="only these types (default: all)")
    p.add_argument("--markdown", action="store_true", help="print Markdown tables")


def _sweep_parser(sub, fields: tuple[str, ...]) -> None:
    """The ``sweep`` command: a parameter sweep on Dask."""
    p = sub.add_parser(
        "sweep", help="run a parameter sweep on Dask and write its Parquet table",
        description="Run every run of a sweep spec (TOML or JSON, docs/sweeps.md) that has "
                    "not finished in OUT: on local worker processes, or on a running "
                    "scheduler. Started again, it skips the finished runs. Ctrl+C stops it; "
                    "the same command resumes.")
    p.add_argument("spec", type=Path, help="the sweep spec (.toml or .json)")
    p.add_argument("--output", "-o", type=Path, required=True, help="the sweep folder")
    p.add_argument("--scheduler", help="a running Dask scheduler, tcp://HOST:PORT "
                                       "(default: start local workers)")
    p.add_argument("--workers", type=int, help="how many local worker processes (default: "
                                               "the CPUs)")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress bar")


def _view_options(p: argparse.ArgumentParser, fields: tuple[str, ...]) -> None:
    """``--field``, ``--muscle``, ``--layers`` and ``--camera``: what a picture shows."""
    p.add_argument("--field", "-f", default="W", choices=fields,
                   help="field to colour the skin by (default W; 'none' for plain skin)")
    p.add_argument("--muscle", "-m", help="whose field (default: the total, W only)")
    p.add_argument("--layers", nargs="+", default=["skin"], choices=LAYER_CHOICES,
                   help="layers to draw (default: skin)")
    p.add_argument("--camera", default="front", choices=CAMERA_CHOICES)


def _types(args) -> int:
    from wrinkle_vis.core.params import TABLE_COLUMNS, parameter_table
    from wrinkle_vis.core.registry import UnknownMuscleTypeError, get_muscle_type, muscle_types

    names = args.type or list(muscle_types())
    try:
        types = [(n, get_muscle_type(n)) for n in names]
    except UnknownMuscleTypeError as exc:
        raise CliError(str(exc)) from None
    for k, (name, cls) in enumerate(types):
        rows = parameter_table(cls)
        title = f"{name} ({cls.__module__}.{cls.__qualname__})"
        print(("\n" if k else "") + (f"## {title}\n" if args.markdown else title))
        if args.markdown:
            print("| " + " | ".join(TABLE_COLUMNS) + " |")
            print("|" + "---|" * len(TABLE_COLUMNS))
            for row in rows:
                print("| " + " | ".join(c.replace("|", "\\|") for c in row) + " |")
            continue
        widths = [max(len(r[i]) for r in [TABLE_COLUMNS, *rows]) for i in range(5)]
        for row in [TABLE_COLUMNS, *rows]:
            print("  " + "  ".join(c.ljust(w) for c, w in zip(row, widths, strict=False))
                  + "  " + row[5])
    return 0


def _sweep(args) -> int:
    """``wrinkle-vis sweep``: one line on an error, exit status 130 after Ctrl+C."""
    if args.workers is not None and args.scheduler is not None:
        raise CliError("give --workers or --scheduler, not both")
    if args.workers is not None and args.workers < 1:
        raise CliError(f"--workers {args.workers}: give 1 or more")
    from wrinkle_vis.sweep import SweepError, SweepSpecError, sweep

    try:
        table = sweep(args.spec, args.output, scheduler=args.scheduler, workers=args.workers,
                      progress=not args.quiet)
    except (SweepSpecError, SweepError) as exc:
        raise CliError(str(exc)) from None
    except KeyboardInterrupt:
        print("wrinkle-vis sweep: interrupted; the finished runs are kept, run the same "
              "command again to resume", file=sys.stderr)
        return 130
    failed = int((table["status"] != "done").sum())
    print(f"{len(table)} runs, {failed} failed: {args.output / 'results.parquet'}")
    return 1 if failed else 0


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
    _check_refine(args)
    fps = getattr(args, "fps", None)
    if fps is not None and not 1 <= fps <= MAX_FPS:
        raise CliError(f"--fps {fps} is outside 1..{MAX_FPS}; choose a frame rate in that "
                       "range (default 12)")


def _check_refine(args) -> None:
    """Check ``--refine-angle`` and ``--refine-levels`` (before any work)."""
    angle = getattr(args, "refine_angle", None)
    levels = getattr(args, "refine_levels", None)
    if angle is not None and not 0.0 < angle < 180.0:
        raise CliError(f"--refine-angle {angle:g} is outside (0, 180) degrees; choose a "
                       "bending threshold in that range (default 3)")
    if levels is not None and not 0 <= levels <= MAX_REFINE_LEVELS:
        raise CliError(f"--refine-levels {levels} is outside 0..{MAX_REFINE_LEVELS}; choose "
                       "a number of levels in that range (default 3)")
    refines = getattr(args, "refine", False) or getattr(args, "figure", None) == "fig11"
    if (angle is not None or levels is not None) and not refines:
        given = "--refine-angle" if angle is not None else "--refine-levels"
        raise CliError(f"{given} sets how the skin is refined; add --refine")


def _refinement(args) -> dict:
    """The refinement keywords of the plotting functions, from the arguments."""
    return {"refine_angle_deg": args.refine_angle, "refine_levels": args.refine_levels}


def _output(args, suffixes: tuple[str, ...]) -> Path:
    """Check ``--output`` before any work: its extension, then that it can be written."""
    out = args.output
    try:
        return _checked_output(out, suffixes)
    except OSError as exc:  # a name over 255 bytes, a path over 4096 bytes, ...
        raise _unusable_output(out, exc) from None


def _unusable_output(out: Path, exc: OSError) -> CliError:
    """One line for an ``--output`` the system refuses to look at (a name too long)."""
    shown = str(out) if len(str(out)) <= 80 else f"{str(out)[:77]}..."
    return CliError(f"--output {shown}: {exc.strerror or exc} (names have at most 255 "
                    "bytes, paths 4096); use a shorter name")


def _checked_output(out: Path, suffixes: tuple[str, ...]) -> Path:
    from wrinkle_vis.core.files import OutputPathError, check_output

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


def _check_face_options(args, layout) -> None:
    """One line for options that cannot go together, and for a scan without landmarks."""
    skin = getattr(args, "skin", None)
    if args.face is not None and skin is not None:
        raise CliError(f"--face {args.face} and --skin {skin}: give one face, the built-in "
                       "one or your scan")
    if args.face == "lee_perry_smith" and args.triangles is not None:
        raise CliError("--triangles sets the procedural face's resolution; the "
                       "lee_perry_smith head has its own (leave --triangles out)")
    if skin is not None and input_problem(skin) is not None:
        raise CliError(f"--skin {skin}: {input_problem(skin)}; check the path")
    if args.landmarks is not None and skin is None and (layout is None or layout.skin is None):
        raise CliError(f"--landmarks {args.landmarks}: landmarks place the muscles on a scan; "
                       "add --skin SCAN")
    scan = skin is not None or (layout is not None and layout.skin is not None)
    has_marks = args.landmarks is not None or (layout is not None and layout.landmarks)
    if scan and not has_marks and (layout is None or not layout.muscles):
        raise CliError(
            f"--skin {skin or layout.skin}: a scan needs landmarks to place the muscles; "
            "give --landmarks FILE.json with {\"nasion\": [x, y, z], ...} (at least 4 of "
            "nasion, nose_tip, chin, eye_inner_L, eye_inner_R, eye_outer_L, eye_outer_R, "
            "mouth_corner_L, mouth_corner_R, in the scan's coordinates), or a --layout that "
            "has them (the app's File > New face from mesh... writes one)")


def _load(args, *, refine: bool = False):
    from wrinkle_vis.datasets import read_landmarks

    layout = _checked_layout(args)
    _check_face_options(args, layout)
    meshes = _layout_meshes(layout, args.layout)
    skin = getattr(args, "skin", None)
    if skin is not None:
        meshes["skin"] = skin
    landmarks = None
    if args.landmarks is not None:
        try:
            landmarks = read_landmarks(args.landmarks)
        except (OSError, ValueError) as exc:
            raise CliError(f"--landmarks {exc}") from None
    face = _built_face(args, layout, meshes, landmarks)
    if getattr(args, "taper", False):
        face = _tapered(face)
    names = _checked_names(args, face)
    if not refine:
        _warn_undersampled(args, face, names)
    model = getattr(args, "skin_model", None)
    face = face if model in (None, face.skin_model) else face.with_skin_model(model)
    notice = default_skin_notice(face.skin.n_points)
    if notice is not None and model is None and (layout is None or layout.skin_model is None):
        print(f"wrinkle-vis {args.command}: note: {notice}", file=sys.stderr)
    face.fold_guard = _fold_guard(getattr(args, "fold_guard", "on"))
    if face.skin.n_triangles >= LARGE_SKIN_TRIANGLES:
        _prepare_muscles(args, face)
    return face


def _fold_guard(choice: str):
    """The face's :attr:`~wrinkle_vis.core.face.FaceModel.fold_guard` for ``--fold-guard``'s
    ``choice``: True (on: the default guard, fans on refined frames), False (off),
    ``FoldGuard(fans=True)`` (fans: everywhere) or ``FoldGuard(fans=False)`` (light: none).
    """
    from wrinkle_vis.core.foldguard import FoldGuard

    if choice in ("fans", "light"):
        return FoldGuard(fans=choice == "fans")
    return choice == "on"


def _checked_layout(args):
    """``--layout``'s layout (None without one), its skin and skull files checked."""
    from wrinkle_vis.core.layout import load_layout

    if args.layout is None:
        return None
    layout = load_layout(args.layout)
    for key in ("skin", "skull"):
        path = layout.resolve(key, args.layout.parent)
        if path is not None and input_problem(path) == "no such file":
            raise CliError(
                f"--layout {args.layout}: its {key} file {str(path)!r} does not exist; "
                f"fix \"{key}\" in the layout (a path relative to the layout's folder, "
                "or null for the built-in face)")
        if path is not None and input_problem(path) is not None:
            raise CliError(f"--layout {args.layout}: its {key} file {str(path)!r} "
                           f"{input_problem(path)}; fix \"{key}\" in the layout")
    return layout


def _built_face(args, layout, meshes: dict, landmarks):
    """The face of the options, the layout, its ``meshes`` and ``landmarks``; a unit
    warning becomes a note on stderr, a face they cannot make one line naming the source.
    """
    import warnings

    from wrinkle_vis.core.mesh import MeshError
    from wrinkle_vis.core.units import UnitWarning
    from wrinkle_vis.datasets import load_face

    try:
        if meshes.get("skin") is not None:  # read here: big scans are announced
            meshes["skin"] = _read_skin(args, Path(meshes["skin"]))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", UnitWarning)
            face = load_face(args.face, args.triangles, layout=layout, landmarks=landmarks,
                             unit=args.unit, **meshes)
        for w in caught:
            if issubclass(w.category, UnitWarning):
                print(f"wrinkle-vis {args.command}: note: {w.message} (--unit)",
                      file=sys.stderr)
            else:
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    except ValueError as exc:  # a face the layout's meshes and landmarks cannot make
        if isinstance(exc, MeshError):  # names its file
            raise
        skin = getattr(args, "skin", None)
        where = (f"--layout {args.layout}" if args.layout else f"--skin {skin}" if skin
                 else f"--face {args.face}" if args.face else "the built-in face")
        raise CliError(f"{where}: {exc}") from None
    return face


def _checked_names(args, face):
    """``--expression`` (as given) after checking it and ``--muscle`` name the face's."""
    names = getattr(args, "expression", None)
    for name in names if isinstance(names, list) else [] if names is None else [names]:
        if name not in face.expressions:
            raise CliError(f"unknown expression {name!r}; choose from: "
                           f"{', '.join(face.expressions)}")
    muscle = getattr(args, "muscle", None)
    if muscle is not None and muscle not in face.muscle_names:
        raise CliError(f"unknown muscle {muscle!r}; choose from: {', '.join(face.muscle_names)}")
    return names


def _prepare_muscles(args, face) -> None:
    """Build every muscle's data on a large skin with a progress bar on stderr (the first
    step also smooths the skin's normals): the first frame's set-up, shown as it goes.
    """
    from tqdm import tqdm

    for muscle in tqdm(face.muscles, desc=f"wrinkle-vis {args.command}: muscles",
                       unit="muscle", delay=PROGRESS_DELAY_S, leave=False):
        face.muscle_data(muscle)


#: A step that takes longer than this (seconds) shows a progress bar.
PROGRESS_DELAY_S = 2.0

#: A skin file this large (bytes) is announced before it is read; a skin of this many
#: triangles gets an estimate of the time its skull and first frame take.
LARGE_SKIN_BYTES = 32 << 20
LARGE_SKIN_TRIANGLES = 200_000


def _read_skin(args, path: Path):
    """The skin at ``path``, read with a line before a large file and, for a large mesh, a
    line with its size and an estimate of the minutes that follow (:func:`_estimate_s`).
    """
    from wrinkle_vis.datasets import read_surface

    size = path.stat().st_size if input_problem(path) is None else 0
    if size >= LARGE_SKIN_BYTES:
        print(f"wrinkle-vis {args.command}: reading {path} ({size / 2**20:,.0f} MiB)...",
              file=sys.stderr, flush=True)
    start = time.perf_counter()
    skin = read_surface(path)
    n = skin.n_triangles
    if n >= LARGE_SKIN_TRIANGLES:
        est = _estimate_s(n)
        more = f"{est:.0f} s" if est < 120 else f"{est / 60:.0f} min"
        print(f"wrinkle-vis {args.command}: note: {path} has {n:,} triangles (read in "
              f"{time.perf_counter() - start:.0f} s); its skull, the muscles and the first "
              f"frame take about {more} more (a skull is cached: the next run is faster)",
              file=sys.stderr, flush=True)
    return skin


def _estimate_s(n_triangles: int) -> float:
    """Seconds a scan of ``n_triangles`` takes from its read to its first frame, roughly:
    the skull (level set, about n^1.2: 313 s at 1.13 M triangles on 2 idle cores, issue 33)
    and the first frame (about n^1.1: 2/3 of the ~35 s the two-level solve alone left at
    1.13 M, ``benchmarks/bench_smoothed_normals.py``, since the muscles are set up near their
    areas of influence only, ``benchmarks/bench_first_frame.py``); a busy machine takes
    longer.
    """
    m = n_triangles / 1e6
    return SKULL_S_PER_MTRI * m**1.2 + FIRST_FRAME_S_PER_MTRI * m**1.1


SKULL_S_PER_MTRI = 250.0
FIRST_FRAME_S_PER_MTRI = 20.0


def _tapered(face):
    """``face`` with the ``taper`` option on for every muscle (``--taper``)."""
    import dataclasses

    for muscle in face.muscles:
        if not muscle.taper:
            face = face.with_muscle(dataclasses.replace(muscle, taper=True))
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
    from wrinkle_vis.core.sampling import (
        UndersampledWrinklesWarning,
        undersampled_line,
        warn_undersampled,
    )

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
    line = undersampled_line(found)  # one line for all of them
    if line:
        print(f"wrinkle-vis {args.command}: warning: {line}", file=sys.stderr)


def _check_track(args) -> None:
    """One line for track options without ``--track``, or out of range (before any work)."""
    given = [flag for flag, value in (("--format", args.format), ("--map", args.map),
                                      ("--fps-in", args.fps_in), ("--max-mb", args.max_mb))
             if value is not None] + (["--smooth"] if args.smooth else [])
    if args.track is None:
        if given:
            raise CliError(f"{given[0]} is an option of a recorded track; add --track FILE")
        return
    if not args.smooth >= 0:
        raise CliError(f"--smooth {args.smooth:g} must be >= 0 seconds (0: no smoothing)")
    for flag, value in (("--fps-in", args.fps_in), ("--max-mb", args.max_mb)):
        if value is not None and not value > 0:
            raise CliError(f"{flag} {value:g} must be a positive number")
    if args.map is not None and not args.map.is_file():
        raise CliError(f"--map {args.map}: no such file; give a layout file or a mapping "
                       "JSON file")


def _read_track(args):
    """The track of ``--track``; its notes (what was interpolated, dropped, ...) printed."""
    from wrinkle_vis.core.tracks import MAX_TRACK_BYTES, TrackError, TrackWarning, read_track

    limit = MAX_TRACK_BYTES if args.max_mb is None else int(args.max_mb * 2**20)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", TrackWarning)
            track = read_track(args.track, args.format, args.fps_in, max_bytes=limit)
    except (TrackError, FileNotFoundError) as exc:
        raise CliError(f"--track {exc}") from None
    args.track_mapping = _read_map(args)
    for note in track.notes:
        print(f"wrinkle-vis {args.command}: note: {args.track.name}: {note}", file=sys.stderr)
    return track


def _track_mapping(args, face):
    """``--map``'s mapping, else the face's, else the FACS default."""
    from wrinkle_vis.core.tracks import default_mapping

    return getattr(args, "track_mapping", None) or face.mapping or default_mapping()


def _read_map(args):
    """The mapping of ``--map`` (a layout file's, or a mapping JSON file); None without."""
    import json

    from wrinkle_vis.core.layout import FORMAT, load_layout
    from wrinkle_vis.core.tracks import TrackMapping

    if args.map is None:
        return None
    try:
        data = json.loads(args.map.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise CliError(f"--map {args.map}: not a JSON file ({exc})") from None
    if isinstance(data, dict) and data.get("format") == FORMAT:
        mapping = load_layout(args.map).mapping
        if mapping is None:
            raise CliError(f"--map {args.map}: the layout has no \"mapping\"; add one or "
                           "leave --map out for the default")
        return mapping
    try:
        return TrackMapping.from_dict(data if isinstance(data, dict) else {"$": data})
    except (TypeError, ValueError) as exc:
        raise CliError(f"--map {args.map}: {exc}") from None


def _performance(args, face, track, fps: float):
    """The track on ``face`` at ``fps`` (:func:`~wrinkle_vis.core.tracks.performance`)."""
    from wrinkle_vis.core.tracks import performance

    return performance(track, _track_mapping(args, face), face.muscle_names, fps=fps,
                       smooth_s=args.smooth, name=args.track.stem)


def _summary_track(args, face, track) -> int:
    """Print the track's channels and the muscles each drives."""
    mapping = _track_mapping(args, face)
    print(f"\n== track {args.track.name}: {track.format}, {track.n_frames} frames, "
          f"{track.duration_s:.3f} s ({track.fps:.4g} frames/s) ==")
    for j, name in enumerate(track.channels):
        drives = {m: w for m, w in mapping.drives(name).items() if m in face.muscle_names}
        text = ", ".join(f"{m} x{w:g}" for m, w in drives.items()) or "drives no muscle"
        values = track.values[:, j]
        print(f"{name:>18}  peak {values.max():.3f}  mean {values.mean():.3f}  -> {text}")
    acts = mapping.activations(track, face.muscle_names)
    driven = [m for j, m in enumerate(face.muscle_names) if acts[:, j].max() > 0]
    print(f"muscles driven: {', '.join(driven) or 'none'}")
    return 0


def _summary(args) -> int:
    _check_track(args)
    track = _read_track(args) if args.track is not None else None
    t0 = time.perf_counter()
    face = _load(args)
    print(f"loaded {face.name} in {time.perf_counter() - t0:.2f} s: "
          f"{face.skin.n_triangles} skin triangles, "
          f"{face.skull.n_triangles if face.skull else 0} skull triangles, "
          f"{len(face.muscles)} muscles")
    if track is not None:
        return _summary_track(args, face, track)
    for name in args.expression or list(face.expressions):
        t0 = time.perf_counter()
        state = face.evaluate(name, intensity=args.intensity)
        ms = 1e3 * (time.perf_counter() - t0)
        print(f"\n== {name} (intensity {args.intensity:g}, {face.skin_model} skin, "
              f"{ms:.2f} ms) ==")
        print(state.summary())
    return 0


def _field(args):
    field = None if args.field == "none" else args.field
    if field is not None:
        _check_field(field, args.__dict__.get("muscle"))
    return field


def _check_field(field: str, muscle: str | None) -> None:
    """A field with no total (the catalogue's; all but W) needs ``--muscle``."""
    from wrinkle_vis.core.fields import check_field

    try:
        check_field(field, muscle)
    except ValueError:
        raise CliError(f"--field {field} belongs to one muscle: add --muscle NAME") from None


def _render(args) -> int:
    from wrinkle_vis.plotting import render_field
    from wrinkle_vis.plotting.offscreen import headless_rendering
    from wrinkle_vis.plotting.writers import save_image

    _output(args, (".png",))
    field = _field(args)
    face = _load(args, refine=args.refine)
    with headless_rendering():
        image = render_field(face, args.expression, field, args.muscle,
                             layers=tuple(args.layers), camera=args.camera,
                             size=tuple(args.size), intensity=args.intensity,
                             refine=args.refine, **_refinement(args))
    written = save_image(image, args.output)
    print(f"wrote {_wrote(args, written)}")
    return 0


def _export(args) -> int:
    from wrinkle_vis.plotting.exchange import GLTF_SUFFIXES
    from wrinkle_vis.plotting.writers import MESH_SUFFIXES, save_mesh

    suffix = args.output.suffix.lower()
    _check_track(args)
    if args.sequence:
        return _export_sequence(args)
    if args.track is not None:
        raise CliError("--track writes the performance as a sequence; add --sequence")
    if suffix == ".pvd":
        raise CliError(f"--output {args.output.name!r}: {suffix} is written as a sequence of "
                       "the expression's ramp; add --sequence")
    if args.fps is not None:
        raise CliError("--fps is the frame rate of --sequence; add --sequence or leave "
                       "--fps out")
    _output(args, MESH_SUFFIXES + GLTF_SUFFIXES)
    if suffix == ".glb":
        return _export_gltf(args)
    args.expression = "surprise" if args.expression is None else args.expression
    face = _load(args)
    state = face.evaluate(args.expression, args.intensity)
    if args.output.suffix.lower() == ".vtm":
        from wrinkle_vis.plotting import to_multiblock

        written = save_mesh(to_multiblock(state), args.output)
    else:
        written = save_mesh(state.to_polydata(), args.output)
    print(f"wrote {_wrote(args, written)}: {written.summary}")
    return 0


def _export_sequence(args) -> int:
    from tqdm import tqdm

    from wrinkle_vis.core.files import OutputPathError
    from wrinkle_vis.plotting.animation import frame_times
    from wrinkle_vis.plotting.exchange import (
        SEQUENCE_SUFFIXES,
        check_sequence_target,
        save_sequence,
        sequence_states,
    )

    _output(args, SEQUENCE_SUFFIXES)
    try:
        check_sequence_target(args.output)
    except OutputPathError as exc:
        raise CliError(f"--output {exc}") from None
    args.expression = "surprise" if args.expression is None else args.expression
    track = _read_track(args) if args.track is not None else None
    face = _load(args)
    fps = args.fps or (12 if track is None else TRACK_FPS)
    expression = face.expressions[args.expression] if track is None else \
        _performance(args, face, track, fps)
    try:
        times = frame_times(expression, fps)
    except ValueError as exc:
        raise CliError(str(exc)) from None
    states = sequence_states(face, expression, times, args.intensity)
    progress = tqdm(states, total=len(times), desc=f"writing {args.output.name}",
                    unit="frame", delay=0.5)
    try:
        written = save_sequence(progress, times, args.output)
    finally:
        progress.close()
        states.close()
    print(f"wrote {_wrote(args, written)}: {written.summary}")
    return 0


def _export_gltf(args) -> int:
    from functools import partial

    from tqdm import tqdm

    from wrinkle_vis.plotting.exchange import METRES_PER_UNIT, face_unit, save_gltf

    if args.intensity != 1.0:
        raise CliError(f"--intensity {args.intensity:g}: a .glb holds each expression at "
                       "full intensity (the morph target's weight is the intensity); leave "
                       "--intensity out")
    face = _load(args)
    unit = args.unit or face_unit(face)
    if unit not in METRES_PER_UNIT:
        raise CliError(f"the face's unit {unit!r} is not one glTF can be scaled from; give "
                       f"it with --unit ({', '.join(METRES_PER_UNIT)})")
    names = [args.expression] if args.expression else list(face.expressions)
    progress = partial(tqdm, desc=f"writing {args.output.name}", unit="expression",
                       delay=0.5)
    written = save_gltf(face, args.output, names, unit=unit, progress=progress,
                        corner_uvs=_gltf_uvs(args, face))
    print(f"wrote {_wrote(args, written)}: {written.summary}")
    return 0


def _bake(args) -> int:
    from functools import partial

    import numpy as np
    from tqdm import tqdm

    from wrinkle_vis.core.files import OutputPathError
    from wrinkle_vis.core.parametric import refined_root_coordinates
    from wrinkle_vis.plotting.bake import bake_maps, check_bake_folder, save_bake
    from wrinkle_vis.plotting.exchange import face_unit
    from wrinkle_vis.plotting.scenes import evaluate

    try:
        check_bake_folder(args.output)
    except OutputPathError as exc:
        raise CliError(f"--output {exc}") from None
    except OSError as exc:
        raise _unusable_output(args.output, exc) from None
    if not 0 <= args.padding <= MAX_PADDING:
        raise CliError(f"--padding {args.padding} is outside 0..{MAX_PADDING}; choose a "
                       "number of texels in that range (default 8)")
    fields = args.field or ["W"]
    for name in fields:
        _check_field(name, args.muscle)
    source = _uv_source(args)  # no UVs: said before any work
    face = _load(args, refine=args.refine)
    uvs = _uvs(source, face)
    state = evaluate(face, args.expression, args.intensity, refine=args.refine,
                     **_refinement(args))
    if state.face.skin is not face.skin:  # refined: each triangle's UVs from its root's
        root, bary = refined_root_coordinates(face, state)
        uvs = np.einsum("mij,mjk->mik", bary, uvs[root])
    progress = partial(tqdm, desc=f"baking {args.output.name}", unit="step", delay=0.5)
    maps = bake_maps(state, uvs, tuple(args.size), fields=[(f, args.muscle) for f in fields],
                     padding=args.padding, unit=args.unit or face_unit(face),
                     progress=progress,
                     info={"expression": args.expression, "intensity": args.intensity,
                           "triangles": state.face.skin.n_triangles,
                           "refined": state.face.skin is not face.skin})
    written = save_bake(maps, args.output)
    print(f"wrote {args.output}: {written.summary}; W sampled back at the texel centres "
          f"within {100 * maps.check['texel_centres_max']:.3g} % of its range")
    return 0


def _gltf_uvs(args, face):
    """The skin's corner UVs when it has them (an OBJ with ``vt``, the built-in head),
    for a glTF's ``TEXCOORD_0``; None for a skin without.
    """
    from wrinkle_vis.plotting.bake import UVError

    try:
        return _uvs(_uv_source(args), face)
    except (CliError, UVError):
        return None


def _uv_source(args):
    """Where the skin's UVs come from: ``"lee_perry_smith"`` (the built-in head's) or an
    OBJ file, checked to hold UVs; a one-line error otherwise.
    """
    from wrinkle_vis.plotting.bake import _parse_obj, read_obj_uvs

    source = args.skin
    if source is None and args.layout is not None:
        from wrinkle_vis.core.layout import load_layout

        layout = load_layout(args.layout)
        source = layout.resolve("skin", args.layout.parent)
        if source is None and layout.face == "lee_perry_smith":
            return "lee_perry_smith"
    if source is None and args.face == "lee_perry_smith":
        return "lee_perry_smith"
    if source is None:
        raise CliError("the built-in face has no UV coordinates; give a skin with UVs: "
                       "--skin head.obj (an OBJ with vt) with --landmarks or --layout for "
                       "its muscles, or bake the real head: --face lee_perry_smith")
    if not Path(source).is_file():
        return source  # _load names the missing file
    if Path(source).suffix.lower() != ".obj" or len(_parse_obj(Path(source))[1]) == 0:
        read_obj_uvs(source, None)  # raises UVError, naming the file and the way out
    return source


def _uvs(source, face):
    """The corner UVs of ``face``'s skin from :func:`_uv_source`'s answer."""
    from wrinkle_vis.plotting.bake import read_obj_uvs

    if source == "lee_perry_smith":
        from wrinkle_vis.datasets.lee_perry_smith import lee_perry_smith_uvs

        return lee_perry_smith_uvs()
    return read_obj_uvs(source, face.skin)


def _animate(args) -> int:
    from tqdm import tqdm

    from wrinkle_vis.plotting.animation import animation_frames, frame_times
    from wrinkle_vis.plotting.offscreen import headless_rendering
    from wrinkle_vis.plotting.writers import ANIMATION_SUFFIXES, save_animation

    _output(args, ANIMATION_SUFFIXES)
    _check_track(args)
    field = _field(args)
    track = _read_track(args) if args.track is not None else None
    face = _load(args, refine=args.refine)
    args.fps = args.fps or (12 if track is None else TRACK_FPS)
    expression = face.expressions[args.expression] if track is None else \
        _performance(args, face, track, args.fps)
    try:
        times = frame_times(expression, args.fps)
    except ValueError as exc:
        raise CliError(str(exc)) from None
    with headless_rendering():
        frames = animation_frames(face, expression, times, field=field, muscle=args.muscle,
                                  layers=tuple(args.layers), camera=args.camera,
                                  size=tuple(args.size), intensity=args.intensity,
                                  label=expression.name, refine=args.refine,
                                  **_refinement(args))
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
    if args.figure == "fig10":
        return _figure10(args)
    if args.times is not None:
        raise CliError("--times is for fig10 (the simulated snapshots); leave it out")
    if not args.expression:
        args.expression = list(FIG9_EXPRESSIONS) if args.figure == "fig9" else ["surprise"]
    face = _load(args, refine=args.refine or args.figure == "fig11")
    size = None if args.size is None else tuple(args.size)
    with headless_rendering():
        if args.figure == "fig9":
            image = figure_expressions(face, args.expression, size=size,
                                       intensity=args.intensity, refine=args.refine,
                                       **_refinement(args))
        else:
            image = figure_refinement(face, expression=args.expression[0],
                                      size=size or (800, 800), intensity=args.intensity,
                                      **_refinement(args))
    written = save_image(image, args.output)
    print(f"wrote {_wrote(args, written)}")
    return 0


def _figure10(args) -> int:
    """fig10: snapshots of the physical skin after a step to one expression."""
    from wrinkle_vis.plotting.figures import figure_dynamics
    from wrinkle_vis.plotting.offscreen import headless_rendering
    from wrinkle_vis.plotting.writers import save_image

    if args.expression and len(args.expression) > 1:
        raise CliError(f"fig10 shows one expression; got {len(args.expression)}")
    times = tuple(args.times or FIG10_TIMES)
    if not all(0.0 < t <= 10.0 for t in times):
        raise CliError("--times must lie in (0, 10] seconds after the step")
    expression = (args.expression or ["surprise"])[0]
    args.skin_model = "physical"  # fig10 is the simulation
    face = _load(args)
    size = None if args.size is None else tuple(args.size)
    with headless_rendering():
        image = figure_dynamics(face, expression, times, size=size, intensity=args.intensity)
    written = save_image(image, args.output)
    print(f"wrote {_wrote(args, written)}")
    return 0


def _app(parser, layout: str | None = None) -> int:
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

    return run(sys.argv[:1], layout=layout)


COMMANDS = {"summary": _summary, "render": _render, "export": _export, "animate": _animate,
            "figure": _figure, "bake": _bake}


def main(argv=None) -> int:
    """Entry point of the ``wrinkle-vis`` command."""
    parser = _parser()
    argv = sys.argv[1:] if argv is None else list(argv)
    if len(argv) == 1 and argv[0] not in COMMANDS and (
            argv[0].endswith(".json") or Path(argv[0]).is_file()):
        layout = Path(argv[0])  # ``wrinkle-vis LAYOUT``: the app on a layout file
        if not layout.is_file():
            what = "is a folder, not a layout file" if layout.is_dir() else "no such file"
            parser.error(f"{layout}: {what}; give a layout file (.json) or a command "
                         f"({', '.join(COMMANDS)})")
        return _app(parser, str(layout))
    args = parser.parse_args(argv)
    if args.command is None:
        return _app(parser)
    if args.command in ("types", "sweep"):
        try:
            return _types(args) if args.command == "types" else _sweep(args)
        except CliError as exc:
            message = " ".join(str(exc).split())
            print(f"wrinkle-vis {args.command}: {message}", file=sys.stderr)
            return 2
    if not (0.0 <= args.intensity <= 1.0):
        parser.error(f"--intensity {args.intensity:g} is outside [0, 1]")
    if getattr(args, "layout", None) is not None and input_problem(args.layout) is not None:
        parser.error(f"--layout {args.layout}: {input_problem(args.layout)}; check the path")
    from wrinkle_vis.core.files import Interrupted, OutputPathError, WriteError, commits
    from wrinkle_vis.core.layout import LayoutError
    from wrinkle_vis.core.mesh import MeshError

    before, received = commits(), []
    try:
        with _signals_raise(received):
            _check_common(args)
            status = COMMANDS[args.command](args)
    except (KeyboardInterrupt, Interrupted) as exc:  # the temporaries are gone by now
        return _interrupted(args, getattr(exc, "signum", signal.SIGINT), before)
    except (CliError, LayoutError, MeshError, OutputPathError, WriteError) as exc:
        if received:
            return _interrupted(args, received[0], before)
        message = " ".join(str(exc).split())  # one line, whatever the message holds
        print(f"wrinkle-vis {args.command}: {message}", file=sys.stderr)
        return 2
    except Exception:
        if received:  # the interrupt, come out of VTK as another error
            return _interrupted(args, received[0], before)
        raise
    return _interrupted(args, received[0], before) if received else status


def _interrupted(args, signum: int, commits_before: int) -> int:
    """Say that the command was interrupted, and whether it had put its output in place;
    the exit status is 128 + the signal's number.
    """
    from wrinkle_vis.core.files import commits

    what = "nothing was changed" if commits() == commits_before else \
        "the output was already in place"
    print(f"wrinkle-vis {args.command}: interrupted; {what}", file=sys.stderr)
    return 128 + int(signum)


if __name__ == "__main__":
    sys.exit(main())
