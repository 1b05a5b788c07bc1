"""
A plug-in muscle type
=====================

Muscle types are plug-ins: a subclass of :class:`wrinkle_vis.Muscle`, registered under a
name, is found by every part of wrinkle-vis (the model, layout files, the app's widgets). A
package makes its type known by declaring it in the entry-point group
``wrinkle_vis.muscles`` (``wrinkle_vis_ring`` in the repository's ``tests/plugins`` is
such a package); this example, to run anywhere, defines its type here and registers it with
:func:`wrinkle_vis.register_muscle_type`. It is a ring muscle, sphincter-like, which pulls
the skin towards its centre and folds it into concentric rings. See :doc:`/plugins` for how
to write one.
"""

from dataclasses import KW_ONLY, dataclass

import numpy as np

import wrinkle_vis as wv
from wrinkle_vis.core.muscle import Geometry, parameter, waters_radial


@wv.register_muscle_type(name="example_ring", override=True)
@dataclass(frozen=True)
class RingMuscle(wv.Muscle):
    """A ring muscle: ``l`` is the radial distance from ``center`` in the ring's plane."""

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

    @property
    def strength_value(self) -> float:
        """The peak pull, in lengths."""
        return self.strength

    @property
    def wrinkle_length(self) -> float:
        """The length the rings span (Eq. 6's R)."""
        return self.radius

    @property
    def attenuation_range(self) -> tuple[float, float]:
        """No attenuation before the rim."""
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


print("muscle types:", ", ".join(wv.muscle_types()))
assert wv.get_muscle_type("example_ring") is RingMuscle  # found by its name

# %%
# A ring around the mouth (an orbicularis oris of sorts), added to the built-in face.
face = wv.datasets.load_face()
left, right = (np.asarray(face.landmarks[k]) for k in ("mouth_corner_L", "mouth_corner_R"))
center = 0.5 * (left + right)
radius = 0.8 * float(np.linalg.norm(left - right))
ring = RingMuscle("orbicularis_ring", center=tuple(center), axis=(0.0, 0.0, 1.0),
                  radius=radius, depth=15.0, lambda_w=0.1, n_wrinkles=3, k0=1.5, alpha=1.0,
                  strength=0.35 * radius)
face = face.with_muscle(ring)
state = face.evaluate({"orbicularis_ring": 1.0})
print(f"W != 0 at {np.count_nonzero(state.W)} vertices, |W| <= {np.abs(state.W).max():.2f} mm")

# %%
# Its wrinkles, refined: W, then plain skin.
face.plot({"orbicularis_ring": 1.0}, "W", refine=True, camera="front")

# %%
face.plot({"orbicularis_ring": 1.0}, None, refine=True, camera="front")

# %%
# Its fields are the same as any muscle's: here the compression.
state.plot("eps", "orbicularis_ring", camera="front")
