"""The refinement engine for animation (core/hierarchy.py, core/refined.py): a hierarchy
built once, frames whose values do not depend on which triangles they split."""

import numpy as np
import pytest
from meshes import sphere as make_sphere

import wrinkle_vis as wv
from wrinkle_vis.core import mesh, refined
from wrinkle_vis.core.hierarchy import (
    Hierarchy,
    canonical_order,
    conforming_triangles,
    corner_angle,
    longest_edge,
    refined_topology,
)
from wrinkle_vis.core.refined import bent


@pytest.fixture(scope="module")
def face():
    return wv.datasets.load_face()


def _hierarchy(surface, depth=3, built=True):
    """The hierarchy of ``surface``; ``built``: all of it, level by level."""
    hier = Hierarchy(surface, surface.vertex_normals(), surface.vertex_normals(),
                     np.zeros((surface.n_points, 3, 3)), depth)
    for level in range(depth if built else 0):
        hier.ensure(np.flatnonzero(hier.node_level == level))
    return hier


def test_neighbour_tables_and_rings_match_the_uniform_subdivision():
    sphere = make_sphere(2)
    hier = _hierarchy(sphere)  # everything, 3 levels
    n_root = sphere.n_triangles
    for level in (1, 2, 3):
        nodes = np.flatnonzero(hier.node_level == level)
        tri = hier.node_tri[nodes]
        uniform = mesh.TriangleSurface(hier.rest, tri)  # the level's uniform mesh
        assert uniform.report().consistently_oriented
        assert len(uniform.report().boundary_edges) == 0
        # the node across each edge shares that edge, traversed the other way
        nbr = hier.node_nbr[nodes]
        assert (nbr >= n_root).all()
        for j in range(3):
            a, b = tri[:, j], tri[:, (j + 1) % 3]
            other = hier.node_tri[nbr[:, j]]
            has = ((other == a[:, None]) | (other == b[:, None])).sum(axis=1)
            assert (has == 2).all()
        # a new vertex's ring is its one-ring in the uniform mesh of its level, in order
        new = np.flatnonzero(hier.level == level)
        adjacency = uniform.adjacency.tolil()
        for v in new[:50]:
            ring = hier.ring[v]
            assert set(ring.tolist()) == set(adjacency.rows[v])
            for j in range(6):  # consecutive ring vertices span a triangle of the level
                t = {v, ring[j], ring[(j + 1) % 6]}
                assert any(set(row) == t for row in tri[(tri == v).any(axis=1)].tolist())


@pytest.mark.parametrize("built", [True, False], ids=["built", "built-as-it-splits"])
def test_the_closure_is_conforming_for_any_split_set(built):
    rng = np.random.default_rng(4)
    sphere = make_sphere(1)
    full = _hierarchy(sphere)
    area = mesh.TriangleSurface(full.rest, full.node_tri[full.node_level == 3]).triangle_areas()
    for _ in range(20):
        hier = _hierarchy(sphere, built=built)
        split = np.zeros(len(hier.node_tri), bool)
        alive = np.arange(sphere.n_triangles)
        for _level in range(3):  # split random leaves, level after level
            pick = alive[rng.random(len(alive)) < 0.3]
            pick = pick[~split[pick] & (hier.node_level[pick] < 3)]
            split, added = refined_topology(hier, split, pick)
            np.testing.assert_array_equal(added[:len(pick)], pick)
            assert split[added].all()
            tris, nodes, present, split_ids = conforming_triangles(hier, split)
            alive = nodes
        rep = mesh.TriangleSurface(hier.rest, tris).report()
        assert len(rep.boundary_edges) == 0 and len(rep.non_manifold_edges) == 0
        assert rep.consistently_oriented
        assert np.isclose(mesh.TriangleSurface(hier.rest, tris).triangle_areas().sum(),
                          area.sum(), rtol=0.05)
        assert hier.final[present[hier.n_root:].nonzero()[0] + hier.n_root].all()
        # the walk from every root meets the split nodes as the walk from the split roots
        np.testing.assert_array_equal(canonical_order(hier, split, split_ids),
                                      canonical_order(hier, split))


def test_a_split_set_that_is_not_closed_is_refused_not_assembled_into_garbage():
    """Two split neighbours of one leaf (which the closure would split) or a split node
    with no children: a clear error, not triangles indexed past their corners."""
    sphere = make_sphere(1)
    hier = _hierarchy(sphere)
    leaf = 0
    a, b = hier.node_nbr[leaf, :2]
    split = np.zeros(len(hier.node_tri), bool)
    split[[a, b]] = True
    with pytest.raises(ValueError, match="not closed.*two or three split neighbours"):
        conforming_triangles(hier, split)
    closed, _ = refined_topology(hier, np.zeros(len(hier.node_tri), bool), np.array([a, b]))
    assert closed[leaf]
    conforming_triangles(hier, closed)  # what the closure makes is taken

    bare = _hierarchy(sphere, built=False)
    split = np.zeros(len(bare.node_tri), bool)
    split[5] = True
    with pytest.raises(ValueError, match="split node 5 has no children.*refined_topology"):
        conforming_triangles(bare, split)


def test_a_split_set_that_breaks_the_level_rule_is_refused_not_assembled_with_a_crack():
    """A corner child of a split root splits while the roots across its parent's edges do
    not: its edge midpoint would hang on their (twice as long) edge. No leaf has two split
    neighbours, so only the level rule sees it; the closure splits those roots."""
    sphere = make_sphere(1)
    hier = _hierarchy(sphere)
    root = 0
    split, _ = refined_topology(hier, np.zeros(len(hier.node_tri), bool), np.array([root]))
    conforming_triangles(hier, split)  # closed: taken
    corner = int(hier.node_child[root])  # the child at corner a: on edges 01 and 20
    across = hier.node_across[corner]
    assert (across >= 0).all() and not split[across].any()
    broken = split.copy()
    broken[corner] = True
    with pytest.raises(ValueError, match=f"not closed: node {corner} split but node "
                                         f"{across[0]}.*level rule.*refined_topology"):
        conforming_triangles(hier, broken)
    closed, _ = refined_topology(hier, split, np.array([corner]))
    assert closed[across].all()
    tris, *_ = conforming_triangles(hier, closed)
    rep = mesh.TriangleSurface(hier.rest, tris).report()
    assert len(rep.boundary_edges) == 0 and len(rep.non_manifold_edges) == 0


def test_skin_vertices_keep_the_unrefined_values_exactly(face):
    for name in ("surprise", "frown", "fear"):
        base = face.evaluate(name, 1.0)
        state = face.evaluate(name, 1.0, refine=True)
        n = face.skin.n_points
        assert len(state.points) > n
        np.testing.assert_array_equal(state.points[:n], base.points)
        np.testing.assert_array_equal(state.W[:n], base.W)


def test_a_vertex_has_the_same_values_whatever_the_frame_splits(face):
    """The frame's values at a vertex do not depend on the topology: two refinements of
    one frame (thresholds 0.5 and 2 degrees) agree wherever they share a vertex."""
    fine = face.evaluate("surprise", 0.8, refine=True, refine_angle_deg=0.5)
    coarse = face.evaluate("surprise", 0.8, refine=True, refine_angle_deg=2.0)
    assert len(fine.points) > len(coarse.points)
    key = {p.tobytes(): i for i, p in enumerate(fine.rest_points)}
    shared = [(key[p.tobytes()], j) for j, p in enumerate(coarse.rest_points)
              if p.tobytes() in key]
    i, j = np.array(shared).T
    assert len(i) > 0.9 * len(coarse.points)
    assert (j >= face.skin.n_points).sum() > 5000  # new vertices in both
    np.testing.assert_allclose(fine.points[i], coarse.points[j], rtol=0, atol=1e-12)
    np.testing.assert_allclose(fine.W[i], coarse.W[j], rtol=0, atol=1e-12)


def test_the_same_frame_gives_the_same_arrays_whatever_came_before(face):
    fresh = wv.datasets.load_face(n_triangles=face.skin.n_triangles)
    for name in ("fear", "frown", "surprise"):
        face.evaluate(name, 0.9, refine=True)
    a = face.evaluate("frown", 0.6, refine=True)
    b = fresh.evaluate("frown", 0.6, refine=True)
    np.testing.assert_array_equal(a.triangles, b.triangles)
    np.testing.assert_array_equal(a.points, b.points)


@pytest.mark.parametrize("rings", [0, 1, 2])
def test_a_frame_is_the_whole_skins_conforming_mesh_whatever_its_zone(monkeypatch, rings):
    """The engine assembles the zone around what the muscles influence, and assembles it
    again, wider, when the closure leaves it (with one ring it does on frown's frames, on
    the graded skin of stop 37: surprise's stay inside; with none, split roots lie outside
    the zone): either way the frame's
    triangles are those of the whole skin's closure, and its split ids (the vertex order)
    those of the whole skin's walk."""
    monkeypatch.setattr(refined, "ZONE_RINGS", rings)
    # the geometric skin: its pulls end at their areas, so the zone is a part of the skin
    face = wv.datasets.load_face().with_skin_model("geometric")
    engine = face._rest.engine(3)
    calls, again = [], []  # conforming_triangles calls; those in _whole (assembled again)
    original = engine._whole

    def whole(*args):
        before = len(calls)
        out = original(*args)
        again.append(len(calls) - before)
        return out

    def counted(*args, **kwargs):
        calls.append(args)
        return conforming_triangles(*args, check=True)  # the engine's sets pass every check

    monkeypatch.setattr(engine, "_whole", whole)
    monkeypatch.setattr(refined, "conforming_triangles", counted)
    for name, t in (("surprise", 0.4), ("surprise", 0.7), ("surprise", 1.0), ("frown", 0.7)):
        root = face.evaluate(name, t)
        active = tuple(m for m in face.muscles if root.activations[m.name] > 0)
        a = np.array([root.activations[m.name] for m in active])
        dyn, tris, split, split_ids = engine.frame(root, active, a, 3.0, 3)
        whole, _, present, walked = conforming_triangles(engine.hier, split)
        np.testing.assert_array_equal(split_ids, walked)  # the zone's walk is the whole's
        assert sorted(map(tuple, np.sort(tris, axis=1))) == \
            sorted(map(tuple, np.sort(whole, axis=1)))
        assert dyn.evaluated[present].all()
    assert any(again) == (rings < 2)


def test_fields_at_new_vertices_add_up_to_the_frame(face):
    state = face.evaluate("fear", 0.9, refine=True)
    total = np.zeros(len(state.points))
    for m in face.muscle_names:
        w = state.fields[m]["W"]
        total += np.nan_to_num(w)
    np.testing.assert_allclose(total, state.W, atol=1e-12)
    eps = state.fields["frontalis_major_L"]["eps"]
    assert np.isfinite(eps[face.skin.n_points:]).any()


def test_the_gradient_option_refines_too(face):
    import dataclasses

    m = face.muscle("frontalis_major_L")
    g = face.with_muscle(dataclasses.replace(m, compression="gradient"))
    state = g.evaluate("surprise", 0.8, refine=True)
    assert len(state.points) > face.skin.n_points
    assert np.isfinite(state.points).all()
    eps = state.fields["frontalis_major_L"]["eps"][face.skin.n_points:]
    assert np.nanmax(eps) > 0.0


def test_the_hierarchy_grows_only_around_what_frames_split():
    """A node has children only where a frame split it, the node across one of its edges,
    or (the level rule) a node across its parent's edges; the rest of the uniform
    subdivision of the touched root triangles is never built."""
    face = wv.datasets.load_face(n_triangles=2000)
    engine = face._rest.engine(3)
    hier = engine.hier
    splits = []
    for name in ("surprise", "frown", "fear"):
        for t in np.linspace(0.1, 1.0, 4):
            face.evaluate(name, t, refine=True)
            splits.append(np.unpackbits(np.frombuffer(engine.last[0][1], np.uint8)))
    n = len(hier.node_tri)
    ever = np.zeros(n, bool)  # split in some frame (a frame's set covers its nodes then)
    for split in splits:
        ever[np.flatnonzero(split[:n])] = True
    allowed = ever.copy()
    nbr = hier.node_nbr[ever].ravel()
    allowed[nbr[nbr >= 0]] = True
    for _ in range(3):  # the nodes across the parents' edges of what is allowed, up
        parents = hier.node_parent[allowed]
        up = hier.node_nbr[parents[parents >= 0]].ravel()
        allowed[up[up >= 0]] = True
    expanded = hier.node_child >= 0
    assert ever.sum() > 500
    assert not (expanded & ~allowed).any()
    assert n == face.skin.n_triangles + 4 * expanded.sum()
    touched = np.unique(hier.node_root[expanded])
    assert n - face.skin.n_triangles < 0.75 * 84 * len(touched)  # whole subtrees: 84 a root


@pytest.mark.parametrize("levels", [1, 2, 4])
def test_other_depths_are_conforming_and_as_deep_as_asked(face, levels):
    state = face.evaluate("frown", refine=True, refine_levels=levels)
    rep = state.surface().report()
    assert len(rep.non_manifold_edges) == 0 and rep.consistently_oriented
    assert len(rep.boundary_edges) == len(face.skin.report().boundary_edges)
    hier = face._rest.engine(levels).hier
    used = hier.level[face._rest.engine(levels).last[2]]
    assert used.max() == levels  # the deepest level is reached, no deeper


def test_a_triangle_splits_for_the_bend_the_expression_adds_not_the_rest_skins():
    """The rest skin's own curvature does not count: a coarse sphere bends 30 degrees or so
    across every triangle, yet nothing splits until its surface is bent further."""
    s = make_sphere(1)
    hier = _hierarchy(s, depth=1)
    rest_bend = hier.node_bend[:s.n_triangles]
    points = np.ascontiguousarray(s.points.T)
    everywhere = np.ones(s.n_triangles, bool)
    assert np.degrees(rest_bend).min() > 20.0
    assert bent(s.triangles, points, 5.0, everywhere).all()
    assert not bent(s.triangles, points, 5.0, everywhere, rest_bend).any()
    bumped = points.copy()
    bumped[:, 0] *= 1.5  # one vertex pushed out: its triangles bend further
    marked = bent(s.triangles, bumped, 5.0, everywhere, rest_bend)
    touching = (s.triangles == 0).any(axis=1)
    assert marked[touching].all()
    far = ~np.isin(s.triangles, s.triangles[touching]).any(axis=1)  # no corner near it
    assert far.any() and not marked[far].any()


def test_a_faint_expression_does_not_split_the_rest_skins_curvature(face):
    """Surprise at 1/30: the muscles move the forehead, but no furrow bends it yet."""
    state = face.evaluate("surprise", 1 / 30, refine=True)
    assert state.triangles.shape == face.skin.triangles.shape


def test_wrinkles_finer_than_the_triangles_split_them_until_they_are_sampled(face):
    """The corrugators' half period u (Eq. 6) is shorter than the face's edges. After
    refinement, hardly a triangle with a corner they wrinkle is both longer than u / 2 and
    deep enough there to bend the skin across it by more than the threshold
    (|W| pi^2 h / u^2; the few left are leaves a level's closure made after that level's
    test); without the rule, the curvature test alone missed one side's furrows. Where
    the furrows are deepest, the edges are at most u / 2."""
    corrugators = [m for m in face.muscles if m.name.startswith("corrugator")]
    u = min(float(m.u) for m in corrugators)
    assert np.median(face.skin.rest_edge_lengths) > u
    theta = np.radians(3.0)
    for intensity in (0.1, 0.5, 1.0):
        state = face.evaluate("frown", intensity, refine=True)
        region = np.zeros(state.n_points, bool)
        for m in corrugators:
            region |= np.isfinite(state.fields[m.name]["H"])
        tris = state.triangles[(region & (state.W != 0.0))[state.triangles].any(axis=1)]
        h = longest_edge(state.rest_points, tris)
        depth = np.where(region, np.abs(state.W), 0.0)[tris].max(axis=1)
        coarse = (2.0 * h > u) & (depth * np.pi ** 2 * h > theta * u * u)
        assert len(tris) > 300 and coarse.mean() < 0.03, (intensity, coarse.mean())
    deepest = depth > 0.5 * depth.max()
    assert deepest.sum() > 50 and h[deepest].max() <= u / 2


def test_node_bend_and_edge_are_their_triangles():
    """Built child by child from shared points and edges, they equal the direct formulas."""
    s = make_sphere(2)
    hier = _hierarchy(s, built=False)
    for level in range(3):  # a third of the root triangles' subtrees, and what they border
        hier.ensure(np.flatnonzero((hier.node_level == level) & (hier.node_root % 3 == 0)))
    np.testing.assert_allclose(hier.node_bend, corner_angle(hier.normal, hier.node_tri),
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(hier.node_edge, longest_edge(hier.rest, hier.node_tri),
                               rtol=0, atol=1e-12)
    assert len(hier.node_tri) > 20 * s.n_triangles // 3


def test_the_muscles_rows_extended_as_the_hierarchy_grows_are_those_built_at_once(
        monkeypatch):
    """Frames of several expressions grow the hierarchy; each active set's rows, extended
    with every growth, equal the rows built in one go from the muscles' data."""
    from wrinkle_vis.core.refined import _RefinedRows

    extended = []
    extend = _RefinedRows.extend
    monkeypatch.setattr(_RefinedRows, "extend",
                        lambda self, *a: extended.append(extend(self, *a)) or extended[-1])
    face = wv.datasets.load_face(n_triangles=2000)
    for name, t in (("frown", 0.3), ("fear", 0.5), ("surprise", 0.4), ("frown", 1.0),
                    ("surprise", 1.0)):
        face.evaluate(name, t, refine=True)
    assert sum(extended) >= 5  # rows were extended in place, not only built anew
    engine = face._rest.engine(3)
    keys = [k for k in engine.cache._entries if k[0] == "assembly"]
    assert len(keys) >= 2
    for _, muscles in keys:
        asm = engine.assembly(muscles)
        fresh = _RefinedRows(engine.hier, [engine.levels(m) for m in muscles])
        assert asm.version == fresh.version
        for name in ("moved", "muscle", "unit", "weights", "hat", "slot", "influenced"):
            np.testing.assert_array_equal(getattr(asm, name), getattr(fresh, name))
        n0 = engine.hier.n_root
        np.testing.assert_array_equal(asm.half_period[n0:], fresh.half_period[n0:])
        assert len(asm.unfinished) == (~engine.hier.final[asm.moved]).sum()
