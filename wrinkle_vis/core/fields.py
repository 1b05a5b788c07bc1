r"""The field catalogue: every per-muscle quantity of the model, described once.

A field is one :class:`FieldSpec`: its key, symbol, name and meaning, the equation that
defines it, its unit, where it is defined (the muscle's area of influence or its wrinkling
region), whether it has a total over the muscles (only :math:`W`, Eq. 4), how to colour it,
and how to compute it. :class:`~wrinkle_vis.core.face.FaceState`'s fields, the plots and
their colour ranges (:mod:`wrinkle_vis.plotting.fields`), the app's field menu and probe,
the command line's ``--field`` choices and the exported point arrays all read :data:`FIELDS`;
:func:`register_field` adds one:

.. code-block:: python

    register_field(FieldSpec(
        "HAt", "H At", "attenuated shape", "H times At: the wrinkle before compression",
        "Eq. 5, 12", unit="length", where="region", signed=True,
        compute=lambda f: f["H"] * f["At"], pointwise=True))
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from .symbols import pretty_symbol

__all__ = ["FIELDS", "FIELD_NAMES", "FRAME_FIELDS", "FieldSpec", "check_field", "field_spec",
           "register_field", "total_fields"]

#: Where a field is defined: the muscle's area of influence, its wrinkling region, or the
#: whole frame (a field of the frame, not of a muscle: :data:`FRAME_FIELDS`).
WHERE = ("aoi", "region", "frame")
#: Units: dimensionless, the face's lengths, degrees.
UNITS = ("1", "length", "deg")


@dataclass(frozen=True)
class FieldSpec:
    """One field of the model.

    Attributes
    ----------
    key : str
        The name in ``state.fields[muscle][key]`` (``"W"`` also names the total).
    symbol, name, meaning : str
        For titles, menus and tooltips.
    equation : str
        Where the paper defines it.
    unit : {"1", "length", "deg"}
        Dimensionless, the face's units, or degrees.
    where : {"aoi", "region", "frame"}
        Defined on the muscle's area of influence or on its wrinkling region (``nan``
        elsewhere); ``"frame"``: a field of the whole frame, the attribute ``key`` of
        :class:`~wrinkle_vis.core.face.FaceState`, the same whichever muscle is chosen
        (:data:`FRAME_FIELDS`).
    total : bool
        Whether it adds up over the muscles into a total (only ``W``, Eq. 4:
        ``state.W``).
    signed : bool
        Takes both signs; drawn with a diverging colour map centred on 0.
    limits : (float, float) or None
        Its fixed range (colour range), or None to take it from the data.
    cmap : str
        Matplotlib colour map name; default ``"RdBu_r"`` for signed fields, else
        ``"viridis"``.
    compute : callable
        ``compute(fields) -> (n,) ndarray``: the field on every skin vertex from
        ``fields``, the muscle's field mapping in a frame (``fields["H"]``, ``fields["At"]``
        ...: other fields, full length), ``nan`` outside :attr:`where` (as the fields it
        is made of are).
    pointwise : bool
        Whether ``compute`` gives each vertex's value from that vertex's values of the
        other fields alone (elementwise), so it may be computed at a few vertices
        (:meth:`~wrinkle_vis.core.face.FaceState.values_at`, the app's probe) with
        ``fields[key]`` ``(k,)`` there; otherwise it is computed on the whole skin.
    """

    key: str
    symbol: str
    name: str
    meaning: str
    equation: str
    unit: str = "1"
    where: str = "aoi"
    total: bool = False
    signed: bool = False
    limits: tuple[float, float] | None = None
    cmap: str = ""
    compute: Callable[[Any], Any] | None = field(default=None, compare=False, repr=False)
    pointwise: bool = False
    rest: bool = False

    def __post_init__(self):
        if not self.key or not self.key.isidentifier():
            raise ValueError(f"field key {self.key!r} must be a name (letters, digits, _)")
        if self.unit not in UNITS:
            raise ValueError(f"field {self.key!r}: unit {self.unit!r} is not one of "
                             f"{', '.join(UNITS)}")
        if self.where not in WHERE:
            raise ValueError(f"field {self.key!r}: where {self.where!r} is not one of "
                             f"{', '.join(WHERE)}")
        if self.compute is None and self.where == "frame":
            object.__setattr__(self, "compute", _frame_attr(self.key))
        if self.compute is None:
            raise ValueError(f"field {self.key!r} needs compute(fields) -> (n,) values")
        if not self.cmap:
            object.__setattr__(self, "cmap", "RdBu_r" if self.signed else "viridis")

    @property
    def diverging(self) -> bool:
        """Signed, drawn centred on 0 (:attr:`signed`)."""
        return self.signed

    def title(self, muscle: str | None = None, units: str = "mm") -> str:
        """A scalar-bar title such as ``"eps, corrugator_L"`` or ``"W (mm), total"``.

        ASCII only: VTK's default font has no Greek letters.
        """
        unit = {"1": "", "length": f" ({units})", "deg": " (deg)"}[self.unit]
        return f"{self.key}{unit}, {muscle or 'total'}"

    def label(self, units: str = "mm") -> str:
        """The key with its unit: ``W (mm)``, ``lambda``."""
        return {"length": f"{self.key} ({units})", "deg": f"{self.key} (deg)"}.get(
            self.unit, self.key)

    @property
    def display(self) -> str:
        """What a menu shows: the symbol and the name, ``λ (length factor)``, ``W (wrinkle
        amplitude)`` and ``w (periodic coordinate)`` (not two entries a case apart).
        """
        return f"{pretty_symbol(self.symbol)} ({self.name})"

    def display_label(self, units: str = "mm") -> str:
        """:meth:`label` with the symbol: ``W (mm)``, ``λ``, ``ε``."""
        unit = {"length": f" ({units})", "deg": " (deg)"}.get(self.unit, "")
        return f"{pretty_symbol(self.symbol)}{unit}"

    def display_title(self, muscle: str | None = None, units: str = "mm") -> str:
        """:meth:`title` with the symbol, for what a scalar bar shows: ``λ, corrugator_L``
        (the bar keeps the ASCII :meth:`title` as its name).
        """
        return f"{self.display_label(units)}, {muscle or 'total'}"


def _static(key: str, attr: str, where: str) -> Callable:
    """A field the muscle defines on the rest skin (``attr`` of its cached data)."""
    return lambda f: f.static(key, attr, where)


def _frame_attr(key: str) -> Callable:
    """A field of the whole frame: the state's attribute ``key`` (``state`` or a muscle's
    field mapping, whose ``frame_attr`` reads it).
    """
    return lambda f: f.frame_attr(key)


def _dynamic(key: str, where: str) -> Callable:
    """A field of the frame (compression, anisotropy, W)."""
    return lambda f: f.frame_value(key, where)


#: The catalogue, by key, in menu order; :func:`register_field` adds to it.
FIELDS: dict[str, FieldSpec] = {f.key: f for f in (
    FieldSpec("lambda", "λ", "length factor",
              "distance from the attachment along the central fibre, over R or L_s",
              "Eq. 2, 13", "1", "aoi", limits=(0.0, 1.0),
              compute=_static("lambda", "lam", "aoi"), pointwise=True,
              rest=True),
    FieldSpec("gamma", "γ", "angular/width factor",
              "angle from the central fibre over Φ (linear) or 2h over W_s (sheet)",
              "Eq. 2, 13", "1", "aoi", limits=(0.0, 1.0),
              compute=_static("gamma", "gamma", "aoi"), pointwise=True,
              rest=True),
    FieldSpec("l", "l", "fibre distance", "distance from the attachment along the fibre",
              "Eq. 1", "length", "aoi", cmap="cividis",
              compute=_static("l", "l", "aoi"), pointwise=True,
              rest=True),
    FieldSpec("w", "w", "periodic coordinate", "position within one wrinkle period",
              "Eq. 7", "length", "region", cmap="twilight",
              compute=_static("w", "w", "region"), pointwise=True,
              rest=True),
    FieldSpec("H", "H", "shape function", "cross-sectional wrinkle shape: furrows and bulges",
              "Eq. 5", "length", "region", signed=True,
              compute=_static("H", "h", "region"), pointwise=True,
              rest=True),
    FieldSpec("At", "At", "attenuation", "fade of the wrinkles away from the central fibre",
              "Eq. 12, 15", "1", "aoi", limits=(0.0, 1.0), cmap="magma",
              compute=_static("At", "at", "aoi"), pointwise=True,
              rest=True),
    FieldSpec("eps", "ε", "compression rate",
              "edge shrinkage weighted by alignment with the contraction",
              "Eq. 9, 10", "1", "aoi", signed=True, cmap="PuOr_r",
              compute=_dynamic("eps", "aoi"), pointwise=True),
    FieldSpec("A", "A", "anisotropy", "wrinkle response to compression, 0 under stretch",
              "Eq. 11", "1", "aoi", limits=(0.0, 1.0), cmap="inferno",
              compute=_dynamic("A", "aoi"), pointwise=True),
    FieldSpec("W", "W", "wrinkle amplitude", "H A At: displacement along the normal",
              "Eq. 4", "length", "region", total=True, signed=True,
              compute=_dynamic("W", "region"), pointwise=True),
)}


#: Fields of the whole frame (not of one muscle), by key: shown as totals, the same whichever
#: muscle is chosen; each is the :class:`~wrinkle_vis.core.face.FaceState` attribute of its key.
FRAME_FIELDS: dict[str, FieldSpec] = {f.key: f for f in (
    FieldSpec("fold_guard", "g", "fold guard",
              "how much the fold guard took away here: the larger of the pull's and W's "
              "reduction, or the shift of a point whose normal turned with its guarded "
              "neighbours (0: the model's own value)",
              "docs/model.md, folds", "1", "frame", total=True, limits=(0.0, 1.0),
              cmap="Reds"),
)}


class _FieldNames(Sequence):
    """The keys of :data:`FIELDS`, always current (a field registered later is in it)."""

    def __getitem__(self, i):
        return tuple(FIELDS)[i]

    def __len__(self) -> int:
        return len(FIELDS)

    def __eq__(self, other) -> bool:
        return isinstance(other, Sequence) and tuple(self) == tuple(other)

    __hash__ = None  # type: ignore[assignment]  # equal by value, so unhashable

    def __repr__(self) -> str:
        return repr(tuple(FIELDS))


#: The keys of the catalogue, in menu order (a live view of :data:`FIELDS`).
FIELD_NAMES: Sequence[str] = _FieldNames()


def register_field(spec: FieldSpec, *, override: bool = False) -> FieldSpec:
    """Add ``spec`` to the catalogue (every layer sees it at once); returns it.

    Raises
    ------
    ValueError
        If its key is taken and ``override`` is false, or it claims a total (only ``W``
        adds up over the muscles: :attr:`FaceState.W`).
    """
    if not isinstance(spec, FieldSpec):
        raise TypeError(f"{spec!r} is not a FieldSpec")
    if spec.key in FIELDS and not override:
        raise ValueError(f"field {spec.key!r} is already in the catalogue; pass override=True "
                         "to replace it")
    if spec.key in FRAME_FIELDS or spec.where == "frame":
        raise ValueError(f"field {spec.key!r}: frame fields are built in (FRAME_FIELDS); the "
                         "catalogue holds the muscles' fields")
    if spec.total and spec.key != "W":
        raise ValueError(f"field {spec.key!r} cannot have a total: only W adds up over the "
                         "muscles (Eq. 4)")
    FIELDS[spec.key] = spec
    return spec


def field_spec(key: str) -> FieldSpec:
    """The :class:`FieldSpec` of ``key``; ``KeyError`` lists the fields."""
    spec = FIELDS.get(key) or FRAME_FIELDS.get(key)
    if spec is None:
        raise KeyError(f"unknown field {key!r}; fields: "
                       f"{', '.join([*FIELDS, *FRAME_FIELDS])}")
    return spec


def total_fields() -> tuple[str, ...]:
    """The keys of the fields that have a total over the muscles (``("W",)``)."""
    return tuple(k for k, f in FIELDS.items() if f.total)


def check_field(key: str, muscle: str | None = None) -> FieldSpec:
    """The spec of ``key``, checked for showing it for ``muscle`` (None: the total).

    Raises
    ------
    KeyError
        For an unknown field, listing the fields.
    ValueError
        For a field with no total and no muscle: "field 'eps' belongs to one muscle; ...".
    """
    spec = field_spec(key)
    if muscle is None and not spec.total:
        raise ValueError(f"field {key!r} belongs to one muscle; name the muscle (only "
                         f"{' and '.join(total_fields())} has a total)")
    return spec
