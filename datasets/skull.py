r"""A closed skull under any scanned skin: a level set of the skin's signed distance.

The skull is the set of points at least the regional soft-tissue depth inside the skin,
under the face only:

.. math::

    F(x) = \max\bigl(d_\text{skin}(x) + t(x),\; r(x)\bigr), \qquad
    \text{skull} = \{x : F(x) = 0\},

with :math:`d_\text{skin}` the skin's signed distance (negative inside; VTK's
``vtkImplicitPolyDataDistance``, signed by the closest point's normal), :math:`t` the
built-in face's regional tissue depth (:func:`~wrinkle_vis.datasets.anatomy.tissue_depth`)
carried onto the scan by the similarity of the landmarks (and scaled by it), and :math:`r`
the signed distance to the region under the face, in the built-in frame: in front of the
ears (:math:`z \ge` :data:`EAR_PLANE_Z`) and above the neck (:math:`y \ge`
:data:`NECK_PLANE_Y`). Its zero set is extracted by VTK's flying edges on a grid of
:data:`SPACING_MM` (scaled), sampled exactly in a band around the surface
(:func:`~wrinkle_vis.datasets.face.sample_narrow_band`), and the largest component is kept.
Marching cubes gives a closed, manifold, self-intersection-free surface that lies on the
level set to within the grid's interpolation error, so the skull is the tissue depth (4.5 to
21 mm on an adult face) inside the skin, never a per-vertex offset that tears where the skin
folds (eyes, nostrils, lips, ears).
"""

from __future__ import annotations

import numpy as np

from wrinkle_vis.core import MeshError, TriangleSurface

__all__ = ["EAR_PLANE_Z", "NECK_PLANE_Y", "SPACING_MM", "scan_skull"]

#: The grid spacing of the level set, in the built-in face's millimetres (scaled onto a scan).
SPACING_MM = 2.0
#: The skull stops at this plane in front of the ears (built-in frame, mm; the built-in
#: eyes' centres lie at z = 68, the ear canals near z = -10).
EAR_PLANE_Z = 12.0
#: ... and at this plane above the neck (the built-in chin's underside is at y = -108).
NECK_PLANE_Y = -104.0


def _frame(landmarks):
    """The similarity ``(rot, scale, shift)`` from the built-in face onto the landmarks."""
    from .face import builtin_landmarks
    from .scans import _shared_landmarks, similarity_transform

    source = builtin_landmarks()
    names = _shared_landmarks(source, landmarks)
    return similarity_transform([source[n] for n in names], [landmarks[n] for n in names])


def _poly(surface: TriangleSurface):
    import pyvista as pv

    tris = np.asarray(surface.triangles)
    return pv.PolyData(np.asarray(surface.points, float),
                       np.c_[np.full(len(tris), 3), tris].ravel())


def skull_field(skin: TriangleSurface, landmarks=None):
    """The skull's field :math:`F` (module docstring) as a function of ``(n, 3)`` points,
    and the box it lives in, ``(field, lo, hi, spacing)``.

    Without landmarks there is no frame: the depth is 2.5 % of the skin's height everywhere
    and the whole inside of the skin counts.
    """
    import vtk

    from . import anatomy

    implicit = vtk.vtkImplicitPolyDataDistance()
    implicit.SetInput(_poly(skin))

    def distance(p):
        from vtk.util.numpy_support import numpy_to_vtk, vtk_to_numpy

        out = vtk.vtkDoubleArray()
        out.SetNumberOfTuples(len(p))
        implicit.FunctionValue(numpy_to_vtk(np.ascontiguousarray(p, float), deep=True), out)
        return vtk_to_numpy(out).copy()

    lo, hi = skin.bounds()
    if not landmarks:
        depth = 0.025 * float(hi[1] - lo[1])
        spacing = depth / 3.0

        def field(p):
            return distance(p) + depth

        pad = 2 * spacing
        return field, lo - pad, hi + pad, spacing
    rot, scale, shift = _frame(landmarks)

    def builtin(p):
        return (np.asarray(p, float) - shift) @ rot / scale

    def field(p):
        q = builtin(p)
        region = scale * np.maximum(EAR_PLANE_Z - q[:, 2], NECK_PLANE_Y - q[:, 1])
        return np.maximum(distance(p) + scale * anatomy.tissue_depth(q), region)

    spacing = SPACING_MM * scale
    inside = skin.points[(builtin(skin.points)[:, 2] > EAR_PLANE_Z)
                         & (builtin(skin.points)[:, 1] > NECK_PLANE_Y)]
    if len(inside) < 4:
        raise MeshError("no skin in front of the ears and above the neck; check that the "
                        "landmarks lie on this skin (nasion, eye corners, nose tip, ...)")
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
        skin and landmarks.

    Raises
    ------
    MeshError
        If the level set is empty (landmarks off the skin, a skin thinner than the tissue).
    """
    import pyvista as pv

    from .face import sample_narrow_band

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
