"""How to colour the fields of the core catalogue (:mod:`wrinkle_vis.core.fields`).

The catalogue itself, what each field is, where it is defined, its unit, whether it has a
total and its colour map, lives in the core (:data:`~wrinkle_vis.core.fields.FIELDS`, the
same dict here); this module adds the colour of undefined values and the colour range.
"""

from __future__ import annotations

import numpy as np

from ..core.fields import FIELDS, FieldSpec, field_spec

__all__ = ["FIELDS", "NAN_COLOR", "FieldInfo", "field_info", "field_range"]

#: Colour of undefined values (NaN): outside the muscle's AOI or wrinkling region.
NAN_COLOR = "#c8c8c8"

#: One field of the catalogue (:class:`wrinkle_vis.core.fields.FieldSpec`).
FieldInfo = FieldSpec


def field_info(key: str) -> FieldSpec:
    """The catalogue entry of ``key``; ``KeyError`` lists the fields."""
    return field_spec(key)


def field_range(info: FieldSpec, values: np.ndarray) -> tuple[float, float]:
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
