"""The built-in anatomy-based face: skin, skull and muscle layout, made procedurally."""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np

from wrinkle_vis.core import (
    Expression,
    FaceModel,
    Layout,
    LinearMuscle,
    SheetMuscle,
    TriangleSurface,
    load_layout,
    paper_expressions,
)
from wrinkle_vis.core.editing import mirrored, snapped
from wrinkle_vis.core.sphincter import SphincterMuscle
from wrinkle_vis.core.units import face_unit_of

from . import anatomy
from ._cache import cached
from .anatomy import BUILTIN_LAYOUT
from .landmarks import builtin_landmarks
from .lee_perry_smith import load_lee_perry_smith
from .scans import orient_outward, read_surface, transfer_layout
from .sdf import contour, front_hit, project_in_plane, project_to_surface
from .skull import scan_skull

__all__ = ["BUILTIN_LAYOUT", "FACES", "build_skin", "build_skull", "builtin_expressions",
           "builtin_landmarks", "builtin_layout", "builtin_muscles", "load_face"]

DEFAULT_TRIANGLES = 4500
#: The built-in skin's supported resolutions (``n_triangles`` of :func:`load_face`).
MIN_TRIANGLES, MAX_TRIANGLES = 500, 250_000


#: Where the built-in skin is meshed finer: ``(centre, radii, fade, factor)``. Inside the
#: ellipsoid ``centre``, ``radii`` (mm) round the lips pyacvd's clusters are ``factor``
#: times smaller in area (edges about half as long), falling smoothly back to 1 at
#: ``fade`` times the radii (:func:`mesh_density`). The lips' edges and the mouth line
#: between them bend within 3 to 5 mm, which 6 mm edges cut into a jagged lip line
#: (issue 32).
MOUTH_REFINEMENT = ((0.0, -59.0, 88.0), (25.0, 15.0, 20.0), 1.8, 4.0)
#: Where the built-in skin is meshed coarser, paying for the lips at the same triangle
#: count: ``(z_face, y_crown, width, factor)``. Behind the face (z below ``z_face``: the
#: sides of the head and neck) and on the crown (y above ``y_crown``) the density falls to
#: ``factor`` over ``width`` mm, except within ``width / 2`` to ``1.5 width`` of the cuts
#: (:data:`SKIN_CUTS`), whose edges stay as fine as the face's. Those parts are smooth
#: (radii of 50 to 100 mm: their 9 mm edges' midpoints lie within 0.31 mm of the level set,
#: the face's 6 mm ones within 1.1 mm) and hold no muscle.
SCALP_COARSENING = (40.0, 80.0, 20.0, 0.3)


def _smoothstep(t: np.ndarray) -> np.ndarray:
    """``t`` clipped to [0, 1] and eased: :math:`t^2 (3 - 2t)`."""
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def mesh_density(points: np.ndarray) -> np.ndarray:
    r"""``(n,)``: the built-in skin's relative mesh density at ``(n, 3)`` points: 1 on the
    face, ``factor`` on the lips (:data:`MOUTH_REFINEMENT`), less on the sides of the head
    and the crown (:data:`SCALP_COARSENING`).

    With :math:`r = \lVert (p - c) / \rho \rVert` the ellipsoidal radius round the mouth,
    :math:`\delta = (1 + (k - 1)\, S((f - r) / (f - 1)))
    (1 - (1 - k_s)\, S(\max((z_f - z) / d, (y - y_c) / d))\, S(e / d - 1/2))`, with
    :math:`e` the distance to the nearest cut and :math:`S` a smoothstep
    (:func:`_smoothstep`, so the triangles grade evenly). A cluster of pyacvd's covers about
    the same :math:`\int \delta \, dA`, so edges are :math:`\propto \delta^{-1/2}`.
    """
    p = np.asarray(points, float)
    mouth = 1.0 + (MOUTH_REFINEMENT[3] - 1.0) * _near_mouth(p)
    z_face, y_crown, width, coarse = SCALP_COARSENING
    away = _smoothstep(np.maximum((z_face - p[:, 2]) / width, (p[:, 1] - y_crown) / width))
    # not along the cuts: pyacvd's large clusters there leave a non-manifold edge or two
    off_cut = _smoothstep(np.min([(p[:, axis] - value) / width - 0.5
                                  for axis, value in SKIN_CUTS], axis=0))
    return mouth * (1.0 - (1.0 - coarse) * away * off_cut)


def _near_mouth(points: np.ndarray) -> np.ndarray:
    """``(n,)`` in [0, 1]: 1 on the lips, falling to 0 where :data:`MOUTH_REFINEMENT`'s
    grading ends (where :func:`_relaxed` evens the triangles).
    """
    centre, radii, fade, _ = MOUTH_REFINEMENT
    r = np.linalg.norm((np.asarray(points, float) - centre) / np.asarray(radii), axis=1)
    return _smoothstep((fade - r) / (fade - 1.0))


def _remesh(surface, n_points: int, subdivide: int = 0, density=None):
    r"""``surface`` remeshed by pyacvd to about ``n_points`` vertices (``subdivide`` linear
    subdivisions first), evenly, or graded by ``density`` (points ``(n, 3)`` -> ``(n,)``
    relative density) when given: pyacvd's point areas and weighted centres are scaled by
    it, so its clusters cover equal shares of :math:`\int \delta \, dA`.
    """
    import pyacvd
    import pyvista as pv

    # clean() turns collapsed triangles into lines and vertices; keep the polygons only
    surface = pv.PolyData(surface.points, faces=surface.faces).triangulate()

    with warnings.catch_warnings():
        # pyacvd 0.4 uses a PyVista 0.49 deprecated attribute; only that warning is silenced
        warnings.filterwarnings("ignore", message=".*_connectivity_array.*")
        clus = pyacvd.Clustering(surface)
        if subdivide:
            clus.subdivide(subdivide)
        if density is not None:
            # pyacvd's own ``weights`` only move the centres, not the areas it balances
            w = density(np.asarray(clus.mesh.points, float))
            clus.area = clus.area * w
            clus.wcent = clus.wcent * w[:, None]
        clus.cluster(n_points)
        # the caller projects the vertices onto the exact level set, so pyacvd need not
        # (its own projection costs 70 times the clustering)
        mesh = clus.create_mesh(moveclus=False)
    faces = mesh.faces.reshape(-1, 4)[:, 1:]
    return TriangleSurface(mesh.points, faces).cleaned().largest_component()


def _triangles_to_points(n_triangles: int, open_surface: bool) -> int:
    return int(round(n_triangles / 2 + (60 if open_surface else 2)))


def split_longest_edges(surface: TriangleSurface, n_triangles: int) -> TriangleSurface:
    """``surface`` with its longest edges split at their midpoints until it has exactly
    ``n_triangles`` triangles (a boundary edge adds one, an interior edge two).

    Orientation is kept (each triangle ``(a, b, c)`` split on ``ab`` becomes ``(a, m, c)``
    and ``(m, b, c)``); the new vertices lie on the straight edges (project them onto the
    surface afterwards). Deterministic: ties are broken by edge index.

    Raises
    ------
    ValueError
        If ``surface`` has more triangles than ``n_triangles``, or an odd number of
        triangles is missing and the surface has no boundary.
    """
    points, tris = np.asarray(surface.points, float), np.asarray(surface.triangles)
    if len(tris) > n_triangles:
        raise ValueError(f"the surface has {len(tris)} triangles, more than {n_triangles}")
    while len(tris) < n_triangles:
        s = TriangleSurface(points, tris)
        deficit = n_triangles - len(tris)
        tri_edges = s.triangle_edges
        counts = np.bincount(tri_edges.ravel(), minlength=len(s.edges))
        lengths = s.rest_edge_lengths
        want = 1 if deficit % 2 else 2  # an odd deficit takes one boundary edge first
        candidates = np.flatnonzero(counts == want)
        if len(candidates) == 0:
            raise ValueError(f"cannot reach {n_triangles} triangles: no "
                             f"{'boundary' if want == 1 else 'interior'} edge to split")
        candidates = candidates[np.lexsort((candidates, -lengths[candidates]))]
        owners = np.argsort(tri_edges.ravel(), kind="stable")  # corner slots by edge id
        first = np.searchsorted(tri_edges.ravel()[owners], candidates)
        used = np.zeros(len(tris), bool)
        budget = 1 if want == 1 else deficit // 2
        new_points, new_tris, replaced = [], [], []
        for edge, start in zip(candidates, first, strict=True):
            slots = owners[start:start + want]
            owner_tris = slots // 3
            if used[owner_tris].any():
                continue
            used[owner_tris] = True
            i, j = s.edges[edge]
            m = len(points) + len(new_points)
            new_points.append(0.5 * (points[i] + points[j]))
            for slot in slots:
                t, k = divmod(int(slot), 3)
                a, b, c = (tris[t][(k + r) % 3] for r in range(3))
                replaced.append(t)
                new_tris += [(a, m, c), (m, b, c)]
            budget -= 1
            if budget == 0:
                break
        keep = np.ones(len(tris), bool)
        keep[replaced] = False
        points = np.vstack([points, new_points])
        tris = np.vstack([tris[keep], np.asarray(new_tris, dtype=tris.dtype)])
    return TriangleSurface(points, tris)


def _remesh_exactly(raw, n_triangles: int, subdivide: int, density=None) -> TriangleSurface:
    """Remesh with pyacvd to at most ``n_triangles`` triangles, then split the longest
    edges up to exactly ``n_triangles`` (:func:`split_longest_edges`).

    pyacvd's triangle count depends on how many vertices its clusters put on the boundary,
    so the same request used to give a mesh of a nearby, different size, and asking for that
    size gave yet another mesh. With an exact count, ``load_face(face.skin.n_triangles)``
    rebuilds ``face``'s skin. A remesh with a non-manifold edge (pyacvd leaves one now and
    then where large clusters meet the boundary) is tried again with one vertex fewer.
    """
    n_points = _triangles_to_points(n_triangles, True)
    for _ in range(8):
        surf = _remesh(raw, n_points, subdivide, density)
        excess = surf.n_triangles - n_triangles
        if excess <= 0 and surf.report().ok:
            return split_longest_edges(surf, n_triangles)
        n_points -= max(excess // 2 + 1, 1)
    raise RuntimeError(f"pyacvd gave more than {n_triangles} triangles or a non-manifold "
                       "mesh 8 times; report this")


#: Where the built-in skin is cut open, ``(axis, value)``: behind the ears (z = -15 mm) and
#: under the chin, across the neck (y = -112 mm); the skin keeps the side above the value.
SKIN_CUTS = ((2, -15.0), (1, -112.0))


def _onto_cuts(surf: TriangleSurface, points: np.ndarray) -> np.ndarray:
    """``points`` ``(n, 3)`` of ``surf`` with its boundary vertices on the cuts
    (:data:`SKIN_CUTS`): each on the cut it lies nearest, where that plane meets the skin's
    level set (:func:`~wrinkle_vis.datasets.sdf.project_in_plane`).

    pyacvd places a vertex at the centre of its cluster, so the clusters along a cut put
    their vertices up to half a cluster inside it, each by another amount: projected onto
    the level set only, the cut edge was a saw (2.6 mm off the plane on average at 4,500
    triangles, up to 4 mm), which shows as a serrated neck.
    """
    counts = np.bincount(surf.triangle_edges.ravel(), minlength=len(surf.edges))
    boundary = np.unique(surf.edges[counts == 1].ravel())
    p = points[boundary]
    gaps = np.stack([np.abs(p[:, axis] - value) for axis, value in SKIN_CUTS], axis=1)
    nearest = np.argmin(gaps, axis=1)
    axes = np.array([a for a, _ in SKIN_CUTS])[nearest]
    values = np.array([v for _, v in SKIN_CUTS])[nearest]
    out = np.array(points, dtype=float)
    out[boundary] = project_in_plane(anatomy.skin_sdf, p, axes, values)
    return out


def _relaxed(surf: TriangleSurface, field, where: np.ndarray, iterations: int = 3,
             step: float = 0.5) -> TriangleSurface:
    r"""``surf`` with its interior vertices moved ``step`` times ``where`` (``(n,)`` in
    [0, 1]) of the way to their neighbours' mean within the tangent plane
    (:math:`p \leftarrow p + s\, w\, (I - n n^T)(\bar q - p)`), then back onto
    ``field``'s level set, ``iterations`` times; boundary vertices stay.

    pyacvd's vertices are cluster centres moved onto the level set, so where the surface
    bends sharply (the lips' borders, the mouth's corners) the projection squeezes some
    triangles to 16-20 degree angles; a few tangential smoothing steps even them out
    without leaving the surface.
    """
    counts = np.bincount(surf.triangle_edges.ravel(), minlength=len(surf.edges))
    fixed = np.asarray(where, float) <= 0.0
    fixed[surf.edges[counts == 1].ravel()] = True
    adj = surf.adjacency
    degree = np.asarray(adj.sum(axis=1)).ravel()
    points = np.array(surf.points, dtype=float)
    for _ in range(iterations):
        n = surf.vertex_normals(points)
        move = step * np.asarray(where, float)[:, None] * (
            adj @ points / degree[:, None] - points)
        move -= np.einsum("ij,ij->i", move, n)[:, None] * n
        move[fixed] = 0.0
        points = points + move
        points[~fixed] = project_to_surface(field, points[~fixed])
    return TriangleSurface(points, surf.triangles)


def build_skin(n_triangles: int = DEFAULT_TRIANGLES) -> TriangleSurface:
    """The skin: the face and scalp in front of the ears, above the neck.

    The skin's signed distance field (:func:`~wrinkle_vis.datasets.anatomy.skin_sdf`) is
    sampled on a 1.6 mm grid, its zero level set extracted with VTK's flying edges, cut
    behind the ears (z = -15 mm) and under the chin (y = -112 mm), remeshed with pyacvd to
    a triangulation that is even except round the lips, where it is finer, and on the crown
    and the sides of the head, where it is coarser (:func:`mesh_density`; at 4,500
    triangles the lips' edges are 3.0 mm, the face's 5.95 mm (5.94 mm when it was even) and
    the crown's 9 mm, so the lips and the mouth line are smooth; finer versions subdivide
    the contour first), brought to
    exactly ``n_triangles`` triangles by splitting the longest edges
    (:func:`split_longest_edges`), and every vertex is projected onto the exact level set,
    the boundary vertices onto where it meets the cut planes (:func:`_onto_cuts`: clean cut
    edges), and the triangles round the mouth are evened out on it (:func:`_relaxed`).
    The same ``n_triangles`` always gives the same mesh, with ``n_triangles`` triangles.
    """
    n_triangles = int(n_triangles)

    def build():
        raw = contour(anatomy.skin_sdf, (-82, -118, -22), (82, 128, 112), 1.6)
        for axis, value in SKIN_CUTS:
            normal = np.zeros(3)
            normal[axis] = -1.0
            origin = np.zeros(3)
            origin[axis] = value
            raw = raw.clip(normal=normal, origin=origin)
        raw = raw.extract_surface(algorithm="dataset_surface").triangulate().clean()
        sub = int(np.clip(np.ceil(np.log(max(n_triangles, 1) / 8000) / np.log(4)), 0, 3))
        surf = _remesh_exactly(raw, n_triangles, sub, mesh_density)
        points = _onto_cuts(surf, project_to_surface(anatomy.skin_sdf, surf.points))
        surf = TriangleSurface(points, surf.triangles).oriented()
        surf = _relaxed(surf, anatomy.skin_sdf, _near_mouth(surf.points))
        return {"points": surf.points, "triangles": surf.triangles}

    arrays = cached("skin", (n_triangles,), build)
    return TriangleSurface(arrays["points"], arrays["triangles"])


def build_skull(n_triangles: int = 12000) -> TriangleSurface:
    """The skull: a closed surface from :func:`~wrinkle_vis.datasets.anatomy.skull_sdf`."""
    def build():
        raw = contour(anatomy.skull_sdf, (-80, -125, -110), (80, 125, 110), 2.5)
        surf = _remesh(raw.triangulate().clean(), _triangles_to_points(n_triangles, False))
        surf = TriangleSurface(project_to_surface(anatomy.skull_sdf, surf.points),
                               surf.triangles).oriented()
        return {"points": surf.points, "triangles": surf.triangles}

    arrays = cached("skull", (int(n_triangles),), build)
    return TriangleSurface(arrays["points"], arrays["triangles"])


def _on_skin(x, y):
    return front_hit(anatomy.skin_sdf, x, y)


def _on_skull(x, y):
    return front_hit(anatomy.skull_sdf, x, y)


#: The frontalis: (name, centre x, width W_s, h^c) of each left sheet, mm. Neighbours'
#: falls overlap exactly (one's [h^c, W_s/2] is the other's), so with equal activations the
#: forehead from x = -44 to 44 rises as one, and the sheets join at the midline.
FRONTALIS = (("frontalis_inner", 9.0, 30.0, 3.0), ("frontalis_major", 26.0, 28.0, 2.0),
             ("frontalis_outer", 42.0, 28.0, 2.0))


def _frontalis() -> list:
    """The six frontalis sheets in one frame, so their furrows run on across the forehead.

    Every sheet has the fibre f pointing down the forehead (tilted 8.5 degrees back, so the
    furrows, which lie across f, are nearly horizontal) and the across axis s = x, and every sheet's
    attachment line is the frame's, shifted along x (and along the sheet normal n = f x s,
    which changes neither l nor h, to sit on the skull). So l, Eq. 7's w and Eq. 5's H are
    one field over the forehead. The pull peaks at R_s, the brows, and falls to 0 at L_s,
    below them; the wrinkling region runs from the hairline (l at y = 76) to L_s, and the fall
    lies inside the last half period, so the skin over all n_w = 3 wrinkles is compressed.
    """
    from scipy.optimize import brentq

    top = _on_skull(0.0, 84.0)
    f = np.array([0.0, -1.0, 0.15]) / np.hypot(1.0, 0.15)  # down, tilted with the forehead
    s = np.array([1.0, 0.0, 0.0])
    n = np.cross(f, s)

    def l_of(p):
        return float((p - top) @ f)

    peak = l_of(_on_skin(0.0, 25.0))  # the brows move most
    end = l_of(_on_skin(0.0, 16.0))  # then the pull fades above the fold under the brows
    start = l_of(_on_skin(0.0, 76.0))  # the wrinkling region starts under the hairline
    out = []
    for name, cx, width, h_c in FRONTALIS:
        base = top + cx * s
        t = brentq(lambda t, b=base: float(anatomy.skull_sdf((b + t * n)[None])[0]), -30.0,
                   30.0)
        m_ac = base + t * n
        half = 0.5 * width * s
        out.append(SheetMuscle(
            name + "_L", attachment_line=(m_ac - half, m_ac + half),
            insertion_line=(m_ac - half + peak * f, m_ac + half + peak * f),
            length=end, width=width, depth=90.0, attenuation_start=h_c, fall_start=peak,
            strength=5.0, lambda_w=start / end, n_wrinkles=3, k0=6.0, alpha=1.0))
    return out


def builtin_muscles() -> list:
    """The built-in muscle layout, left (``_L``, +x) and right (``_R``) muscles.

    Frontalis inner, major and outer are sheet muscles in one frame from the hairline to the
    brows (surprise, :func:`_frontalis`); corrugator supercilii runs from the bone under the
    glabella to the inner end of the brow, so its pull squeezes the skin between the brows
    into vertical furrows (frown); the others move the mouth (zygomaticus major, levator
    labii superioris, depressor anguli oris) and are linear muscles of Waters' kind.
    Orbicularis oculi (left and right) and orbicularis oris are sphincters
    (:func:`_orbicularis_oculi`, :func:`_orbicularis_oris`). Attachments lie on the skull,
    insertions and the sphincters' points on the skin.
    """
    left = _frontalis()
    left.append(LinearMuscle(
        "corrugator_L", _on_skull(1.5, 21.0), _on_skin(14.0, 27.0), radius=18.0,
        max_angle_deg=70.0, lambda_w=0.1, n_wrinkles=2, k0=3.0, alpha=1.0, strength=3.5))
    for name, a, i, phi in (
        ("zygomaticus_major", (52.0, -14.0), (25.0, -57.0), 25.0),
        ("levator_labii_superioris", (22.0, -14.0), (14.0, -45.0), 25.0),
        ("depressor_anguli_oris", (22.0, -84.0), (25.0, -62.0), 25.0),
    ):
        m_a, m_i = _on_skull(*a), _on_skin(*i)
        left.append(LinearMuscle(
            name + "_L", m_a, m_i, radius=1.3 * float(np.linalg.norm(m_i - m_a)),
            max_angle_deg=phi, lambda_w=0.4, n_wrinkles=2, k0=0.8, alpha=1.0, strength=5.0))
    left.append(_orbicularis_oculi())
    out = []
    for m in left:
        out += [m, mirrored(m, name=m.name[:-2] + "_R")]
    out.append(_orbicularis_oris())
    out += _action_unit_muscles()
    # attachments from the skull's level set onto the skull mesh (< 1 mm away); a sheet's
    # lines keep their frame (see _frontalis)
    skull = {"skull": build_skull()}
    return [snapped(m, skull, lines=False) for m in out]


def _action_unit_muscles() -> list:
    """The muscles of the wrinkle-producing action units that the paper's face lacks
    (FACS, Ekman, Friesen and Hager 2002; Gray's Anatomy for the origins), linear muscles
    whose furrows lie across their fibres:

    - ``levator_labii_superioris_alaeque_nasi_L``/``_R`` (AU9, nose wrinkler): from the
      frontal process of the maxilla beside the root of the nose down to the ala and the
      upper lip; its pull raises the ala and wrinkles the side of the nose across.
    - ``procerus`` (AU4 with the corrugators, brow lowerer): from the nasal bone up into
      the skin between the brows; its pull draws that skin down into horizontal lines at
      the root of the nose.
    - ``mentalis`` (AU17, chin raiser): from the incisive fossa of the mandible down into
      the skin of the chin; its pull raises the chin boss and wrinkles it across.
    """
    llsan = LinearMuscle(
        "levator_labii_superioris_alaeque_nasi_L", _on_skull(9.0, 6.0), _on_skin(13.0, -30.0),
        radius=42.0, max_angle_deg=28.0, lambda_w=0.15, n_wrinkles=3, k0=3.5, alpha=1.0,
        strength=3.5)
    procerus = LinearMuscle(
        "procerus", _on_skull(0.0, -4.0), _on_skin(0.0, 22.0), radius=32.0,
        max_angle_deg=30.0, lambda_w=0.3, n_wrinkles=2, k0=2.0, alpha=1.0, strength=4.0)
    mentalis = LinearMuscle(
        "mentalis", _on_skull(0.0, -74.0), _on_skin(0.0, -94.0), radius=28.0,
        max_angle_deg=40.0, lambda_w=0.3, n_wrinkles=2, k0=2.5, alpha=1.0, strength=4.0)
    return [llsan, mirrored(llsan, name=llsan.name[:-2] + "_R"), procerus, mentalis]


def _orbicularis_oculi() -> SphincterMuscle:
    """The left orbicularis oculi: an ellipse around the eye, out to the temple (a = 42 mm
    in its plane, which leans back with the side of the head) and up to the brow
    (b = 22 mm), whose squeeze wrinkles a 100 degree fan at the outer corner of the eye
    (crow's feet, :class:`~wrinkle_vis.core.sphincter.SphincterMuscle`).

    The band starts at the outer corner of the eye (rho = 0.4); the squeeze is uniform up to
    rho_s = 0.8 (kappa = 0.25) and fades out by the ellipse. The n_w = 4 periods of the
    sector put three crow's feet on the central ray and about 25 degrees above and below
    it (the furrows at the sector's ends have At = 0).
    """
    return SphincterMuscle(
        "orbicularis_oculi_L", _on_skin(32.0, 0.0), _on_skin(60.0, -3.0), _on_skin(32.0, 22.0),
        depth=22.0, sector_deg=50.0, sector_center_deg=0.0, lambda_w=0.4, n_wrinkles=4,
        k0=2.5, alpha=1.0, fall_start=25.0, strength=3.0, compression="gradient")


def _orbicularis_oris() -> SphincterMuscle:
    """The orbicularis oris: an ellipse around the mouth, out past the corners (a = 40 mm in
    its plane) and up under the nose (b = 26 mm), whose squeeze (kappa = 0.25 up to
    rho_s = 0.86) wrinkles the band around the lips (rho >= 0.3) into n_w = 18 lines that
    radiate from the mouth (lip lines), all around (Theta = 180 degrees, At = 1).
    """
    return SphincterMuscle(
        "orbicularis_oris", _on_skin(0.0, -59.0), _on_skin(34.0, -59.0), _on_skin(0.0, -37.0),
        depth=22.0, sector_deg=180.0, sector_center_deg=90.0, attenuation_start_deg=180.0,
        lambda_w=0.3, n_wrinkles=18, k0=2.5, alpha=1.0, fall_start=24.0, strength=3.0,
        compression="gradient")


def _pair(prefix: str, value: float) -> dict[str, float]:
    return {f"{prefix}_L": value, f"{prefix}_R": value}


#: Waters' (1987) six universal expressions, by Ekman and Friesen's action units (FACS), on
#: the built-in muscles: ``(name, {muscle prefix: activation}, description)``. A prefix
#: without a side names a pair; the action units without a muscle here (the lids, the jaw)
#: are left out. Levator labii superioris stays at 0.6: at full activation its pull alone
#: creases the side of the nose past the realism limit (99th percentile 10 degrees refined).
WATERS_SIX = (
    ("happiness", {"zygomaticus_major": 1.0, "orbicularis_oculi": 0.6},
     "AU 6 + 12: the cheeks raised (orbicularis oculi) and the lip corners pulled up "
     "(zygomaticus major)"),
    ("anger", {"corrugator": 1.0, "orbicularis_oculi": 0.5, "orbicularis_oris": 0.6},
     "AU 4 + 7 + 23: the brows lowered and drawn together (corrugator), the lids "
     "tightened (orbicularis oculi), the lips tightened (orbicularis oris)"),
    ("surprise", {"frontalis_inner": 1.0, "frontalis_major": 0.8, "frontalis_outer": 1.0},
     "AU 1 + 2: the inner and outer brows raised (frontalis)"),
    ("sadness", {"frontalis_inner": 0.8, "corrugator": 0.5, "depressor_anguli_oris": 1.0},
     "AU 1 + 4 + 15: the inner brows raised (frontalis inner) and drawn together "
     "(corrugator), the lip corners pulled down (depressor anguli oris)"),
    ("fear", {"frontalis_inner": 1.0, "frontalis_outer": 0.6, "corrugator": 0.6,
              "depressor_anguli_oris": 0.5},
     "AU 1 + 2 + 4 + 20: the brows raised and drawn together (frontalis, corrugator), the "
     "lips stretched down (depressor anguli oris)"),
    ("disgust", {"levator_labii_superioris": 0.6, "orbicularis_oculi": 0.4,
                 "depressor_anguli_oris": 0.4},
     "AU 9 + 10 + 15: the upper lip raised (levator labii superioris), the cheeks "
     "raised and the lids narrowed (orbicularis oculi), the lip corners down"),
)


def _activations(spec: dict) -> dict[str, float]:
    out: dict[str, float] = {}
    for prefix, value in spec.items():
        out.update({prefix: value} if prefix == "orbicularis_oris" else _pair(prefix, value))
    return out


def builtin_expressions() -> dict[str, Expression]:
    """The paper's expressions (Sec. 3: ``surprise``, ``frown``, ``fear``, unchanged), plus

    - ``smile``: zygomaticus major;
    - ``duchenne_smile``: zygomaticus major with orbicularis oculi, whose squeeze wrinkles
      the outer corners of the eyes (crow's feet);
    - ``squint``: orbicularis oculi alone;
    - ``pucker``: orbicularis oris, whose squeeze wrinkles the lips (lip lines);
    - Waters' six (``waters_happiness``, ``waters_anger``, ``waters_surprise``,
      ``waters_sadness``, ``waters_fear``, ``waters_disgust``; :data:`WATERS_SIX`).
    """
    ex = paper_expressions()
    ex["smile"] = Expression("smile", {"zygomaticus_major_L": 1.0, "zygomaticus_major_R": 1.0},
                             description="zygomaticus major pull the mouth corners up")
    ex["duchenne_smile"] = Expression(
        "duchenne_smile", {**_pair("zygomaticus_major", 1.0), **_pair("orbicularis_oculi", 1.0)},
        description="zygomaticus major pull the mouth corners up, orbicularis oculi squeeze "
                    "the eyes: crow's feet")
    ex["squint"] = Expression(
        "squint", _pair("orbicularis_oculi", 1.0),
        description="orbicularis oculi squeeze the eyes: crow's feet")
    ex["pucker"] = Expression(
        "pucker", {"orbicularis_oris": 1.0},
        description="orbicularis oris squeeze the lips: lip lines")
    for name, spec, description in WATERS_SIX:
        ex[f"waters_{name}"] = Expression(f"waters_{name}", _activations(spec),
                                          description=f"Waters (1987): {description}")
    return ex


def builtin_layout() -> Layout:
    """The built-in face's layout, computed from the code (the shipped file is a copy),
    with the default track mapping (:func:`~wrinkle_vis.core.tracks.default_mapping`).
    """
    from wrinkle_vis.core.tracks import default_mapping

    return Layout(name="built-in face", muscles=tuple(builtin_muscles()),
                  expressions=builtin_expressions(), landmarks=builtin_landmarks(),
                  mapping=default_mapping())


#: The built-in faces :func:`load_face` knows by name.
FACES = ("procedural", "lee_perry_smith")


def _as_layout(layout) -> tuple[Layout | None, Path | None]:
    if layout is None:
        return None, None
    if isinstance(layout, Layout):
        return layout, None
    path = Path(layout)
    return load_layout(path), path.parent


def _check_fits(lay: Layout, skin: TriangleSurface, what: str) -> None:
    """A clear error when ``lay``'s muscles lie far outside ``skin`` (a layout made for
    another face, or in another unit).
    """
    pts = [np.asarray(m.insertion, float).reshape(-1, 3) for m in lay.muscles
           if "insertion" in m.point_parameters]
    if not pts:
        return
    lo, hi = skin.bounds()
    margin = 0.25 * float(np.linalg.norm(hi - lo))
    pts = np.vstack(pts)
    outside = np.any((pts < lo - margin) | (pts > hi + margin), axis=1)
    spread = float(np.linalg.norm(np.ptp(pts, axis=0))) if len(pts) > 1 else 0.0
    if len(pts) > 1 and spread < 0.02 * float(np.linalg.norm(hi - lo)):
        raise ValueError(
            f"{what}: its muscles span {spread:.3g} units on a skin "
            f"{float(np.linalg.norm(hi - lo)):.4g} units across; the layout was made for a "
            "face in another unit: name its skin file in the layout's \"skin\", or give "
            "the skin it was made for")
    if outside.any():
        raise ValueError(
            f"{what}: its muscles lie outside the skin ({int(outside.sum())} of "
            f"{len(pts)} insertions, skin {lo.round(3).tolist()} to {hi.round(3).tolist()}); "
            "the layout was made for another face or unit: name its skin file in the "
            "layout's \"skin\", or give the skin it was made for")


def load_face(name: str | int | None = None, n_triangles: int | None = None, *, skin=None,
              skull=None, layout=None, landmarks=None, unit: str | None = None,
              base: str | os.PathLike | None = None) -> FaceModel:
    """A face ready to evaluate: a built-in one (by name), or a scan of your own.

    Parameters
    ----------
    name : str, optional
        A built-in face (:data:`FACES`): ``"procedural"`` (the default), the anatomy-based
        face made by this package's code, or ``"lee_perry_smith"``, a real head scan with
        21 muscles placed on its anatomy and a closed skull
        (:mod:`~wrinkle_vis.datasets.lee_perry_smith`; CC BY 3.0, Lee Perry-Smith /
        Infinite Realities). A number here is ``n_triangles`` (as in earlier versions).
    n_triangles : int, optional
        How many skin triangles the procedural skin has, exactly (the paper's model has
        about 4,500), in 500..250,000; the same number always gives the same mesh. Default:
        the number a ``layout`` records (:attr:`Layout.n_triangles`), else 4,500. Finer
        versions have the same shape and the same muscles. Only for the procedural face.
    skin : path or TriangleSurface, optional
        A face of your own (OBJ, PLY, STL, VTP, VTK, or what meshio reads); it is
        triangulated, welded and oriented outward
        (:func:`~wrinkle_vis.datasets.scans.read_surface`,
        :func:`~wrinkle_vis.datasets.scans.orient_outward`).
    skull : path or TriangleSurface, optional
        Its skull; by default a closed skull is built under the skin
        (:func:`~wrinkle_vis.datasets.skull.scan_skull`: the level set at the regional
        tissue depth under the face with ``landmarks``, at 2.5 % of the skin's height
        without).
    layout : path or Layout, optional
        Muscles and expressions; by default the built-in layout, which is moved onto a
        ``skin`` of your own from ``landmarks`` (:func:`transfer_layout`). A layout's own
        ``skin`` and ``skull`` paths are read relative to its file, its ``face`` names a
        built-in face and its ``unit`` the unit; a layout naming its skin file and its
        landmarks (:func:`~wrinkle_vis.datasets.scans.scan_layout`) reopens the same face,
        bit for bit.
    landmarks : dict of str to (3,) array_like, optional
        Named points on ``skin`` (:data:`~wrinkle_vis.datasets.scans.LANDMARKS`).
    unit : str, optional
        The unit of the skin's lengths (``"mm"``, ``"cm"``, ``"m"``, ...); default the
        layout's, else ``"mm"`` for the built-in faces and, for a scan, a guess from its
        height (with a :class:`~wrinkle_vis.core.units.UnitWarning`).
    base : path, optional
        The folder a layout's ``skin`` and ``skull`` paths are relative to; default the
        layout file's folder, or the current folder for a ``Layout`` object (give the
        folder of the file it was read from).

    Returns
    -------
    FaceModel
        For the procedural face: skin, skull, 21 muscles (9 pairs, the orbicularis oris,
        procerus and mentalis) and the expressions ``neutral``, ``surprise``, ``frown``,
        ``fear`` (the paper's Section 3), ``smile``, ``duchenne_smile``, ``squint``,
        ``pucker`` and Waters' six
        (:func:`builtin_expressions`); the Lee Perry-Smith head has the same muscles and
        expressions.
        A skin of your own with neither a layout nor landmarks gets no muscles.

    Raises
    ------
    ValueError
        For an unknown name (listing :data:`FACES`), a resolution out of range, or a layout
        whose muscles lie outside the skin (a layout made for another face).

    Notes
    -----
    The procedural face is deterministic, made by this package's own code (no scan, no
    download): signed distance fields of the skin and skull
    (:mod:`wrinkle_vis.datasets.anatomy`, with the forensic tissue-depth source cited
    there), VTK's flying edges through PyVista, and pyacvd remeshing. Units are millimetres;
    y is up, the face looks towards +z, x points to the subject's left, and the origin lies
    between the eyes. Results are cached on disk (``$WRINKLE_VIS_CACHE`` or
    ``~/.cache/wrinkle-vis``) under a key that changes with the code.
    Licence: the procedural face, the same as wrinkle-vis; the Lee Perry-Smith head,
    CC BY 3.0 (see :mod:`~wrinkle_vis.datasets.lee_perry_smith`).
    """
    name, n_triangles = _name_and_resolution(name, n_triangles)
    lay, folder = _as_layout(layout)
    folder = Path(base) if base is not None else folder
    name = _face_name(name, lay, skin)
    if name == "lee_perry_smith":
        return _skinned(_lee_perry_smith_face(lay, skin, skull), lay)
    used = lay if lay is not None else load_layout(BUILTIN_LAYOUT)
    skin, skull = _layout_surfaces(used, folder, skin, skull)
    if skin is None:
        face = _procedural_face(used, lay is not None, n_triangles, skull, landmarks, unit)
    else:
        skin_mesh = _surface(skin)
        unit = face_unit_of(skin_mesh, unit or used.unit)
        face = _scan_face(skin_mesh, _surface(skull), used, lay is None, landmarks, unit)
    return _skinned(face, lay)


def _name_and_resolution(name, n_triangles: int | None) -> tuple[object, int | None]:
    """``(name, n_triangles)``, with a number given as the name taken as ``n_triangles``."""
    if isinstance(name, (int, np.integer)) and not isinstance(name, bool):
        if n_triangles is not None:
            raise ValueError("give the resolution once: load_face(n_triangles=...)")
        return None, int(name)
    return name, n_triangles


def _face_name(name, lay: Layout | None, skin) -> str | None:
    """The built-in face asked for: ``name``, else the one a layout without a skin names;
    checked against :data:`FACES`.
    """
    if name is None and lay is not None and skin is None and lay.skin is None:
        name = lay.face
    if name is not None and (not isinstance(name, str) or name not in FACES):
        raise ValueError(f"no built-in face {name!r}; the built-in faces are: "
                         f"{', '.join(FACES)}")
    return name


def _lee_perry_smith_face(lay: Layout | None, skin, skull) -> FaceModel:
    """The Lee Perry-Smith head, with ``lay``'s muscles when given (its skin is its own)."""
    if skin is not None:
        raise ValueError("the lee_perry_smith face has its own skin; drop skin=... or "
                         "the name")
    return load_lee_perry_smith(layout=lay, skull=_surface(skull))


def _layout_surfaces(lay: Layout, folder: Path | None, skin, skull) -> tuple:
    """``(skin, skull)``: those given, else the files ``lay`` names, relative to
    ``folder`` (the layout file's; the current folder for a ``Layout`` object).
    """
    if skin is None and lay.skin is not None:
        skin = (folder or Path.cwd()) / lay.skin
    if skull is None and lay.skull is not None:
        skull = (folder or Path.cwd()) / lay.skull
    return skin, skull


def _procedural_face(lay: Layout, given: bool, n_triangles: int | None, skull, landmarks,
                     unit: str | None) -> FaceModel:
    """The procedural skin at ``n_triangles`` (default the layout's, else 4,500) with
    ``lay``'s muscles; a layout that was ``given`` is checked to fit the skin.
    """
    if n_triangles is None:
        n_triangles = (lay.n_triangles if lay.n_triangles is not None
                       else DEFAULT_TRIANGLES)
    n = int(n_triangles)
    if not (MIN_TRIANGLES <= n <= MAX_TRIANGLES):
        raise ValueError(f"n_triangles = {n} is outside the supported "
                         f"{MIN_TRIANGLES}..{MAX_TRIANGLES}; choose a number in that "
                         "range")
    skin = build_skin(n)
    if given:
        _check_fits(lay, skin, f"layout {lay.name!r} on the built-in face")
    return FaceModel(skin, _surface(skull) or build_skull(), lay.muscles, lay.expressions,
                     name=lay.name, landmarks=lay.landmarks if landmarks is None else landmarks,
                     unit=unit or lay.unit or "mm", mapping=lay.mapping)


def _skinned(face: FaceModel, layout) -> FaceModel:
    """``face`` with the skin model and material a layout records (as is without)."""
    if layout is None or (layout.skin_model is None and not layout.skin_material):
        return face
    return face.with_skin_model(layout.skin_model or face.skin_model, layout.material())


def _surface(value):
    """A skin or skull given as a path (read) or a surface, oriented outward."""
    if value is None:
        return None
    if isinstance(value, TriangleSurface):
        return orient_outward(value)
    return read_surface(value)


def _scan_face(skin, skull, lay, builtin_layout_used, landmarks, unit):
    """A face on a scanned ``skin``: the level-set skull unless one is given, and ``lay``'s
    muscles, moved onto the skin from ``landmarks`` when ``lay`` is the built-in layout
    (none without landmarks).
    """
    landmarks = dict(landmarks) if landmarks is not None else (
        None if builtin_layout_used else dict(lay.landmarks) or None)
    if skull is None:
        skull = scan_skull(skin, landmarks)
    if builtin_layout_used:
        if not landmarks:
            return FaceModel(skin, skull, (), {"neutral": paper_expressions()["neutral"]},
                             name="scan without muscles", unit=unit)
        lay = transfer_layout(lay, skin, landmarks, skull)
    else:
        _check_fits(lay, skin, f"layout {lay.name!r}")
    return FaceModel(skin, skull, lay.muscles, lay.expressions, name=lay.name,
                     landmarks=landmarks or lay.landmarks, unit=unit, mapping=lay.mapping)
