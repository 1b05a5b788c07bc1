"""Loading real scans, building a skull under them, and moving a muscle layout onto them."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from wrinkle_vis.core import Layout, MeshError, TriangleSurface, load_layout
from wrinkle_vis.core.mesh import closest_points
from wrinkle_vis.core.units import face_unit_of

from .anatomy import BUILTIN_LAYOUT
from .landmarks import LANDMARKS, fit_landmarks, similarity_transform
from .skull import scan_skull

__all__ = ["LANDMARKS", "fit_landmarks", "orient_outward", "read_landmarks", "read_surface",
           "scan_layout", "similarity_transform", "transfer_layout"]

def read_surface(path: str | os.PathLike, *, weld_tolerance: float = 0.0) -> TriangleSurface:
    """Read a triangle surface from OBJ, PLY, STL, VTP, VTK (PyVista) or what meshio reads.

    Polygons are triangulated, duplicate vertices (UV seams) welded, unused vertices dropped
    and coordinates checked, and the triangles are oriented consistently and outward
    (:func:`orient_outward`): a scan saved inside out, or with some triangles flipped, would
    otherwise put the skull outside the skin and push the wrinkles into the face.
    Boundaries and non-manifold edges are allowed; see ``surface.report()``.

    The file is checked before a reader sees it
    (:func:`~wrinkle_vis.datasets.meshfile.check_mesh_file`: counts against its size, OBJ
    indices against their ranges), so a damaged or hostile file is refused in one line
    instead of crashing VTK, and VTK's own messages are kept off the terminal.

    Raises
    ------
    FileNotFoundError
        If there is no such file.
    MeshError
        If the path is not a regular file (a folder, a pipe, a device, a link loop: saying
        which), the file is damaged (counts it cannot hold, indices out of range) or holds no
        triangles or non-finite coordinates, or cannot be oriented consistently, naming the
        file.
    """
    from wrinkle_vis.core.files import input_problem

    from .meshfile import check_mesh_file

    path = Path(path)
    problem = input_problem(path)
    if problem == "no such file":
        raise FileNotFoundError(f"no mesh file at {path}; check the path")
    if problem is not None:
        raise MeshError(f"{path} {problem}; give a mesh file (OBJ, PLY, STL, VTP)")
    check_mesh_file(path)
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

    from .meshfile import quiet_vtk

    with quiet_vtk():
        try:
            mesh = pv.read(path)
        except Exception as first:  # unknown to VTK: let meshio try
            return _read_meshio(path, first)
        if getattr(mesh, "n_points", 1) == 0:
            raise MeshError(f"{path}: nothing readable in the file (damaged, or not a "
                            f"{path.suffix or 'mesh'} file); export it again (OBJ, PLY, STL "
                            "or VTP)")
        _check_connectivity(path, mesh)
        mesh = mesh.extract_surface(algorithm="dataset_surface") if not isinstance(
            mesh, pv.PolyData) else mesh
        mesh = mesh.triangulate()
    if mesh.n_cells == 0:
        raise MeshError(f"{path}: no triangles or polygons in the file")
    faces = mesh.faces.reshape(-1, 4)[:, 1:]
    return np.asarray(mesh.points, float), faces


def _read_meshio(path: Path, first: Exception) -> tuple[np.ndarray, np.ndarray]:
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
    points, faces = np.asarray(m.points, float)[:, :3], np.concatenate(tris)
    if faces.size and (faces.min() < 0 or faces.max() >= len(points)):
        raise MeshError(f"{path}: a cell names a point outside 0..{len(points) - 1}; the "
                        "file is damaged: export it again (OBJ, PLY, STL or VTP)")
    return points, faces


def _check_connectivity(path: Path, mesh) -> None:
    """Refuse cells naming points the mesh does not have, before a VTK filter follows them
    (out of range, VTK reads memory it does not own).
    """
    from vtkmodules.util.numpy_support import vtk_to_numpy

    getters = ("GetPolys", "GetStrips", "GetLines", "GetVerts", "GetCells")
    if not hasattr(mesh, "GetNumberOfPoints"):
        return
    n = mesh.GetNumberOfPoints()
    for getter in getters:
        cells = getattr(mesh, getter, lambda: None)()
        conn = None if cells is None else cells.GetConnectivityArray()
        if conn is None or conn.GetNumberOfTuples() == 0:
            continue
        ids = vtk_to_numpy(conn)
        lo, hi = int(ids.min()), int(ids.max())
        if lo < 0 or hi >= n:
            raise MeshError(f"{path}: a cell names point {hi if hi >= n else lo}, outside "
                            f"0..{n - 1}; the file is damaged: export it again (OBJ, PLY, "
                            "STL or VTP)")


def _fan(polys: np.ndarray) -> np.ndarray:
    k = polys.shape[1]
    return np.concatenate([polys[:, [0, i, i + 1]] for i in range(1, k - 1)])


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
        Where attachments go; default the level-set skull under the target skin
        (:func:`~wrinkle_vis.datasets.skull.scan_skull`).

    Returns
    -------
    Layout
        Muscles mapped by the least-squares similarity of the landmarks, lengths scaled by
        its scale, each point projected onto the surface its parameter declares
        (:meth:`~wrinkle_vis.core.muscle.Muscle.point_surfaces`: insertions onto the target
        skin, attachments onto the target skull; a sheet's lines are only mapped: they set
        its frame, which neighbouring sheets share; a linear muscle's radius keeps its ratio
        to the muscle's length); the expressions unchanged; the target's landmarks.
    """
    rot, scale, shift = fit_landmarks(layout.landmarks, landmarks)
    if target_skull is None:
        target_skull = scan_skull(target_skin, landmarks)
    surfaces = {"skin": target_skin, "skull": target_skull}
    muscles = []
    for m in layout.muscles:
        moved = m.transformed(lambda p: scale * p @ rot.T + shift, scale)
        changes = {}
        for param, where in moved.point_surfaces().items():
            arr = np.asarray(getattr(moved, param), float)
            if arr.ndim > 1:  # a sheet's lines are its frame: moved, not projected
                continue
            changes[param] = closest_points(surfaces[where], arr.reshape(-1, 3)).reshape(
                arr.shape)
        if {"attachment", "insertion"} <= set(changes) and hasattr(moved, "radius"):
            # keep the area of influence's reach beyond the insertion: radius / |m_I - m_A|
            before = np.linalg.norm(np.subtract(moved.insertion, moved.attachment))
            after = np.linalg.norm(changes["insertion"] - changes["attachment"])
            changes["radius"] = float(moved.radius) * float(after / before)
        muscles.append(moved.replace(**changes))
    return Layout(name=f"{layout.name} on {target_skin.n_points}-vertex skin",
                  muscles=tuple(muscles), expressions=layout.expressions,
                  landmarks={k: tuple(map(float, v)) for k, v in landmarks.items()},
                  mapping=layout.mapping)


def read_landmarks(path: str | os.PathLike) -> dict[str, tuple]:
    """Named landmarks from a JSON file: ``{"nasion": [x, y, z], ...}``, or a layout file
    (or any JSON object) with such an object under ``"landmarks"``.

    Raises
    ------
    FileNotFoundError
        If there is no such file.
    ValueError
        One line naming the file and what is wrong (not JSON, no landmarks, a bad point,
        fewer than 4 of :data:`LANDMARKS`).
    """
    import json

    from wrinkle_vis.core.layout import finite_number, read_json

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no landmarks file at {path}; check the path")
    data = read_json(path)  # one-line LayoutError (a ValueError): not JSON, too deep, ...
    if isinstance(data, dict) and isinstance(data.get("landmarks"), dict):
        data = data["landmarks"]
    if not isinstance(data, dict) or not data:
        raise ValueError(f'{path}: expected {{"nasion": [x, y, z], ...}} (or a layout with '
                         '"landmarks"); found no landmarks')
    out = {}
    for name, value in data.items():
        ok = isinstance(value, list) and len(value) == 3 and all(map(finite_number, value))
        if not ok:
            raise ValueError(f"{path}: landmark {name!r}: expected [x, y, z] of finite "
                             f"numbers; found {json.dumps(value)[:60]}")
        out[str(name)] = tuple(float(x) for x in value)
    known = [n for n in out if n in LANDMARKS]
    if len(known) < 4:
        raise ValueError(f"{path}: needs at least 4 of the landmarks {', '.join(LANDMARKS)}; "
                         f"found {', '.join(out)}")
    return out


def scan_layout(skin: str | os.PathLike, landmarks: dict, *,
                layout_path: str | os.PathLike | None = None, unit: str | None = None,
                name: str | None = None, layout: Layout | None = None) -> Layout:
    """The layout of a scan: ``layout`` (default the built-in one) moved onto the skin
    file ``skin`` from ``landmarks``, naming the file and the landmarks.

    Saved with :func:`~wrinkle_vis.core.layout.save_layout` at ``layout_path``, it is a
    whole face: ``load_face(layout=layout_path)`` reads the skin, rebuilds the same skull
    (:func:`~wrinkle_vis.datasets.skull.scan_skull`) and gives the same face, bit for bit.

    Parameters
    ----------
    skin : path
        The scan (any format :func:`read_surface` reads).
    landmarks : dict of str to (3,) array_like
        Named points on it (at least 4 of :data:`LANDMARKS`).
    layout_path : path, optional
        Where the layout will be saved: ``skin`` is recorded relative to its folder (with
        ``..`` where needed); without it, as an absolute path.
    unit : str, optional
        The scan's length unit; default guessed from its size
        (:func:`~wrinkle_vis.core.units.guess_unit`, with a warning).
    name : str, optional
        The layout's name; default the file's stem.
    layout : Layout, optional
        The muscles to move; default the built-in face's.
    """
    skin_path = Path(skin).resolve()
    surface = read_surface(skin_path)
    marks = {k: tuple(float(x) for x in v) for k, v in dict(landmarks).items()}
    unit = face_unit_of(surface, unit)
    source = layout if layout is not None else load_layout(BUILTIN_LAYOUT)
    moved = transfer_layout(source, surface, marks, scan_skull(surface, marks))
    where = str(skin_path)
    if layout_path is not None:
        where = os.path.relpath(skin_path, Path(layout_path).resolve().parent)
    return Layout(name=name or skin_path.stem, muscles=moved.muscles,
                  expressions=moved.expressions, skin=Path(where).as_posix(), skull=None,
                  landmarks=marks, unit=unit, mapping=moved.mapping)
