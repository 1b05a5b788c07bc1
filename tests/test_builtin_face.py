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
    # a nanometre: the physical skin's solve leaves |W| of 1e-13 mm where the corrugators'
    # regions reach below the eyes' line (the geometric skin's W is exactly 0 there)
    wrinkled = face.skin.points[np.abs(state.W) > 1e-6]
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

    # points only: a sheet's lines set its frame, shared by the six frontalis (next test)
    points = [(m, p) for m in face.muscles for p in m.point_parameters
              if np.ndim(getattr(m, p)) == 1]
    assert len(points) == 33  # 12 linear muscles' ends, 3 sphincters' centres and axis ends
    for m, p in points:
        pts = np.asarray(getattr(m, p)).reshape(-1, 3)
        surf = face.skull if m.point_surfaces()[p] == "skull" else face.skin
        assert np.linalg.norm(closest_points(surf, pts) - pts, axis=1).max() < 0.75


def test_the_frontalis_sheets_share_one_frame_so_their_furrows_join(face):
    """Same fibre, across axis, origin of l, L_s, lambda_w and n_w: one w and H field."""
    sheets = [m for m in face.muscles if m.name.startswith("frontalis")]
    assert len(sheets) == 6
    f0, s0, _ = sheets[0].frame
    for m in sheets:
        f, s, _ = m.frame
        np.testing.assert_allclose(f, f0, atol=1e-12)
        np.testing.assert_allclose(np.abs(s @ s0), 1.0, atol=1e-12)
        assert m.attachment_center @ f == pytest.approx(sheets[0].attachment_center @ f0)
        assert (m.length_value, m.lambda_w, m.n_wrinkles) == (
            sheets[0].length_value, sheets[0].lambda_w, sheets[0].n_wrinkles)
    rest = face.skin.points
    w = [m.region(rest)["w"] for m in sheets]
    both = np.isfinite(w[0]) & np.isfinite(w[2])  # inner_L and major_L overlap
    assert both.any()
    np.testing.assert_allclose(w[0][both], w[2][both], atol=1e-9)


def test_neighbouring_frontalis_sheets_lift_the_forehead_as_one(face):
    """Their falls across the fibre overlap exactly and add up to one: between x = -44 and
    44 the six sheets pull like one sheet, -K r(l) f, with no seam where they meet.
    """
    from wrinkle_vis.core.muscle import ramp_fall

    sheets = [m for m in face.muscles if m.name.startswith("frontalis")]
    rest = face.skin.points
    total = sum(m.unit_displacement(rest) for m in sheets)
    m = sheets[0]
    f = m.frame[0]
    l = (rest - m.attachment_center) @ f
    one = -m.strength * ramp_fall(l, m.fall_start_value, m.length_value)[:, None] * f
    deep = [np.abs((rest - s.attachment_center) @ s.frame[2]) < 0.5 * s.depth_value
            for s in sheets]
    inside = (np.abs(rest[:, 0]) <= 44.0) & np.all(deep, axis=0) & (
        np.abs(one).max(axis=1) > 0)
    assert inside.sum() > 200
    np.testing.assert_allclose(total[inside], one[inside], atol=1e-9)


def test_triangles_are_well_shaped_and_even(face):
    p, t = face.skin.points, face.skin.triangles
    e = [p[t[:, (i + 1) % 3]] - p[t[:, i]] for i in range(3)]
    cos = [np.einsum("ij,ij->i", -e[i - 1], e[i]) / np.linalg.norm(e[i - 1], axis=1)
           / np.linalg.norm(e[i], axis=1) for i in range(3)]
    min_angle = np.degrees(np.arccos(np.clip(np.max(cos, axis=0), -1, 1)))
    assert min_angle.min() > 20.0
    # even where the mesh density is 1 (all but the lips, finer, and the crown and the
    # sides of the head, coarser: datasets.face.mesh_density)
    from wrinkle_vis.datasets.face import mesh_density

    lengths = face.skin.rest_edge_lengths
    even = lengths[mesh_density(p[face.skin.edges].mean(axis=1)) == 1.0]
    assert len(even) > 0.4 * len(lengths)
    assert even.std() / even.mean() < 0.25


@pytest.mark.slow
def test_finer_resolution_has_the_same_shape_and_muscles(face, procedural_at):
    fine = procedural_at(20000)
    assert 18000 <= fine.skin.n_triangles <= 22000
    assert fine.muscles == face.muscles
    lo0, hi0 = face.skin.bounds()
    lo1, hi1 = fine.skin.bounds()
    np.testing.assert_allclose(lo1, lo0, atol=2.0)
    np.testing.assert_allclose(hi1, hi0, atol=2.0)


@pytest.mark.slow
def test_wrinkle_count_along_the_frontalis_central_fibre_equals_n_w(procedural_at):
    face = procedural_at(60000)
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
