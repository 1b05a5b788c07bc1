r"""A closed skull under any scanned skin: a level set of the skin's signed distance.

The skull is the set of points at least the regional soft-tissue depth inside the skin,
under the face only:

.. math::

    F(x) = \max\bigl(d_\text{skin}(x) + t(x),\; r(x)\bigr), \qquad
    \text{skull} = \{x : F(x) = 0\},

with :math:`d_\text{skin}` the signed distance to the skin's outer surface (negative
inside; VTK's ``vtkImplicitPolyDataDistance``, signed by the closest point's normal; the
triangles of cavities such as a mouth bag or eye sockets, from which no ray escapes, are left
out, :func:`exterior`), :math:`t` the
built-in face's regional tissue depth (:func:`~wrinkle_vis.datasets.anatomy.tissue_depth`)
carried onto the scan by the similarity of the landmarks (and scaled by it), and :math:`r`
the signed distance to the region under the face, in the built-in frame: in front of the
ears (:math:`z \ge` :data:`EAR_PLANE_Z`) and above the neck (:math:`y \ge`
:data:`NECK_PLANE_Y`). Its zero set is extracted by VTK's flying edges on a grid of
:data:`SPACING_MM` (scaled), sampled exactly in a band around the surface
(:func:`~wrinkle_vis.datasets.sdf.sample_narrow_band`), and the largest component is kept.
Marching cubes gives a closed, manifold, self-intersection-free surface that lies on the
level set to within the grid's interpolation error, so the skull is the tissue depth (4.5 to
21 mm on an adult face) inside the skin, never a per-vertex offset that tears where the skin
folds (eyes, nostrils, lips, ears).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from wrinkle_vis.core import MeshError, TriangleSurface

from ._cache import cached
from .landmarks import builtin_landmarks, fit_landmarks
from .sdf import sample_narrow_band

__all__ = ["EAR_PLANE_Z", "NECK_PLANE_Y", "SPACING_MM", "exterior", "scan_skull",
           "skull_field"]

#: The grid spacing of the level set, in the built-in face's millimetres (scaled onto a scan).
SPACING_MM = 2.5
#: The skull stops at this plane in front of the ears (built-in frame, mm; the built-in
#: eyes' centres lie at z = 68, the ear canals near z = -10).
EAR_PLANE_Z = 12.0
#: ... and at this plane above the neck (the built-in chin's underside is at y = -108).
NECK_PLANE_Y = -104.0


def _frame(landmarks):
    """The similarity ``(rot, scale, shift)`` from the built-in face onto the landmarks."""
    return fit_landmarks(builtin_landmarks(), landmarks)


def _poly(surface: TriangleSurface):
    import pyvista as pv

    tris = np.asarray(surface.triangles)
    return pv.PolyData(np.asarray(surface.points, float),
                       np.c_[np.full(len(tris), 3), tris].ravel())


def exterior(skin: TriangleSurface, candidates=None) -> TriangleSurface:
    """``skin`` without the triangles inside its cavities (a mouth bag, eye sockets,
    nostrils, ear canals): those from which no ray escapes.

    A triangle is kept when a ray from its centre along its outward normal, or along one
    of four rays tilted 45 degrees from it, meets no other triangle within the skin's size
    (:func:`_segment_hits`). ``candidates`` (``(m,)`` bool) limits the test to some
    triangles; the others are kept.
    """
    from wrinkle_vis.core.mesh import tangent_bases, unit_rows

    tri = np.asarray(skin.triangles)
    centre = skin.points[tri].mean(axis=1)
    normal = unit_rows(skin.face_normals())
    u, v = tangent_bases(normal)
    size = float(np.linalg.norm(np.ptp(skin.points, axis=0)))
    hits = _segment_hits(skin)
    shut = np.ones(len(tri), bool) if candidates is None else np.asarray(candidates, bool)
    shut = shut & np.isfinite(normal).all(axis=1)
    for d in (normal, *[unit_rows(normal + s * w) for w in (u, v) for s in (1.0, -1.0)]):
        ids = np.flatnonzero(shut)
        shut[ids] = hits(centre[ids] + 1e-4 * size * d[ids], centre[ids] + size * d[ids])
    return TriangleSurface(skin.points, tri[~shut]).without_unused()


def _segment_hits(surface: TriangleSurface, cells_per_bucket: int = 1):
    """Whether segments meet ``surface``, as a function of their ends ``start``, ``end``
    ``(k, 3)`` that returns ``(k,)`` bool: VTK's static cell locator (``IntersectWithLine``,
    no tolerance) with ``cells_per_bucket`` triangles a bucket on average, not VTK's ten: a
    ray then tests about half the triangles (the answers do not depend on the buckets).
    """
    import vtk

    locator = vtk.vtkStaticCellLocator()
    locator.SetDataSet(_poly(surface))
    locator.SetNumberOfCellsPerNode(cells_per_bucket)
    locator.SetMaxNumberOfBuckets(max(surface.n_triangles, 1))
    locator.BuildLocator()
    t, x, pc = vtk.mutable(0.0), [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
    sub, cell = vtk.mutable(0), vtk.mutable(0)
    meets = locator.IntersectWithLine

    def hits(start: np.ndarray, end: np.ndarray) -> np.ndarray:
        return np.array([bool(meets(a, b, 0.0, t, x, pc, sub, cell))
                         for a, b in zip(start.tolist(), end.tolist(), strict=True)], bool)

    return hits


def _evaluator(surface: TriangleSurface):
    """VTK's signed distance to ``surface`` as a function of ``(n, 3)`` points."""
    import vtk
    from vtk.util.numpy_support import numpy_to_vtk, vtk_to_numpy

    function = vtk.vtkImplicitPolyDataDistance()
    function.SetInput(_poly(surface))

    def evaluate(p):
        out = vtk.vtkDoubleArray()
        out.SetNumberOfTuples(len(p))
        function.FunctionValue(numpy_to_vtk(np.ascontiguousarray(p, float), deep=True), out)
        return vtk_to_numpy(out).copy()

    return evaluate


def _cavities(whole, lo, hi, cell):
    """``(cavity, corner)``: a voxel grid (``cell`` apart, from ``corner``) marking the
    voxels enclosed by the skin but outside its tissue (a mouth bag, eye sockets), after a
    closing by one voxel seals slits narrower than that (parted lips).
    """
    from scipy.ndimage import binary_closing, binary_fill_holes

    corner = np.asarray(lo, float) - cell
    dims = np.ceil((np.asarray(hi) - corner) / cell).astype(int) + 2
    axes = [corner[i] + cell * np.arange(dims[i]) for i in range(3)]
    gx, gy, gz = np.meshgrid(*axes, indexing="ij")
    solid = whole(np.c_[gx.ravel(), gy.ravel(), gz.ravel()]).reshape(gx.shape) < 0
    sealed = binary_closing(solid, np.ones((3, 3, 3), bool), border_value=0)  # lips' slit
    return binary_fill_holes(sealed | solid) & ~solid, corner


def _outer_distance(skin, candidates, lo, hi, cell):
    r"""The distance to the skin's outer surface (:func:`exterior`), negative inside: in
    the tissue (VTK's sign for the outer surface or for the whole skin) or in a cavity
    (:func:`_cavities` on a grid of ``cell`` over the box ``lo``..``hi``, trusted deeper
    than a voxel from the outer surface).
    """
    whole = _evaluator(skin)
    outer = _evaluator(exterior(skin, candidates))
    cavity, corner = _cavities(whole, lo, hi, cell)
    top = np.array(cavity.shape) - 1

    def distance(p):
        d = outer(p)
        idx = np.clip(np.rint((p - corner) / cell).astype(int), 0, top)
        enclosed = cavity[idx[:, 0], idx[:, 1], idx[:, 2]] & (np.abs(d) > cell)
        inside = (d < 0) | enclosed
        rest = ~inside
        inside[rest] = whole(p[rest]) < 0
        return np.where(inside, -np.abs(d), np.abs(d))

    return distance


def skull_field(skin: TriangleSurface, landmarks=None):
    """The skull's field :math:`F` (module docstring) as a function of ``(n, 3)`` points,
    and the box it lives in, ``(field, lo, hi, spacing)``.

    Without landmarks there is no frame: the depth is 2.5 % of the skin's height everywhere
    and the whole inside of the skin counts.
    """
    from . import anatomy

    lo, hi = skin.bounds()
    if not landmarks:
        depth = 0.025 * float(hi[1] - lo[1])
        spacing = depth / 2.0
        distance = _outer_distance(skin, None, lo, hi, 2 * spacing)

        def field(p):
            return distance(p) + depth

        pad = 2 * spacing
        return field, lo - pad, hi + pad, spacing
    rot, scale, shift = _frame(landmarks)

    def builtin(p):
        return (np.asarray(p, float) - shift) @ rot / scale

    spacing = SPACING_MM * scale
    q = builtin(skin.points)
    inside = skin.points[(q[:, 2] > EAR_PLANE_Z) & (q[:, 1] > NECK_PLANE_Y)]
    if len(inside) < 4:
        raise MeshError("no skin in front of the ears and above the neck; check that the "
                        "landmarks lie on this skin (nasion, eye corners, nose tip, ...)")
    near = (q[:, 2] > EAR_PLANE_Z - 30.0) & (q[:, 1] > NECK_PLANE_Y - 30.0)
    distance = _outer_distance(skin, near[skin.triangles].any(axis=1), lo, hi, 4 * spacing)

    def field(p):
        q = builtin(p)
        region = scale * np.maximum(EAR_PLANE_Z - q[:, 2], NECK_PLANE_Y - q[:, 1])
        return np.maximum(distance(p) + scale * anatomy.tissue_depth(q), region)

    pad = 3 * spacing
    return field, inside.min(axis=0) - pad, inside.max(axis=0) + pad, spacing


def scan_skull(skin: TriangleSurface, landmarks=None) -> TriangleSurface:
    """A closed, manifold skull under ``skin`` (module docstring).

    Parameters
    ----------
    skin : TriangleSurface
        The skin, oriented outward (:func:`~wrinkle_vis.datasets.scans.orient_outward`);
        open scans (a head open at the neck, a bust open at its base) are fine.
    landmarks : dict of str to (3,) array_like, optional
        Named points on the skin (:data:`~wrinkle_vis.datasets.scans.LANDMARKS`), which set
        the tissue depth and the region under the face. Without them: the whole inside of
        the skin at 2.5 % of its height.

    Returns
    -------
    TriangleSurface
        Closed (no boundary edges), manifold, outward-oriented; deterministic for the same
        skin and landmarks, and cached on disk under a key of both (and of this code), like
        the procedural face (``$WRINKLE_VIS_CACHE``), so a scan's face reopens in a moment.

    Raises
    ------
    MeshError
        If the level set is empty (landmarks off the skin, a skin thinner than the tissue).
    """
    import hashlib

    digest = hashlib.sha256(Path(__file__).read_bytes())
    digest.update(Path(__file__).with_name("landmarks.py").read_bytes())  # the similarity
    digest.update(np.ascontiguousarray(skin.points, float).tobytes())
    digest.update(np.ascontiguousarray(skin.triangles, np.int64).tobytes())
    marks = sorted((str(k), tuple(map(float, v))) for k, v in dict(landmarks or {}).items())
    digest.update(repr(marks).encode())

    def build():
        surf = _build_skull(skin, landmarks)
        return {"points": surf.points, "triangles": surf.triangles}

    arrays = cached("scan-skull", (digest.hexdigest(),), build)
    return TriangleSurface(arrays["points"], arrays["triangles"])


def _build_skull(skin: TriangleSurface, landmarks) -> TriangleSurface:
    """:func:`scan_skull` without its cache."""
    import pyvista as pv

    field, lo, hi, spacing = skull_field(skin, landmarks)
    dims = np.ceil((hi - lo) / spacing).astype(int) + 1
    values = sample_narrow_band(field, lo, dims, spacing)
    # the box's faces are outside: the level set closes inside the grid
    values = values.reshape(dims[::-1])
    values[[0, -1], :, :] = values[:, [0, -1], :] = np.inf
    values[:, :, [0, -1]] = np.inf
    values = np.minimum(values.ravel(), 1e6 * spacing)
    values[values == 0.0] = 1e-9 * spacing  # no grid vertex on the level set itself
    grid = pv.ImageData(dimensions=dims, spacing=(spacing,) * 3, origin=lo)
    grid.point_data["F"] = values
    raw = grid.contour([0.0], scalars="F", method="flying_edges")
    if raw.n_cells == 0:
        raise MeshError("no skull fits inside this skin: the tissue depth is thicker than "
                        "the head; check the landmarks and the skin's unit")
    faces = raw.faces.reshape(-1, 4)[:, 1:]
    surf = TriangleSurface(np.asarray(raw.points, float), faces).largest_component()
    surf = surf.without_unused()
    if surf.signed_volume() < 0:
        surf = TriangleSurface(surf.points, surf.triangles[:, ::-1])
    return surf
