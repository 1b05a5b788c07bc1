"""The app's probe read from the compact per-muscle data (issue 28): the same values as
the full fields interpolated at the point, unrefined and refined, and no full-length field
built for it (it built all 153 of them every frame: 5 ms unrefined, 44 ms refined)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import wrinkle_vis as wv
from wrinkle_vis.app.session import Session, SurfacePoint
from wrinkle_vis.core.fields import FRAME_FIELDS


@pytest.fixture(scope="module")
def face():
    return wv.datasets.load_face()


def _by_full_fields(state, corners, weights) -> dict:
    """The probe as it was: every field built full and interpolated at the point."""
    def interpolated(values):
        v = values[corners]
        ok = np.isfinite(v)
        nearest = int(np.argmax(weights))
        if not ok[nearest] or weights[nearest] == 1.0:
            return float(v[nearest])
        return float(weights[ok] @ v[ok] / weights[ok].sum())

    out = {"total": {"W": interpolated(state.W),
                     **{k: interpolated(np.asarray(state.field_values(k)))
                        for k in FRAME_FIELDS}}}
    for name in state.face.muscle_names:
        values = {f: interpolated(state.fields[name][f]) for f in wv.FIELD_NAMES}
        if any(np.isfinite(v) for v in values.values()):
            out[name] = values
    return out


@pytest.mark.parametrize("refine", [False, True])
def test_the_probe_builds_no_full_field_and_gives_what_they_give(face, refine):
    session = Session(face)
    session.set_expression("fear")
    session.set_refine(refine)
    aoi = face.muscle_data(face.muscle("frontalis_major_L")).region
    points = [session.vertex_point(int(aoi[len(aoi) // 2])),
              SurfacePoint(int(np.flatnonzero((face.skin.triangles == aoi[3]).any(1))[0]),
                           (0.2, 0.3, 0.5)),
              session.vertex_point(0)]
    for where in points:
        session.set_intensity(session.intensity * 0.99)  # a new frame: nothing built yet
        got = session.probe(where)
        state, corners, weights = session._located(where)
        built = [(m, k) for m in face.muscle_names for k in state.fields[m]._cache]
        assert built == [], f"the probe built full fields {built[:3]}..."
        want = _by_full_fields(state, corners, weights)
        assert got.keys() == want.keys()
        for name, values in want.items():
            assert got[name].keys() == values.keys()
            assert np.array_equal(list(got[name].values()), list(values.values()),
                                  equal_nan=True), name  # bit for bit
    assert "frontalis_major_L" in session.probe(points[0])


@pytest.mark.parametrize("refine", [False, True])
def test_the_probe_keeps_rest_values_only_while_the_face_and_point_stay(face, refine):
    """The probe keeps what depends on the rest skin alone (which muscles hold the point,
    their lambda, gamma, l, w, H, At) from frame to frame, not across an edit, and the
    frame's triangle at the point for that frame only: every frame of a sweep, then the
    same point after its muscle was widened and lengthened, gives what the full fields
    give, bit for bit, where the point is found anew."""
    import dataclasses

    session = Session(face)
    session.set_expression("surprise")
    session.set_refine(refine)
    aoi = face.muscle_data(face.muscle("frontalis_major_L")).region
    where = SurfacePoint(int(np.flatnonzero((face.skin.triangles == aoi[len(aoi) // 3])
                                            .any(1))[0]), (0.2, 0.3, 0.5))

    def check():
        got = session.probe(where)
        state, corners, weights = session._located(where)  # as the probe found them
        session._located_memo = None  # found anew in this frame
        _, again, weights_again = session._located(where)
        assert np.array_equal(again, corners) and np.array_equal(weights_again, weights)
        want = _by_full_fields(state, corners, weights)
        assert got.keys() == want.keys()
        for name, values in want.items():
            assert np.array_equal(list(got[name].values()), list(values.values()),
                                  equal_nan=True), name

    for intensity in (0.5, 0.8, 1.0):
        session.set_intensity(intensity)
        check()
    before = session.probe(where)["frontalis_major_L"]
    m = session.face.muscle("frontalis_major_L")
    session.set_face(session.face.with_muscle(dataclasses.replace(
        m, width=1.3 * m.width, length=1.1 * m.length)))
    check()
    after = session.probe(where)["frontalis_major_L"]
    assert after["gamma"] != before["gamma"]  # the edit moved the rest values


@settings(max_examples=50, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), k=st.integers(1, 40), scale=st.integers(-6, 6))
def test_the_ray_tests_cross_product_is_numpys_bit_for_bit(seed, k, scale):
    """The probe's ray test (Möller-Trumbore) takes its cross products without
    ``np.cross``'s overhead: the same values to the last bit, rows by rows and a vector by
    rows (the probe's triangle and weights do not move)."""
    from wrinkle_vis.core.mesh import _cross_any

    rng = np.random.default_rng(seed)
    a = rng.standard_normal((k, 3)) * 10.0 ** scale
    b, d = rng.standard_normal((k, 3)), rng.standard_normal(3)
    for x, y in ((a, b), (d, b), (a, d)):
        assert np.array_equal(_cross_any(x, y).view(np.int64), np.cross(x, y).view(np.int64))
