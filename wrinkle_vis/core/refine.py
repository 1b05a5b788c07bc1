"""Adaptive refinement of a triangle surface: 1-to-4 (red) splits closed by green bisections.

The paper refines "where surface curvature (measured from the vertex surface normals) of
influenced triangles is too large" by recursive quaternary subdivision (Sec. 3, Fig. 11).
Here a level splits every marked triangle 1-to-4 at its edge midpoints; a triangle two of
whose edges are split is split 1-to-4 too (repeated until stable), and a triangle with one
split edge is bisected from the opposite corner, so the result is conforming: no hanging
vertices, every interior edge shared by exactly two triangles.

New vertices do not sit on the straight midpoints of the split edges, which would keep the
coarse mesh's facets however often it is refined, but on the smooth surface through the old
vertices and their tangent planes (:func:`~wrinkle_vis.core.mesh.phong_midpoints`); each new
vertex carries the normal of that surface, so the next level is smooth too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .mesh import TriangleSurface, phong_midpoints
from .refined import bent

__all__ = ["Refinement", "bent_triangles", "refine_triangles"]


@dataclass(frozen=True)
class Refinement:
    """One refinement level.

    Attributes
    ----------
    surface : TriangleSurface
        The refined surface: the old vertices first, then one per split edge.
    parents : (k, 2) int
        The two old vertices of the edge each new vertex splits.
    normals : (n + k, 3) float
        Unit rest normals of every vertex of ``surface`` (the old ones as given).
    n_red, n_green : int
        Triangles split 1-to-4 and bisected.
    """

    surface: TriangleSurface
    parents: np.ndarray
    normals: np.ndarray
    n_red: int
    n_green: int


def refine_triangles(surface: TriangleSurface, marked, normals=None) -> Refinement:
    """Split the ``marked`` triangles 1-to-4 and close the refinement conformingly.

    Parameters
    ----------
    surface : TriangleSurface
        The surface (its ``points`` are the rest positions new vertices are made from).
    marked : (m,) bool or (k,) int
        Triangles to split.
    normals : (n, 3) float, optional
        Unit normals of the smooth surface at the vertices; default
        :meth:`TriangleSurface.vertex_normals`.

    Returns
    -------
    Refinement
        New vertices lie on the smooth surface at the middle of the split edges
        (:func:`~wrinkle_vis.core.mesh.phong_midpoints`), at rest.
    """
    tri, te, edges = surface.triangles, surface.triangle_edges, surface.edges
    mark = np.zeros(surface.n_triangles, bool)
    mark[np.asarray(marked)] = True
    split = np.zeros(len(edges), bool)
    split[te[mark].ravel()] = True
    while True:  # a triangle with two split edges becomes red: split its third too
        count = split[te].sum(axis=1)
        promote = count == 2
        if not promote.any():
            break
        split[te[promote].ravel()] = True
    count = split[te].sum(axis=1)
    n = surface.n_points
    new_id = np.full(len(edges), -1, np.int64)
    new_id[split] = n + np.arange(int(split.sum()))
    mid = new_id[te]  # (m, 3): new vertex on edges 01, 12, 20, or -1

    red = count == 3
    a, b, c = tri[red].T
    ab, bc, ca = mid[red].T
    red_children = np.concatenate([np.c_[a, ab, ca], np.c_[ab, b, bc], np.c_[ca, bc, c],
                                   np.c_[ab, bc, ca]])
    green = np.flatnonzero(count == 1)
    k = np.argmax(mid[green] >= 0, axis=1)  # which edge (k, k+1) is split
    vk = tri[green, k]
    vk1 = tri[green, (k + 1) % 3]
    vk2 = tri[green, (k + 2) % 3]
    m = mid[green, k]
    green_children = np.concatenate([np.c_[vk, m, vk2], np.c_[m, vk1, vk2]])
    keep = tri[count == 0]
    parents = edges[split]
    nrm = surface.vertex_normals() if normals is None else np.asarray(normals, dtype=float)
    mid, mid_normals = phong_midpoints(surface.points, nrm, parents)
    refined = TriangleSurface(np.vstack([surface.points, mid]),
                              np.concatenate([keep, red_children, green_children]))
    return Refinement(refined, parents, np.vstack([nrm, mid_normals]), int(red.sum()),
                      len(green))


def bent_triangles(surface: TriangleSurface, points: np.ndarray, angle_deg: float,
                   candidates=None) -> np.ndarray:
    """``(m,) bool``: triangles whose vertex normals at ``points`` differ by more than
    ``angle_deg`` (the largest angle between two of its three vertex normals).

    ``candidates`` ``(m,) bool`` restricts the test (to the influenced triangles). The
    refined frames' own test (:func:`wrinkle_vis.core.refined.bent`) on a surface.
    """
    if candidates is None:
        candidates = np.ones(surface.n_triangles, bool)
    return bent(surface.triangles, np.ascontiguousarray(np.asarray(points, float).T),
                angle_deg, np.asarray(candidates, bool))
