"""The plugin-style registry of muscle types.

Built-in and third-party muscle types register through the same two paths: the
:func:`register_muscle_type` decorator, and the entry-point group ``wrinkle_vis.muscles``
(``name = "package.module:Class"``), which is loaded lazily on the first look-up. A plug-in
that fails to import is skipped with a :class:`MusclePluginWarning` naming it.
"""

from __future__ import annotations

import importlib
import warnings
from importlib.metadata import entry_points
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .muscle import Muscle

__all__ = [
    "ENTRY_POINT_GROUP",
    "MusclePluginWarning",
    "TypeLookup",
    "UnknownMuscleTypeError",
    "get_muscle_type",
    "muscle_from_dict",
    "muscle_types",
    "register_muscle_type",
]

ENTRY_POINT_GROUP = "wrinkle_vis.muscles"

_REGISTRY: dict[str, type] = {}
_ENTRY_POINTS_LOADED = False


class TypeLookup:
    """What each muscle type brings to another layer (its placement widget, its glyph),
    looked up along the class hierarchy.

    At each class of a type's MRO, a value :meth:`register`-ed for that class comes first,
    then the class's own declaration ``attribute = "package.module:name"`` (or the object
    itself); a type with neither anywhere gets ``default``.

    Parameters
    ----------
    attribute : str
        The class attribute a type declares it in (``"widget"``, ``"glyph"``).
    default : object
        What a type gets that declares nothing.
    kind : str
        How the error message names what the declaration should point at
        (``"Class"``, ``"function"``).
    """

    def __init__(self, attribute: str, default, kind: str):
        self.attribute, self.default, self.kind = attribute, default, kind
        self.registered: dict[type, object] = {}

    def register(self, muscle_type: type, value=None):
        """Use ``value`` for ``muscle_type`` and its subclasses, over what the type declares.
        Usable as a decorator: ``@lookup.register(MyMuscle)``.
        """
        from .muscle import Muscle

        if value is None:
            return lambda v: self.register(muscle_type, v)
        if not (isinstance(muscle_type, type) and issubclass(muscle_type, Muscle)):
            raise TypeError(f"{muscle_type!r} is not a Muscle subclass")
        self.registered[muscle_type] = value
        return value

    def __call__(self, muscle_type: type):
        """The value for ``muscle_type``.

        Raises
        ------
        ImportError
            If a declaration cannot be imported; the message names the type and the
            declaration.
        """
        for cls in muscle_type.__mro__:
            if cls in self.registered:
                return self.registered[cls]
            declared = cls.__dict__.get(self.attribute)
            if declared:
                return self._resolve(declared, cls)
        return self.default

    def _resolve(self, declared, cls: type):
        if callable(declared):
            return declared
        module, _, attr = str(declared).partition(":")
        try:
            return getattr(importlib.import_module(module), attr)
        except (ImportError, AttributeError) as exc:
            raise ImportError(
                f"muscle type {cls.__name__} declares {self.attribute} = {declared!r}, which "
                f"cannot be imported ({exc}); install the package that provides it, or fix "
                f"the declaration as 'package.module:{self.kind}'") from exc


class MusclePluginWarning(UserWarning):
    """A muscle plug-in could not be loaded and was skipped."""


class UnknownMuscleTypeError(KeyError):
    """No muscle type of that name is installed; the message lists the installed ones."""

    def __str__(self) -> str:  # KeyError quotes its argument; we want the sentence
        return str(self.args[0])


def register_muscle_type(cls=None, *, name: str | None = None, override: bool = False):
    """Register a :class:`~wrinkle_vis.core.muscle.Muscle` subclass (usable as a decorator).

    Parameters
    ----------
    cls : type, optional
        The muscle class. Without it, returns a decorator.
    name : str, optional
        Registry key; default ``cls.type_name``, else the lower-cased class name.
    override : bool, default False
        Replace a different class already registered under ``name``.

    Returns
    -------
    type
        ``cls`` itself, with ``type_name`` set to the key.

    Raises
    ------
    TypeError
        If ``cls`` is not a ``Muscle`` subclass.
    ValueError
        If ``name`` is taken by another class and ``override`` is false.
    """
    if cls is None:
        return lambda c: register_muscle_type(c, name=name, override=override)
    from .muscle import Muscle

    if not (isinstance(cls, type) and issubclass(cls, Muscle)):
        raise TypeError(f"{cls!r} is not a subclass of wrinkle_vis.core.muscle.Muscle")
    key = name or cls.__dict__.get("type_name") or cls.__name__.lower()
    current = _REGISTRY.get(key)
    if current is not None and current is not cls and not override:
        raise ValueError(
            f"muscle type {key!r} is already registered by {_qualname(current)}; "
            f"pass override=True to replace it with {_qualname(cls)}"
        )
    cls.type_name = key
    _REGISTRY[key] = cls
    return cls


def _qualname(cls: type) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


def _load_entry_points() -> None:
    global _ENTRY_POINTS_LOADED
    if _ENTRY_POINTS_LOADED:
        return
    _ENTRY_POINTS_LOADED = True
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        load_entry_point(ep)


def load_entry_point(ep) -> type | None:
    """Load one entry point of ``wrinkle_vis.muscles``; warn and return None if it fails."""
    from .muscle import Muscle

    try:
        obj = ep.load()
    except Exception as exc:  # a broken plug-in must not break the toolkit
        _skipped(ep, f"it failed to import with {type(exc).__name__}: {exc}")
        return None
    if isinstance(obj, type) and issubclass(obj, Muscle):
        if _REGISTRY.get(obj.type_name) is not obj:
            try:
                register_muscle_type(obj, name=obj.__dict__.get("type_name") or ep.name)
            except (TypeError, ValueError) as exc:
                _skipped(ep, str(exc))
                return None
        return obj
    return None  # a module that registered its types by decorator on import


def _skipped(ep, why: str) -> None:
    """Warn, in one line, that plug-in ``ep`` was skipped and why: no source line (the
    warning is not about a line of the caller's), the reason's own line breaks joined.
    """
    message = " ".join(f"wrinkle-vis skipped the muscle plug-in {ep.name!r} ({ep.value}): "
                       f"{why}".split())
    warnings.warn_explicit(message, MusclePluginWarning, filename=f"<plug-in {ep.name}>",
                           lineno=0, module=__name__)


def muscle_types() -> dict[str, type]:
    """All registered muscle types, built-in and plug-in, as ``{name: class}``."""
    _load_entry_points()
    return dict(sorted(_REGISTRY.items()))


def get_muscle_type(name: str) -> type[Muscle]:
    """The muscle class registered as ``name``.

    Raises
    ------
    UnknownMuscleTypeError
        Naming the installed types.
    """
    if name not in _REGISTRY:
        _load_entry_points()
    try:
        return _REGISTRY[name]
    except KeyError:
        installed = ", ".join(sorted(_REGISTRY)) or "none"
        raise UnknownMuscleTypeError(
            f"unknown muscle type {name!r}; installed types: {installed}. A plug-in type "
            f"needs its package installed (entry-point group {ENTRY_POINT_GROUP!r})"
        ) from None


def muscle_from_dict(data) -> object:
    """Build any registered muscle from its ``to_dict()`` form (``data["type"]`` picks it)."""
    if "type" not in data:
        raise ValueError(f"muscle {data.get('name')!r} has no 'type'; one of: "
                         f"{', '.join(muscle_types())}")
    return get_muscle_type(data["type"]).from_dict(data)
