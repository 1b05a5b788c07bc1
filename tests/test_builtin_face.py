import numpy as np
import pytest

import wrinkle_vis as wv


@pytest.fixture(scope="module")
def face():
    return wv.datasets.load_face()


def test_builtin_face_is_a_clean_paper_sized_skin(face):
    assert 4000 <= face.skin.n_triangles <= 5000
    rep = face.skin.report()
    assert rep.n_components == 1 and len(rep.non_manifold_edges) == 0
    assert len(rep.degenerate_triangles) == 0 and rep.consistently_oriented
    # outward: normals on the forehead look forwards (+z)
    n = face.skin.vertex_normals()
    fore = (np.abs(face.skin.points[:, 0]) < 20) & (np.abs(face.skin.points[:, 1] - 50) < 10)
    assert fore.any() and np.all(n[fore, 2] > 0.5)


def test_builtin_face_is_deterministic_and_cached(face):
    again = wv.datasets.load_face()
    np.testing.assert_array_equal(again.skin.points, face.skin.points)
    np.testing.assert_array_equal(again.skin.triangles, face.skin.triangles)


def test_builtin_face_has_paired_muscles_for_the_paper_expressions(face):
    for ex in ("surprise", "frown", "fear"):
        for m in face.expressions[ex].activations:
            face.muscle(m)
    names = set(face.muscle_names)
    assert all(n[:-2] + "_R" in names for n in names if n.endswith("_L"))


@pytest.mark.parametrize("expression", ["surprise", "frown", "fear"])
def test_paper_expressions_wrinkle_the_upper_face_only(face, expression):
    state = face.evaluate(expression)
    wrinkled = face.skin.points[state.W != 0]
    assert len(wrinkled) > 0
    assert wrinkled[:, 1].min() > 0.0  # above the eyes' centre line: brows and forehead


def test_bad_resolution(face):
    with pytest.raises(ValueError, match="n_triangles"):
        wv.datasets.load_face(10)


def test_skull_is_closed_and_inside_the_skin_with_regional_gaps(face):
    from wrinkle_vis.core.mesh import closest_points
    from wrinkle_vis.datasets import anatomy
    from wrinkle_vis.datasets.face import _on_skin

    rep = face.skull.report()
    assert len(rep.boundary_edges) == 0 and rep.n_components == 1
    assert anatomy.skin_sdf(face.skull.points).max() < -1.0  # strictly inside, > 1 mm
    gaps = {}
    for name, pos, depth in anatomy.TISSUE_DEPTHS:
        if pos[2] <= 40:
            continue
        s = _on_skin(pos[0], pos[1])
        gaps[name] = float(np.linalg.norm(closest_points(face.skull, s[None])[0] - s))
        assert abs(gaps[name] - depth) < 5.0, (name, gaps[name], depth)
    assert gaps["mid_cheek"] > gaps["upper_lip"] > gaps["glabella"] > gaps["supraglabella"]


def test_attachments_on_the_skull_and_insertions_on_the_skin(face):
    from wrinkle_vis.core.mesh import closest_points

    for m in face.muscles:
        for p in m.point_parameters:
            pts = np.asarray(getattr(m, p)).reshape(-1, 3)
            surf = face.skull if p.startswith("attachment") else face.skin
            assert np.linalg.norm(closest_points(surf, pts) - pts, axis=1).max() < 0.75


def test_triangles_are_well_shaped_and_even(face):
    p, t = face.skin.points, face.skin.triangles
    e = [p[t[:, (i + 1) % 3]] - p[t[:, i]] for i in range(3)]
    cos = [np.einsum("ij,ij->i", -e[i - 1], e[i]) / np.linalg.norm(e[i - 1], axis=1)
           / np.linalg.norm(e[i], axis=1) for i in range(3)]
    min_angle = np.degrees(np.arccos(np.clip(np.max(cos, axis=0), -1, 1)))
    assert min_angle.min() > 20.0
    lengths = face.skin.rest_edge_lengths
    assert lengths.std() / lengths.mean() < 0.25


@pytest.mark.slow
def test_finer_resolution_has_the_same_shape_and_muscles(face):
    fine = wv.datasets.load_face(20000)
    assert 18000 <= fine.skin.n_triangles <= 22000
    assert fine.muscles == face.muscles
    lo0, hi0 = face.skin.bounds()
    lo1, hi1 = fine.skin.bounds()
    np.testing.assert_allclose(lo1, lo0, atol=2.0)
    np.testing.assert_allclose(hi1, hi0, atol=2.0)


@pytest.mark.slow
def test_wrinkle_count_along_the_frontalis_central_fibre_equals_n_w():
    face = wv.datasets.load_face(60000)
    state = face.evaluate("surprise")
    for name in ("frontalis_major_L", "frontalis_inner_R"):
        m = face.muscle(name)
        f, s, _ = m.frame
        v = face.skin.points - m.attachment_center
        near = (np.abs(v @ s) < 1.0) & np.isfinite(state.fields[name]["H"])
        l = (v @ f)[near]
        h = state.fields[name]["H"][near]
        order = np.argsort(l)
        l, h = l[order], h[order]
        # crests: where H rises above the middle of its range and falls back
        above = h > 0.5 * (m.d + (m.d - m.k0 * 2**m.alpha))
        crests = np.count_nonzero(above[1:] & ~above[:-1]) + int(above[0])
        assert crests == m.n_wrinkles, (name, crests)
        assert l.max() - l.min() > 0.9 * (1 - m.lambda_w) * m.wrinkle_length


def _furrow_direction(muscle):
    """Furrows run across the fibre: lines of constant l."""
    fibre = muscle.frame[0] if hasattr(muscle, "frame") else muscle.fibre
    return np.cross(fibre, [0.0, 0.0, 1.0])  # on a face looking at +z


@pytest.mark.parametrize(("expression", "directions"),
                         [("surprise", {"horizontal"}), ("frown", {"vertical"}),
                          ("fear", {"horizontal", "vertical"})])
def test_furrows_run_the_way_the_paper_shows(face, expression, directions):
    found = set()
    state = face.evaluate(expression)
    for name, a in state.activations.items():
        if a == 0:
            continue
        d = _furrow_direction(face.muscle(name))
        d /= np.linalg.norm(d)
        assert np.abs(state.fields[name]["W"][np.isfinite(state.fields[name]["W"])]).max() > 0
        found.add("horizontal" if abs(d[0]) > 0.8 else "vertical" if abs(d[1]) > 0.8 else "?")
    assert found == directions
