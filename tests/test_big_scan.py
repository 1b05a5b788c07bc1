"""The first frame of a big scan (issue 33 M12): each muscle is evaluated only near its area
of influence, shape operators only where the skin moves, and every shortcut gives the same
numbers, to the bit, as the full computation it replaces."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from meshes import grid, sphere

import wrinkle_vis as wv
from wrinkle_vis import LinearMuscle, SheetMuscle, TriangleSurface
from wrinkle_vis.core.mesh import cotangent_laplacian, occluded, shape_operators
from wrinkle_vis.core.muscledata import _MuscleData, tangential
from wrinkle_vis.core.sphincter import SphincterMuscle

coordinate = st.floats(-50.0, 50.0)
point = st.tuples(coordinate, coordinate, coordinate)


@st.composite
def muscles(draw):
    kind = draw(st.sampled_from(["linear", "sheet", "sphincter"]))
    a, b, c = (np.array(draw(point)) for _ in range(3))
    if kind == "linear":
        length = np.linalg.norm(b - a)
        if length < 1.0:
            b = a + np.array([1.0, 0.0, 0.0])
            length = 1.0
        return LinearMuscle("m", tuple(a), tuple(b), radius=length * draw(st.floats(1.05, 3)),
                            max_angle_deg=draw(st.floats(1.0, 90.0)))
    if kind == "sheet":
        across = np.array(draw(st.tuples(*[st.floats(-20, 20)] * 3)))
        fibre = b - a
        if np.linalg.norm(fibre) < 1.0 or np.linalg.norm(np.cross(fibre, across)) < \
                0.1 * np.linalg.norm(fibre) * max(np.linalg.norm(across), 1e-9):
            fibre, across = np.array([0.0, 30.0, 0.0]), np.array([10.0, 0.0, 0.0])
        return SheetMuscle("m", (tuple(a - across), tuple(a + across)),
                           (tuple(a + fibre - across), tuple(a + fibre + across)))
    u, v = b - a, c - a
    if np.linalg.norm(u) < 1.0 or np.linalg.norm(np.cross(u, v)) < 0.1 * np.linalg.norm(u) * \
            max(np.linalg.norm(v), 1e-9):
        u, v = np.array([20.0, 0.0, 0.0]), np.array([3.0, 12.0, 1.0])
    return SphincterMuscle("m", tuple(a), tuple(a + u), tuple(a + v))


def _cloud(muscle, seed: int) -> TriangleSurface:
    """Points in and around the muscle's area of influence, as a surface of one triangle."""
    rng = np.random.default_rng(seed)
    pts = np.asarray(muscle.point_parameters and np.concatenate(
        [np.reshape(getattr(muscle, k), (-1, 3)) for k in muscle.point_parameters]))
    centre, span = pts.mean(axis=0), 3.0 * np.ptp(pts, axis=0).max() + 1.0
    cloud = centre + span * rng.uniform(-1, 1, (4000, 3))
    return TriangleSurface(cloud, [[0, 1, 2]])


@settings(max_examples=60, deadline=None)
@given(muscles(), st.integers(0, 2**16))
def test_the_candidates_hold_the_whole_area_of_influence(muscle, seed):
    skin = _cloud(muscle, seed)
    in_aoi = np.flatnonzero(muscle.region(skin.points)["in_aoi"])
    assume(in_aoi.size > 0)  # a cloud that misses the area of influence tests nothing
    cand = muscle.candidates(skin)
    assert np.all(np.diff(cand) > 0)
    assert np.isin(in_aoi, cand).all()


def test_a_bounded_muscle_has_few_candidates_on_a_big_skin():
    m = LinearMuscle("m", (0.0, 0.0, 0.0), (0.0, 10.0, 0.0), radius=12.0, max_angle_deg=20.0)
    skin = grid(101, 101, 400.0)  # 400 units across, the muscle 12 long
    cand = m.candidates(skin)
    assert 0 < len(cand) < 0.01 * skin.n_points
    assert np.isin(np.flatnonzero(m.region(skin.points)["in_aoi"]), cand).all()


def _reference(skin, muscle, normals) -> dict:
    """What the face built from every vertex before (issue 33 M12): the AOI, its arrays."""
    reg = muscle.region(skin.points)
    in_aoi = reg["in_aoi"].copy()
    inside = np.flatnonzero(in_aoi)
    in_aoi[inside[muscle.hidden(skin.points[inside], skin)]] = False
    aoi = np.flatnonzero(in_aoi)
    region_pos = np.flatnonzero(reg["in_region"][aoi])
    return {"aoi": aoi, "region_pos": region_pos, "lam": reg["lam"][aoi],
            "gamma": reg["gamma"][aoi], "l": reg["l"][aoi], "at": reg["At"][aoi],
            "w": reg["w"][aoi][region_pos], "h": reg["H"][aoi][region_pos],
            "unit_disp": tangential(muscle.unit_displacement(skin.points[aoi]),
                                    normals[aoi])}


def test_muscle_data_from_the_candidates_equal_those_from_every_vertex():
    face = wv.datasets.load_face()
    normals = face._rest.slide_normals
    muscles = list(face.muscles) + [m.replace(compression="gradient") for m in face.muscles
                                    if m.type_name != "linear"][:2]
    for m in muscles:
        got = _MuscleData.build(face.skin, m, normals)
        for key, want in _reference(face.skin, m, normals).items():
            assert np.array_equal(getattr(got, key), want), (m.name, key)


@pytest.mark.parametrize("surface", [sphere(3, 40.0), grid(25, 19, 60.0, bump=15.0)])
def test_shape_operators_at_some_vertices_are_those_rows_of_all(surface):
    ids = np.random.default_rng(1).choice(surface.n_points, surface.n_points // 3,
                                          replace=False)
    assert np.array_equal(shape_operators(surface, at=ids), shape_operators(surface)[ids])


def _laplacian_by_triangles(surface):
    """The cotangent stiffness as it was built: one entry per triangle corner, summed."""
    p, t = surface.points, surface.triangles
    rows, cols, vals = [], [], []
    for k in range(3):
        i, j, o = t[:, (k + 1) % 3], t[:, (k + 2) % 3], t[:, k]
        u, v = p[i] - p[o], p[j] - p[o]
        cross = np.linalg.norm(np.cross(u, v), axis=1)
        cot = np.einsum("ij,ij->i", u, v) / np.maximum(cross, 1e-300)
        rows += [i, j]
        cols += [j, i]
        vals += [-0.5 * cot, -0.5 * cot]
    n = surface.n_points
    off = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                        shape=(n, n))
    return (off - sp.diags(np.asarray(off.sum(axis=1)).ravel())).tocsr()


@pytest.mark.parametrize("surface", [sphere(3, 40.0), grid(25, 19, 60.0, bump=15.0)])
def test_cotangent_stiffness_summed_per_edge_is_the_same(surface):
    got, _ = cotangent_laplacian(surface)
    want = _laplacian_by_triangles(surface)
    assert (got != want).nnz == 0
    assert np.array_equal(got.toarray(), want.toarray())


def test_occlusion_matches_every_ray_against_every_triangle():
    skin = sphere(3, 40.0)
    rng = np.random.default_rng(4)
    pts = skin.points[rng.choice(skin.n_points, 200, replace=False)] * 0.9
    corners = skin.points[skin.triangles]
    for d in rng.normal(size=(4, 3)):
        d /= np.linalg.norm(d)
        want = np.zeros(len(pts), bool)
        for k, p in enumerate(pts):  # Möller-Trumbore on every triangle
            e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
            h = np.cross(d, e2)
            det = np.einsum("ij,ij->i", e1, h)
            with np.errstate(divide="ignore", invalid="ignore"):
                t = p - corners[:, 0]
                u = np.einsum("ij,ij->i", t, h) / det
                q = np.cross(t, e1)
                v = (q @ d) / det
                s = np.einsum("ij,ij->i", e2, q) / det
            want[k] = ((det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (s > 1.0)).any()
        assert want.any()
        assert np.array_equal(occluded(skin, pts, d, 1.0), want)


def test_unique_ids_are_numpys_unique():
    from wrinkle_vis.core.stacked import _unique_ids

    ids = np.random.default_rng(2).integers(0, 500, 3000)
    union, inverse = _unique_ids(ids, return_inverse=True)
    want, want_inverse = np.unique(ids, return_inverse=True)
    assert np.array_equal(union, want) and np.array_equal(inverse, want_inverse)
    assert np.array_equal(_unique_ids(np.zeros(0, np.intp)), np.zeros(0, np.intp))


def test_cli_shows_the_muscles_set_up_of_a_large_face_as_it_goes(capsys, monkeypatch):
    """M12: a big scan's first frame printed nothing while it was set up. (The thresholds
    are lowered so that the built-in face counts as large.)"""
    import wrinkle_vis.cli as cli

    monkeypatch.setattr(cli, "LARGE_SKIN_TRIANGLES", 1000)
    monkeypatch.setattr(cli, "PROGRESS_DELAY_S", 0.0)
    assert cli.main(["summary", "-e", "surprise"]) == 0
    err = capsys.readouterr().err
    n = len(wv.datasets.load_face().muscles)
    assert "wrinkle-vis summary: muscles:" in err and f"/{n} " in err
    monkeypatch.setattr(cli, "LARGE_SKIN_TRIANGLES", 10**9)
    assert cli.main(["summary", "-e", "surprise"]) == 0
    assert capsys.readouterr().err == ""  # a small face: no bar
