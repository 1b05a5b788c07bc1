"""The built-in skin's cut edges are clean (issue 32): pyacvd's boundary vertices used to sit
up to 4 mm inside the cuts, each by another amount, so the neck cut was a saw.
"""

from __future__ import annotations

import numpy as np

from wrinkle_vis.datasets import anatomy
from wrinkle_vis.datasets.face import SKIN_CUTS, build_skin


def test_the_skin_boundary_lies_on_the_cuts_and_on_the_surface():
    skin = build_skin(4500)
    counts = np.bincount(skin.triangle_edges.ravel(), minlength=len(skin.edges))
    boundary = np.unique(skin.edges[counts == 1].ravel())
    p = skin.points[boundary]
    gaps = np.stack([np.abs(p[:, axis] - value) for axis, value in SKIN_CUTS], axis=1)
    assert gaps.min(axis=1).max() < 1e-6  # on a cut plane, every one
    assert np.abs(anatomy.skin_sdf(p)).max() < 1e-3  # and on the skin's surface
    neck = gaps[:, 1] < 1e-6
    assert neck.sum() >= 20  # the neck cut has its vertices, not only the back cut
    # nothing of the skin below the neck cut or behind the ears
    assert skin.points[:, 1].min() >= -112.0 - 1e-6
    assert skin.points[:, 2].min() >= -15.0 - 1e-6
    assert skin.n_triangles == 4500 and skin.report().ok
