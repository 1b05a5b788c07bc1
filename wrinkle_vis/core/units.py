"""The unit of a face's lengths, looked up in one place (bars, probe, summaries).

A face knows its unit (:attr:`FaceModel.unit <wrinkle_vis.core.face.FaceModel>`): from its
layout file (``"unit"``), set by the caller, or guessed from its size
(:func:`guess_unit`, with a :class:`UnitWarning`). Default muscle parameters are given in
millimetres and converted to the face's unit (:data:`LENGTH_UNITS`).
"""

from __future__ import annotations

import math
import warnings
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .mesh import TriangleSurface

__all__ = ["DEFAULT_UNIT", "HEAD_METRES", "HUMAN_LANDMARK_RADIUS_M", "HUMAN_SIZE_FACTOR",
           "LENGTH_UNITS", "UnitWarning", "check_unit", "face_unit", "face_unit_of",
           "guess_unit", "landmark_radius", "millimetre", "physical_metres_per_unit"]

#: The unit of a face that does not say: the built-in face is in millimetres.
DEFAULT_UNIT = "mm"

#: Metres in one unit of a face's lengths, by the unit's name.
LENGTH_UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "um": 1e-6, "in": 0.0254, "ft": 0.3048}

class UnitWarning(UserWarning):
    """A face's unit was guessed from its size; set it to silence this."""


def check_unit(unit) -> str:
    """``unit`` if it is a known length unit (:data:`LENGTH_UNITS`).

    Raises
    ------
    ValueError
        Naming the unit and the known ones.
    """
    if not isinstance(unit, str) or unit not in LENGTH_UNITS:
        raise ValueError(f"unknown length unit {unit!r}; use one of "
                         f"{', '.join(LENGTH_UNITS)}")
    return unit


def guess_unit(height: float) -> str | None:
    """The unit in which a head (or face) ``height`` units tall is a human size, or None.

    A human face or head is 0.12 to 0.5 m tall: a height in 0.05..1.0 reads as metres,
    5..100 as centimetres, 50..1000 as millimetres (centimetres win 50..100 only when the
    height is under 60, the tallest bust in centimetres). Outside those: None.
    """
    h = float(height)
    if not math.isfinite(h) or h <= 0:
        return None
    if 0.05 <= h <= 1.0:
        return "m"
    if 5.0 <= h < 60.0:
        return "cm"
    if 60.0 <= h <= 1000.0:
        return "mm"
    return None


def face_unit(face) -> str:
    """The unit of ``face``'s lengths (a ``FaceModel``, or anything with a ``face``).

    The face's ``unit`` attribute when it has a non-empty one, else :data:`DEFAULT_UNIT`.
    Every label that shows a length (scalar bars, the probe, summaries) asks here.
    """
    if not hasattr(face, "unit") and hasattr(face, "face"):  # a FaceState
        face = face.face
    unit = getattr(face, "unit", None)
    return str(unit) if unit else DEFAULT_UNIT


#: The sizes in metres a skin's largest extent may have (a face to a bust, generously).
HEAD_METRES = (0.01, 10.0)


def face_unit_of(skin: TriangleSurface, unit: str | None = None) -> str:
    """``unit`` checked, or the unit guessed from the skin's height (with a
    :class:`UnitWarning`; ``"mm"`` when nothing fits).

    A skin no unit makes a head of (its largest extent outside :data:`HEAD_METRES` in every
    unit of :data:`LENGTH_UNITS`, e.g. 4e29 or 4e-31 units) is refused when no unit is given,
    and warned about when one is.

    Raises
    ------
    ValueError
        One line: the skin's size, and that no unit makes it a head; or an unknown unit.
    """
    lo, hi = skin.bounds()
    height = float(hi[1] - lo[1])
    extent = float(np.max(hi - lo))
    possible = any(HEAD_METRES[0] <= extent * f <= HEAD_METRES[1]
                   for f in LENGTH_UNITS.values())
    if unit is not None:
        unit = check_unit(unit)
        if not possible:
            warnings.warn(f"the skin is {extent:.4g} {unit} across "
                          f"({extent * LENGTH_UNITS[unit]:.3g} m), a head in no unit; check "
                          "the file", UnitWarning, stacklevel=3)
        return unit
    if not possible:
        raise ValueError(f"the skin is {extent:.4g} units across, a head in no unit "
                         f"({', '.join(LENGTH_UNITS)}); the file's coordinates are damaged "
                         "or scaled: check it, or scale it to millimetres")
    guess = guess_unit(height)
    warnings.warn(f"the skin's unit is not given; a face {height:.4g} units tall reads as "
                  f"{guess or 'mm'}: pass unit=... (or \"unit\" in its layout) to say",
                  UnitWarning, stacklevel=3)
    return guess or "mm"


def millimetre(face) -> float:
    """A millimetre in ``face``'s unit (a ``FaceModel``, :func:`face_unit`): the lengths a
    new muscle starts with are given in millimetres, the built-in face's unit.
    """
    return LENGTH_UNITS["mm"] / LENGTH_UNITS[face_unit(face)]


#: The RMS distance of a human face's landmarks from their centroid, in metres: the built-in
#: face's nine (44.5 mm; the Lee Perry-Smith scan's are 47.5 mm).
HUMAN_LANDMARK_RADIUS_M = 0.0445

#: A face's landmarks within this factor of :data:`HUMAN_LANDMARK_RADIUS_M` (in its unit)
#: make a human face: a child's to a large adult's, with room to spare.
HUMAN_SIZE_FACTOR = 2.0


def landmark_radius(landmarks) -> float:
    r"""The RMS distance of ``landmarks`` (name to (3,) point) from their centroid,
    :math:`\sqrt{\tfrac1k \sum_i \lVert y_i - \bar y \rVert^2}`, in their unit.
    """
    p = np.array([tuple(v) for v in dict(landmarks).values()], dtype=float).reshape(-1, 3)
    return float(np.sqrt(np.mean(np.sum((p - p.mean(axis=0)) ** 2, axis=1))))


def physical_metres_per_unit(face) -> float:
    r"""Metres in one of ``face``'s units for the physically based skin, whose material is a
    human's skin in SI units (per-area stiffnesses, density, tissue thickness).

    The face's own unit (:func:`face_unit`), unless its landmarks put it outside human
    size in that unit (their :func:`landmark_radius` more than :data:`HUMAN_SIZE_FACTOR`
    times from :data:`HUMAN_LANDMARK_RADIUS_M`): then the face is simulated at human size,
    :math:`s = r_\text{human} / r_\text{landmarks}` metres per unit. A statue or a scan in
    a unit of its own (the Demosthenes bust is 2.69 units tall: 2.69 mm as millimetres)
    would otherwise carry the human membrane's reach, :math:`\sqrt{Y / \kappa}` = 16 mm,
    over the whole of a 2.7 mm face and smooth its compression away; the geometric skin
    has no such length and scales with the face. A face without landmarks keeps its unit.
    """
    declared = LENGTH_UNITS[face_unit(face)]
    landmarks = getattr(face, "landmarks", None)
    if not landmarks:
        return declared
    radius = landmark_radius(landmarks)
    if not math.isfinite(radius) or radius <= 0.0:
        return declared
    ratio = radius * declared / HUMAN_LANDMARK_RADIUS_M
    if 1.0 / HUMAN_SIZE_FACTOR <= ratio <= HUMAN_SIZE_FACTOR:
        return declared
    return HUMAN_LANDMARK_RADIUS_M / radius
