"""The field catalogue: what each quantity of the model is, and how to colour it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["FIELDS", "NAN_COLOR", "FieldInfo", "field_info", "field_range"]

#: Colour of undefined values (NaN): outside the muscle's AOI or wrinkling region.
NAN_COLOR = "#c8c8c8"


@dataclass(frozen=True)
class FieldInfo:
    """One field of the model.

    Attributes
    ----------
    key : str
        The name in ``state.fields[muscle][key]`` (``"W"`` also names the total).
    symbol, name, meaning : str
        For titles, menus and tooltips.
    equation : str
        Where the paper defines it.
    unit : str
        ``"1"`` for dimensionless, ``"length"`` for the face's units, ``"deg"``.
    cmap : str
        Matplotlib colour map: sequential, or diverging for signed fields.
    diverging : bool
        Signed field, drawn centred on 0.
    limits : (float, float) or None
        Fixed colour range, or None to take it from the data.
    """

    key: str
    symbol: str
    name: str
    meaning: str
    equation: str
    unit: str
    cmap: str
    diverging: bool
    limits: tuple[float, float] | None

    def title(self, muscle: str | None = None, units: str = "mm") -> str:
        """A scalar-bar title such as ``"eps, corrugator_L"`` or ``"W (mm), total"``.

        ASCII only: VTK's default font has no Greek letters.
        """
        unit = {"1": "", "length": f" ({units})", "deg": " (deg)"}[self.unit]
        return f"{self.key}{unit}, {muscle or 'total'}"


FIELDS: dict[str, FieldInfo] = {f.key: f for f in (
    FieldInfo("lambda", "λ", "length factor",
              "distance from the attachment along the central fibre, over R or L_s",
              "Eq. 2, 13", "1", "viridis", False, (0.0, 1.0)),
    FieldInfo("gamma", "γ", "angular/width factor",
              "angle from the central fibre over Φ (linear) or 2h over W_s (sheet)",
              "Eq. 2, 13", "1", "viridis", False, (0.0, 1.0)),
    FieldInfo("l", "l", "fibre distance", "distance from the attachment along the fibre",
              "Eq. 1", "length", "cividis", False, None),
    FieldInfo("w", "w", "periodic coordinate", "position within one wrinkle period",
              "Eq. 7", "length", "twilight", False, None),
    FieldInfo("H", "H", "shape function", "cross-sectional wrinkle shape: furrows and bulges",
              "Eq. 5", "length", "RdBu_r", True, None),
    FieldInfo("At", "At", "attenuation", "fade of the wrinkles away from the central fibre",
              "Eq. 12, 15", "1", "magma", False, (0.0, 1.0)),
    FieldInfo("eps", "ε", "compression rate",
              "edge shrinkage weighted by alignment with the contraction",
              "Eq. 9, 10", "1", "PuOr_r", True, None),
    FieldInfo("A", "A", "anisotropy", "wrinkle response to compression, 0 under stretch",
              "Eq. 11", "1", "inferno", False, (0.0, 1.0)),
    FieldInfo("W", "W", "wrinkle amplitude", "H A At: displacement along the normal",
              "Eq. 4", "length", "RdBu_r", True, None),
)}


def field_info(key: str) -> FieldInfo:
    """The :class:`FieldInfo` of ``key``; ``KeyError`` lists the fields."""
    try:
        return FIELDS[key]
    except KeyError:
        raise KeyError(f"unknown field {key!r}; fields: {', '.join(FIELDS)}") from None


def field_range(info: FieldInfo, values: np.ndarray) -> tuple[float, float]:
    """Colour range: fixed limits, symmetric about 0 for signed fields, else the data's."""
    if info.limits is not None:
        return info.limits
    finite = np.asarray(values)[np.isfinite(values)]
    if finite.size == 0:
        return (-1.0, 1.0) if info.diverging else (0.0, 1.0)
    if info.diverging:
        m = float(np.abs(finite).max()) or 1.0
        return (-m, m)
    lo, hi = float(finite.min()), float(finite.max())
    return (lo, hi) if hi > lo else (lo, lo + 1.0)
