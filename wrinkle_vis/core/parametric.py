r"""Where a refined skin lies on the skin it refines: root triangles and barycentrics.

Adaptive refinement (:mod:`wrinkle_vis.core.refined`) splits the skin's triangles at their
edges' midpoints, level by level, and closes the result with a few more triangles; every
triangle of a refined frame lies inside one triangle of the unrefined (root) skin. In that
triangle's parameter space a midpoint is the mean of its edge's ends,

.. math:: b(m_{pq}) = \tfrac12 \left(b(p) + b(q)\right),

so every refined vertex has barycentric coordinates in a root triangle, and every corner of
a refined triangle has them in the root triangle that holds the whole triangle (one per
side of a root edge, as per-corner data such as UVs need).
"""

from __future__ import annotations

import numpy as np

__all__ = ["refined_root_coordinates"]


def _convert(src_ids: np.ndarray, src_bary: np.ndarray, dst_ids: np.ndarray) -> np.ndarray:
    """``(k, 3)``: barycentrics over the vertices ``src_ids`` ``(k, 3)`` re-expressed over
    ``dst_ids`` ``(k, 3)`` (weights on vertices ``dst_ids`` lacks are dropped).
    """
    match = src_ids[:, :, None] == dst_ids[:, None, :]
    return np.einsum("ki,kij->kj", src_bary, match)


def _vertex_coordinates(hier) -> tuple[np.ndarray, np.ndarray]:
    """For every vertex of the hierarchy: a root triangle that holds it and its
    barycentric coordinates there, ``(v,)`` and ``(v, 3)``.
    """
    t0 = hier.skin.n_triangles
    root_tris = hier.node_tri[:t0]
    n = len(hier.rest)
    vroot = np.full(n, -1, np.int64)
    vbary = np.zeros((n, 3))
    vroot[root_tris.ravel()] = np.repeat(np.arange(t0), 3)
    ids = np.flatnonzero(vroot >= 0)
    vbary[ids] = (root_tris[vroot[ids]] == ids[:, None]).astype(float)
    parents = np.flatnonzero(hier.node_mid[:, 0] >= 0)
    levels = hier.node_level[parents]
    for level in np.unique(levels):  # a level's corners come from the levels above it
        nodes = parents[levels == level]
        corners, mids = hier.node_tri[nodes], hier.node_mid[nodes]
        root = hier.node_root[nodes]
        dst = root_tris[root]
        b = np.stack([_convert(root_tris[vroot[corners[:, j]]], vbary[corners[:, j]], dst)
                      for j in range(3)], axis=1)  # (k, 3 corners, 3)
        for j, (p, q) in enumerate(((0, 1), (1, 2), (2, 0))):
            vroot[mids[:, j]] = root
            vbary[mids[:, j]] = 0.5 * (b[:, p] + b[:, q])
    return vroot, vbary


def _engine_of(face, refined_face):
    for engine in face._rest._engines.values():
        last = engine.last
        if last is not None and last[1] is refined_face:
            return engine.hier, last[2]
    raise ValueError("the state is not the latest refined frame of this face; evaluate it "
                     "again with refine=True and ask at once")


def refined_root_coordinates(face, state) -> tuple[np.ndarray, np.ndarray]:
    """Where the triangles of ``state``'s refined skin lie on ``face``'s skin.

    Parameters
    ----------
    face : FaceModel
        The unrefined face.
    state : FaceState
        Its latest refined frame (``face.evaluate(..., refine=True)``), or an unrefined
        one (each triangle is then its own root).

    Returns
    -------
    root : (m,) int
        For every triangle of ``state.face.skin``, the triangle of ``face.skin`` it lies in.
    bary : (m, 3, 3) float
        The barycentric coordinates of its three corners in that root triangle (rows sum
        to 1): ``bary[k] @ face.skin.points[face.skin.triangles[root[k]]]`` are the corners
        on the flat root triangle, and the same weights interpolate any per-corner data of
        the root skin, UVs across seams included.

    Raises
    ------
    ValueError
        If ``state`` is a refined frame other than the latest of ``face``.
    """
    tris = np.asarray(state.face.skin.triangles)
    if state.face.skin is face.skin:
        return np.arange(len(tris)), np.broadcast_to(np.eye(3), (len(tris), 3, 3)).copy()
    hier, order = _engine_of(face, state.face)
    vroot, vbary = _vertex_coordinates(hier)
    root_tris = np.asarray(face.skin.triangles)
    corners = np.asarray(order)[tris]  # (m, 3) hierarchy vertices
    ids = root_tris[vroot[corners]]  # (m, 3 corners, 3) root vertices
    support = np.where(vbary[corners] > 1e-12, ids, -1).reshape(len(tris), 9)
    support.sort(axis=1)
    new = np.ones_like(support, bool)
    new[:, 1:] = support[:, 1:] != support[:, :-1]
    new &= support >= 0
    if not (new.sum(axis=1) == 3).all():
        raise ValueError("a refined triangle does not lie in one root triangle")
    triple = support[new].reshape(-1, 3)  # sorted root vertices of each holding triangle
    base = int(root_tris.max()) + 1
    keys = np.sort(root_tris, axis=1) @ np.array([base * base, base, 1])
    sort = np.argsort(keys)
    want = triple @ np.array([base * base, base, 1])
    at = np.clip(np.searchsorted(keys, want, sorter=sort), 0, len(keys) - 1)
    root = sort[at]
    if not (keys[root] == want).all():
        raise ValueError("a refined triangle's corners are not those of one root triangle")
    dst = root_tris[root]
    bary = np.stack([_convert(ids[:, j], vbary[corners[:, j]], dst) for j in range(3)], axis=1)
    return root, bary
