"""The ring muscle's placement widget: its centre slides on the skin, its disc is drawn.

Imported only when the app shows a ring muscle (``RingMuscle.widget`` names it), so the
muscle type itself needs no VTK.
"""

from __future__ import annotations

import numpy as np
import pyvista as pv

from wrinkle_vis.core.mesh import closest_points
from wrinkle_vis.widgets import Handle, PlacementWidget

__all__ = ["RingWidget"]


class RingWidget(PlacementWidget):
    """A handle for the centre (on the skin) and the ring's disc in the muscles view."""

    @classmethod
    def handles(cls, muscle):
        return (Handle("center", None, "skin"),)

    @classmethod
    def create(cls, muscle_type, name, face, at):
        center = closest_points(face.skin, np.asarray(at, float)[None])[0]
        vertex = int(np.argmin(np.linalg.norm(face.skin.points - center, axis=1)))
        axis = face.skin.vertex_normals()[vertex]
        return muscle_type(name, tuple(center), tuple(axis), radius=15.0, depth=10.0)

    def aoi_meshes(self, muscle):
        disc = pv.Disc(center=muscle.center, normal=muscle.axis, inner=0.0,
                       outer=muscle.radius, c_res=48)
        return {"aoi_disc": disc}
