"""A frame's fields at a few vertices, read from the compact per-muscle data (issue 28):
``FaceState.values_at`` gives exactly the full fields' values there, unrefined and refined,
without building one full-length field."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import wrinkle_vis as wv
from wrinkle_vis.core.fields import FIELD_NAMES, FIELDS, FieldSpec, register_field


@pytest.fixture(scope="module")
def face():
    return wv.datasets.load_face()


def _sample(state, k=300, seed=0):
    """``k`` vertices of the frame's skin, some on the unrefined skin and, on a refined
    frame, some of the new ones."""
    rng = np.random.default_rng(seed)
    return rng.choice(state.n_points, size=min(k, state.n_points), replace=False)


def _built(state) -> set[tuple[str, str]]:
    """The (muscle, field) pairs whose full-length array the state has built."""
    return {(m, key) for m in state.face.muscle_names for key in state.fields[m]._cache}


def _assert_same_as_full(state, vertices):
    at = state.values_at(vertices)
    # every value read before any full field is built (a read after reads the full one)
    read = {m: {key: at[m][key] for key in FIELD_NAMES} for m in at if m != "total"}
    assert not _built(state), "values_at built full-length fields"
    assert np.array_equal(at["total"]["W"], state.W[vertices])
    for m in state.face.muscle_names:
        for key in FIELD_NAMES:
            full = state.fields[m][key][vertices]
            if m in at:
                assert np.array_equal(read[m][key], full, equal_nan=True), (m, key)
            else:  # a muscle left out defines nothing there
                assert np.isnan(full).all(), (m, key)
    return at


@pytest.mark.parametrize("refine", [False, True])
def test_values_at_are_the_full_fields_there_bit_for_bit(face, refine):
    state = face.evaluate("fear", 0.9, refine=refine)
    vertices = _sample(state)
    if refine:
        assert state.n_points > face.skin.n_points
        assert (vertices >= face.skin.n_points).any(), "no new vertex sampled"
    _assert_same_as_full(state, vertices)


def test_values_at_the_unrefined_skins_vertices_of_a_refined_frame_bit_for_bit(face):
    """At vertices the unrefined frame has (a probe's corners often are), the refined
    frame's values are read from the unrefined frame's: the full fields' there."""
    rng = np.random.default_rng(2)
    for _ in range(6):
        state = face.evaluate("fear", 0.9, refine=True)  # no full field built yet
        _assert_same_as_full(state, rng.choice(face.skin.n_points, 3, replace=False))


def test_the_muscles_levels_list_their_vertices_in_ascending_order(face):
    """What the refined values at a few vertices search in: each muscle's levels on the
    hierarchy, added to as it grows over several expressions, keep their ids ascending."""
    for expression in ("fear", "surprise", "smile"):
        state = face.evaluate(expression, 1.0, refine=True)
    engine = state.fields._state.source._engine
    for m in face.muscles:
        ids = engine.levels(m).ids
        assert np.all(np.diff(ids) > 0), m.name


def test_values_at_on_a_refined_physical_frame_bit_for_bit(face):
    """The physical skin's correction carried to the new vertices is read as the full
    fields read it."""
    state = face.evaluate("fear", 0.9, refine=True, skin="physical")
    vertices = _sample(state, seed=1)
    assert (vertices >= face.skin.n_points).any(), "no new vertex sampled"
    _assert_same_as_full(state, vertices)


def test_values_at_with_the_gradient_option_and_a_muscle_at_rest(face):
    m = face.muscle("frontalis_major_L")
    g = face.with_muscle(dataclasses.replace(m, compression="gradient"))
    for refine in (False, True):
        state = g.evaluate("surprise", 0.8, refine=refine)
        assert state.activations["corrugator_L"] == 0.0  # at rest: eps defined, W = 0
        _assert_same_as_full(state, _sample(state, seed=1))


@pytest.mark.parametrize("refine", [False, True])
def test_only_the_muscles_whose_aoi_holds_a_vertex_are_given(face, refine):
    state = face.evaluate("surprise", 1.0, refine=refine)
    aoi = face.muscle_data(face.muscle("frontalis_major_L")).aoi
    anywhere = np.concatenate([face.muscle_data(m).aoi for m in face.muscles])
    nowhere = np.setdiff1d(np.arange(face.skin.n_points), anywhere)  # in no muscle's AOI
    assert len(nowhere) and set(state.values_at(nowhere[:3])) == {"total"}
    vertices = np.concatenate([aoi[:2], nowhere[:2]])
    at = _assert_same_as_full(state, vertices)
    holding = {m.name for m in face.muscles if np.isin(vertices, face.muscle_data(m).aoi).any()}
    assert set(at) - {"total"} == holding and len(holding) < len(face.muscles)
    assert np.isfinite(at["frontalis_major_L"]["lambda"][:2]).all()
    assert np.isnan(at["frontalis_major_L"]["lambda"][2:]).all()


@pytest.mark.parametrize("pointwise", [True, False])
def test_a_registered_field_is_computed_at_the_vertices_only_when_pointwise(face, pointwise):
    spec = FieldSpec("HAt", "H At", "attenuated shape", "H At", "Eq. 5, 12", unit="length",
                     where="region", signed=True, compute=lambda f: f["H"] * f["At"],
                     pointwise=pointwise)
    register_field(spec)
    try:
        state = face.evaluate("surprise", 0.7, refine=True)
        vertices = _sample(state, seed=2)
        at = state.values_at(vertices)["frontalis_major_L"]["HAt"]
        assert bool(_built(state)) != pointwise  # a non-pointwise field is built in full
        full = state.fields["frontalis_major_L"]["HAt"][vertices]
        assert np.array_equal(at, full, equal_nan=True) and np.isfinite(at).any()
    finally:
        FIELDS.pop("HAt")


@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**32 - 1), gradient=st.booleans(), k=st.integers(0, 6))
def test_compression_at_a_few_rows_is_the_whole_aois_there_bit_for_bit(face, seed, gradient,
                                                                        k):
    """A muscle's compression at a few AOI rows (what a probe reads of a muscle at rest)
    is its compression over the whole AOI at those rows, to the last bit, for random
    deformations, both compression measures."""
    rng = np.random.default_rng(seed)
    muscle = face.muscles[int(rng.integers(len(face.muscles)))]
    muscle = dataclasses.replace(muscle, compression="gradient" if gradient else "edges")
    data = face.with_muscle(muscle).muscle_data(muscle)
    skin = face.skin
    rows = rng.integers(0, len(data.aoi), k)
    for _ in range(2):  # the second through what the first kept of the rows
        points = skin.points + 0.02 * np.ptp(skin.points) * rng.standard_normal(
            skin.points.shape)
        got = data.compression_at(skin, points, rows)
        assert got.shape == (k,)
        assert np.array_equal(got.view(np.int64),
                              data.compression(skin, points)[rows].view(np.int64))
