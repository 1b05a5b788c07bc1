"""Muscle glyphs: the geometry that draws a muscle, looked up per type along its class
hierarchy (as :func:`wrinkle_vis.widgets.widget_factory` looks up placement widgets).

A muscle type declares its glyph as ``glyph = "package.module:function"`` (a string, so the
core never imports VTK), or one is registered for it with :func:`register_glyph`. A glyph is
a function ``glyph(muscle) -> pyvista.PolyData``. A type with neither gets
:func:`generic_glyph`, drawn from its declared point parameters.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pyvista as pv

from ..core.muscle import Muscle
from ..core.registry import TypeLookup

__all__ = ["generic_glyph", "glyph_factory", "linear_glyph", "register_glyph", "sheet_glyph"]

Glyph = Callable[[Muscle], pv.PolyData]



def register_glyph(muscle_type: type, glyph: Glyph | None = None):
    """Use ``glyph`` for ``muscle_type`` and its subclasses, over what the type declares in
    its ``glyph`` attribute. Usable as a decorator: ``@register_glyph(MyMuscle)``.
    """
    return _LOOKUP.register(muscle_type, glyph)


def glyph_factory(muscle_type: type) -> Glyph:
    """The glyph of a muscle type, looked up along its class hierarchy
    (:class:`~wrinkle_vis.core.registry.TypeLookup`): a glyph registered with
    :func:`register_glyph`, then the class's own ``glyph = "module:function"``, else
    :func:`generic_glyph`. ``ImportError`` names a declaration that cannot be imported.
    """
    return _LOOKUP(muscle_type)


def linear_glyph(muscle) -> pv.PolyData:
    """A linear muscle: a fibre from the attachment to the insertion, thick at the bone."""
    a, b = np.asarray(muscle.attachment), np.asarray(muscle.insertion)
    line = pv.Line(a, b, resolution=16)
    t = np.linspace(0.0, 1.0, line.n_points)
    line.point_data["r"] = muscle.length * (0.06 - 0.035 * t)
    return line.tube(scalars="r", absolute=True, n_sides=12, capping=True)


def sheet_glyph(muscle) -> pv.PolyData:
    """A sheet muscle: a ribbon of seven fibres from the attachment line to the insertion
    line.
    """
    att, ins = np.asarray(muscle.attachment_line), np.asarray(muscle.insertion_line)
    s = np.linspace(0.0, 1.0, 7)[:, None]
    starts = att[0] + s * (att[1] - att[0])
    ends = ins[0] + s * (ins[1] - ins[0])
    t = np.linspace(0.0, 1.0, 9)[None, :, None]
    points = (starts[:, None] + t * (ends - starts)[:, None]).reshape(-1, 3)
    lines = np.hstack([np.full((7, 1), 9), np.arange(63).reshape(7, 9)]).ravel()
    return pv.PolyData(points, lines=lines).tube(  # seven fibres in one filter run
        radius=0.012 * muscle.fibre_length, n_sides=8, capping=True)


def generic_glyph(muscle) -> pv.PolyData:
    """A muscle type with no glyph of its own, drawn from its declared point parameters.

    The points on the skull come first, then those on the skin (each line's two ends in
    order); a fibre runs through them, as a tube a thirtieth of their span thick. A type
    with a single point gets a three-armed marker there, as wide as its wrinkling length
    (its ``wrinkle_length``).
    """
    surfaces = muscle.point_surfaces()
    order = sorted(surfaces, key=lambda p: surfaces[p] != "skull")  # stable: skull first
    pts = np.concatenate([np.asarray(getattr(muscle, p), float).reshape(-1, 3)
                          for p in order]) if order else np.zeros((0, 3))
    if len(pts) == 0:
        raise ValueError(f"{muscle.type_name} muscle {muscle.name!r} has no point "
                         "parameters to draw; give its type a glyph (register_glyph)")
    span = float(np.ptp(pts, axis=0).max()) if len(pts) > 1 else 0.0
    if span > 0.0:
        fibre = pv.MultipleLines(pts) if len(pts) > 2 else pv.Line(pts[0], pts[1])
        return fibre.tube(radius=span / 30.0, n_sides=10, capping=True)
    half = 0.5 * _size(muscle)
    arms = [pv.Line(pts[0] - half * e, pts[0] + half * e).tube(radius=half / 8.0, n_sides=8)
            for e in np.eye(3)]
    return arms[0].append_polydata(*arms[1:])


def _size(muscle) -> float:
    """The width of a one-point marker: the muscle's wrinkling length, else 4."""
    try:
        size = float(muscle.wrinkle_length)
    except (NotImplementedError, AttributeError, TypeError, ValueError):
        return 4.0
    return size if np.isfinite(size) and size > 0 else 4.0


#: The glyphs by muscle type (:func:`register_glyph`, :func:`glyph_factory`).
_LOOKUP = TypeLookup("glyph", generic_glyph, "function")
_GLYPHS = _LOOKUP.registered
