"""Small analytic meshes for the tests."""

from __future__ import annotations

import numpy as np

from wrinkle_vis import TriangleSurface, subdivide


def grid(nx: int = 31, ny: int = 31, size: float = 60.0, bump: float = 0.0) -> TriangleSurface:
    """A square of ``size`` in the xy plane, centred on the origin, facing +z.

    ``bump`` lifts it into a smooth dome ``z = bump * exp(-(x^2 + y^2) / size^2)``.
    """
    x, y = np.meshgrid(np.linspace(-size / 2, size / 2, nx), np.linspace(-size / 2, size / 2, ny))
    z = bump * np.exp(-(x**2 + y**2) / size**2)
    pts = np.c_[x.ravel(), y.ravel(), z.ravel()]
    idx = np.arange(nx * ny).reshape(ny, nx)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    return TriangleSurface(pts, np.r_[np.c_[a, b, c], np.c_[a, c, d]])


def sphere(levels: int = 3, radius: float = 1.0) -> TriangleSurface:
    """An outward-oriented sphere: a subdivided octahedron pushed onto the sphere."""
    pts = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    tri = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4],
                    [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    s = subdivide(TriangleSurface(pts, tri), levels)
    p = s.points / np.linalg.norm(s.points, axis=1)[:, None]
    return TriangleSurface(radius * p, s.triangles)


def rotation(seed: int) -> np.ndarray:
    """A random proper rotation matrix."""
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] *= -1
    return q


def assert_c1_along_random_lines(muscle, seed: int = 3, lines: int = 6) -> None:
    """The muscle's displacement has no slope jump along random lines through [-25, 25]^3:
    a kink shows as a spike of the second difference."""
    rng = np.random.default_rng(seed)
    for _ in range(lines):
        a, b = rng.uniform(-25, 25, 3), rng.uniform(-25, 25, 3)
        t = np.linspace(0, 1, 20001)
        d = muscle.displacement(a + t[:, None] * (b - a), 1.0)
        second = np.diff(d, 2, axis=0)
        assert np.abs(second).max() < 1e-5 * max(1.0, np.abs(d).max())
