"""Layout files: a face's meshes, muscles and expressions as versioned JSON.

.. code-block:: json

    {"format": "wrinkle-vis-layout", "version": 1, "name": "my face",
     "skin": "head.obj", "skull": null,
     "muscles": [{"type": "linear", "name": "corrugator_L", "attachment": [...], ...}],
     "expressions": {"frown": {"name": "frown", "activations": {"corrugator_L": 1.0}, ...}},
     "landmarks": {"nose_tip": [0.0, -29.0, 110.0], ...}}

Mesh paths are relative to the layout file; ``null`` means the built-in face's mesh (skin)
or, for the skull, one built from the skin. Saving is atomic: the file is written beside its
destination, flushed to disk and renamed over it, so a crash never leaves half a file.
Loading checks every field and names the file, the JSON path of the bad field, what was
expected and what was found.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .expressions import Expression
from .muscle import Muscle, MuscleParameterError
from .registry import UnknownMuscleTypeError, get_muscle_type

__all__ = ["FORMAT", "VERSION", "Layout", "LayoutError", "atomic_write_text", "load_layout",
           "save_layout"]

FORMAT = "wrinkle-vis-layout"
VERSION = 1


class LayoutError(ValueError):
    """A malformed layout; names the file, the JSON path, what was expected and found."""

    def __init__(self, source: str, path: str, expected: str, found: Any):
        self.source, self.path, self.expected, self.found = source, path, expected, found
        super().__init__(f"{source}: {path}: expected {expected}; found {_show(found)}")


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
    """

    name: str = "face"
    muscles: tuple = ()
    expressions: dict = field(default_factory=dict)
    skin: str | None = None
    skull: str | None = None
    landmarks: dict = field(default_factory=dict)

    def __post_init__(self):
        object.__setattr__(self, "muscles", tuple(self.muscles))
        object.__setattr__(self, "expressions", dict(self.expressions))
        object.__setattr__(self, "landmarks", {
            k: tuple(float(x) for x in v) for k, v in dict(self.landmarks).items()})

    def __eq__(self, other) -> bool:
        return isinstance(other, Layout) and self.to_dict() == other.to_dict()

    __hash__ = None

    def to_dict(self) -> dict:
        """The JSON-ready form of the file."""
        return {"format": FORMAT, "version": VERSION, "name": self.name, "skin": self.skin,
                "skull": self.skull, "muscles": [m.to_dict() for m in self.muscles],
                "expressions": {k: e.to_dict() for k, e in self.expressions.items()},
                "landmarks": {k: list(v) for k, v in self.landmarks.items()}}

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
                 "landmarks"}
        for key in data:
            _expect(key in known, source, f"$.{key}", f"one of {sorted(known)}", key)
        name = data.get("name", "face")
        _expect(isinstance(name, str), source, "$.name", "a string", name)
        for key in ("skin", "skull"):
            value = data.get(key)
            _expect(value is None or (isinstance(value, str) and value), source, f"$.{key}",
                    "a mesh path or null", value)
        muscles = _muscles(data.get("muscles", []), source)
        expressions = _expressions(data.get("expressions", {}), source,
                                   {m.name for m in muscles})
        return cls(name=name, muscles=muscles, expressions=expressions,
                   skin=data.get("skin"), skull=data.get("skull"),
                   landmarks=_landmarks(data.get("landmarks", {}), source))

    def resolve(self, key: str, base: str | os.PathLike) -> Path | None:
        """The absolute path of ``skin`` or ``skull`` relative to folder ``base``."""
        value = getattr(self, key)
        return None if value is None else (Path(base) / value).resolve()


def _expect(ok: bool, source: str, path: str, expected: str, found: Any) -> None:
    if not ok:
        raise LayoutError(source, path, expected, found)


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
        except UnknownMuscleTypeError as exc:
            raise LayoutError(source, f"{path}.type", str(exc), kind) from None
        try:
            muscle = cls.from_dict(item)
        except MuscleParameterError as exc:
            where = f"{path}.{exc.param}" if exc.param else path
            raise LayoutError(source, where, "valid muscle parameters", str(exc)) from None
        except (TypeError, ValueError) as exc:
            raise LayoutError(source, path, "valid muscle parameters", str(exc)) from None
        _expect(muscle.name not in names, source, f"{path}.name", "a name no other muscle has",
                muscle.name)
        names.add(muscle.name)
        out.append(muscle)
    return tuple(out)


def _expressions(items: Any, source: str, muscles: set[str]) -> dict[str, Expression]:
    _expect(isinstance(items, dict), source, "$.expressions",
            "an object of expressions by name", items)
    out = {}
    for key, item in items.items():
        path = f"$.expressions.{key}"
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
        except (TypeError, ValueError) as exc:
            raise LayoutError(source, path, "a valid expression", str(exc)) from None
    return out


def _landmarks(items: Any, source: str) -> dict:
    _expect(isinstance(items, dict), source, "$.landmarks",
            "an object of landmark name to [x, y, z]", items)
    for key, value in items.items():
        ok = isinstance(value, list) and len(value) == 3 and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)
            for x in value)
        _expect(ok, source, f"$.landmarks.{key}", "[x, y, z] of finite numbers", value)
    return items


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` to ``path`` atomically (temporary file, fsync, rename)."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


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
        For invalid JSON or any bad field, with the file, the JSON path, expected and found.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no layout file at {path}; check the path, or save one "
                                "with save_layout()")
    text = path.read_text(encoding="utf-8")
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise LayoutError(str(path), f"line {exc.lineno} column {exc.colno}",
                          "valid JSON", exc.msg) from None
    return Layout.from_dict(data, source=str(path))
