"""Interactive placement widgets, looked up per muscle type from the registry.

A muscle type declares its widget as ``widget = "package.module:Class"`` (or one is registered
for it with :func:`register_widget`); :func:`widget_factory` finds it along the class
hierarchy, and a type with none gets :class:`GenericWidget`, a handle per point parameter.
"""

from .placement import (
    COLORS,
    GenericWidget,
    Handle,
    LinearWidget,
    PlacementWidget,
    SheetWidget,
    boundary_lines,
    handles_for,
    layer_of,
    register_widget,
    snapped,
    snapped_points,
    spherical_sector,
    widget_factory,
)

__all__ = ["COLORS", "GenericWidget", "Handle", "LinearWidget", "PlacementWidget",
           "SheetWidget", "boundary_lines", "handles_for", "layer_of", "register_widget",
           "snapped", "snapped_points", "spherical_sector", "widget_factory"]
