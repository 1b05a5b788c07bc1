"""An example third-party muscle type for wrinkle-vis: a ring muscle.

A sphincter-like muscle (the paper's future work): skin inside a disc of ``radius`` around
``center`` in the plane normal to ``axis`` is pulled towards the centre, and wrinkles form
concentric rings between ``lambda_w * radius`` and ``radius``. It is discovered through the
entry-point group ``wrinkle_vis.muscles`` declared in this package's ``pyproject.toml``.
"""

from __future__ import annotations

from dataclasses import KW_ONLY, dataclass

import numpy as np

from wrinkle_vis import Muscle
from wrinkle_vis.core.muscle import Geometry, waters_radial

__all__ = ["RingMuscle"]


@dataclass(frozen=True)
class RingMuscle(Muscle):
    """A ring muscle: ``l`` is the radial distance from ``center`` in the ring's plane."""

    type_name = "ring"
    point_parameters = ("center",)
    widget = "wrinkle_vis_ring.widget:RingWidget"  # its own placement widget
    length_parameters = ("radius", "depth", "k0", "strength")

    center: tuple
    axis: tuple
    _: KW_ONLY
    radius: float
    depth: float = 10.0
    lambda_w: float = 0.3
    n_wrinkles: int = 2
    k0: float = 0.5
    alpha: float = 1.0
    strength: float = 1.0

    def __post_init__(self):
        self._check_common()
        self._check_point("center")
        axis = self._check_point("axis")
        if not np.linalg.norm(axis) > 0:
            self._fail("axis", self.axis, "a non-zero vector")
        self._check("radius", 0.0, lo_open=True)
        self._check("depth", 0.0, lo_open=True)
        self._check("strength", 0.0, 0.5 * self.radius)

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
