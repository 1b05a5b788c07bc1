"""An example third-party muscle type for wrinkle-vis: a ring muscle.

A sphincter-like muscle (the paper's future work): skin inside a disc of ``radius`` around
``center`` in the plane normal to ``axis`` is pulled towards the centre, and wrinkles form
concentric rings between ``lambda_w * radius`` and ``radius``. It is discovered through the
entry-point group ``wrinkle_vis.muscles`` declared in this package's ``pyproject.toml``.

The whole type is this file: each parameter carries its metadata (:func:`parameter`), which
gives it its controls in the app's parameter panel, its checks and its documentation; its
glyph and placement widget are named by strings, so the type itself needs no VTK.
"""

from __future__ import annotations

from dataclasses import KW_ONLY, dataclass

import numpy as np

from wrinkle_vis import Muscle
from wrinkle_vis.core.mesh import closest_points
from wrinkle_vis.core.muscle import Geometry, parameter, waters_radial

__all__ = ["RingMuscle"]


@dataclass(frozen=True)
class RingMuscle(Muscle):
    """A ring muscle: ``l`` is the radial distance from ``center`` in the ring's plane."""

    type_name = "ring"
    widget = "wrinkle_vis_ring.widget:RingWidget"  # its own placement widget
    glyph = "wrinkle_vis_ring.widget:ring_glyph"  # and its own glyph

    center: tuple = parameter(kw_only=False, label="centre", symbol="c", unit="point",
                              shape=(3,), surface="skin", doc="the ring's centre")
    axis: tuple = parameter(kw_only=False, label="axis", symbol="a", unit="vector",
                            doc="the normal of the ring's plane")
    _: KW_ONLY
    radius: float = parameter(label="radius", symbol="r", unit="length", lo=0.0,
                              lo_open=True, step=1.0, doc="the ring's outer radius")
    depth: float = parameter(10.0, label="depth", symbol="t", unit="length", lo=0.0,
                             lo_open=True, step=1.0, doc="half thickness along the axis")
    lambda_w: float = parameter(0.3, label="lambda_w", symbol="λ_w", unit="1", lo=0.0,
                                hi=1.0, hi_open=True, step=0.05,
                                doc="where the rings start, as a fraction of the radius")
    n_wrinkles: int = parameter(2, label="n_w", symbol="n_w", unit="count", lo=1, step=1,
                                doc="the number of rings")
    strength: float = parameter(1.0, label="K", symbol="K", unit="length", lo=0.0, step=0.5,
                                doc="peak pull towards the centre, below radius / 2")

    def __post_init__(self):
        self._check_common()
        if not np.linalg.norm(self.axis) > 0:
            self._fail("axis", self.axis, "a non-zero vector")
        self._check("strength", 0.0, 0.5 * self.radius)

    @classmethod
    def create(cls, name, at, skin, skull=None):
        """A ring of radius 15 on the skin at ``at``, its axis the skin's normal there."""
        center = closest_points(skin, np.asarray(at, float)[None])[0]
        vertex = int(np.argmin(np.linalg.norm(skin.points - center, axis=1)))
        axis = skin.vertex_normals()[vertex]
        return cls(name, tuple(center), tuple(axis), radius=15.0, depth=10.0)

    @property
    def strength_value(self) -> float:
        return self.strength

    @property
    def wrinkle_length(self) -> float:
        return self.radius

    @property
    def attenuation_range(self) -> tuple[float, float]:
        return (self.radius, self.radius)

    def _geometry(self, points):
        axis = np.asarray(self.axis) / np.linalg.norm(self.axis)
        v = points - np.asarray(self.center)
        along = v @ axis
        radial = v - along[:, None] * axis
        dist = np.linalg.norm(radial, axis=1)
        lam = dist / self.radius
        in_aoi = (lam <= 1.0) & (np.abs(along) <= self.depth)
        direction = -radial / np.where(dist > 0, dist, 1.0)[:, None]
        return Geometry(l=dist, lam=lam, gamma=np.zeros(len(points)), coordinate=dist,
                        in_aoi=in_aoi, direction=direction, extra={"radial": dist})

    def _falloff(self, points, geometry):
        return waters_radial(geometry.l, 0.5 * self.radius, self.radius)
