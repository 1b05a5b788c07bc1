"""Sweep specs: read (TOML or JSON), check every value before any run, expand to runs.

A spec names the faces, the expressions, the parameters to vary and what each run writes
(``docs/sweeps.md`` documents every key; ``docs/examples/sweep.toml`` is an example).
:func:`load_spec` checks it whole and raises :class:`SweepSpecError`, one line naming the
file, the key and the way out, before anything runs; :meth:`SweepSpec.runs` expands it to
the runs, each named by a hash of its parameters (:func:`run_id`).
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from wrinkle_vis.core.expressions import Expression
from wrinkle_vis.core.layout import Layout, LayoutError, load_layout
from wrinkle_vis.core.muscle import Muscle, MuscleParameterError
from wrinkle_vis.core.params import Parameter
from wrinkle_vis.core.skin import DEFAULT_SKIN_MODEL

__all__ = ["IMAGE_FIELDS", "MESH_FORMATS", "Run", "SweepSpec", "SweepSpecError", "load_spec",
           "parse_spec", "run_id"]

#: Mesh formats a run can write: VTK XML, PLY (both with every field as point arrays) and
#: binary glTF (the neutral skin with the run's frame as a morph target).
MESH_FORMATS = ("vtp", "ply", "glb")
#: Cameras an image can take (:data:`wrinkle_vis.plotting.CAMERAS`, without importing it).
CAMERAS = ("front", "three_quarter", "side", "forehead", "upper_face")
#: Fields an image can show ("none": plain skin; the rest: the catalogue's total fields).
IMAGE_FIELDS = ("W", "none")
#: Per-vertex arrays a run can save: the frame's own, and per active muscle its fields.
FRAME_ARRAYS = ("W", "points", "deformed_points", "rest_points", "triangles", "normals")
MUSCLE_ARRAYS = ("lambda", "gamma", "l", "eps", "At", "A", "H", "w")
#: The skin model of a run whose parameters name none (:attr:`Run.params`): runs from before
#: there were skin models were geometric, and their ids stay what they were. Not the default
#: of a spec that names no skin model (that is :data:`~wrinkle_vis.core.skin.DEFAULT_SKIN_MODEL`).
ID_SKIN_MODEL = "geometric"
_TOP_KEYS = {"name", "seed", "samples", "faces", "expressions", "intensity", "times_s",
             "refine", "skin_model", "vary", "outputs", "prominence"}
_TRACK_KEYS = ("track", "name", "format", "fps", "resample_fps")
_BUILTIN_FACES = ("procedural", "lee_perry_smith")
_MIN_TRIANGLES, _MAX_TRIANGLES = 500, 250_000  # wrinkle_vis.datasets.face's range
_MAX_RUNS = 10_000_000


class SweepSpecError(ValueError):
    """A bad sweep spec: one line naming the file, the key, the problem and the way out."""


@dataclass(frozen=True)
class Run:
    """One run of a sweep: its parameters (plain JSON values), id and seed.

    Attributes
    ----------
    params : dict
        ``face`` (a dict: ``name``, ``n_triangles``, ``layout``, the layout file's name, and
        ``layout_sha256``, the hash of its contents: not its path, so that the id is the same
        wherever the file lies),
        ``expression`` (a name, ``{"name", "activations"}``, or a recorded track:
        ``{"name", "track", "track_sha256", "format", "fps"}``, the file's name and the hash
        of its contents), ``intensity``, ``time_s`` (None: the expression's peak; on a
        track, seconds from its first frame), ``refine``, ``skin_model`` (only when not
        :data:`ID_SKIN_MODEL`, so the geometric runs keep the ids they had before skin
        models) and ``set``: ``{muscle:
        {parameter: value}}`` for every muscle a varied parameter touches.
    columns : dict
        The run's row in the table: its plain parameters and one column per varied
        parameter (its ``label``).
    layout_path : str or None
        Where the face's layout file lies (a worker reads it from there).
    track_path : str or None
        Where the track file lies, for a run of a recorded track.
    """

    params: dict
    columns: dict
    layout_path: str | None = None
    track_path: str | None = None

    @cached_property
    def id(self) -> str:
        """A hash of :attr:`params` (:func:`run_id`)."""
        return run_id(self.params)

    @cached_property
    def seed(self) -> int:
        """A seed derived from the id: the first 8 hex digits as an integer."""
        return int(self.id[:8], 16)


def run_id(params: Mapping) -> str:
    """The first 16 hex digits of the SHA-256 of ``params`` as canonical JSON (sorted keys,
    no spaces, floats as Python writes them): the same parameters give the same id on any
    machine.
    """
    text = json.dumps(params, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass(frozen=True)
class _Face:
    params: dict  # name, n_triangles, layout, layout_sha256
    layout: Layout
    label: str
    path: str | None = None


@dataclass(frozen=True)
class _Track:
    params: dict  # name, track (file name), track_sha256, format, fps
    path: str
    times: tuple  # the frames' times, or resampled
    duration_s: float

    @property
    def name(self) -> str:
        return self.params["name"]


@dataclass(frozen=True)
class _Vary:
    label: str
    parameter: str
    targets: dict  # face label -> tuple of muscle names
    values: tuple | None  # a list or a grid
    random: tuple | None  # (low, high, integer)


@dataclass(frozen=True)
class SweepSpec:
    """A checked sweep spec (:func:`load_spec`).

    Attributes
    ----------
    source : str
        Where it came from (a file name), for messages.
    name : str
        The sweep's name.
    outputs : dict
        What each run writes: ``images`` (``fields``, ``cameras``, ``size``,
        ``raking_light``) or None, ``meshes`` (a list of :data:`MESH_FORMATS`),
        ``arrays`` (a list of names) and ``prominence`` (of the crests and furrows the
        metrics count, as a fraction of each cut's range).
    """

    source: str
    name: str
    seed: int
    samples: int
    faces: tuple
    expressions: tuple
    intensity: tuple
    times_s: tuple
    refine: tuple
    vary: tuple
    outputs: dict
    raw: dict = field(repr=False, default_factory=dict)
    skin_models: tuple = (DEFAULT_SKIN_MODEL,)
    times_given: bool = False

    def runs(self) -> list[Run]:
        """Every run, in the spec's order: the product of the faces, expressions,
        intensities, times, refinements, skin models and the varied lists and grids, times
        ``samples`` joint draws of the random parameters (seeded by ``seed``). A recorded
        track's times are its frames (or ``resample_fps``), unless ``times_s`` is given.
        """
        draws = self._draws()
        grid_vary = [v for v in self.vary if v.values is not None]
        rand_vary = [v for v in self.vary if v.random is not None]
        out = []
        for face, expr, k in itertools.product(self.faces, self.expressions, self.intensity):
            times = expr.times if isinstance(expr, _Track) and not self.times_given \
                else self.times_s
            for t, refine, skin in itertools.product(times, self.refine, self.skin_models):
                for combo in itertools.product(*(v.values for v in grid_vary)):
                    for draw in draws:
                        chosen = list(zip(grid_vary, combo, strict=True)) + list(
                            zip(rand_vary, draw, strict=True))
                        out.append(_run(face, expr, k, t, refine, chosen, skin))
        return out

    def _draws(self) -> list[tuple]:
        rand_vary = [v for v in self.vary if v.random is not None]
        if not rand_vary:
            return [()]
        columns = []
        for index, v in enumerate(self.vary):
            if v.random is None:
                continue
            rng = np.random.default_rng([self.seed, index])
            lo, hi, integer = v.random
            if integer:
                columns.append([int(x) for x in rng.integers(lo, hi + 1, self.samples)])
            else:
                columns.append([float(x) for x in rng.uniform(lo, hi, self.samples)])
        return list(zip(*columns, strict=True))

    def outputs_key(self) -> str:
        """A hash of :attr:`outputs`: a finished run that wrote other outputs is redone."""
        return run_id(self.outputs)


def _run(face: _Face, expr, k: float, t, refine: bool, chosen: list,
         skin: str = DEFAULT_SKIN_MODEL) -> Run:
    overrides: dict[str, dict] = {}
    track = expr if isinstance(expr, _Track) else None
    columns = {"face": face.label, "n_triangles": face.params["n_triangles"],
               "expression": expr if isinstance(expr, str) else expr.name if track
               else expr["name"],
               "intensity": k, "time_s": t, "refine": refine, "skin_model": skin}
    for vary, value in chosen:
        for muscle in vary.targets[face.label]:
            overrides.setdefault(muscle, {})[vary.parameter] = value
        columns[vary.label] = value
    params = {"face": face.params, "expression": track.params if track else expr,
              "intensity": k, "time_s": t, "refine": refine,
              "set": {m: dict(sorted(p.items())) for m, p in sorted(overrides.items())}}
    if skin != ID_SKIN_MODEL:  # the geometric runs keep the ids they had before skin models
        params["skin_model"] = skin
    return Run(params, columns, face.path, track.path if track else None)


# ---------------------------------------------------------------------- reading
def load_spec(spec: str | os.PathLike | Mapping) -> SweepSpec:
    """Read and check a sweep spec: a ``.toml`` or ``.json`` file, or a mapping.

    Raises
    ------
    SweepSpecError
        One line naming the file, the key, what is wrong and the way out: an unreadable
        file, an unknown key, face, expression, muscle, muscle type or parameter, a value
        outside its parameter's declared range (:class:`~wrinkle_vis.core.params.Parameter`),
        an empty grid, or a run whose muscles do not validate together.
    """
    if isinstance(spec, SweepSpec):
        return spec
    if isinstance(spec, Mapping):
        return parse_spec(dict(spec), "<spec>", Path.cwd())
    path = Path(spec)
    if not path.is_file():
        what = "is a folder" if path.is_dir() else "does not exist"
        raise SweepSpecError(f"{path}: {what}; give a sweep spec file (.toml or .json)")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SweepSpecError(f"{path}: cannot be read ({exc}); check the file") from None
    try:
        if path.suffix.lower() == ".json":
            data = json.loads(text)
        else:
            data = tomllib.loads(text)
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as exc:
        kind = "JSON" if path.suffix.lower() == ".json" else "TOML"
        raise SweepSpecError(f"{path}: not valid {kind}: {exc}") from None
    if not isinstance(data, dict):
        raise SweepSpecError(f"{path}: expected a table of keys at the top; found "
                             f"{type(data).__name__}")
    return parse_spec(data, str(path), path.parent)


def parse_spec(data: dict, source: str, base: Path) -> SweepSpec:
    """Check the spec ``data`` (read from ``source``; relative paths from ``base``)."""
    e = _Errors(source)
    unknown = sorted(set(data) - _TOP_KEYS)
    if unknown:
        e.fail(unknown[0], f"unknown key; the keys are: {', '.join(sorted(_TOP_KEYS))}")
    faces = tuple(_face(e, f"faces[{i}]", f, base)
                  for i, f in enumerate(_list(e, data, "faces", ["procedural"])))
    labels = [f.label for f in faces]
    if len(set(labels)) != len(labels):
        e.fail("faces", "the same face is listed twice; list each once")
    expressions = tuple(_expression(e, f"expressions[{i}]", x, faces, base)
                        for i, x in enumerate(_list(e, data, "expressions", ["surprise"])))
    intensity = tuple(_number(e, f"intensity[{i}]", x, 0.0, 1.0)
                      for i, x in enumerate(_list(e, data, "intensity", [1.0])))
    times = tuple(None if x is None else _number(e, f"times_s[{i}]", x, 0.0, math.inf)
                  for i, x in enumerate(_list(e, data, "times_s", [None])))
    refine = tuple(_bool(e, f"refine[{i}]", x)
                   for i, x in enumerate(_list(e, data, "refine", [False])))
    skins = tuple(_skin_model(e, f"skin_model[{i}]", x)
                  for i, x in enumerate(_list(e, data, "skin_model", [DEFAULT_SKIN_MODEL])))
    if len(set(skins)) != len(skins):
        e.fail("skin_model", "a skin model is listed twice; list each once")
    _check_track_times(e, expressions, times, "times_s" in data)
    vary = tuple(_vary(e, f"vary[{i}]", v, faces)
                 for i, v in enumerate(_list(e, data, "vary", [], allow_empty=True)))
    vlabels = [v.label for v in vary]
    dup = sorted({x for x in vlabels if vlabels.count(x) > 1})
    if dup:
        e.fail("vary", f"two entries vary {dup[0]!r}; give one a 'label' or merge them")
    has_random = any(v.random is not None for v in vary)
    samples = data.get("samples", 1 if not has_random else None)
    if samples is None:
        e.fail("samples", "a random parameter needs 'samples = N' (how many draws)")
    samples = _integer(e, "samples", samples, 1)
    seed = _integer(e, "seed", data.get("seed", 0), 0)
    name = data.get("name", Path(source).stem)
    if not isinstance(name, str) or not name:
        e.fail("name", f"expected a non-empty string; found {name!r}")
    spec = SweepSpec(source=source, name=name, seed=seed, samples=samples, faces=faces,
                     expressions=expressions, intensity=intensity, times_s=times,
                     refine=refine, vary=vary, outputs=_outputs(e, data.get("outputs", {})),
                     raw=data, skin_models=skins, times_given="times_s" in data)
    spec.outputs["prominence"] = _number(e, "prominence", data.get("prominence", 0.1), 0.0,
                                         1.0)
    _check_runs(e, spec)
    return spec


class _Errors:
    def __init__(self, source: str):
        self.source = source

    def fail(self, key: str, message: str):
        raise SweepSpecError(f"{self.source}: {key}: {message}")


def _list(e: _Errors, data: Mapping, key: str, default: list, allow_empty: bool = False):
    value = data.get(key, default)
    if not isinstance(value, list):
        value = [value]
    if not value and not allow_empty:
        e.fail(key, "is empty; list at least one value (or leave the key out for the "
                    f"default {default!r})")
    return value


def _number(e: _Errors, key: str, value, lo: float, hi: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(
            value):
        e.fail(key, f"expected a number; found {value!r}")
    if not lo <= value <= hi:
        e.fail(key, f"{value:g} is outside [{lo:g}, {hi:g}]")
    return float(value)


def _integer(e: _Errors, key: str, value, lo: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < lo:
        e.fail(key, f"expected an integer >= {lo}; found {value!r}")
    return int(value)


def _bool(e: _Errors, key: str, value) -> bool:
    if not isinstance(value, bool):
        e.fail(key, f"expected true or false; found {value!r}")
    return value


def _face(e: _Errors, key: str, value, base: Path) -> _Face:
    if isinstance(value, str):
        value = {"name": value} if value in _BUILTIN_FACES or not value.endswith(
            ".json") else {"layout": value}
    if not isinstance(value, dict):
        e.fail(key, f"expected a face name or a table {{name = ..., n_triangles = ...}}; "
                    f"found {value!r}")
    extra = sorted(set(value) - {"name", "layout", "n_triangles"})
    if extra:
        e.fail(f"{key}.{extra[0]}", "unknown key; a face has name, layout and n_triangles")
    name, layout_path = value.get("name"), value.get("layout")
    n = value.get("n_triangles")
    if n is not None:
        n = _integer(e, f"{key}.n_triangles", n, 0)
        if not _MIN_TRIANGLES <= n <= _MAX_TRIANGLES:
            e.fail(f"{key}.n_triangles", f"{n} is outside the supported "
                   f"{_MIN_TRIANGLES}..{_MAX_TRIANGLES}")
    if layout_path is not None:
        path = (base / layout_path).resolve()
        try:
            layout = load_layout(path)
        except (FileNotFoundError, LayoutError) as exc:
            e.fail(f"{key}.layout", " ".join(str(exc).split()))
        sha = hashlib.sha256(path.read_bytes()).hexdigest()
        params = {"name": name, "layout": path.name, "layout_sha256": sha, "n_triangles": n}
        label = f"{path.stem}" + (f"@{n}" if n else "")
        return _Face(params, layout, label, str(path))
    name = name or "procedural"
    if name not in _BUILTIN_FACES:
        e.fail(f"{key}.name", f"no built-in face {name!r}; the built-in faces are "
                              f"{', '.join(_BUILTIN_FACES)} (or give layout = 'file.json')")
    if name == "lee_perry_smith" and n is not None:
        e.fail(f"{key}.n_triangles", "only the procedural face takes n_triangles")
    from wrinkle_vis.datasets.face import BUILTIN_LAYOUT
    from wrinkle_vis.datasets.lee_perry_smith import LAYOUT

    layout = load_layout(LAYOUT if name == "lee_perry_smith" else BUILTIN_LAYOUT)
    params = {"name": name, "layout": None, "layout_sha256": None, "n_triangles": n}
    return _Face(params, layout, name + (f"@{n}" if n else ""))


def _skin_model(e: _Errors, key: str, value) -> str:
    from wrinkle_vis.core.skin import check_skin_model

    try:
        return check_skin_model(value)
    except (ValueError, TypeError) as exc:
        e.fail(key, str(exc))
    return value


def _expression(e: _Errors, key: str, value, faces: tuple, base: Path) -> Any:
    if isinstance(value, dict) and "track" in value:
        return _track(e, key, value, faces, base)
    if isinstance(value, str):
        for f in faces:
            if value not in f.layout.expressions:
                e.fail(key, f"face {f.label} has no expression {value!r}; it has "
                            f"{', '.join(f.layout.expressions)}")
        return value
    if not isinstance(value, dict) or set(value) - {"name", "activations"} or not isinstance(
            value.get("activations"), dict):
        e.fail(key, "expected an expression name or a table {name = ..., activations = "
                    f"{{muscle = activation, ...}}}}; found {value!r}")
    name = str(value.get("name", "custom"))
    acts = value["activations"]
    for f in faces:
        names = [m.name for m in f.layout.muscles]
        unknown = sorted(set(acts) - set(names))
        if unknown:
            e.fail(f"{key}.activations.{unknown[0]}", f"face {f.label} has no such muscle; "
                   f"its muscles are {', '.join(names)}")
    try:
        Expression(name, acts)
    except (TypeError, ValueError) as exc:
        e.fail(f"{key}.activations", str(exc))
    return {"name": name, "activations": {k: float(v) for k, v in sorted(acts.items())}}


def _track(e: _Errors, key: str, value: dict, faces: tuple, base: Path) -> _Track:
    """A recorded track to play (``{track = "file.csv", name, format, fps,
    resample_fps}``): read and mapped on every face now, so a bad file or a track that
    drives none of a face's muscles is one line before any run.
    """
    from wrinkle_vis.core.tracks import TrackError, default_mapping, read_track

    extra = sorted(set(value) - set(_TRACK_KEYS))
    if extra:
        e.fail(f"{key}.{extra[0]}", f"unknown key; a track has {', '.join(_TRACK_KEYS)}")
    if not isinstance(value["track"], str) or not value["track"]:
        e.fail(f"{key}.track", f"expected a track file's path; found {value['track']!r}")
    fmt, fps = value.get("format"), value.get("fps")
    if fmt is not None and not isinstance(fmt, str):
        e.fail(f"{key}.format", f"expected a format name; found {fmt!r}")
    if fps is not None:
        fps = _number(e, f"{key}.fps", fps, 1e-3, 1e4)
    path = (base / value["track"]).resolve()
    try:
        track = read_track(path, fmt, fps)
    except (TrackError, OSError, ValueError) as exc:
        e.fail(f"{key}.track", " ".join(str(exc).split()))
    times = tuple(float(t) for t in track.times)
    if value.get("resample_fps") is not None:
        rate = _number(e, f"{key}.resample_fps", value["resample_fps"], 1e-3, 1e4)
        times = tuple(float(t) for t in track.frame_times(rate))
    for f in faces:
        mapping = f.layout.mapping or default_mapping()
        names = {m.name for m in f.layout.muscles}
        if not any(names & set(mapping.drives(c)) for c in track.channels):
            e.fail(f"{key}.track", f"{path.name} drives none of face {f.label}'s muscles "
                   "through its mapping; add a mapping to the face's layout or choose "
                   "another track")
    name = value.get("name", path.stem)
    if not isinstance(name, str) or not name:
        e.fail(f"{key}.name", f"expected a non-empty string; found {name!r}")
    params = {"name": name, "track": path.name,
              "track_sha256": hashlib.sha256(path.read_bytes()).hexdigest(),
              "format": track.format, "fps": fps}
    return _Track(params, str(path), times, track.duration_s)


def _check_track_times(e: _Errors, expressions: tuple, times: tuple, given: bool) -> None:
    """Times asked of a track lie on it (``times_s`` given) and are not the peak."""
    for x in expressions:
        if not isinstance(x, _Track) or not given:
            continue
        for j, t in enumerate(times):
            if t is None:
                e.fail(f"times_s[{j}]", f"a track ({x.params['track']}) has no peak; give "
                                        "times in seconds, or leave times_s out for its "
                                        "frames")
            if t > x.duration_s + 1e-9:
                e.fail(f"times_s[{j}]", f"{t:g} s is past the end of track "
                                        f"{x.params['track']} ({x.duration_s:g} s); give "
                                        "times on it")


# ---------------------------------------------------------------------- varied parameters
def _vary(e: _Errors, key: str, value, faces: tuple) -> _Vary:
    if not isinstance(value, dict):
        e.fail(key, f"expected a table; found {value!r}")
    extra = sorted(set(value) - {"muscle", "muscles", "type", "parameter", "values", "grid",
                                 "random", "label"})
    if extra:
        e.fail(f"{key}.{extra[0]}", "unknown key; an entry has muscle, muscles or type, "
                                    "parameter, one of values, grid or random, and label")
    which = [k for k in ("muscle", "muscles", "type") if k in value]
    if len(which) != 1:
        e.fail(key, "name what to vary with exactly one of muscle = 'name', muscles = "
                    "[...] or type = 'sheet' (every muscle of that type)")
    param = value.get("parameter")
    if not isinstance(param, str):
        e.fail(f"{key}.parameter", f"expected a parameter name; found {param!r}")
    targets, classes = {}, set()
    for f in faces:
        muscles = _targets(e, key, which[0], value[which[0]], f)
        targets[f.label] = tuple(m.name for m in muscles)
        classes |= {type(m) for m in muscles}
    spec = _parameter(e, f"{key}.parameter", param, classes)
    kinds = [k for k in ("values", "grid", "random") if k in value]
    if len(kinds) != 1:
        e.fail(key, "give exactly one of values = [...], grid = {start, stop, num} or "
                    "random = {low, high}")
    what = value[which[0]]
    label = value.get("label") or (
        f"{'+'.join(what) if isinstance(what, list) else what}.{param}" if which[0] != "type"
        else f"type:{what}.{param}")
    where = f"{key}.{kinds[0]}"
    if kinds[0] == "random":
        lo, hi = _random(e, where, value["random"], spec)
        return _Vary(label, param, targets, None, (lo, hi, spec.unit == "count"))
    values = _grid(e, where, value["grid"], spec) if kinds[0] == "grid" else value["values"]
    if not isinstance(values, list) or not values:
        e.fail(where, "is empty; give at least one value")
    values = tuple(_value(e, f"{where}[{i}]", v, spec) for i, v in enumerate(values))
    return _Vary(label, param, targets, values, None)


def _targets(e: _Errors, key: str, kind: str, what, face: _Face) -> list[Muscle]:
    muscles = face.layout.muscles
    names = [m.name for m in muscles]
    if kind == "type":
        chosen = [m for m in muscles if m.type_name == what]
        if not chosen:
            types = sorted({m.type_name for m in muscles})
            e.fail(f"{key}.type", f"face {face.label} has no {what!r} muscles; its muscle "
                                  f"types are {', '.join(types)}")
        return chosen
    wanted = [what] if kind == "muscle" else what
    if not isinstance(wanted, list) or not wanted or not all(isinstance(w, str)
                                                             for w in wanted):
        e.fail(f"{key}.{kind}", f"expected muscle names; found {what!r}")
    for w in wanted:
        if w not in names:
            e.fail(f"{key}.{kind}", f"face {face.label} has no muscle {w!r}; its muscles "
                                    f"are {', '.join(names)}")
    return [muscles[names.index(w)] for w in wanted]


def _parameter(e: _Errors, key: str, name: str, classes: set) -> Parameter:
    specs = []
    for cls in sorted(classes, key=lambda c: c.type_name):
        try:
            specs.append(cls.parameter(name))
        except KeyError as exc:
            e.fail(key, exc.args[0])
    spec = specs[0]
    if not (spec.is_number or spec.unit == "option"):
        e.fail(key, f"{name!r} is a {spec.unit} parameter; a sweep varies numbers and "
                    "options (move points in a layout file and list it under faces)")
    if len({(s.unit, s.lo, s.hi, s.lo_open, s.hi_open, s.choices) for s in specs}) > 1:
        e.fail(key, f"{name!r} means different things for the types "
                    f"{', '.join(sorted(c.type_name for c in classes))}; vary each type apart")
    return spec


def _value(e: _Errors, key: str, v, spec: Parameter):
    if spec.unit == "option":
        if v not in spec.choices or isinstance(v, bool) != isinstance(spec.choices[0], bool):
            e.fail(key, f"{spec.name} = {v!r} is not one of "
                        f"{', '.join(map(repr, spec.choices))}")
        return v
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        e.fail(key, f"{spec.name} = {v!r} is not a number")
    if spec.unit == "count":
        if float(v) != int(v):
            e.fail(key, f"{spec.name} = {v!r} is not an integer")
        v = int(v)
    lo_ok = v > spec.lo if spec.lo_open else v >= spec.lo
    hi_ok = v < spec.hi if spec.hi_open else v <= spec.hi
    if not (lo_ok and hi_ok):
        hint = f" ({spec.hint})" if spec.hint else ""
        e.fail(key, f"{spec.name} = {v:g} is outside its range {spec.range_text()}{hint}")
    return v if spec.unit == "count" else float(v)


def _grid(e: _Errors, key: str, grid, spec: Parameter) -> list:
    if not isinstance(grid, dict) or not {"start", "stop"} <= set(grid) or (
            ("num" in grid) == ("step" in grid)) or set(grid) - {"start", "stop", "num",
                                                                  "step"}:
        e.fail(key, f"expected {{start, stop, num}} or {{start, stop, step}}; found {grid!r}")
    start = _number(e, f"{key}.start", grid["start"], -math.inf, math.inf)
    stop = _number(e, f"{key}.stop", grid["stop"], -math.inf, math.inf)
    if "num" in grid:
        num = grid["num"]
        if isinstance(num, bool) or not isinstance(num, int) or num < 1:
            e.fail(f"{key}.num", f"the grid is empty: num = {num!r}; give num >= 1")
        values = np.linspace(start, stop, num)
    else:
        step = _number(e, f"{key}.step", grid["step"], -math.inf, math.inf)
        if step == 0 or (stop - start) / step < 0:
            e.fail(key, f"the grid is empty: no step of {step:g} leads from {start:g} to "
                        f"{stop:g}")
        count = int(math.floor((stop - start) / step + 1e-9)) + 1
        values = start + step * np.arange(count)
    if spec.unit == "count":
        return [float(round(v)) if abs(v - round(v)) < 1e-9 else float(v) for v in values]
    return [float(v) for v in values]


def _random(e: _Errors, key: str, value, spec: Parameter) -> tuple:
    if not isinstance(value, dict) or set(value) != {"low", "high"}:
        e.fail(key, f"expected {{low, high}}; found {value!r}")
    if spec.unit == "option":
        e.fail(key, f"{spec.name} is an option; list its values instead")
    lo = _value(e, f"{key}.low", value["low"], spec)
    hi = _value(e, f"{key}.high", value["high"], spec)
    if not lo < hi:
        e.fail(key, f"low = {lo:g} must be below high = {hi:g}")
    return lo, hi


# ---------------------------------------------------------------------- outputs
def _outputs(e: _Errors, value) -> dict:
    if not isinstance(value, dict):
        e.fail("outputs", f"expected a table; found {value!r}")
    extra = sorted(set(value) - {"images", "meshes", "arrays"})
    if extra:
        e.fail(f"outputs.{extra[0]}", "unknown key; outputs has images, meshes and arrays")
    images = value.get("images")
    if images is not None:
        images = _images(e, images)
    meshes = value.get("meshes", [])
    if not isinstance(meshes, list) or any(m not in MESH_FORMATS for m in meshes):
        e.fail("outputs.meshes", f"expected a list of {', '.join(MESH_FORMATS)}; found "
                                 f"{meshes!r}")
    arrays = value.get("arrays", [])
    known = FRAME_ARRAYS + MUSCLE_ARRAYS
    if not isinstance(arrays, list) or any(a not in known for a in arrays):
        e.fail("outputs.arrays", f"expected a list of {', '.join(known)} (the last "
                                 f"{len(MUSCLE_ARRAYS)} per active muscle); found {arrays!r}")
    return {"images": images, "meshes": sorted(set(meshes)), "arrays": sorted(set(arrays))}


def _images(e: _Errors, value) -> dict:
    if not isinstance(value, dict) or set(value) - {"fields", "cameras", "size",
                                                     "raking_light"}:
        e.fail("outputs.images", "expected a table with fields, cameras, size and "
                                 f"raking_light; found {value!r}")
    fields = value.get("fields", ["W"])
    cameras = value.get("cameras", ["front"])
    size = value.get("size", [400, 400])
    if not isinstance(fields, list) or not fields or any(f not in IMAGE_FIELDS
                                                         for f in fields):
        e.fail("outputs.images.fields", f"expected a list of {', '.join(IMAGE_FIELDS)}; "
                                        f"found {fields!r}")
    if not isinstance(cameras, list) or not cameras or any(c not in CAMERAS for c in cameras):
        e.fail("outputs.images.cameras", f"expected a list of {', '.join(CAMERAS)}; found "
                                         f"{cameras!r}")
    if (not isinstance(size, list) or len(size) != 2 or any(
            isinstance(s, bool) or not isinstance(s, int) or not 16 <= s <= 8192
            for s in size)):
        e.fail("outputs.images.size", f"expected [width, height], 16 to 8192 pixels each; "
                                      f"found {size!r}")
    return {"fields": fields, "cameras": cameras, "size": size,
            "raking_light": _bool(e, "outputs.images.raking_light",
                                  value.get("raking_light", True))}


def _check_runs(e: _Errors, spec: SweepSpec) -> None:
    """Every run's muscles validate together (a strength against its fall start, an
    attenuation start against its angle): built once per distinct set of values.
    """
    count = (len(spec.faces) * len(spec.expressions) * len(spec.intensity)
             * len(spec.times_s) * len(spec.refine) * spec.samples
             * math.prod(len(v.values) for v in spec.vary if v.values is not None))
    if count > _MAX_RUNS:
        e.fail("vary", f"{count} runs is more than {_MAX_RUNS}; split the sweep")
    seen = set()
    for run in spec.runs():
        face = next(f for f in spec.faces if f.params == run.params["face"])
        by_name = {m.name: m for m in face.layout.muscles}
        for muscle, changes in run.params["set"].items():
            key = (face.label, muscle, tuple(sorted(changes.items())))
            if key in seen:
                continue
            seen.add(key)
            try:
                by_name[muscle].replace(**changes)
            except MuscleParameterError as exc:
                e.fail("vary", f"face {face.label}: {exc}")
