"""What a muscle parameter is: its label, symbol, unit, range, step and surface, declared once.

A muscle type declares each parameter as a dataclass field made by :func:`parameter`; the
field's metadata holds a :class:`Parameter`, which validation
(:meth:`~wrinkle_vis.core.muscle.Muscle._check_common`), the app's parameter panel, layout
validation, the command line (``wrinkle-vis types``) and the documentation read. Nothing
else lists a type's parameters.

.. code-block:: python

    @register_muscle_type
    @dataclass(frozen=True)
    class RingMuscle(Muscle):
        type_name = "ring"
        center: tuple = parameter(label="centre", symbol="c", unit="point", shape=(3,),
                                  surface="skin", kw_only=False)
        _: KW_ONLY
        radius: float = parameter(label="R", symbol="R", unit="length", lo=0.0,
                                  lo_open=True, step=1.0)
"""

from __future__ import annotations

import dataclasses
import math
import unicodedata
from dataclasses import dataclass

import numpy as np

from .symbols import display_label

__all__ = ["MAX_COUNT", "PARAMETER_KEY", "PHYSICAL_UNITS", "SURFACES", "TABLE_COLUMNS", "UNITS",
           "Parameter", "ParameterValueError", "control_character", "format_value", "parameter",
           "parameter_table"]

#: The key of a :class:`Parameter` in a dataclass field's metadata.
PARAMETER_KEY = "wrinkle_vis.parameter"
#: The kinds of value a parameter holds: lengths in the face's units (they scale with the
#: face), angles in degrees, dimensionless numbers, integer counts, and points or lines; the
#: physically based skin's material constants (:mod:`wrinkle_vis.core.skin`) in SI units.
PHYSICAL_UNITS = ("N/m", "N/m^3", "kg/m^3", "m", "1/s", "s")
UNITS = ("length", "deg", "1", "count", "point", "vector", "option", *PHYSICAL_UNITS)
#: The surfaces a point parameter lies on.
SURFACES = ("skin", "skull")
#: The largest count (``n_wrinkles``, ``iterations``): far beyond any mesh, and exact as a
#: float.
MAX_COUNT = 10**9


def format_value(value) -> str:
    """How an error message shows a parameter's value: a float with ``:g``, a huge integer
    by its number of digits, anything else by its ``repr``.
    """
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, int) and abs(value) >= 10**16:  # too long to show (or to repr)
        return f"an integer of about {int(value.bit_length() * math.log10(2)) + 1} digits"
    return repr(value)


class ParameterValueError(ValueError):
    """A value a parameter does not allow (:meth:`Parameter.validate`).

    Attributes
    ----------
    allowed : str
        What is allowed, e.g. ``"(0, inf)"``, ``"a real number"``, ``"an integer >= 1"``.
    hint : str
        A way out, or ``""``.
    """

    def __init__(self, allowed: str, hint: str = ""):
        super().__init__(allowed + (f". {hint}" if hint else ""))
        self.allowed, self.hint = allowed, hint


@dataclass(frozen=True)
class Parameter:
    """One parameter of a muscle type, as every layer shows and checks it.

    Attributes
    ----------
    name : str
        The dataclass field (filled in by :meth:`Muscle.parameters`).
    label : str
        ASCII label for panels and messages, e.g. ``"Phi (deg)"``.
    symbol : str
        The paper's symbol, e.g. ``"Φ"``.
    unit : str
        One of :data:`UNITS`.
    doc : str
        One line: what it is.
    lo, hi : float
        The static range (bounds that depend on other parameters are checked by the type).
    lo_open, hi_open : bool
        Whether the bounds are excluded.
    step : float
        The panel's step.
    derived : str or None
        For an optional parameter (default None): the attribute holding the value it
        takes then (``"fall_start_value"``), which :meth:`Muscle.resolved` reads.
    surface : str or None
        For a point parameter: ``"skin"`` or ``"skull"``, where its points lie.
    shape : tuple of int
        ``()`` for a number, ``(3,)`` for a point, ``(2, 3)`` for a line.
    hint : str
        Added to the error message when the value is out of range.
    choices : tuple
        For an option (``unit="option"``): its values, the default first (``(False, True)``
        makes a check box).
    choice_labels : tuple of str
        How the panel names each choice (default their ``str``).
    """

    name: str = ""
    label: str = ""
    symbol: str = ""
    unit: str = "1"
    doc: str = ""
    lo: float = -math.inf
    hi: float = math.inf
    lo_open: bool = False
    hi_open: bool = False
    step: float = 0.1
    derived: str | None = None
    surface: str | None = None
    shape: tuple = ()
    hint: str = ""
    choices: tuple = ()
    choice_labels: tuple = ()

    def __post_init__(self):
        if self.unit not in UNITS:
            raise ValueError(f"parameter {self.name or self.label!r}: unit {self.unit!r} is "
                             f"not one of {', '.join(UNITS)}")
        if self.surface is not None and self.surface not in SURFACES:
            raise ValueError(f"parameter {self.name or self.label!r}: surface "
                             f"{self.surface!r} is not one of {', '.join(SURFACES)}")
        if (self.unit == "option") != bool(self.choices):
            raise ValueError(f"parameter {self.name or self.label!r}: an option (and only "
                             "an option) has choices")
        if self.choice_labels and len(self.choice_labels) != len(self.choices):
            raise ValueError(f"option {self.name or self.label!r}: one label per choice")
        if self.unit == "point" and self.shape not in ((3,), (2, 3)):
            raise ValueError(f"point parameter {self.name or self.label!r} needs shape (3,) "
                             f"or (2, 3); got {self.shape}")

    @property
    def is_point(self) -> bool:
        """A point or a line, which placement widgets edit and the skin or skull holds."""
        return self.unit == "point"

    @property
    def is_number(self) -> bool:
        """A real number or a count, which the parameter panel edits."""
        return self.unit in ("length", "deg", "1", "count", *PHYSICAL_UNITS)

    @property
    def is_length(self) -> bool:
        """Scales with the face (:meth:`Muscle.transformed`)."""
        return self.unit == "length"

    @property
    def is_flag(self) -> bool:
        """An option that is on or off (a check box)."""
        return self.unit == "option" and set(self.choices) == {False, True}

    @property
    def labelled_choices(self) -> dict:
        """``{value: label}`` of an option's choices, in order."""
        labels = self.choice_labels or tuple(map(str, self.choices))
        return dict(zip(self.choices, labels, strict=True))

    @property
    def display(self) -> str:
        """The label people read: :attr:`label` with the symbol it spells
        (:func:`~wrinkle_vis.core.symbols.display_label`): ``Φ (deg)``, ``k₀``, ``hᶜ``.
        """
        return display_label(self.label, self.symbol)

    @property
    def optional(self) -> bool:
        """None is allowed and means the :attr:`derived` value."""
        return self.derived is not None

    def validate(self, value, lo: float | None = None, hi: float | None = None, *,
                 lo_open: bool | None = None, hi_open: bool | None = None) -> float | int:
        """``value`` as a float (an int for a count) when this parameter allows it, the one
        check that muscles (:meth:`~wrinkle_vis.core.muscle.Muscle._check_common`) and the
        skin's material (:class:`~wrinkle_vis.core.skin.SkinMaterial`) share.

        Parameters
        ----------
        value : object
            A real number (not a bool) inside the range; for a count an integral number in
            ``[lo, MAX_COUNT]``.
        lo, hi, lo_open, hi_open : optional
            Bounds in place of the declared ones (ranges that depend on other parameters).

        Raises
        ------
        ParameterValueError
            Naming what is allowed.
        """
        lo = self.lo if lo is None else lo
        hi = self.hi if hi is None else hi
        lo_open = self.lo_open if lo_open is None else lo_open
        hi_open = self.hi_open if hi_open is None else hi_open
        if self.unit == "count":
            integral = isinstance(value, (int, np.integer)) or (
                isinstance(value, float) and value.is_integer())
            if isinstance(value, (bool, np.bool_)) or not integral or \
                    not lo <= int(value) <= MAX_COUNT:
                raise ParameterValueError(
                    f"an integer >= {lo:g}",
                    f"at most {MAX_COUNT:.0e}" if integral and int(value) > lo else "")
            return int(value)
        if isinstance(value, (bool, np.bool_)):
            raise ParameterValueError("a real number")
        try:
            x = float(value)
        except OverflowError:  # an int beyond 1.8e308: out of any range
            x = math.inf
        except (TypeError, ValueError):
            raise ParameterValueError("a real number") from None
        if not math.isfinite(x) or x < lo or x > hi or (lo_open and x == lo) or (
                hi_open and x == hi):
            left = "(" if lo_open or lo == -math.inf else "["
            right = ")" if hi_open or hi == math.inf else "]"
            raise ParameterValueError(
                f"{left}{format_value(float(lo))}, {format_value(float(hi))}{right}")
        return x

    def range_text(self) -> str:
        """The static range as ``[0, 1)``, ``(0, inf)``, or ``integer >= 1``."""
        if self.unit == "count":
            return f"integer >= {self.lo:g}"
        left = "(" if self.lo_open or self.lo == -math.inf else "["
        right = ")" if self.hi_open or self.hi == math.inf else "]"
        return f"{left}{self.lo:g}, {self.hi:g}{right}"


def parameter(default=dataclasses.MISSING, *, kw_only: bool = True, **meta):
    """A muscle dataclass field carrying its :class:`Parameter` (``meta`` are its attributes).

    Parameters
    ----------
    default : optional
        The default; none makes the parameter required. An optional parameter (one with
        ``derived``) defaults to None.
    kw_only : bool, default True
        Keyword-only in the constructor (the point parameters of the built-in types are
        positional: ``kw_only=False``).
    **meta
        ``label``, ``symbol``, ``unit``, ``doc``, ``lo``, ``hi``, ``lo_open``, ``hi_open``,
        ``step``, ``derived``, ``surface``, ``shape``, ``hint``, ``choices``,
        ``choice_labels``.

    Returns
    -------
    dataclasses.Field
    """
    if default is dataclasses.MISSING and meta.get("derived"):
        default = None
    spec = Parameter(**meta)
    return dataclasses.field(default=default, kw_only=kw_only,
                             metadata={PARAMETER_KEY: spec})


#: The columns of :func:`parameter_table`.
TABLE_COLUMNS = ("parameter", "symbol", "unit", "allowed", "default", "meaning")


def parameter_table(muscle_type, length_unit: str = "face units") -> list[tuple[str, ...]]:
    """A muscle type's parameters as rows of text (:data:`TABLE_COLUMNS`), from their
    metadata: what ``wrinkle-vis types`` prints and the documentation tabulates.

    Parameters
    ----------
    muscle_type : type
        A :class:`~wrinkle_vis.core.muscle.Muscle` subclass.
    length_unit : str
        How to name the unit of lengths.

    Returns
    -------
    list of tuple of str
        One row per parameter, in declaration order: name, symbol, unit (a point's surface),
        allowed range, default (``required``, a value, or ``derived``), meaning.
    """
    defaults = {f.name: f.default for f in dataclasses.fields(muscle_type)}
    rows: list[tuple[str, ...]] = []
    for p in muscle_type.parameters():
        default = defaults.get(p.name, dataclasses.MISSING)
        if p.optional:
            shown = "derived"
        elif default is dataclasses.MISSING:
            shown = "required"
        else:
            shown = f"{default:g}" if isinstance(default, float) else str(default)
        if p.is_point:
            unit = f"{'line' if p.shape == (2, 3) else 'point'} on the {p.surface or 'skin'}"
            allowed = ""
        else:
            unit = {"length": length_unit, "deg": "degrees", "1": "", "count": "",
                    "vector": "vector"}.get(p.unit, p.unit)
            allowed = "" if p.unit == "vector" else p.range_text()
        rows.append((p.name, p.symbol, unit, allowed, shown, p.doc))
    return rows


def control_character(text: str) -> str | None:
    """The first control or format character of ``text`` (Unicode categories Cc and Cf:
    newline, escape, NUL, zero-width joiner, ...) as ``"U+001B"``, or None when it has none.

    Names with them are refused: they reach terminals raw (escape sequences) and cut
    array names in VTK files (NUL). Any other Unicode is fine.
    """
    for ch in text:
        if unicodedata.category(ch) in ("Cc", "Cf"):
            return f"U+{ord(ch):04X}"
    return None
