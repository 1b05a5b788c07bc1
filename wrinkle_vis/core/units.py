"""The unit of a face's lengths, looked up in one place (bars, probe, summaries)."""

from __future__ import annotations

__all__ = ["DEFAULT_UNIT", "face_unit"]

#: The unit of a face that does not say: the built-in face is in millimetres.
DEFAULT_UNIT = "mm"


def face_unit(face) -> str:
    """The unit of ``face``'s lengths (a ``FaceModel``, or anything with a ``face``).

    The face's ``unit`` attribute when it has a non-empty one, else :data:`DEFAULT_UNIT`.
    Every label that shows a length (scalar bars, the probe, summaries) asks here.
    """
    if not hasattr(face, "unit") and hasattr(face, "face"):  # a FaceState
        face = face.face
    unit = getattr(face, "unit", None)
    return str(unit) if unit else DEFAULT_UNIT
