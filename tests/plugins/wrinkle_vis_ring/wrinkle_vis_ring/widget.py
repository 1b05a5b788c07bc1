"""The ring muscle's placement widget (its centre slides on the skin, its disc is drawn)
and its glyph (a torus round the axis).

Imported only when a ring muscle is shown (``RingMuscle.widget`` and ``RingMuscle.glyph``
name them), so the muscle type itself needs no VTK.
"""

from __future__ import annotations

import numpy as np
import pyvista as pv

from wrinkle_vis.widgets import PlacementWidget

__all__ = ["RingWidget", "ring_glyph"]


def ring_glyph(muscle) -> pv.PolyData:
    """The ring as a tube of radius ``radius / 12`` round its centre, in its plane."""
    axis = np.asarray(muscle.axis, float) / np.linalg.norm(muscle.axis)
    helper = [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0]
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    t = np.linspace(0.0, 2.0 * np.pi, 65)[:, None]
    ring = np.asarray(muscle.center) + muscle.radius * (np.cos(t) * e1 + np.sin(t) * e2)
    return pv.Spline(ring, 64).tube(radius=muscle.radius / 12.0, n_sides=10)


class RingWidget(PlacementWidget):
    """The ring's disc in the muscles view (the handle for the centre, on the skin, comes
    from the parameter's declared surface).
    """

    def aoi_meshes(self, muscle):
        disc = pv.Disc(center=muscle.center, normal=muscle.axis, inner=0.0,
                       outer=muscle.radius, c_res=48)
        return {"aoi_disc": disc}
