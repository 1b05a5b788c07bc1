"""Loading real scans, building a skull under them, and moving a muscle layout onto them."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from wrinkle_vis.core import Layout, MeshError, TriangleSurface
from wrinkle_vis.core.editing import snapped

__all__ = ["LANDMARKS", "offset_skull", "orient_outward", "read_surface",
           "similarity_transform", "transfer_layout"]

#: The landmarks ``transfer_layout`` understands (L is the subject's left, +x).
LANDMARKS = ("nasion", "nose_tip", "chin", "eye_inner_L", "eye_inner_R", "eye_outer_L",
             "eye_outer_R", "mouth_corner_L", "mouth_corner_R")


def read_surface(path: str | os.PathLike, *, weld_tolerance: float = 0.0) -> TriangleSurface:
    """Read a triangle surface from OBJ, PLY, STL, VTP, VTK (PyVista) or what meshio reads.

    Polygons are triangulated, duplicate vertices (UV seams) welded, unused vertices dropped
    and coordinates checked, and the triangles are oriented consistently and outward
    (:func:`orient_outward`): a scan saved inside out, or with some triangles flipped, would
    otherwise put the skull outside the skin and push the wrinkles into the face.
    Boundaries and non-manifold edges are allowed; see ``surface.report()``.

    Raises
    ------
    FileNotFoundError
        If there is no such file.
    MeshError
        If the file holds no triangles or non-finite coordinates, or cannot be oriented
        consistently, naming the file.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no mesh file at {path}; check the path")
    points, faces = _read_any(path)
    try:
        surface = orient_outward(TriangleSurface(points, faces).welded(weld_tolerance)
                                 .cleaned())
    except MeshError as exc:
        raise MeshError(f"{path}: {exc}") from None
    return surface


def orient_outward(surface: TriangleSurface) -> TriangleSurface:
    """``surface`` with every connected component oriented consistently and outward.

    Each component is first made consistent (triangles flipped to agree with their
    neighbours across manifold edges, :meth:`TriangleSurface.oriented`), then turned
    outward: flipped when its signed volume about its own centroid is negative. For a
    closed component that is its enclosed volume; for an open scan (a face, a head open at
    the neck) it is the volume of the cone from the centroid, positive when the normals
    point away from the middle of the scan. A component too flat to tell (its volume below
    1e-9 of its bounding box's) keeps its orientation. An outward, consistent surface is
    returned as it is (the same object).

    Raises
    ------
    MeshError
        If a component cannot be oriented consistently (a non-orientable surface, such as a
        Moebius strip, or triangles that cross themselves), with the way out.
    """
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    rep = surface.report()
    if rep.consistently_oriented:
        oriented = surface
    else:
        oriented = surface.oriented()
        if not oriented.report().consistently_oriented:
            raise MeshError(
                "the triangles cannot be oriented consistently (a non-orientable or "
                "self-crossing surface); repair the mesh first, e.g. in MeshLab: Filters > "
                "Normals > Re-Orient all faces coherently")
    tris = oriented.triangles
    tri_edges = oriented.triangle_edges
    counts = np.bincount(tri_edges.ravel(), minlength=len(oriented.edges))
    slots = np.argsort(tri_edges.ravel(), kind="stable")
    edge_sorted = tri_edges.ravel()[slots]
    pair = (edge_sorted[:-1] == edge_sorted[1:]) & (counts[edge_sorted[:-1]] == 2)
    a, b = slots[:-1][pair] // 3, slots[1:][pair] // 3
    m = len(tris)
    graph = csr_matrix((np.ones(len(a)), (a, b)), shape=(m, m))
    n_comp, comp = connected_components(graph, directed=False)
    flip = np.zeros(n_comp, bool)
    for c in range(n_comp):
        t = tris[comp == c]
        pts = oriented.points[np.unique(t)]
        centre = pts.mean(axis=0)
        p = oriented.points - centre
        volume = float(np.einsum("ij,ij->", p[t[:, 0]], np.cross(p[t[:, 1]], p[t[:, 2]]))
                       / 6.0)
        extent = float(np.prod(np.maximum(np.ptp(pts, axis=0), 1e-300)))
        flip[c] = volume < -1e-9 * extent
    if not flip.any():
        return oriented
    out = tris.copy()
    turn = flip[comp]
    out[turn] = out[turn][:, ::-1]
    return TriangleSurface(oriented.points, out)


def _read_any(path: Path) -> tuple[np.ndarray, np.ndarray]:
    import pyvista as pv

    try:
        mesh = pv.read(path)
    except Exception as first:  # unknown to VTK: let meshio try
        try:
            import meshio

            m = meshio.read(path)
        except Exception as second:
            raise MeshError(f"{path}: neither VTK ({first}) nor meshio ({second}) can read "
                            "it; convert it to OBJ, PLY, STL or VTP") from None
        tris = [c.data for c in m.cells if c.type == "triangle"]
        tris += [_fan(c.data) for c in m.cells if c.type in ("quad", "polygon")]
        if not tris:
            raise MeshError(f"{path}: no triangles or polygons in the file") from None
        return np.asarray(m.points, float)[:, :3], np.concatenate(tris)
    mesh = mesh.extract_surface(algorithm="dataset_surface") if not isinstance(
        mesh, pv.PolyData) else mesh
    mesh = mesh.triangulate()
    if mesh.n_cells == 0:
        raise MeshError(f"{path}: no triangles or polygons in the file")
    faces = mesh.faces.reshape(-1, 4)[:, 1:]
    return np.asarray(mesh.points, float), faces


def _fan(polys: np.ndarray) -> np.ndarray:
    k = polys.shape[1]
    return np.concatenate([polys[:, [0, i, i + 1]] for i in range(1, k - 1)])


def similarity_transform(source, target) -> tuple[np.ndarray, float, np.ndarray]:
    r"""Least-squares similarity :math:`y = s R x + t` from ``(k, 3)`` source to target
    landmarks (Umeyama 1991), ``k >= 3``.

    Returns
    -------
    rotation : (3, 3) float
    scale : float
    translation : (3,) float
    """
    x, y = np.asarray(source, float), np.asarray(target, float)
    mx, my = x.mean(axis=0), y.mean(axis=0)
    xc, yc = x - mx, y - my
    u, sig, vt = np.linalg.svd(yc.T @ xc / len(x))
    d = np.ones(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        d[-1] = -1
    rot = u @ np.diag(d) @ vt
    scale = float((sig * d).sum() / (xc**2).sum(axis=1).mean())
    return rot, scale, my - scale * rot @ mx


def _shared_landmarks(source: dict, target: dict) -> list[str]:
    names = [n for n in source if n in target]
    if len(names) < 4:
        raise ValueError(
            f"transfer needs at least 4 landmarks named in both the layout and the target; "
            f"shared: {names or 'none'}. Known names: {', '.join(LANDMARKS)}")
    return names


def offset_skull(skin: TriangleSurface, depth) -> TriangleSurface:
    """A skull under ``skin``: its vertices moved inwards along the normals by ``depth``
    (a number, or ``(n,)`` per vertex, in the skin's units).
    """
    depth = np.broadcast_to(np.asarray(depth, float), (skin.n_points,))
    return TriangleSurface(skin.points - depth[:, None] * skin.vertex_normals(),
                           skin.triangles)


def regional_depth(skin: TriangleSurface, landmarks: dict) -> np.ndarray:
    """``(n,)``: the built-in face's regional tissue depth, mapped onto ``skin`` through
    the similarity that takes the built-in landmarks onto ``landmarks``.
    """
    from . import anatomy
    from .face import builtin_landmarks

    source = builtin_landmarks()
    names = _shared_landmarks(source, landmarks)
    rot, scale, shift = similarity_transform([source[n] for n in names],
                                             [landmarks[n] for n in names])
    in_builtin = (skin.points - shift) @ rot / scale
    return scale * anatomy.tissue_depth(in_builtin)


def transfer_layout(layout: Layout, target_skin: TriangleSurface, landmarks: dict,
                    target_skull: TriangleSurface | None = None) -> Layout:
    """Move a muscle layout onto another face from a handful of named landmarks.

    Parameters
    ----------
    layout : Layout
        The source layout; its ``landmarks`` name points on its own face.
    target_skin : TriangleSurface
        The target face's skin.
    landmarks : dict of str to (3,) array_like
        The same landmarks on the target (at least 4 shared names, see :data:`LANDMARKS`).
    target_skull : TriangleSurface, optional
        Where attachments go; default a skull offset from the target skin by the regional
        tissue depth (:func:`regional_depth`).

    Returns
    -------
    Layout
        Muscles mapped by the least-squares similarity of the landmarks, lengths scaled by
        its scale, each point projected onto the surface its parameter declares
        (:func:`~wrinkle_vis.core.editing.snapped`: insertions onto the target skin,
        attachments onto the target skull; a sheet's lines are only mapped: they set its
        frame, which neighbouring sheets share); the expressions unchanged; the target's landmarks.
    """
    names = _shared_landmarks(layout.landmarks, landmarks)
    rot, scale, shift = similarity_transform([layout.landmarks[n] for n in names],
                                             [landmarks[n] for n in names])
    if target_skull is None:
        target_skull = offset_skull(target_skin, regional_depth(target_skin, landmarks))
    surfaces = {"skin": target_skin, "skull": target_skull}
    muscles = [snapped(m.transformed(lambda p: scale * p @ rot.T + shift, scale), surfaces,
                       lines=False)  # a sheet's lines are its frame: moved, not projected
               for m in layout.muscles]
    return Layout(name=f"{layout.name} on {target_skin.n_points}-vertex skin",
                  muscles=tuple(muscles), expressions=layout.expressions,
                  landmarks={k: tuple(map(float, v)) for k, v in landmarks.items()})
