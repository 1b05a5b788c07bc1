"""Untangling a skin that passes through itself (datasets/eyelids.py), as the built-in head's
derivation does at its eyelids and an ear."""

import numpy as np
import pytest

from wrinkle_vis.core.certificate import intersecting_pairs
from wrinkle_vis.datasets.eyelids import untangle


def _looped_sheet(n_t: int, b: float = 1.5) -> tuple[np.ndarray, np.ndarray]:
    """A strip whose cross-section is a trochoid, x = t - b sin t, z = b (1 - cos t), for
    t in [-3, 3], with ``n_t`` samples, extruded along y: for b > 1 it loops, and passes
    through itself at x = 0 where its two branches meet at about 120 degrees."""
    t, y = np.meshgrid(np.linspace(-3.0, 3.0, n_t), np.linspace(0.0, 3.0, 6), indexing="ij")
    pts = np.column_stack([(t - b * np.sin(t)).ravel(), y.ravel(), (b * (1 - np.cos(t))).ravel()])
    i = (np.arange(n_t - 1)[:, None] * 6 + np.arange(5)[None, :]).ravel()
    tri = np.vstack([np.column_stack([i, i + 6, i + 1]), np.column_stack([i + 1, i + 6, i + 7])])
    return pts, tri


@pytest.mark.parametrize("n_t", (13, 25))
def test_untangle_unwinds_a_sheet_that_loops_through_itself(n_t):
    pts, tri = _looped_sheet(n_t)
    assert len(intersecting_pairs(pts, tri)) > 0
    out = untangle(pts, tri, float32=False)
    assert len(intersecting_pairs(out, tri)) == 0
    assert np.linalg.norm(out - pts, axis=1).max() < 2.5  # the loop is 3 across


def test_a_loop_that_meets_itself_on_flat_branches_needs_the_growing_region():
    # on the finer strip the crossing triangles lie on the flat branches, where an umbrella
    # step moves nothing: without the region growing, the steps never get anywhere (with
    # it, test_untangle_unwinds_a_sheet_that_loops_through_itself[25])
    pts, tri = _looped_sheet(25)
    with pytest.raises(RuntimeError, match="still crosses itself"):
        untangle(pts, tri, float32=False, patience=10**6, max_steps=30)


def test_untangle_leaves_a_clean_skin_as_it_is():
    pts, tri = _looped_sheet(13, b=0.8)  # no loop
    assert len(intersecting_pairs(pts, tri)) == 0
    np.testing.assert_array_equal(untangle(pts, tri, float32=False), pts)
    held = np.zeros(len(pts), bool)
    held[:6] = True  # asked to smooth only these: nothing else moves
    out = untangle(pts, tri, float32=False, hold=held, clearance=2)
    np.testing.assert_array_equal(out[~held], pts[~held])
    assert np.any(out[held] != pts[held])


def test_untangle_with_float32_returns_what_the_package_stores():
    pts, tri = _looped_sheet(13)
    out = untangle(pts, tri)
    np.testing.assert_array_equal(out, out.astype(np.float32).astype(float))
    assert len(intersecting_pairs(out, tri)) == 0
