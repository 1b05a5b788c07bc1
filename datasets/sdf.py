"""Signed distance primitives and smooth booleans, vectorized over ``(n, 3)`` points, and
the level-set tools that turn a field into a surface: sampling it on a grid
(:func:`sample_narrow_band`), extracting its zero set (:func:`contour`), and moving points
onto that set (:func:`project_to_surface`, :func:`front_hit`).

Negative inside, positive outside. The ellipsoid distance is the usual first-order bound,
exact on the surface, which is all a level-set extraction needs.
"""

from __future__ import annotations

import numpy as np


def sphere(p: np.ndarray, center, radius: float) -> np.ndarray:
    """``(n,)``: distance to a sphere."""
    return np.linalg.norm(p - np.asarray(center, float), axis=1) - radius


def ellipsoid(p: np.ndarray, center, radii) -> np.ndarray:
    """``(n,)``: approximate signed distance to an axis-aligned ellipsoid."""
    r = np.asarray(radii, float)
    q = (p - np.asarray(center, float)) / r
    k0 = np.linalg.norm(q, axis=1)
    k1 = np.linalg.norm(q / r, axis=1)
    return np.where(k1 > 0, k0 * (k0 - 1.0) / np.where(k1 > 0, k1, 1.0), -r.min())


def capsule(p: np.ndarray, a, b, radius: float) -> np.ndarray:
    """``(n,)``: distance to the segment ``a b`` minus ``radius``."""
    a = np.asarray(a, float)
    ab = np.asarray(b, float) - a
    t = np.clip((p - a) @ ab / (ab @ ab), 0.0, 1.0)
    return np.linalg.norm(p - a - t[:, None] * ab, axis=1) - radius


def smooth_union(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    """Polynomial smooth minimum (blend width ``k``); never above ``min(a, b)``."""
    h = np.maximum(k - np.abs(a - b), 0.0) / k
    return np.minimum(a, b) - h * h * k * 0.25


def smooth_difference(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    """``a`` minus ``b`` with a blend of width ``k``; never below ``max(a, -b)``."""
    return -smooth_union(-a, b, k)


def mirrored(fn, p: np.ndarray, *args) -> np.ndarray:
    """``fn`` applied to ``p`` with ``|x|``: a feature and its left-right mirror at once."""
    q = p.copy()
    q[:, 0] = np.abs(q[:, 0])
    return fn(q, *args)


def project_to_surface(field, points: np.ndarray, steps: int = 4) -> np.ndarray:
    """``(n, 3)``: points moved onto the zero set of ``field`` by Newton steps."""
    p = np.array(points, dtype=float)
    eps = 1e-3
    for _ in range(steps):
        d = field(p)
        grad = np.stack([(field(p + e) - field(p - e)) / (2 * eps)
                         for e in np.eye(3) * eps], axis=1)
        p -= (d / np.maximum(np.einsum("ij,ij->i", grad, grad), 1e-12))[:, None] * grad
    return p


def project_in_plane(field, points: np.ndarray, axis: np.ndarray, value: np.ndarray,
                     steps: int = 6) -> np.ndarray:
    """``(n, 3)``: points put on the plane ``p[axis] = value`` (``axis`` and ``value``
    ``(n,)``, one plane per point) and moved within it onto the zero set of ``field`` by
    Newton steps along the gradient with its component across the plane removed: onto the
    curve where the plane meets the surface.
    """
    p = np.array(points, dtype=float)
    rows = np.arange(len(p))
    p[rows, axis] = value
    eps = 1e-3
    for _ in range(steps):
        d = field(p)
        grad = np.stack([(field(p + e) - field(p - e)) / (2 * eps)
                         for e in np.eye(3) * eps], axis=1)
        grad[rows, axis] = 0.0
        p -= (d / np.maximum(np.einsum("ij,ij->i", grad, grad), 1e-12))[:, None] * grad
    return p


def sample_narrow_band(field, lo, dims, spacing: float, coarse: int = 4) -> np.ndarray:
    """``dims``-shaped samples of ``field`` (x fastest), exact within a band around its zero
    set and trilinearly interpolated from a grid ``coarse`` times sparser elsewhere.

    Far from the surface only the sign matters to the contouring, and the coarse samples
    have the right sign there, so this gives the same surface at a fraction of the cost.
    """
    from scipy.ndimage import map_coordinates

    lo = np.asarray(lo, float)
    dims = np.asarray(dims)
    cdims = (dims - 1) // coarse + 2
    axes = [lo[i] + coarse * spacing * np.arange(cdims[i]) for i in range(3)]
    cz, cy, cx = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    cvals = field(np.c_[cx.ravel(), cy.ravel(), cz.ravel()]).reshape(cz.shape)
    fine = [np.arange(dims[i]) / coarse for i in (2, 1, 0)]
    fz, fy, fx = np.meshgrid(*fine, indexing="ij")
    values = map_coordinates(cvals, [fz.ravel(), fy.ravel(), fx.ravel()], order=1)
    band = np.abs(values) < 1.5 * coarse * spacing
    idx = np.flatnonzero(band)
    k, rest = np.divmod(idx, dims[0] * dims[1])
    j, i = np.divmod(rest, dims[0])
    pts = lo + spacing * np.c_[i, j, k]
    values[idx] = field(pts)
    return values


def contour(field, lo, hi, spacing: float):
    """The zero set of ``field`` in the box ``lo``..``hi`` (``(3,)`` each) on a grid of
    ``spacing``: VTK's flying edges on :func:`sample_narrow_band`'s samples (a PyVista
    ``PolyData``).
    """
    import pyvista as pv

    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    dims = np.ceil((hi - lo) / spacing).astype(int) + 1
    grid = pv.ImageData(dimensions=dims, spacing=(spacing,) * 3, origin=lo)
    grid.point_data["d"] = sample_narrow_band(field, lo, dims, spacing)
    return grid.contour([0.0], scalars="d", method="flying_edges")


def front_hit(field, x: float, y: float, z_start: float = 140.0) -> np.ndarray:
    """``(3,)``: the first point of ``field``'s zero set seen from the front at ``(x, y)``."""
    p = np.array([[x, y, z_start]])
    for _ in range(2000):
        d = float(field(p)[0])
        if abs(d) < 1e-4:
            return project_to_surface(field, p)[0]
        p[0, 2] -= max(d, 0.05) if d > 0 else d
        if p[0, 2] < -z_start:
            break
    raise ValueError(f"no surface in front of (x, y) = ({x:g}, {y:g}); move the point")
