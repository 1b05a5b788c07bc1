"""The balls' search on refined frames: its cheap pair test against the exact nearest point."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from wrinkle_vis.core.foldguard import _apart, _closest_on_triangles


def _pairs_near_contact(seed: int, k: int = 4000):
    """Random triangles (some slivers, some far from the origin) and balls whose radius is
    the distance from their centre to the triangle times a factor near 1 (both sides of
    contact, down to a relative 1e-7), the centre anywhere around the triangle."""
    rng = np.random.default_rng(seed)
    shift = rng.choice([0.0, 50.0]) * rng.normal(size=3)
    a, b, c = (rng.normal(size=(k, 3)) + shift for _ in range(3))
    sliver = rng.random(k) < 0.2
    c[sliver] = a[sliver] + rng.uniform(0, 1, (sliver.sum(), 1)) * (b - a)[sliver] \
        + 1e-6 * rng.normal(size=(sliver.sum(), 3))
    w = rng.dirichlet([1.0, 1.0, 1.0], k)
    q = w[:, :1] * a + w[:, 1:2] * b + w[:, 2:] * c
    centres = q + rng.uniform(0.01, 3.0, (k, 1)) * rng.normal(size=(k, 3))
    dist = np.linalg.norm(_closest_on_triangles(centres, a, b, c) - centres, axis=1)
    factor = 1.0 + rng.choice([-1.0, 1.0], k) * 10.0 ** rng.uniform(-7, 0, k)
    return centres, dist * np.abs(factor), a, b, c


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_a_pair_found_apart_is_one_the_nearest_point_puts_outside(seed):
    """``_apart`` never drops a (ball, triangle) pair whose nearest point lies inside the
    ball (the search's own test, ``|q - c|^2 < r^2``), on balls within a relative 1e-7 of
    touching their triangle, and it does drop most of the pairs far apart (a test that
    calls nothing apart would pass the first check)."""
    centres, r, a, b, c = _pairs_near_contact(seed)
    apart = _apart(centres, r, a, b, c)
    q = _closest_on_triangles(centres, a, b, c)
    dd = np.einsum("ij,ij->i", q - centres, q - centres)
    meet = dd < r * r
    assert not (apart & meet).any()
    far = dd > (2.0 * r) ** 2
    assert apart[far].mean() > 0.5
