"""Signed distance primitives and smooth booleans, vectorized over ``(n, 3)`` points.

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
