"""Conversion of core arrays to ``pyvista.PolyData``."""

from __future__ import annotations

import numpy as np
import pyvista as pv

from ..core.face import FIELD_NAMES, FaceState
from ..core.mesh import TriangleSurface

__all__ = ["field_array_name", "to_polydata", "to_surface_polydata"]


def field_array_name(field: str, muscle: str | None = None) -> str:
    """The point-array name of a field: ``"W"`` for the total, ``"<muscle>.<field>"``."""
    return field if muscle is None else f"{muscle}.{field}"


def to_surface_polydata(surface: TriangleSurface, points=None) -> pv.PolyData:
    """A :class:`TriangleSurface` (optionally at other ``(n, 3)`` points) as ``PolyData``."""
    pts = surface.points if points is None else np.asarray(points, dtype=float)
    faces = np.hstack([np.full((surface.n_triangles, 1), 3), surface.triangles]).ravel()
    return pv.PolyData(np.array(pts, dtype=float), faces=faces)


def to_polydata(state: FaceState) -> pv.PolyData:
    """The final skin of ``state`` with every field as a named point array.

    Arrays: ``W`` (total), ``W_raw`` (before the fold guard), ``fold_guard`` (how much the
    guard took away, 0 where it did not act), ``deformation`` (``(n, 3)``: deformed minus
    rest), ``rest_points`` (``(n, 3)``), and for every muscle ``"<muscle>.<field>"`` for
    each field of :data:`~wrinkle_vis.core.face.FIELD_NAMES` (``nan`` where the muscle does
    not define it).
    """
    mesh = to_surface_polydata(state.face.skin, state.points)
    mesh.point_data["W"] = np.asarray(state.W)
    mesh.point_data["W_raw"] = np.asarray(getattr(state, "W_raw", state.W))
    mesh.point_data["fold_guard"] = np.asarray(getattr(state, "fold_guard",
                                                       np.zeros(len(state.W))))
    mesh.point_data["deformation"] = state.deformed_points - state.rest_points
    mesh.point_data["rest_points"] = np.asarray(state.rest_points)
    for muscle in state.face.muscle_names:
        for field in FIELD_NAMES:
            mesh.point_data[field_array_name(field, muscle)] = np.asarray(
                state.fields[muscle][field])
    mesh.set_active_scalars("W")
    return mesh
