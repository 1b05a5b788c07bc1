"""Layout files: a face's meshes, muscles and expressions as versioned JSON.

.. code-block:: json

    {"format": "wrinkle-vis-layout", "version": 1, "name": "my face",
     "skin": "head.obj", "skull": null,
     "muscles": [{"type": "linear", "name": "corrugator_L", "attachment": [...], ...}],
     "expressions": {"frown": {"name": "frown", "activations": {"corrugator_L": 1.0}, ...}},
     "landmarks": {"nose_tip": [0.0, -29.0, 110.0], ...},
     "n_triangles": 4500, "unit": "mm", "face": null,
     "skin_model": "physical", "skin_material": {"membrane_stiffness": 150.0}}

Mesh paths are relative to the layout file; ``null`` means the built-in face's mesh (skin)
or, for the skull, one built from the skin. ``n_triangles`` (optional) records the
resolution the built-in skin was requested at, which rebuilds exactly the same mesh
(:func:`wrinkle_vis.datasets.load_face`). ``unit`` (optional) is the unit of every length in
the file and of the skin's coordinates (:data:`~wrinkle_vis.core.units.LENGTH_UNITS`). A
layout that names its skin file and its landmarks is a whole face: reopening it rebuilds the
same skin, skull and muscles (the skull is made from the skin and the landmarks,
deterministically). ``face`` (optional) names a built-in face whose skin and skull the
layout uses when ``skin`` is null (``"lee_perry_smith"``; null: the procedural face).
``mapping`` (optional) says which muscles a recorded track's channels drive
(:class:`~wrinkle_vis.core.tracks.TrackMapping`: ``{"AU04": {"muscles": {"corrugator_L":
1.0, ...}, "curve": [[0, 0], [1, 1]]}, ...}``, muscles of ``$.muscles`` only); without it a
track plays through :func:`~wrinkle_vis.core.tracks.default_mapping`.
``skin_model`` (optional) is the skin model the face evaluates with
(:data:`~wrinkle_vis.core.skin.SKIN_MODELS`; null: the default for the skin's size,
:func:`~wrinkle_vis.core.skin.default_skin_model`) and ``skin_material``
(optional) the physical skin's parameters that differ from their defaults, each checked
against its declaration in :class:`~wrinkle_vis.core.skin.SkinMaterial`.
Saving is atomic
(:func:`wrinkle_vis.core.files.atomic_output`): the file is written beside its destination,
flushed to disk and renamed over it, so a crash never leaves half a file, and a file saved
over keeps its permissions. Loading checks every field and names the file, the JSON path of
the bad field, what was expected and what was found; any unreadable file (not UTF-8, not
JSON, nested too deeply) raises :class:`LayoutError`.
"""

from __future__ import annotations

import json
import math
import os
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .expressions import Expression
from .files import atomic_write_text, input_problem
from .muscle import Muscle, MuscleParameterError
from .params import control_character
from .registry import UnknownMuscleTypeError, get_muscle_type, muscle_types
from .skin import SKIN_MODELS, SkinMaterial
from .tracks import TrackMapping
from .units import LENGTH_UNITS

__all__ = ["FORMAT", "VERSION", "Layout", "LayoutError", "atomic_write_text", "load_layout",
           "finite_number", "parse_json", "read_json", "save_layout"]

FORMAT = "wrinkle-vis-layout"
VERSION = 1


class LayoutError(ValueError):
    """A malformed layout; names the file, the JSON path, what was expected and found."""

    def __init__(self, source: str, path: str, expected: str, found: Any):
        self.source, self.path, self.expected, self.found = source, path, expected, found
        super().__init__(f"{_escaped(source)}: {_escaped(path)}: expected {expected}; found "
                         f"{_show(found)}")


def _escaped(text: str) -> str:
    r"""``text`` with control and format characters as ``\uXXXX`` (keys from a file reach
    the terminal only so).
    """
    return "".join(f"\\u{ord(c):04x}" if control_character(c) else c for c in str(text))


def _show(value: Any) -> str:
    text = json.dumps(value) if _jsonable(value) else repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def _jsonable(value: Any) -> bool:
    try:
        json.dumps(value)
    except (TypeError, ValueError):
        return False
    return True


@dataclass(frozen=True)
class Layout:
    """A face's layout: mesh paths, muscles and expressions.

    Parameters
    ----------
    name : str
        A label.
    muscles : tuple of Muscle
        The muscles, with unique names.
    expressions : dict of str to Expression
        Named expressions over those muscles.
    skin, skull : str or None
        Mesh paths, relative to the layout file's folder when relative.
    landmarks : dict of str to (3,) float
        Named points on the skin.
    n_triangles : int or None
        The resolution the built-in skin was requested at (the ``n_triangles`` argument
        of :func:`wrinkle_vis.datasets.load_face`), so that reopening the layout rebuilds
        the same mesh; None when not recorded (the loader's default) or for a skin file.
    unit : str or None
        The unit of the layout's lengths and its skin's coordinates (a key of
        :data:`~wrinkle_vis.core.units.LENGTH_UNITS`); None when not recorded.
    face : str or None
        The built-in face the layout is for when ``skin`` is None (a name
        :func:`wrinkle_vis.datasets.load_face` knows); None: the procedural face.
    mapping : TrackMapping or None
        Which muscles a recorded track's channels drive; None: not recorded (the default
        mapping plays).
    skin_model : str or None
        The skin model the face evaluates with (``"geometric"`` or ``"physical"``); None
        when not recorded (the default for the skin's size,
        :func:`~wrinkle_vis.core.skin.default_skin_model`).
    skin_material : dict of str to float
        The physical skin's parameters that differ from their defaults
        (:class:`~wrinkle_vis.core.skin.SkinMaterial`).
    """

    name: str = "face"
    muscles: tuple = ()
    expressions: dict = field(default_factory=dict)
    skin: str | None = None
    skull: str | None = None
    landmarks: dict = field(default_factory=dict)
    n_triangles: int | None = None
    unit: str | None = None
    face: str | None = None
    mapping: TrackMapping | None = None
    skin_model: str | None = None
    skin_material: dict = field(default_factory=dict)

    def __post_init__(self):
        object.__setattr__(self, "skin_material", dict(self.skin_material))
        object.__setattr__(self, "muscles", tuple(self.muscles))
        object.__setattr__(self, "expressions", dict(self.expressions))
        object.__setattr__(self, "landmarks", {
            k: tuple(float(x) for x in v) for k, v in dict(self.landmarks).items()})
        if self.mapping is not None:  # a muscle removed from the layout drives nothing
            object.__setattr__(self, "mapping", self.mapping.restricted(
                [m.name for m in self.muscles]))

    def __eq__(self, other) -> bool:
        return isinstance(other, Layout) and self.to_dict() == other.to_dict()

    __hash__ = None  # type: ignore[assignment]  # equal by value, so unhashable

    def to_dict(self) -> dict:
        """The JSON-ready form of the file (``n_triangles``, ``unit`` and ``face`` only
        when recorded).
        """
        out = {"format": FORMAT, "version": VERSION, "name": self.name, "skin": self.skin,
               "skull": self.skull, "muscles": [m.to_dict() for m in self.muscles],
               "expressions": {k: e.to_dict() for k, e in self.expressions.items()},
               "landmarks": {k: list(v) for k, v in self.landmarks.items()}}
        if self.n_triangles is not None:
            out["n_triangles"] = int(self.n_triangles)
        if self.unit is not None:
            out["unit"] = str(self.unit)
        if self.face is not None:
            out["face"] = str(self.face)
        if self.mapping is not None:
            out["mapping"] = self.mapping.to_dict()
        if self.skin_model is not None:
            out["skin_model"] = str(self.skin_model)
        if self.skin_material:
            out["skin_material"] = dict(self.skin_material)
        return out

    def material(self) -> SkinMaterial:
        """The physical skin's :class:`~wrinkle_vis.core.skin.SkinMaterial` of the layout."""
        return SkinMaterial(**self.skin_material)

    @classmethod
    def from_dict(cls, data: Any, source: str = "<layout>") -> Layout:
        """Validate and build a layout from the parsed JSON of a file.

        Raises
        ------
        LayoutError
            For the first bad field, with its JSON path.
        """
        _expect(isinstance(data, dict), source, "$", "a JSON object", data)
        _expect(data.get("format") == FORMAT, source, "$.format", repr(FORMAT),
                data.get("format"))
        version = data.get("version")
        _expect(version == VERSION, source, "$.version",
                f"{VERSION} (this wrinkle-vis reads version {VERSION})", version)
        known = {"format", "version", "name", "skin", "skull", "muscles", "expressions",
                 "landmarks", "n_triangles", "unit", "face", "mapping", "skin_model",
                 "skin_material"}
        for key in data:
            _expect(key in known, source, f"$.{key}", f"one of {sorted(known)}", key)
        name = data.get("name", "face")
        _expect(isinstance(name, str) and control_character(name) is None, source, "$.name",
                "a string without control characters", name)
        for key in ("skin", "skull"):
            value = data.get(key)
            _expect(value is None or (isinstance(value, str) and bool(value)), source,
                    f"$.{key}", "a mesh path or null", value)
        n_triangles = data.get("n_triangles")
        _expect(n_triangles is None or (isinstance(n_triangles, int)
                                        and not isinstance(n_triangles, bool)
                                        and n_triangles > 0),
                source, "$.n_triangles", "a positive whole number of triangles or null",
                n_triangles)
        unit = data.get("unit")
        _expect(unit is None or (isinstance(unit, str) and unit in LENGTH_UNITS), source, "$.unit",
                f"a length unit ({', '.join(LENGTH_UNITS)}) or null", unit)
        face = data.get("face")
        _expect(face is None or (isinstance(face, str) and bool(face)), source, "$.face",
                "the name of a built-in face or null", face)
        skin_model = data.get("skin_model")
        _expect(skin_model is None or skin_model in SKIN_MODELS, source, "$.skin_model",
                f"a skin model ({', '.join(SKIN_MODELS)}) or null", skin_model)
        material = _skin_material(data.get("skin_material", {}), source)
        muscles = _muscles(data.get("muscles", []), source)
        expressions = _expressions(data.get("expressions", {}), source,
                                   {m.name for m in muscles})
        mapping = _mapping(data.get("mapping"), source, {m.name for m in muscles})
        return cls(name=name, muscles=muscles, expressions=expressions,
                   skin=data.get("skin"), skull=data.get("skull"),
                   landmarks=_landmarks(data.get("landmarks", {}), source),
                   n_triangles=n_triangles, unit=unit, face=face, mapping=mapping,
                   skin_model=skin_model, skin_material=material)

    def resolve(self, key: str, base: str | os.PathLike) -> Path | None:
        """The absolute path of ``skin`` or ``skull`` relative to folder ``base``."""
        value = getattr(self, key)
        return None if value is None else (Path(base) / value).resolve()


def _expect(ok: bool, source: str, path: str, expected: str, found: Any) -> None:
    if not ok:
        raise LayoutError(source, path, expected, found)


def _skin_material(items: Any, source: str) -> dict:
    """The physical skin's parameters of a layout, each checked against its declaration."""
    _expect(isinstance(items, dict), source, "$.skin_material",
            "an object of skin parameter name to value", items)
    specs = {p.name: p for p in SkinMaterial.parameters()}
    for key, value in items.items():
        path = f"$.skin_material.{key}"
        _expect(key in specs, source, path, f"one of {sorted(specs)}", key)
        spec = specs[key]
        expected = f"{key} ({spec.symbol}, {spec.doc}) in {spec.range_text()} {spec.unit}"
        _expect(isinstance(value, (int, float)) and not isinstance(value, bool), source, path,
                expected, value)
        try:
            SkinMaterial(**{key: value})
        except ValueError:
            raise LayoutError(source, path, expected, value) from None
    return dict(items)


def _muscles(items: Any, source: str) -> tuple[Muscle, ...]:
    _expect(isinstance(items, list), source, "$.muscles", "a list of muscles", items)
    out, names = [], set()
    for i, item in enumerate(items):
        path = f"$.muscles[{i}]"
        _expect(isinstance(item, dict), source, path, "a muscle object", item)
        kind = item.get("type")
        _expect(isinstance(kind, str), source, f"{path}.type", "a muscle type name", kind)
        try:
            cls = get_muscle_type(kind)
        except UnknownMuscleTypeError:
            raise LayoutError(source, f"{path}.type", "a muscle type that is installed "
                              f"(installed types: {', '.join(muscle_types())}; a plug-in "
                              "type needs its package installed)", kind) from None
        try:
            muscle = cls.from_dict(item)
        except MuscleParameterError as exc:
            where = f"{path}.{exc.param}" if exc.param else path
            raise LayoutError(source, where, _expected(cls, exc.param), str(exc)) from None
        except (TypeError, ValueError, OverflowError) as exc:
            raise LayoutError(source, path, "valid muscle parameters", str(exc)) from None
        _expect(muscle.name not in names, source, f"{path}.name", "a name no other muscle has",
                muscle.name)
        names.add(muscle.name)
        out.append(muscle)
    return tuple(out)


def _expected(cls: type[Muscle], param: str | None) -> str:
    """What a layout's muscle parameter should be, from the type's declared metadata."""
    try:
        spec = cls.parameter(param) if param else None
    except KeyError:
        spec = None
    if spec is None or not spec.label:
        return "valid muscle parameters"
    if spec.is_point:
        what = "[x, y, z]" if spec.shape == (3,) else "[[x, y, z], [x, y, z]]"
        return f"{spec.name} ({spec.doc}): {what} on the {spec.surface or 'skin'}"
    return f"{spec.name} ({spec.symbol}, {spec.doc}) in {spec.range_text()}" + (
        " or null (derived)" if spec.optional else "")


def _expressions(items: Any, source: str, muscles: set[str]) -> dict[str, Expression]:
    _expect(isinstance(items, dict), source, "$.expressions",
            "an object of expressions by name", items)
    out = {}
    for key, item in items.items():
        path = f"$.expressions.{key}"
        _expect(control_character(key) is None, source, path,
                "a name without control characters (any other Unicode is fine)", key)
        _expect(isinstance(item, dict), source, path, "an expression object", item)
        acts = item.get("activations", {})
        _expect(isinstance(acts, dict), source, f"{path}.activations",
                "an object of muscle name to activation", acts)
        for muscle, value in acts.items():
            _expect(muscle in muscles, source, f"{path}.activations.{muscle}",
                    "the name of a muscle in $.muscles", muscle)
            _expect(isinstance(value, (int, float)) and not isinstance(value, bool)
                    and 0 <= value <= 1, source, f"{path}.activations.{muscle}",
                    "a number in [0, 1]", value)
        try:
            out[key] = Expression.from_dict({"name": key, **item})
        except (TypeError, ValueError, OverflowError) as exc:
            raise LayoutError(source, path, "a valid expression", str(exc)) from None
    return out


def _mapping(items: Any, source: str, muscles: set[str]) -> TrackMapping | None:
    """The optional ``$.mapping``: channels to muscle weights and response curves."""
    if items is None:
        return None
    _expect(isinstance(items, dict), source, "$.mapping",
            "an object of channel name to {\"muscles\": {...}, \"curve\": [...]}", items)
    for key, item in items.items():
        path = f"$.mapping.{key}"
        _expect(isinstance(item, dict) and isinstance(item.get("muscles", {}), dict), source,
                path, "{\"muscles\": {muscle name: weight in [0, 1]}, \"curve\": [[x, y], "
                "...]}", item)
        for muscle in item.get("muscles", {}):
            _expect(muscle in muscles, source, f"{path}.muscles.{muscle}",
                    "the name of a muscle in $.muscles", muscle)
    try:
        return TrackMapping.from_dict(items)
    except (TypeError, ValueError) as exc:
        raise LayoutError(source, "$.mapping", "a valid track mapping", str(exc)) from None


def finite_number(value: Any) -> bool:
    """Whether ``value`` is a JSON number (not a bool) that is a finite float (an integer
    beyond 1.8e308 is not).
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:  # an int too large for a float
        return False


def _landmarks(items: Any, source: str) -> dict:
    _expect(isinstance(items, dict), source, "$.landmarks",
            "an object of landmark name to [x, y, z]", items)
    for key, value in items.items():
        ok = isinstance(value, list) and len(value) == 3 and all(map(finite_number, value))
        _expect(ok, source, f"$.landmarks.{key}", "[x, y, z] of finite numbers", value)
    return items


def save_layout(layout: Layout, path: str | os.PathLike) -> None:
    """Save ``layout`` as JSON at ``path``, atomically."""
    atomic_write_text(path, json.dumps(layout.to_dict(), indent=2) + "\n")


def load_layout(path: str | os.PathLike) -> Layout:
    """Read a layout file.

    Raises
    ------
    FileNotFoundError
        Naming the path.
    LayoutError
        For a file that cannot be read (permissions, not UTF-8 text, invalid JSON, JSON
        nested too deeply, a key twice in one object, a number of over 4300 digits) or any
        bad field, with the file, the JSON path (or the line and column), expected and
        found.
    """
    path = Path(path)
    problem = input_problem(path)
    if problem == "no such file":
        raise FileNotFoundError(f"no layout file at {path}; check the path, or save one "
                                "with save_layout()")
    if problem is not None:  # a folder, a pipe, a device, a link loop: say which
        raise LayoutError(str(path), "$", "a layout file (.json)", problem)
    data = read_json(path)
    try:
        return Layout.from_dict(data, source=str(path))
    except RecursionError:
        raise LayoutError(str(path), "$", "JSON nested at most a few hundred levels deep",
                          "deeper nesting") from None


def read_json(path: str | os.PathLike) -> Any:
    """The JSON value of the file at ``path`` (:func:`parse_json`).

    Raises
    ------
    LayoutError
        If the file cannot be read, or :func:`parse_json` refuses it.
    """
    try:
        raw = Path(path).read_bytes()
    except (OSError, ValueError) as exc:
        raise LayoutError(str(path), "$", "a readable file",
                          getattr(exc, "strerror", None) or str(exc)) from None
    return parse_json(raw, str(path))


class _Duplicated(dict):
    """A JSON object that had ``key`` more than once (found after parsing, with its path)."""

    key: str = ""


def _object(pairs: list) -> dict:
    out = dict(pairs)
    if len(out) == len(pairs):
        return out
    dup = _Duplicated(out)
    seen = set()
    for key, _ in pairs:  # the first key given twice
        if key in seen:
            dup.key = key
            break
        seen.add(key)
    return dup


def parse_json(raw: bytes, source: str) -> Any:
    """Parse ``raw``, strict JSON in UTF-8 (a byte-order mark is allowed and skipped).

    Refused, each with a one-line :class:`LayoutError` naming ``source`` and where: bytes
    that are not UTF-8, invalid JSON, nesting deeper than Python's recursion limit, a key
    twice in one object (JSON leaves it undefined which one counts), an integer of over
    4300 digits.
    """
    raw = raw.removeprefix(b"\xef\xbb\xbf")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise LayoutError(source, f"line {line} (byte {exc.start})",
                          "UTF-8 text (save the file as UTF-8)",
                          f"the byte 0x{raw[exc.start]:02x}") from None
    try:
        data = json.loads(text, object_pairs_hook=_object)
    except json.JSONDecodeError as exc:
        raise LayoutError(source, f"line {exc.lineno} column {exc.colno}",
                          "valid JSON", exc.msg) from None
    except RecursionError:
        raise LayoutError(source, "$", "JSON nested at most a few hundred levels deep",
                          "deeper nesting") from None
    except ValueError:  # an integer beyond Python's digit limit
        raise _too_long(text, source) from None
    _refuse_duplicates(data, source)
    return data


def _too_long(text: str, source: str) -> LayoutError:
    """The error for the first integer of ``text`` over Python's limit on the digits of an
    integer it converts (``sys.get_int_max_str_digits()``, 4300 by default).
    """
    limit = sys.get_int_max_str_digits()
    match = re.search(rf"\d{{{limit + 1},}}", text) if limit else None
    if match is None:
        return LayoutError(source, "$", "valid JSON", "a value Python cannot convert")
    line = text.count("\n", 0, match.start()) + 1
    column = match.start() - text.rfind("\n", 0, match.start())
    return LayoutError(source, f"line {line} column {column}",
                       f"a number of at most {limit} digits",
                       f"a number of {len(match.group())} digits")


def _refuse_duplicates(data: Any, source: str) -> None:
    """Raise for the first object (depth first) that had a key twice, with its JSON path."""
    stack = [(data, "$")]
    while stack:
        value, where = stack.pop()
        if isinstance(value, _Duplicated):
            raise LayoutError(source, f"{where}.{value.key}", "each key once in an object",
                              value.key)
        if isinstance(value, dict):
            stack.extend((v, f"{where}.{k}") for k, v in reversed(value.items()))
        elif isinstance(value, list):
            stack.extend((v, f"{where}[{i}]") for i, v in reversed(list(enumerate(value))))
