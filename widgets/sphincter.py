"""The sphincter muscle's placement widget and glyph.

Imported only when a sphincter muscle is shown (``SphincterMuscle.widget`` and ``.glyph``
name them), so the muscle type itself needs no VTK. The widget has three handles on the skin:
the centre and the ends of the two semi-axes; it draws the ellipse (the AOI), the band's inner
ellipse and the sector's two rays (the wrinkling region) in the ellipse's plane.
"""

from __future__ import annotations

import numpy as np
import pyvista as pv

from wrinkle_vis.core.sphincter import SphincterMuscle

from .placement import PlacementWidget

__all__ = ["SphincterWidget", "sphincter_outline", "sphincter_glyph"]


def _ellipse_points(muscle: SphincterMuscle, rho: float, angles) -> np.ndarray:
    """``(k, 3)``: points of the ellipse of elliptic radius ``rho`` at elliptic ``angles``
    (radians from the a axis towards the b axis), in the muscle's plane.
    """
    a, b = muscle.semi_axes
    e1, e2, _ = muscle.frame
    t = np.asarray(angles, dtype=float)
    return (np.asarray(muscle.center) + np.outer(rho * a * np.cos(t), e1)
            + np.outer(rho * b * np.sin(t), e2))


def _polyline(points: np.ndarray, closed: bool = False) -> pv.PolyData:
    n = len(points)
    ids = list(range(n)) + ([0] if closed else [])
    return pv.PolyData(points, lines=np.array([len(ids), *ids]))


def sphincter_outline(muscle: SphincterMuscle, resolution: int = 96) -> dict[str, pv.PolyData]:
    """The muscle's shapes in its plane: ``"aoi_ellipse"`` (ρ = 1), and ``"region_band"``,
    the wrinkling region's outline (the inner ellipse ρ = λ_w and the ellipse, joined by the
    sector's two rays; the whole band when the sector is the full turn).
    """
    full = np.linspace(0.0, 2.0 * np.pi, resolution, endpoint=False)
    out = {"aoi_ellipse": _polyline(_ellipse_points(muscle, 1.0, full), closed=True)}
    theta_c, half = np.radians(muscle.sector_center_deg), np.radians(muscle.sector_deg)
    lam = muscle.lambda_w
    if muscle.sector_deg >= 180.0:
        inner = _polyline(_ellipse_points(muscle, lam, full), closed=True) if lam > 0 else None
        out["region_band"] = inner if inner is not None else pv.PolyData()
        return out
    k = max(8, int(resolution * muscle.sector_deg / 180.0))
    arc = np.linspace(theta_c - half, theta_c + half, k)
    outer = _ellipse_points(muscle, 1.0, arc)
    inner = _ellipse_points(muscle, lam, arc[::-1])
    out["region_band"] = _polyline(np.vstack([outer, inner]), closed=True)
    return out


def sphincter_glyph(muscle: SphincterMuscle) -> pv.PolyData:
    """The muscles view's glyph: a tube along the ellipse, through the band's middle
    (ρ = (1 + λ_w)/2), where the muscle's fibres run around its centre.
    """
    rho = 0.5 * (1.0 + muscle.lambda_w)
    t = np.linspace(0.0, 2.0 * np.pi, 97)
    ring = _polyline(_ellipse_points(muscle, rho, t))
    return ring.tube(radius=0.04 * min(muscle.semi_axes), n_sides=10)


class SphincterWidget(PlacementWidget):
    """Sphincter muscle: the centre and the ends of the two semi-axes, each a handle on
    the skin (their declared surface, :func:`~wrinkle_vis.widgets.placement.handles_for`);
    the ellipse (the AOI) and the wrinkling region's outline (band and sector) drawn in the
    muscles view. A new one comes from :meth:`SphincterMuscle.create`.
    """

    def aoi_meshes(self, muscle) -> dict[str, pv.PolyData]:
        """The ellipse and the outline of the wrinkling region, in the muscle's plane."""
        return sphincter_outline(muscle)
