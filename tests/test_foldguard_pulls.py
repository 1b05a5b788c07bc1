"""The pulls' guard's rounds (stop 40) give what the code they replaced gave, bit for bit: the
scaled pull and its lengths kept per changed vertex, the changed triangles' terms taken by
take (as rows once many change), the changed edges deduplicated by a mark, the search
graph's structure grouped by a CSR transpose instead of a sort; ``skin_scale`` against the
rounds as they were, on random pulled sheets. Stop 41: the clamp's certificate past a scaled
pull and on the frame evaluated again, against the exact checks; the pulled triangles' rows
taken from every row, against those computed alone."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from wrinkle_vis.core.foldguard import FoldGuard, pulls
from wrinkle_vis.core.foldguard._base import soft_clamp


def _sheet(nx: int, ny: int, rng: np.random.Generator):
    """A jittered ``nx x ny`` grid sheet, two triangles a cell (some flipped)."""
    x, y = np.meshgrid(np.linspace(-5, 5, nx), np.linspace(-5, 5, ny))
    pts = np.c_[x.ravel(), y.ravel(), 0.02 * (x * x).ravel()]
    pts += 0.02 * rng.standard_normal(pts.shape)
    idx = np.arange(nx * ny).reshape(ny, nx)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    return pts, np.r_[np.c_[a, b, c], np.c_[a, c, d]]


def _old_edge_structure(edges: np.ndarray, n: int) -> dict:
    """``_edge_structure`` as it was (the grouping by second end by a stable argsort)."""
    a, b = edges[:, 0], edges[:, 1]
    m = len(a)
    into, out_ = np.bincount(b, minlength=n), np.bincount(a, minlength=n)
    indptr = np.concatenate([[0], np.cumsum(into + out_), [2 * m + n]])
    ids = np.arange(m)
    by_b = np.argsort(b, kind="stable")
    first_in = np.cumsum(into) - into
    rev = np.empty(m, dtype=np.intp)
    rev[by_b] = indptr[b[by_b]] + ids - first_in[b[by_b]]
    fwd = indptr[a] + into[a] + ids - (np.cumsum(out_) - out_)[a]
    indices = np.empty(2 * m + n, dtype=np.int32)
    indices[rev], indices[fwd], indices[2 * m:] = a, b, np.arange(n)
    slot = np.empty(2 * m, dtype=np.int32)
    slot[rev], slot[fwd] = ids, ids
    return {"indices": indices, "indptr": indptr.astype(np.int32), "slot": slot,
            "slots": np.stack([fwd, rev]).astype(np.int32)}


def _old_update(b, c, low, pull_t, f, changed, corners, rows_terms, top):
    """``_update`` as it was: the changed triangles by a mark over every vertex, gathered by
    fancy indexing, the pull times the factors on the fly."""
    mark = np.zeros(len(f), bool)
    mark[changed] = True
    c0, c1, c2 = corners
    redo = np.flatnonzero(mark[c0] | mark[c1] | mark[c2])
    Nt, A1, A2, a0 = rows_terms
    b[redo], c[redo] = pulls._quadratic(pull_t, corners[:, redo], Nt[:, redo], A1[:, redo],
                                        A2[:, redo], f)
    low[redo] = a0[redo] - 1.0 + pulls._lowest_sigma(b[redo], c[redo], top)


def _old_reweigh(graph, changed, lift_of):
    """``_reweigh`` as it was: the changed edges by a mark over every edge."""
    at = pulls._ranges(graph["indptr"], changed)
    mark = np.zeros(len(graph["w"]), bool)
    mark[graph["slot"][at]] = True
    j = np.flatnonzero(mark)
    w = pulls._weights(graph, j, lift_of)
    graph["w"][j] = w
    graph["mat"].data[graph["slots"][0, j]] = w
    graph["mat"].data[graph["slots"][1, j]] = w


def _old_skin_scale(rest, deformed, tri, min_area=0.2, knee=0.5, iterations=20, reach=4.0,
                    start=None):
    """``skin_scale`` as it was (its rounds scanning every pulled triangle and edge)."""
    terms = pulls.pull_terms(rest, tri)
    base = rest if start is None else start
    pull_t = np.ascontiguousarray((deformed - base).T)
    f = np.ones(len(rest))
    size = np.sqrt((pull_t * pull_t).sum(axis=0))
    top = 1.0 / knee
    rows, corners, Nt, a0, A1, A2 = pulls._pulled_triangles(terms, size > 0, base, start)
    if not len(rows):
        return f
    b, c = pulls._quadratic(pull_t, corners, Nt, A1, A2)
    low = pulls._lowest_sigma(b, c, top) if start is None else \
        a0 - 1.0 + pulls._lowest_sigma(b, c, top)
    graph = None
    for _ in range(iterations):
        bad = np.flatnonzero(low < min_area)
        if not len(bad):
            break
        if graph is None:
            graph = pulls._edge_graph(size, terms, reach)
        s_star = pulls._first_root(np.maximum(a0[bad] - min_area, 1e-12), b[bad], c[bad])
        limit = pulls._limits(s_star, corners[:, bad].T, graph, top)
        near = np.flatnonzero(limit < top)
        step = soft_clamp(np.ones(len(near)), limit[near], knee)
        if np.all(step == 1.0):
            break
        f[near] *= step
        changed = near[step != 1.0]
        _old_update(b, c, low, pull_t, f, changed, corners, (Nt, A1, A2, a0), top)
        _old_reweigh(graph, changed, f * size)
    return f


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(2, 300), m=st.integers(0, 900))
def test_the_edges_grouped_by_second_end_are_the_stable_argsort(seed, n, m):
    rng = np.random.default_rng(seed)
    e = np.sort(rng.integers(0, n, size=(m, 2)), axis=1)
    e = np.unique(e[e[:, 0] != e[:, 1]], axis=0)  # sorted by first end, then second
    got = pulls._by_second_end(e[:, 0], e[:, 1], np.bincount(e[:, 0], minlength=n), n)
    np.testing.assert_array_equal(got, np.argsort(e[:, 1], kind="stable"))
    new, old = pulls._edge_structure(e, n), _old_edge_structure(e, n)
    for key in old:
        np.testing.assert_array_equal(new[key], old[key], err_msg=key)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), size=st.integers(1, 5000), count=st.integers(0, 400))
def test_the_distinct_ids_are_those_a_mark_gives(seed, size, count):
    rng = np.random.default_rng(seed)
    ids = rng.integers(0, size, count).astype(rng.choice([np.int32, np.intp]))
    got = pulls._distinct(ids, size)
    assert got.dtype == np.intp
    np.testing.assert_array_equal(got, np.unique(ids))


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 60), count=st.integers(0, 60))
def test_the_ranges_are_the_rows_entries(seed, n, count):
    rng = np.random.default_rng(seed)
    indptr = np.concatenate([[0], np.cumsum(rng.integers(0, 5, n))]).astype(np.int32)
    rows = rng.integers(0, n, count)
    want = np.concatenate([np.arange(indptr[v], indptr[v + 1]) for v in rows] + [[]])
    got = pulls._ranges(indptr, rows)
    assert got.dtype == np.intp
    np.testing.assert_array_equal(got, want)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), start=st.booleans())
def test_the_update_with_a_kept_scaled_pull_matches_the_old_one(seed, start):
    """Rounds of random factor changes, few or many vertices at a time: ``_update`` (the
    scaled pull kept, the terms taken by column or, once many change, as rows) and the old
    one give the same b, c and least areas, bit for bit."""
    rng = np.random.default_rng(seed)
    pts, tri = _sheet(int(rng.integers(3, 12)), int(rng.integers(3, 12)), rng)
    terms = pulls.pull_terms(pts, tri)
    pull_t = np.ascontiguousarray(rng.normal(scale=0.5, size=pts.shape).T)
    pull_t[:, rng.random(len(pts)) < 0.3] = 0.0
    size = np.sqrt((pull_t * pull_t).sum(axis=0))
    base = pts + rng.normal(scale=0.1, size=pts.shape) if start else pts
    rows, corners, Nt, a0, A1, A2 = pulls._pulled_triangles(terms, size > 0, base,
                                                            base if start else None)
    b, c = pulls._quadratic(pull_t, corners, Nt, A1, A2)
    low = a0 - 1.0 + pulls._lowest_sigma(b, c, 2.0)
    old = (b.copy(), c.copy(), low.copy())
    f, scaled = np.ones(len(pts)), pull_t.copy()
    cache: dict = {}
    for _ in range(4):
        changed = np.flatnonzero(rng.random(len(pts)) < rng.choice([0.02, 0.3, 1.0]))
        f[changed] *= rng.uniform(0.1, 1.0, len(changed))
        scaled[:, changed] = np.take(pull_t, changed, axis=1) * f[changed]
        pulls._update(b, c, low, scaled, changed, corners, (Nt, A1, A2, a0), 2.0, cache)
        _old_update(*old, pull_t, f, changed, corners, (Nt, A1, A2, a0), 2.0)
        for got, want in zip((b, c, low), old, strict=True):
            np.testing.assert_array_equal(got, want)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), held=st.booleans())
def test_the_factors_are_those_of_the_old_rounds(seed, held):
    """``skin_scale`` on random pulled sheets (a pull dragging skin over its neighbour, from
    the rest skin or from a skin of its own) against its rounds as they were."""
    rng = np.random.default_rng(seed)
    pts, tri = _sheet(int(rng.integers(6, 22)), int(rng.integers(6, 22)), rng)
    pull = np.zeros_like(pts)
    centre = rng.uniform(-3, 3)
    pull[:, 0] = -rng.uniform(2, 8) * np.exp(-((pts[:, 0] - centre) / rng.uniform(0.5, 2))
                                            ** 2)
    pull[rng.random(len(pts)) < 0.1] = 0.0
    start = pts + rng.normal(scale=0.05, size=pts.shape) if held else None
    base = pts if start is None else start
    got = pulls.skin_scale(pts, base + pull, tri, start=start)
    want = _old_skin_scale(pts, base + pull, tri, start=start)
    np.testing.assert_array_equal(got, want)


def test_a_sheet_the_guard_acts_on_takes_the_new_rounds():
    """The random sheets above do reach the rounds: the guard scales a pull of theirs."""
    rng = np.random.default_rng(3)
    pts, tri = _sheet(20, 20, rng)
    pull = np.zeros_like(pts)
    pull[:, 0] = -8.0 * np.exp(-(pts[:, 0] / 1.0) ** 2)
    f = pulls.skin_scale(pts, pts + pull, tri)
    assert f.min() < 0.9
    np.testing.assert_array_equal(f, _old_skin_scale(pts, pts + pull, tri))


FIELDS = ("points", "W", "deformed_points", "fold_guard", "W_raw", "fields")


def _no_certificates(monkeypatch) -> None:
    """Every certificate of the guard off: ``certify`` and the fresh frame's clamp
    certificate (``_clamp_only``, looked up in ``foldguard.frame``) answer None."""
    from wrinkle_vis.core import foldguard

    monkeypatch.setattr(foldguard.frame, "certify", lambda *a, **k: None)
    monkeypatch.setattr(foldguard.frame, "_clamp_only", lambda *a, **k: None)


def _same_frames(a, b) -> bool:
    def same(x, y) -> bool:
        if isinstance(x, dict):
            return x.keys() == y.keys() and all(same(x[k], y[k]) for k in x)
        if hasattr(x, "__dataclass_fields__"):
            return all(same(getattr(x, k), getattr(y, k)) for k in x.__dataclass_fields__)
        return np.array_equal(np.asarray(x), np.asarray(y))

    return all(same(getattr(a, k), getattr(b, k)) for k in FIELDS)


@pytest.mark.slow
def test_a_scaled_pulls_frames_keep_the_clamps_certificate_and_are_exact(wv_head,
                                                                         monkeypatch):
    """Where the pull guard scales a pull on the face's own skin (the head's smile), the
    clamp's certificate is kept for the frame's raw W and the frame evaluated again on the
    guarded skin gets its own (``_clamp_only``): the frames are bit for bit those of the
    exact checks, with the default guard (the clamp certified, not acting) and with one
    whose clamp acts; a certificate that wrongly says the clamp cannot act is seen."""
    from wrinkle_vis.core import foldguard

    face = wv_head.with_skin_model("geometric")
    acts = face.activations_for("smile", 1.0)
    for guard in (FoldGuard(), FoldGuard(eta=0.05)):
        raw = face.evaluate(acts, fold_guard=False)
        got = face.guarded(face.evaluate(acts, fold_guard=False), guard)
        assert np.any(got.deformed_points != raw.deformed_points)  # a pull was scaled
        with monkeypatch.context() as m:
            _no_certificates(m)
            want = face.guarded(face.evaluate(acts, fold_guard=False), guard)
        assert _same_frames(got, want), guard
    with monkeypatch.context() as m:  # the clamp acts (eta 0.05): a wrong skip differs
        m.setattr(foldguard.frame, "_clamp_only",
                  lambda *a, **k: foldguard.Certified(False, False, False, True))
        wrong = face.guarded(face.evaluate(acts, fold_guard=False), FoldGuard(eta=0.05))
    assert not _same_frames(wrong, want)


@pytest.mark.parametrize("eta", [0.9, 0.02])
def test_a_scaled_pull_keeps_the_clamps_certificate_only_where_it_holds(eta):
    """``guard_frame`` on a sheet whose pull the guard scales: the clamp's certificate
    (``|W| <= (1 - 1e-5) knee eta r`` on the rest radii, whatever the pull) kept past the
    scaling gives the frame of no certificate, bit for bit, where it holds (the clamp is
    the identity) and where it does not (the clamp acts: ``eta`` 0.02)."""
    from wrinkle_vis.core.foldguard import Certified, guard_frame
    from wrinkle_vis.core.foldguard._base import _vertex_normals

    rng = np.random.default_rng(3)
    pts, tri = _sheet(20, 20, rng)
    pull = np.zeros_like(pts)
    pull[:, 0] = -8.0 * np.exp(-(pts[:, 0] / 1.0) ** 2)
    deformed = pts + pull
    W = 0.05 * np.sin(pts[:, 1]) * (np.abs(pts[:, 0]) < 3)
    terms = pulls.pull_terms(pts, tri)
    n = _vertex_normals(deformed, tri, np.arange(len(pts)), terms)
    points = deformed + W[:, None] * n
    radii = np.full((len(pts), 2), 0.5)
    guard = FoldGuard(eta=eta)
    clamp = bool(np.all(np.abs(W) <= (1 - 1e-5) * guard.knee * guard.eta * 0.5))
    assert clamp == (eta > 0.5)
    got = guard_frame(pts, deformed, points, W, tri, radii, guard, terms=terms,
                      certified=Certified(False, False, False, clamp))
    want = guard_frame(pts, deformed, points, W, tri, radii, guard,
                       terms=pulls.pull_terms(pts, tri))
    assert got.scale.min() < 0.9  # the pull is scaled
    assert clamp or np.any(got.W != W)  # (eta 0.02: the clamp acts)
    for k in ("deformed", "points", "W", "scale", "acted"):
        np.testing.assert_array_equal(getattr(got, k), getattr(want, k), err_msg=k)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), share=st.floats(0.0, 1.0), normals_only=st.booleans())
def test_the_pulled_triangles_terms_taken_from_every_row_are_those_computed_alone(
        seed, share, normals_only):
    """``_triangles_of`` on fresh terms, whatever share of the triangles is pulled (above
    three quarters every row is found and the pulled ones taken, ``_columns``): the values
    and memory layout (einsum's sums follow it) of the pulled triangles' rows computed on
    their own, as before (so every sum on them is the same)."""
    rng = np.random.default_rng(seed)
    pts, tri = _sheet(int(rng.integers(3, 14)), int(rng.integers(3, 14)), rng)
    moving = rng.random(len(pts)) < share
    terms = pulls.pull_terms(pts, tri)
    got = pulls._triangles_of(terms, moving, normals_only)
    corners = np.ascontiguousarray(tri.T)
    rows = np.flatnonzero(moving[corners].any(axis=0))
    if len(rows) == len(tri):  # (every triangle: the terms themselves, as before)
        want = (rows, corners, *pulls._row_terms(pts, corners))
    else:
        want = (rows, corners[:, rows],
                *pulls._row_terms(pts, corners[:, rows], normals_only, order="F"))
    for a, b in zip(got, want, strict=False):
        if a is None:
            continue
        assert np.array_equal(a, b)
        assert (a.flags.c_contiguous, a.flags.f_contiguous) == \
            (b.flags.c_contiguous, b.flags.f_contiguous)


@pytest.mark.slow
@pytest.mark.parametrize("skin", ["geometric", "physical"])
def test_a_clamp_certified_at_some_vertices_searches_the_others_alone(skin, monkeypatch):
    """The refined pucker at full intensity with a guard whose clamp acts on the rest radii
    (eta 0.2): its certificate fails at some of the 13,000 wrinkled vertices (``clamp_ok``),
    so the rest radii are searched at those alone and the others are given no bound; the
    frame is bit for bit that of the exact checks (every radius searched), and a mask that
    wrongly passes every vertex changes it."""
    import wrinkle_vis as wv
    from wrinkle_vis.core import foldguard

    guard = FoldGuard(eta=0.2)
    fast, exact = wv.datasets.load_face(), wv.datasets.load_face()
    raw = fast.evaluate("pucker", refine=True, skin=skin, fold_guard=False)
    cert = foldguard.certify(fast, raw, guard)
    assert not cert.clamp and 0 < np.count_nonzero(~cert.clamp_ok) < np.count_nonzero(raw.W) / 4
    got = fast.evaluate("pucker", refine=True, skin=skin, fold_guard=guard)
    with monkeypatch.context() as m:
        _no_certificates(m)
        want = exact.evaluate("pucker", refine=True, skin=skin, fold_guard=guard)
    assert _same_frames(got, want)
    wrong = foldguard.Certified(False, False, False, False, clamp_ok=np.ones(len(got.W), bool))
    with monkeypatch.context() as m:
        m.setattr(foldguard.frame, "certify", lambda *a, **k: wrong)
        bad = wv.datasets.load_face().evaluate("pucker", refine=True, skin=skin,
                                               fold_guard=guard)
    assert not _same_frames(bad, want)


def _old_skin_edges(corners: np.ndarray, n: int) -> np.ndarray:
    """``_skin_edges`` as it was (stop 41): one sort of a key min * n + max per side."""
    a, b = corners.ravel(), np.roll(corners, -1, axis=0).ravel()
    key = np.unique(np.minimum(a, b).astype(np.int64) * n + np.maximum(a, b))
    return np.stack([key // n, key % n], axis=1).astype(np.intp)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 80), m=st.integers(0, 120),
       repeat=st.sampled_from([1, 2, 256, 300]))
def test_the_skins_edges_from_a_csr_matrix_are_those_of_the_sorted_keys(seed, n, m, repeat):
    """Stop 42: the unique sides of the triangles, merged by a CSR matrix's
    ``sum_duplicates`` (boolean entries), are those one sort of keys gives, in the same
    order, with triangles that repeat a corner (an edge from a vertex to itself) and a
    triangle repeated up to 300 times (a side met 600 times: a count in 8 bits would wrap
    to 0 and drop it); and the rest lengths are ``norm(rest[a] - rest[b])`` bit for bit."""
    from wrinkle_vis.core.foldguard import _base

    rng = np.random.default_rng(seed)
    tri = rng.integers(0, n, (m, 3))
    if m:
        tri = np.r_[tri, np.repeat(tri[:1], repeat, axis=0)]
    corners = np.ascontiguousarray(tri.T).astype(np.intp)
    got = _base._skin_edges(corners, n)
    assert got.dtype == np.intp and got.shape[1] == 2
    np.testing.assert_array_equal(got, _old_skin_edges(corners, n))
    rest = rng.standard_normal((n, 3)) * rng.uniform(1e-3, 1e3)
    terms = pulls.pull_terms(rest, tri)
    edges, length = _base._terms_edges(terms)
    np.testing.assert_array_equal(edges, got)
    want = np.linalg.norm(rest[got[:, 0]] - rest[got[:, 1]], axis=1)
    assert length.tobytes() == want.tobytes()


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), bad=st.integers(1, 12),
       budget=st.sampled_from([2, 64, 10**6]), scale=st.sampled_from([0.05, 1.0, 20.0]))
def test_the_small_search_is_scipys_search_bit_for_bit(seed, bad, budget, scale):
    """Stop 42: the rounds' search in Python from a few bad triangles (``_local_limits``)
    gives scipy's bounded search's array bit for bit (the least sums over paths, whatever the
    order; a vertex exactly at ``top`` kept, as scipy's ``limit`` keeps it; s* of 0, inf and
    NaN as the source row takes them), or None past its budget; on a graph reweighed in
    place, pulls with unpulled vertices, and sums near ``top``."""
    rng = np.random.default_rng(seed)
    pts, tri = _sheet(int(rng.integers(3, 12)), int(rng.integers(3, 12)), rng)
    size = rng.uniform(0, scale, len(pts)) * (rng.random(len(pts)) < 0.7)
    terms = pulls.pull_terms(pts, tri)
    graph = pulls._edge_graph(size, terms, 4.0)
    changed = np.flatnonzero(rng.random(len(pts)) < 0.3)
    pulls._reweigh(graph, changed, size * np.where(rng.random(len(pts)) < 0.5, 0.5, 1.0))
    top = 2.0
    rows = rng.choice(len(tri), size=min(bad, len(tri)), replace=False)
    s_star = rng.choice([0.0, 1e-13, 0.3, 1.7, top, np.inf, np.nan], size=len(rows))
    s_star = np.where(rng.random(len(rows)) < 0.5, s_star, rng.uniform(0, top, len(rows)))
    corners = np.asarray(tri)[rows]
    with np.errstate(invalid="ignore"):  # (a NaN s*: the source row takes it as no edge)
        want = pulls._limits(s_star, corners, graph, top)
        got = pulls._local_limits(s_star, corners, graph, top, budget)
        again = pulls._limits(s_star, corners, graph, top, local=True)
    assert again.tobytes() == want.tobytes()
    if got is None:
        assert np.count_nonzero(np.isfinite(want)) > budget
        return
    assert got.shape == want.shape and got.tobytes() == want.tobytes()


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), bad=st.integers(1, 4))
def test_the_small_search_keeps_a_vertex_exactly_at_top(seed, bad):
    """Stop 42: ``top`` set to a vertex's own least path sum (found by scipy's search with
    no bound), so that vertex lies exactly on the limit through a relaxed edge: scipy's
    bounded search keeps it, and so must the small search (``<=``, not ``<``), bit for
    bit."""
    rng = np.random.default_rng(seed)
    pts, tri = _sheet(int(rng.integers(3, 8)), int(rng.integers(3, 8)), rng)
    size = rng.uniform(0.5, 1.0, len(pts))
    graph = pulls._edge_graph(size, pulls.pull_terms(pts, tri), 4.0)
    rows = rng.choice(len(tri), size=min(bad, len(tri)), replace=False)
    corners = np.asarray(tri)[rows]
    s_star = rng.uniform(0.0, 0.5, len(rows))
    free = pulls._limits(s_star, corners, graph, np.inf)
    reached = np.setdiff1d(np.flatnonzero(np.isfinite(free)), corners.ravel())
    assume(len(reached))
    top = float(free[reached[np.argmax(free[reached])]])  # the farthest: on the limit
    want = pulls._limits(s_star, corners, graph, top)
    got = pulls._local_limits(s_star, corners, graph, top, 10**6)
    assert np.count_nonzero(want == top) >= 1
    assert got is not None and got.tobytes() == want.tobytes()
