import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from meshes import grid, sphere

import wrinkle_vis as wv
from wrinkle_vis.core.refine import bent_triangles, refine_triangles


@given(seed=st.integers(0, 10_000), fraction=st.floats(0.0, 1.0), levels=st.integers(1, 3))
@settings(max_examples=30, deadline=None)
def test_refinement_is_conforming_and_keeps_the_surface(seed, fraction, levels):
    s = sphere(3)
    area = s.triangle_areas().sum()
    rng = np.random.default_rng(seed)
    normals = None
    for _ in range(levels):
        r = refine_triangles(s, rng.random(s.n_triangles) < fraction, normals)
        s, normals = r.surface, r.normals
    rep = s.report()
    assert len(rep.boundary_edges) == 0 and len(rep.non_manifold_edges) == 0  # no T-junction
    assert rep.consistently_oriented and len(rep.degenerate_triangles) == 0
    # new vertices lie near the unit sphere, not on the coarse facets, whose straight
    # midpoints miss it by up to the sagitta
    e = sphere(3).edges
    sag = 1.0 - np.linalg.norm(sphere(3).points[e].mean(axis=1), axis=1).min()
    assert np.abs(np.linalg.norm(s.points, axis=1) - 1.0).max() < 0.2 * sag
    assert area <= s.triangle_areas().sum() < 4 * np.pi


def test_only_marked_triangles_and_their_closure_change():
    g = grid(9, 9)
    r = refine_triangles(g, [40])
    kept = {tuple(t) for t in r.surface.triangles.tolist()}
    untouched = [t for t in g.triangles.tolist() if not set(t) & set(g.triangles[40])]
    assert all(tuple(t) in kept for t in untouched)
    assert r.n_red == 1 and r.n_green == 3  # the three neighbours are bisected
    assert r.surface.n_triangles == g.n_triangles - 4 + 4 + 2 * 3
    np.testing.assert_allclose(r.surface.points[g.n_points:],
                               g.points[r.parents].mean(axis=1))


@given(seed=st.integers(0, 10_000), fraction=st.floats(0.05, 0.5))
@settings(max_examples=30, deadline=None)
def test_no_triangle_keeps_two_split_edges_and_marked_ones_are_red(seed, fraction):
    g = grid(7, 7)
    marked = np.random.default_rng(seed).random(g.n_triangles) < fraction
    r = refine_triangles(g, marked)
    split = {tuple(sorted(p)) for p in r.parents.tolist()}
    n_split = np.array([sum(tuple(sorted((t[i], t[(i + 1) % 3]))) in split for i in range(3))
                        for t in g.triangles.tolist()])
    assert set(n_split.tolist()) <= {0, 1, 3}
    assert np.all(n_split[marked] == 3)
    assert r.n_red == np.count_nonzero(n_split == 3) >= marked.sum()
    assert r.n_green == np.count_nonzero(n_split == 1)


def test_bent_triangles():
    s = sphere(1)
    assert bent_triangles(s, s.points, 5.0).all()  # a coarse sphere bends everywhere
    assert not bent_triangles(s, s.points, 89.0).any()
    g = grid(4, 4)
    assert not bent_triangles(g, g.points, 1.0).any()


@pytest.fixture(scope="module")
def face():
    return wv.datasets.load_face()


def test_refine_off_gives_exactly_the_unrefined_state(face):
    a = face.evaluate("surprise")
    for kwargs in ({"refine": False}, {"refine": True, "refine_levels": 0}):
        b = face.evaluate("surprise", **kwargs)
        np.testing.assert_array_equal(a.points, b.points)
        np.testing.assert_array_equal(a.triangles, b.triangles)
        np.testing.assert_array_equal(a.W, b.W)


@pytest.mark.parametrize("skin", ["geometric", "physical"])
def test_refined_state_is_conforming_and_refines_only_influenced_triangles(face, skin):
    state = face.evaluate("surprise", refine=True, skin=skin)
    base = face.evaluate("surprise", skin=skin)
    assert len(state.triangles) > face.skin.n_triangles
    rep = state.surface().report()
    assert len(rep.boundary_edges) == len(face.skin.report().boundary_edges)
    assert len(rep.non_manifold_edges) == 0 and rep.consistently_oriented
    # regions with no wrinkles keep their triangles: the lower face is untouched
    low = {tuple(t) for t in face.skin.triangles.tolist()
           if face.skin.points[t][:, 1].max() < 0.0}
    kept = {tuple(t) for t in state.triangles.tolist()}
    assert low <= kept
    # only influenced triangles (a corner moved by 0.1 µm or more, or wrinkled) are split;
    # the conforming closure reaches at most one ring further, so triangles two rings away
    # are all kept (the geometric pull leaves most vertices exactly at rest; the physical
    # skin relaxes everywhere, by 1e-12 to 1e-5 mm far from the muscles)
    moved = np.linalg.norm(base.deformed_points - base.rest_points, axis=1)
    influenced = (base.W != 0) | (moved > 1e-4)
    near = influenced.copy()
    for _ in range(2):
        near = near | (face.skin.adjacency @ near.astype(float) > 0)
    far = face.skin.triangles[~near[face.skin.triangles].any(axis=1)]
    assert len(far) > 1000
    assert {tuple(t) for t in far.tolist()} <= kept


def test_fields_at_new_vertices_are_evaluated_exactly(face):
    state = face.evaluate("surprise", refine=True)
    new = np.arange(face.skin.n_points, len(state.rest_points))
    assert len(new)
    for name in ("frontalis_major_L", "frontalis_inner_R"):
        region = face.muscle(name).region(state.rest_points[new])
        f = state.fields[name]
        np.testing.assert_allclose(f["H"][new], region.H, equal_nan=True)
        np.testing.assert_allclose(f["At"][new], region.At, equal_nan=True)
        np.testing.assert_allclose(f["lambda"][new][region.in_aoi], region.lam[region.in_aoi])
        disp = face.muscle(name).unit_displacement(state.rest_points[new])
        assert np.isfinite(disp).all()


def test_refined_skins_are_reused_between_frames(face):
    a = face.evaluate("surprise", refine=True)
    b = face.evaluate("surprise", refine=True)
    assert a.face is b.face


def test_wrinkle_count_equals_n_w_on_surprise_with_refinement(face):
    state = face.evaluate("surprise", refine=True)
    for name in ("frontalis_major_L", "frontalis_inner_R", "frontalis_outer_L"):
        m = face.muscle(name)
        f, s, _ = m.frame
        v = state.rest_points - m.attachment_center
        h_all = state.fields[name]["H"]
        near = (np.abs(v @ s) < 2.0) & np.isfinite(h_all)
        h = h_all[near][np.argsort((v @ f)[near])]
        above = h > 0.5 * (m.d + (m.d - m.k0 * 2**m.alpha))
        assert np.count_nonzero(above[1:] & ~above[:-1]) + int(above[0]) == m.n_wrinkles


def test_bad_refinement_options(face):
    with pytest.raises(ValueError, match="refine_angle_deg"):
        face.evaluate("surprise", refine=True, refine_angle_deg=0)
    with pytest.raises(ValueError, match="refine_levels"):
        face.evaluate("surprise", refine=True, refine_levels=-1)
