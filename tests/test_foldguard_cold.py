"""The pull guard's cold triangles (stop 39b): a triangle whose corners' pulls are all within
their rest-only bound cannot fall below ``min_area``, so the exact check over the others
alone decides as the exact check over every triangle did, and the guarded frames are the
same, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import wrinkle_vis as wv
from wrinkle_vis.core import foldguard
from wrinkle_vis.core.foldguard import FoldGuard, pull_terms, skin_scale


def _mesh(rng: np.random.Generator, n: int, m: int):
    """``n`` points and ``m`` triangles, a few degenerate (a corner twice, or flat)."""
    tri = rng.integers(0, n, size=(m, 3))
    k = m // 8
    tri[:k, 1] = tri[:k, 0]
    points = rng.normal(size=(n, 3))
    return points, tri


def _exact_any_bad(terms: dict, pull_t: np.ndarray, size: np.ndarray, min_area: float,
                   top: float) -> bool:
    """The exact check over every pulled triangle, as ``skin_scale`` makes it (the code
    the cold pass stands for): a triangle with a corner where the pull is not 0."""
    moving = size > 0
    rows, corners, N, A1, A2 = foldguard._triangles_of(terms, moving)
    if not len(rows):
        return False
    b, c = foldguard._quadratic(pull_t, corners, N, A1, A2)
    return bool((foldguard._lowest_sigma(b, c, top) < min_area).any())


def _pull(points, pull):
    pull_t = np.ascontiguousarray(pull.T)
    return pull_t, np.sqrt((pull_t * pull_t).sum(axis=0))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31), n=st.integers(3, 40), m=st.integers(1, 60),
       min_area=st.sampled_from([0.05, 0.2, 0.6]), knee=st.sampled_from([0.5, 0.8]))
def test_pulls_within_the_cold_limits_keep_every_triangle_above_min_area(
        seed, n, m, min_area, knee):
    # every corner's pull at its vertex's limit (the worst length), in random directions,
    # or pulls of equal length and opposite direction on an edge's ends
    rng = np.random.default_rng(seed)
    points, tri = _mesh(rng, n, m)
    terms = pull_terms(points, tri)
    top = 1.0 / knee
    tau = foldguard._cold_limits(terms, min_area, top)
    finite = np.isfinite(tau)
    assert (tau[finite] > 0).all()
    used = np.zeros(n, bool)
    used[tri.ravel()] = True
    assert np.isinf(tau[~used]).all()  # no triangle there: nothing to bound
    for _ in range(5):
        d = rng.normal(size=(n, 3))
        d /= np.linalg.norm(d, axis=1)[:, None]
        pull = np.where(finite[:, None], d * np.where(finite, tau, 0.0)[:, None], 0.0)
        pull_t, size = _pull(points, pull)
        assert not _exact_any_bad(terms, pull_t, size, min_area, top)
        low = foldguard._lowest_sigma(*foldguard._quadratic(
            pull_t, terms["corners"], *foldguard._terms_rows(terms)), top)
        assert (low >= min_area).all()


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31), n=st.integers(3, 40), m=st.integers(1, 60),
       scale=st.sampled_from([0.0, 1e-13, 0.01, 0.1, 0.3, 1.0, 3.0]),
       local=st.booleans(), nan=st.booleans())
def test_the_cold_pass_decides_as_the_exact_check_over_every_triangle(
        seed, n, m, scale, local, nan):
    # local: only a few vertices pulled, the rest exactly still (a geometric skin's pull)
    rng = np.random.default_rng(seed)
    points, tri = _mesh(rng, n, m)
    terms = pull_terms(points, tri)
    pull = rng.normal(scale=scale, size=(n, 3))
    if local:
        pull[rng.random(n) < 0.7] = 0.0
    if nan:
        pull[rng.integers(n)] = np.nan
    pull_t, size = _pull(points, pull)
    assert not foldguard._cold_pass(terms, pull_t, size, 0.2, 2.0)  # no rows yet: exact
    foldguard._terms_rows(terms)
    want = not _exact_any_bad(terms, pull_t, size, 0.2, 2.0)
    got = foldguard._cold_pass(terms, pull_t, size, 0.2, 2.0)
    assert want or not got  # never clears a pull the exact check scales
    warm = np.count_nonzero(~(size <= foldguard._cold_limits(terms, 0.2, 2.0)))
    moving = np.count_nonzero(size)
    if 2 * moving > n and 2 * warm < moving:  # (mostly cold: it decides, as the exact check)
        assert got == want
    else:  # (a local pull, or mostly warm: the exact check decides)
        assert not got


def test_the_cold_pass_leaves_a_local_pull_to_the_exact_check():
    # the pulled triangles of a local pull (the geometric skin's) are kept per moving set:
    # where most moving vertices are warm, the exact check over them is as cheap
    points, tri = _mesh(np.random.default_rng(1), 30, 50)
    terms = pull_terms(points, tri)
    foldguard._terms_rows(terms)
    pull = np.zeros((30, 3))
    pull[:4] = 10.0  # warm: far beyond any cold limit
    pull_t, size = _pull(points, pull)
    assert not foldguard._cold_pass(terms, pull_t, size, 0.2, 2.0)
    pull[4:10] = 1e-13  # cold, but the pull moves a third of the skin only
    pull_t, size = _pull(points, pull)
    assert not foldguard._cold_pass(terms, pull_t, size, 0.2, 2.0)
    pull[4:] = 1e-13  # the rest moved by a rounding: cold
    pull_t, size = _pull(points, pull)
    assert foldguard._cold_pass(terms, pull_t, size, 0.2, 2.0) == \
        (not _exact_any_bad(terms, pull_t, size, 0.2, 2.0))


def _reference_scale(monkeypatch, *args, **kwargs):
    """``skin_scale`` as before stop 39b: the exact check over every pulled triangle."""
    with monkeypatch.context() as m:
        m.setattr(foldguard.pulls, "_cold_pass", lambda *a: False)
        return skin_scale(*args, **kwargs)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31), n=st.integers(4, 40), m=st.integers(1, 60),
       scale=st.sampled_from([1e-13, 0.05, 0.3, 1.0]))
def test_skin_scale_with_cold_triangles_is_the_exact_checks_bit_for_bit(seed, n, m, scale):
    rng = np.random.default_rng(seed)
    points, tri = _mesh(rng, n, m)
    deformed = points + rng.normal(scale=scale, size=points.shape)
    mp = pytest.MonkeyPatch()
    try:
        terms, fresh = pull_terms(points, tri), pull_terms(points, tri)
        foldguard._terms_rows(terms)
        got = skin_scale(points, deformed, tri, terms=terms)
        want = _reference_scale(mp, points, deformed, tri, terms=fresh)
    finally:
        mp.undo()
    assert np.array_equal(got, want)


def test_the_cold_limits_are_kept_per_min_area_and_knee():
    face = wv.datasets.load_face()
    terms = pull_terms(face.skin.points, face.skin.triangles)
    a = foldguard._cold_limits(terms, 0.2, 2.0)
    assert foldguard._cold_limits(terms, 0.2, 2.0) is a  # kept
    b = foldguard._cold_limits(terms, 0.4, 2.0)
    c = foldguard._cold_limits(terms, 0.2, 1.25)
    assert b is not a and c is not a
    assert (b <= a).all() and (b < a).any()  # a higher floor: shorter pulls
    assert (c >= a).all() and (c > a).any()  # a shorter range: longer pulls
    other = pull_terms(face.skin.points * 2.0, face.skin.triangles)  # another skin: its own
    assert np.allclose(foldguard._cold_limits(other, 0.2, 2.0), 2.0 * a, rtol=1e-9)


@pytest.mark.parametrize("guard", [FoldGuard(), FoldGuard(min_area=0.5, knee=0.3)])
@pytest.mark.parametrize("expr", ["frown", "smile"])
def test_physical_frames_are_those_of_the_exact_check(monkeypatch, guard, expr):
    # a ramp on the physical skin (its solve moves every vertex) guarded with the cold
    # pass and without it; the strict guard makes the pull guard act; then the muscles
    # change (another expression on the same skin's kept terms)
    face, ref = wv.datasets.load_face(), wv.datasets.load_face()
    seen = []
    cold_pass = foldguard._cold_pass

    def spy(*args):
        seen.append(cold_pass(*args))
        return seen[-1]

    monkeypatch.setattr(foldguard.pulls, "_cold_pass", spy)
    for name in (expr, "surprise"):
        for level in (0.3, 0.7, 1.0):
            s = face.evaluate(name, level, skin="physical", fold_guard=False)
            r = ref.evaluate(name, level, skin="physical", fold_guard=False)
            got = foldguard.guarded(face, s, guard)
            with monkeypatch.context() as m:
                m.setattr(foldguard.pulls, "_cold_pass", lambda *a: False)
                want = foldguard.guarded(ref, r, guard)
            for k in ("points", "W", "deformed_points", "fold_guard"):
                a, b = getattr(got, k), getattr(want, k)
                assert (a is None and b is None) or np.array_equal(a, b), k
    assert True in seen  # the cold pass cleared frames
    if guard.min_area == 0.5:
        assert False in seen  # and the exact check's fallback ran where it found one
