import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

import wrinkle_vis as wv

alphas = st.floats(-1.0, 6.0, allow_nan=False)
k0s = st.floats(0.01, 5.0, allow_nan=False)


@pytest.mark.parametrize("alpha", [-1.0, -0.5, 0.0, 0.5, 1.0, 2.0, 4.0])
@pytest.mark.parametrize("k0", [0.1, 1.0, 3.0])
def test_eq8_volume_is_zero_over_a_period(alpha, k0):
    u = 1.7
    left = quad(lambda w: wv.shape_function(w, u, k0, alpha), 0, u)[0]
    right = quad(lambda w: wv.shape_function(w, u, k0, alpha), u, 2 * u)[0]
    assert abs(left + right) < 1e-9 * max(1.0, k0 * u)


def test_bulge_height_closed_form_and_limit_at_minus_one():
    assert wv.bulge_height(2.0, -1.0) == pytest.approx(np.log(2.0))
    assert wv.bulge_height(1.0, 0.0) == pytest.approx(0.5)
    assert wv.bulge_height(1.0, 1.0) == pytest.approx(0.75)
    # continuous through alpha = -1
    assert wv.bulge_height(1.0, -1.0 + 1e-7) == pytest.approx(wv.bulge_height(1.0, -1.0), 1e-6)


@given(k0=k0s, alpha=alphas, u=st.floats(0.1, 10.0))
def test_shape_crest_and_furrow_values(k0, alpha, u):
    d = wv.bulge_height(k0, alpha)
    h = wv.shape_function([0.0, u, 2 * u], u, k0, alpha)
    np.testing.assert_allclose(h, [d - k0 * 2**alpha, d, d - k0 * 2**alpha], rtol=1e-12,
                               atol=1e-12)


@given(k0=k0s, alpha=alphas)
def test_shape_is_continuous_and_periodic(k0, alpha):
    u = 1.3
    w = np.linspace(0, 2 * u, 4001)
    h = wv.shape_function(w, u, k0, alpha)
    assert np.max(np.abs(np.diff(h))) < 0.02 * k0 * max(1.0, 2**alpha) * (1 + abs(alpha))
    # through the periodic coordinate: l and l + 2u give the same height
    l = np.linspace(5.0, 30.0, 97)
    w1 = wv.periodic_coordinate(l, 0.2, 30.0, 4)
    w2 = wv.periodic_coordinate(l + 2 * wv.half_period(0.2, 30.0, 4), 0.2, 30.0, 4)
    np.testing.assert_allclose(wv.shape_function(w1, u, k0, alpha),
                               wv.shape_function(w2, u, k0, alpha), atol=1e-9)


@pytest.mark.parametrize("alpha", [0.25, 1.0, 2.0, 3.0])
def test_furrow_kink_is_sharper_than_crest_kink_for_positive_alpha(alpha):
    k0, u, h = 1.0, 1.0, 1e-7
    furrow = (wv.shape_function(h, u, k0, alpha) - wv.shape_function(0.0, u, k0, alpha)) / h
    crest = (wv.shape_function(u, u, k0, alpha) - wv.shape_function(u - h, u, k0, alpha)) / h
    assert abs(furrow) > abs(crest)
    assert furrow == pytest.approx(k0 * 2**alpha * (1 + alpha) / u, rel=1e-4)
    assert crest == pytest.approx(k0 / u, rel=1e-4)


def test_half_period_and_periodic_coordinate_floor():
    assert wv.half_period(0.5, 40.0, 5) == pytest.approx(2.0)
    # int() is the floor: values below lambda_w R wrap into [0, 2u) too
    w = wv.periodic_coordinate([20.0, 21.0, 23.9, 24.0, 19.0], 0.5, 40.0, 5)
    np.testing.assert_allclose(w, [0.0, 1.0, 3.9, 0.0, 3.0], atol=1e-12)
    assert np.all((w >= 0) & (w < 4.0))


def test_anisotropy_values():
    np.testing.assert_allclose(wv.anisotropy([0.0, 1.0, -0.5, 0.5, 2.0]),
                               [0.0, 1.0, 0.0, np.cos(np.pi / 4), 1.0], atol=1e-15)
    assert np.isnan(wv.anisotropy(np.nan))


@given(st.floats(0.0, 1.0), st.floats(0.0, 1.0))
def test_anisotropy_is_monotone(a, b):
    lo, hi = sorted((a, b))
    assert wv.anisotropy(lo) <= wv.anisotropy(hi)
    assert wv.anisotropy(lo) == pytest.approx(np.cos(np.pi / 2 * (1 - lo)), abs=1e-15)


@given(start=st.floats(0, 50), span=st.floats(0.01, 50))
@settings(max_examples=50)
def test_attenuation_profile(start, span):
    end = start + span
    assert wv.attenuation(start, start, end) == 1.0
    assert wv.attenuation(start * 0.5, start, end) == 1.0
    assert wv.attenuation(end, start, end) == pytest.approx(0.0, abs=1e-15)
    x = np.linspace(start, end, 200)
    a = wv.attenuation(x, start, end)
    assert np.all(np.diff(a) < 0)
    s = (x - start) / span
    np.testing.assert_allclose(a, -0.5 * (1 + s**2) * s + 1, atol=1e-12)


def test_edge_shrinkage_eq9():
    rest = np.array([[0, 0, 0], [2, 0, 0], [0, 4, 0]], float)
    now = np.array([[0, 0, 0], [1.5, 0, 0], [0, 5, 0]], float)
    tau = wv.edge_shrinkage(rest, now, [[0, 1], [0, 2]])
    np.testing.assert_allclose(tau, [0.25, -0.25])


def _axis_grid(n, direction):
    """A grid of points with edges only along ``direction`` and across it (no diagonals)."""
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    across = np.cross([0, 0, 1.0], d)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    pts = i.ravel()[:, None] * d + j.ravel()[:, None] * across
    idx = np.arange(n * n).reshape(n, n)
    edges = np.r_[np.c_[idx[:-1].ravel(), idx[1:].ravel()],
                  np.c_[idx[:, :-1].ravel(), idx[:, 1:].ravel()]]
    return pts, edges, d


@given(s=st.floats(-0.5, 0.9), angle=st.floats(0, 2 * np.pi))
@settings(max_examples=40)
def test_compression_equals_shrink_where_edges_are_parallel(s, angle):
    pts, edges, d = _axis_grid(6, [np.cos(angle), np.sin(angle), 0])
    deformed = pts - s * np.outer(pts @ d, d)  # shrink by s along d
    directions = np.tile(-d, (len(pts), 1))  # sign must not matter (|cos|)
    eps = wv.compression(pts, deformed, edges, directions)
    np.testing.assert_allclose(eps, s, atol=1e-9)


def test_compression_weights_by_abs_cosine_on_a_triangulated_vertex():
    # a centre vertex with edges at 0, 45 and 90 degrees to the x direction
    rest = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    now = rest * np.array([0.8, 1.0, 1.0])
    edges = np.array([[0, 1], [0, 2], [0, 3]])
    eps = wv.compression(rest, now, edges, np.tile([1.0, 0, 0], (4, 1)))
    tau_diag = (np.sqrt(2) - np.hypot(0.8, 1.0)) / np.sqrt(2)
    w = np.array([1.0, np.sqrt(0.5), 0.0])
    expected = (w[0] * 0.2 + w[1] * tau_diag) / w.sum()
    assert eps[0] == pytest.approx(expected)


def test_compression_is_zero_where_weights_vanish():
    rest = np.array([[0, 0, 0], [0, 1, 0]], float)
    eps = wv.compression(rest, rest * 0.5, [[0, 1]], np.tile([1.0, 0, 0], (2, 1)))
    np.testing.assert_array_equal(eps, [0.0, 0.0])
    eps = wv.compression(rest, rest * 0.5, [[0, 1]], np.full((2, 3), np.nan))
    np.testing.assert_array_equal(eps, [0.0, 0.0])
