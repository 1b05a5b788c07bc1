"""The skull under a scan: closed, manifold, not crossing itself, inside the skin, under
the face only (datasets/skull.py), on the head and the bust in ../shared/realmeshes."""

from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
import vtk
from scipy.sparse.csgraph import connected_components

import wrinkle_vis as wv
from wrinkle_vis.core.mesh import self_intersections, tangent_bases
from wrinkle_vis.datasets import read_surface
from wrinkle_vis.datasets.scans import similarity_transform
from wrinkle_vis.datasets.skull import EAR_PLANE_Z, NECK_PLANE_Y, exterior, scan_skull
from wrinkle_vis.plotting import to_surface_polydata

REAL = Path(__file__).resolve().parents[2] / "shared" / "realmeshes"
HEAD = REAL / "lee_perry_smith_head.obj"
BUST = REAL / "demosthenes_bust.obj"
EXAMPLE = Path(wv.datasets.__file__).with_name("examples") / "lee_perry_smith.json"
#: The bust's landmarks seen from the front (x, y); z is where a ray from +z meets the skin.
BUST_XY = {"nasion": (0.19, 1.33), "nose_tip": (0.2, 1.02), "chin": (0.2, 0.64),
           "eye_inner_L": (0.28, 1.29), "eye_inner_R": (0.10, 1.29),
           "eye_outer_L": (0.45, 1.28), "eye_outer_R": (-0.08, 1.28),
           "mouth_corner_L": (0.40, 0.89), "mouth_corner_R": (0.03, 0.89)}

needs_scans = pytest.mark.skipif(not HEAD.exists(), reason="../shared/realmeshes is not here")


def manifold_vertices(surface) -> bool:
    """Every vertex's corners joined across the edges through it form one fan."""
    tri = surface.triangles
    m = len(tri)
    corner = np.arange(3 * m).reshape(m, 3)  # corner id = 3 * triangle + slot
    te = surface.triangle_edges  # (m, 3): the edges of slots (0, 1), (1, 2), (2, 0)
    # pair corners of the same vertex in two triangles sharing an edge through it
    edges = te.ravel()
    order = np.argsort(edges, kind="stable")
    a, b = order[:-1], order[1:]
    same = edges[a] == edges[b]
    a, b = a[same], b[same]  # (triangle*3 + edge slot) pairs sharing an edge
    ta, sa, tb, sb = a // 3, a % 3, b // 3, b % 3
    links_a, links_b = [], []
    for end in (0, 1):
        va = tri[ta, (sa + end) % 3]
        ka = (sa + end) % 3
        kb = np.where(tri[tb, sb] == va, sb, (sb + 1) % 3)
        links_a.append(corner[ta, ka])
        links_b.append(corner[tb, kb])
    la, lb = np.concatenate(links_a), np.concatenate(links_b)
    graph = sp.csr_matrix((np.ones(len(la)), (la, lb)), shape=(3 * m, 3 * m))
    n_fans = connected_components(graph, directed=False)[0]
    return n_fans == len(np.unique(tri))


def front_landmarks(skin, xy):
    poly = to_surface_polydata(skin)
    top = float(skin.points[:, 2].max()) + 1.0
    return {k: tuple(poly.ray_trace((x, y, top), (x, y, -top), first_point=True)[0])
            for k, (x, y) in xy.items()}


@pytest.fixture(scope="module", params=["head", "bust"])
def scan(request):
    if not HEAD.exists():
        pytest.skip("../shared/realmeshes is not here")
    if request.param == "head":
        skin = read_surface(HEAD)
        marks = wv.load_layout(EXAMPLE).landmarks
    else:
        skin = read_surface(BUST)
        marks = front_landmarks(skin, BUST_XY)
    source = wv.datasets.builtin_landmarks()
    names = list(source)
    rot, scale, shift = similarity_transform([source[n] for n in names],
                                             [marks[n] for n in names])
    return {"skin": skin, "marks": marks, "skull": scan_skull(skin, marks),
            "mm": scale, "builtin": lambda p: (np.asarray(p) - shift) @ rot / scale}


@needs_scans
@pytest.mark.slow
def test_closed_manifold_one_piece_outward(scan):
    rep = scan["skull"].report()
    assert len(rep.boundary_edges) == 0 and len(rep.non_manifold_edges) == 0
    assert len(rep.degenerate_triangles) == 0 and rep.n_components == 1
    assert rep.consistently_oriented and scan["skull"].signed_volume() > 0
    skull = scan["skull"]  # manifold vertices too: every vertex's triangles form one fan
    assert manifold_vertices(skull)
    euler = skull.n_points - len(skull.edges) + skull.n_triangles
    assert euler % 2 == 0 and euler <= 2  # a closed orientable surface


@needs_scans
@pytest.mark.slow
def test_no_self_intersections(scan):
    assert len(self_intersections(scan["skull"])) == 0


@needs_scans
@pytest.mark.slow
def test_at_least_a_millimetre_inside_the_skin_everywhere(scan):
    """Every skull point is covered (a ray along its outward normal meets the skin) and at
    least 1 mm from the skin's outer surface (a mouth bag or eye sockets inside the head are
    not the face's surface)."""
    skull, skin = scan["skull"], scan["skin"]
    outer = to_surface_polydata(exterior(skin))
    d = np.abs(to_surface_polydata(skull).compute_implicit_distance(outer)["implicit_distance"])
    assert d.min() > 1.0 * scan["mm"]
    # and about the regional depth: 4.5 mm (forehead) to 21 mm (mid cheek), median ~7
    assert 4.0 * scan["mm"] < np.median(d) < 15.0 * scan["mm"]
    locator = vtk.vtkStaticCellLocator()
    locator.SetDataSet(to_surface_polydata(skin))
    locator.BuildLocator()
    n = skull.vertex_normals()
    u, v = tangent_bases(n)
    far = float(np.ptp(skin.points, axis=0).max())
    t, x, pc, sub, cell = vtk.mutable(0.0), [0.0] * 3, [0.0] * 3, vtk.mutable(0), vtk.mutable(0)

    def covered(i):  # a ray along the normal, or tilted 30 degrees (a slit between the lips)
        rays = [n[i]] + [n[i] + 0.58 * s * w[i] for w in (u, v) for s in (1, -1)]
        p = skull.points[i]
        return any(locator.IntersectWithLine(p, p + far * r, 0.0, t, x, pc, sub, cell)
                   for r in rays)

    assert all(covered(i) for i in range(skull.n_points))


@needs_scans
@pytest.mark.slow
def test_under_the_face_only(scan):
    q = scan["builtin"](scan["skull"].points)
    tol = 2.5  # the grid's spacing, mm
    assert q[:, 2].min() > EAR_PLANE_Z - tol  # in front of the ears
    assert q[:, 1].min() > NECK_PLANE_Y - tol  # above the neck
    # ... and all the face: from above the brows to the chin, cheek to cheek
    assert q[:, 1].max() > 60.0 and q[:, 1].min() < -90.0
    assert q[:, 0].min() < -45.0 and q[:, 0].max() > 45.0


def test_manifold_vertices_sees_two_cones_touching_at_a_tip():
    from meshes import sphere

    ball = sphere(2)
    assert manifold_vertices(ball)
    tip = int(np.argmax(ball.points[:, 2]))
    # a second ball, its lowest vertex glued to the first one's top: a non-manifold vertex
    other = ball.points + [0, 0, 2.0]
    low = int(np.argmin(other[:, 2]))
    ids = np.arange(ball.n_points) + ball.n_points
    ids[low] = tip
    pts = np.vstack([ball.points, other])
    glued = wv.TriangleSurface(pts, np.vstack([ball.triangles, ids[ball.triangles]]))
    assert len(glued.report().non_manifold_edges) == 0  # the edges cannot tell
    assert not manifold_vertices(glued.without_unused())


def test_self_intersections_finds_a_crossing_and_not_a_touch():
    from meshes import sphere

    ball = sphere(3)
    assert len(self_intersections(ball)) == 0
    two = wv.TriangleSurface(np.vstack([ball.points, 0.9 * ball.points + [0.5, 0, 0]]),
                             np.vstack([ball.triangles, ball.triangles + ball.n_points]))
    pairs = self_intersections(two)
    assert len(pairs) > 0
    assert np.all((pairs[:, 0] < ball.n_triangles) != (pairs[:, 1] < ball.n_triangles))
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.3, 0.3, -1], [0.3, 0.3, 1]], float)
    crossing = wv.TriangleSurface(pts, [[0, 1, 2], [0, 3, 4]])  # share a corner, cross
    np.testing.assert_array_equal(self_intersections(crossing), [[0, 1]])
    touching = wv.TriangleSurface(pts, [[0, 1, 2], [0, 4, 1]])  # share an edge only
    assert len(self_intersections(touching)) == 0


@pytest.mark.slow
def test_the_procedural_skull_of_a_plain_skin_is_closed(wv_face):
    skull = scan_skull(wv_face.skin)  # no landmarks: 2.5 % of the height, all inside
    rep = skull.report()
    assert len(rep.boundary_edges) == 0 and len(rep.non_manifold_edges) == 0
    assert len(self_intersections(skull)) == 0
    d = to_surface_polydata(skull).compute_implicit_distance(
        to_surface_polydata(wv_face.skin))["implicit_distance"]
    assert np.max(d) < -1.0
