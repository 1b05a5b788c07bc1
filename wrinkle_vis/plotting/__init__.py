"""PyVista adapters: the face state as ``PolyData`` with every field as a point array."""

from .polydata import field_array_name, to_polydata, to_surface_polydata

__all__ = ["field_array_name", "to_polydata", "to_surface_polydata"]
