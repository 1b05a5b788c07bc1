"""Conversion of core arrays to ``pyvista.PolyData``."""

from __future__ import annotations

import numpy as np
import pyvista as pv

from ..core.face import FIELD_NAMES, FaceState
from ..core.fields import field_spec
from ..core.mesh import TriangleSurface
from ..core.units import LENGTH_UNITS, face_unit

__all__ = ["field_array_name", "to_polydata", "to_surface_polydata"]

#: The separator of a muscle's name and a field's key in a point array's name.
SEPARATOR = "__"


def field_array_name(field: str, muscle: str | None = None) -> str:
    """The point-array name of a field: ``"W"`` for the total, ``"<muscle>__<field>"``
    for a muscle's (``corrugator_L__W``).

    With a muscle name that is a Python identifier (the built-in faces' are) the array name
    is one too, so ParaView's calculator and Python take it unquoted. Field keys hold no
    ``__``, so the last ``__`` of a name splits it back into muscle and field.
    """
    return field if muscle is None else f"{muscle}{SEPARATOR}{field}"


def to_surface_polydata(surface: TriangleSurface, points=None) -> pv.PolyData:
    """A :class:`TriangleSurface` (optionally at other ``(n, 3)`` points) as ``PolyData``."""
    pts = surface.points if points is None else np.asarray(points, dtype=float)
    faces = np.hstack([np.full((surface.n_triangles, 1), 3), surface.triangles]).ravel()
    return pv.PolyData(np.array(pts, dtype=float), faces=faces)


def to_polydata(state: FaceState) -> pv.PolyData:
    """The final skin of ``state`` with every field as a named point array.

    Point arrays: ``Normals`` (``(n, 3)``, the final skin's unit vertex normals, set as the
    active normals so that viewers shade smoothly), ``W`` (total), ``W_raw`` (before the
    fold guard), ``fold_guard`` (how much the guard took away, 0 where it did not act),
    ``deformation`` (``(n, 3)``: deformed minus rest), ``rest_points`` (``(n, 3)``), and
    for every muscle
    ``"<muscle>__<field>"`` (:func:`field_array_name`) for each field of
    :data:`~wrinkle_vis.core.face.FIELD_NAMES` (``nan`` where the muscle does not define it).

    Field data: ``unit`` (the lengths' unit, e.g. ``"mm"``), ``metres_per_unit`` (a
    number, for readers without string arrays) and ``display_names`` (one string
    ``"<array> = <title>"`` per field array, the title as scalar bars show it, e.g.
    ``"corrugator_L__W = W (mm), corrugator_L"``; ASCII, as VTK's string arrays need).
    """
    mesh = to_surface_polydata(state.face.skin, state.points)
    mesh.point_data["Normals"] = np.asarray(state.normals, dtype=float)
    mesh.GetPointData().SetActiveNormals("Normals")
    mesh.point_data["W"] = np.asarray(state.W)
    mesh.point_data["W_raw"] = np.asarray(getattr(state, "W_raw", state.W))
    mesh.point_data["fold_guard"] = np.asarray(getattr(state, "fold_guard",
                                                       np.zeros(len(state.W))))
    mesh.point_data["deformation"] = state.deformed_points - state.rest_points
    mesh.point_data["rest_points"] = np.asarray(state.rest_points)
    unit = face_unit(state)
    shown = [("W", None)]
    for muscle in state.face.muscle_names:
        for field in FIELD_NAMES:
            mesh.point_data[field_array_name(field, muscle)] = np.asarray(
                state.fields[muscle][field])
            shown.append((field, muscle))
    mesh.field_data["unit"] = [unit]
    if unit in LENGTH_UNITS:
        mesh.field_data["metres_per_unit"] = np.array([LENGTH_UNITS[unit]])
    mesh.field_data["display_names"] = [  # VTK's string arrays are ASCII: \u escapes
        f"{field_array_name(f, m)} = {field_spec(f).title(m, unit)}".encode(
            "ascii", "backslashreplace").decode("ascii") for f, m in shown]
    mesh.set_active_scalars("W")
    return mesh
