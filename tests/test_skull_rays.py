"""The skull's cavity test (datasets/skull.py, issue 33 M12) casts its rays against a finer
cell locator than VTK's default: the same answers as the code before, which used VTK's
default buckets."""

from __future__ import annotations

import numpy as np
import pytest
import vtk
from hypothesis import given, settings
from hypothesis import strategies as st
from meshes import grid, sphere

from wrinkle_vis import TriangleSurface
from wrinkle_vis.core.mesh import tangent_bases, unit_rows
from wrinkle_vis.datasets.skull import _segment_hits, exterior
from wrinkle_vis.plotting import to_surface_polydata


def _vtk_hits(surface: TriangleSurface, start, end) -> np.ndarray:
    """One ``vtkStaticCellLocator.IntersectWithLine`` call a segment, VTK's default buckets
    (the old code)."""
    locator = vtk.vtkStaticCellLocator()
    locator.SetDataSet(to_surface_polydata(surface))
    locator.BuildLocator()
    t, x, pc, sub, cell = vtk.mutable(0.0), [0.0] * 3, [0.0] * 3, vtk.mutable(0), vtk.mutable(0)
    return np.array([bool(locator.IntersectWithLine(a, b, 0.0, t, x, pc, sub, cell))
                     for a, b in zip(start, end, strict=True)])


def _vtk_exterior(skin: TriangleSurface) -> TriangleSurface:
    """:func:`exterior` as it was: a locator call per triangle and direction."""
    tri = skin.triangles
    centre = skin.points[tri].mean(axis=1)
    normal = unit_rows(skin.face_normals())
    u, v = tangent_bases(normal)
    size = float(np.linalg.norm(np.ptp(skin.points, axis=0)))
    shut = np.isfinite(normal).all(axis=1)
    for d in (normal, *[unit_rows(normal + s * w) for w in (u, v) for s in (1.0, -1.0)]):
        ids = np.flatnonzero(shut)
        shut[ids] = _vtk_hits(skin, centre[ids] + 1e-4 * size * d[ids],
                              centre[ids] + size * d[ids])
    return TriangleSurface(skin.points, tri[~shut]).without_unused()


def _bagged_ball() -> TriangleSurface:
    """A ball with a smaller ball inside it (a cavity no ray leaves) and a dented cap (a
    pocket some rays leave)."""
    outer, inner = sphere(3, 50.0), sphere(2, 20.0)
    p = outer.points.copy()
    cap = p[:, 2] > 35.0
    p[cap, 2] = 70.0 - p[cap, 2]  # pushed in: a pocket open to +z
    rng = np.random.default_rng(1)
    q = inner.points + rng.normal(scale=0.5, size=inner.points.shape)
    return TriangleSurface(np.r_[p, q], np.r_[outer.triangles, inner.triangles + len(p)])


@pytest.mark.parametrize("make", [_bagged_ball, lambda: grid(15, 15, 60.0, bump=20.0)])
def test_exterior_keeps_the_triangles_the_per_ray_vtk_code_kept(make):
    skin = make()
    got, old = exterior(skin), _vtk_exterior(skin)
    assert np.array_equal(got.points, old.points)
    assert np.array_equal(got.triangles, old.triangles)
    if make is _bagged_ball:  # the inner ball is gone, the outer one is not
        assert 0 < got.n_triangles < sphere(3).n_triangles + 1


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_tri=st.integers(1, 60),
       per_bucket=st.integers(1, 12))
def test_segment_hits_match_vtks_default_locator_on_random_soups(seed, n_tri, per_bucket):
    """Random triangles and segments in a unit box (some along an axis): the finer
    locator finds every segment the default one finds, and no other."""
    rng = np.random.default_rng(seed)
    corners = rng.uniform(-1, 1, size=(n_tri, 3, 3))
    surface = TriangleSurface(corners.reshape(-1, 3), np.arange(3 * n_tri).reshape(-1, 3))
    start = rng.uniform(-1.5, 1.5, size=(200, 3))
    end = start + rng.normal(size=(200, 3)) * rng.uniform(0.01, 3.0, size=(200, 1))
    end[:30] = start[:30] + 2.0 * np.eye(3)[rng.integers(0, 3, 30)]  # along an axis
    got = _segment_hits(surface, per_bucket)(start, end)
    assert np.array_equal(got, _vtk_hits(surface, start, end))
