"""The per-frame metrics a sweep records (wrinkle_vis.core.metrics)."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

import wrinkle_vis as wv
from wrinkle_vis.core.mesh import TriangleSurface
from wrinkle_vis.core.metrics import METRICS, fibre_section, frame_metrics, muscle_metrics


@pytest.fixture(scope="module")
def small_face():
    return wv.datasets.load_face(n_triangles=1000)


def test_every_metric_is_described_and_returned(small_face):
    m = frame_metrics(small_face.evaluate("frown"), time_s=1.5, frame_seconds=0.25)
    assert set(METRICS) <= set(m)
    assert {k for k in m if k not in METRICS} == {"crests:corrugator_L", "crests:corrugator_R"}
    assert m["time_s"] == 1.5 and m["frame_seconds"] == 0.25
    assert math.isnan(frame_metrics(small_face.evaluate("frown"))["time_s"])


def test_amplitude_and_compression_are_the_frames_own(small_face):
    state = small_face.evaluate("surprise")
    m = frame_metrics(state)
    assert m["W_min"] == state.W.min() and m["W_max"] == state.W.max()
    assert m["W_range"] == pytest.approx(state.W.max() - state.W.min())
    active = [k for k, a in state.activations.items() if a > 0]
    eps = np.concatenate([state.fields[k]["eps"] for k in active])
    eps = eps[np.isfinite(eps)]
    assert m["active_muscles"] == len(active) == 6
    assert m["eps_max"] == eps.max() and m["eps_mean"] == pytest.approx(eps.mean())
    assert m["compressed_fraction"] == pytest.approx((eps > 0).mean())


def test_refined_frown_counts_the_corrugators_crests(small_face):
    m = frame_metrics(small_face.evaluate("frown", refine=True))
    assert m["crests:corrugator_L"] == m["crests:corrugator_R"] == 2
    assert m["crests"] == m["n_w"] == 4 and m["crests_match"] == 1.0 and m["furrows"] >= 2
    assert m["furrow_depth_median"] > 0 and m["furrow_side_slope_deg_median"] > 0


@pytest.mark.parametrize("n_w", [2, 3])
def test_refined_surprise_has_n_w_crests_along_every_frontalis(wv_face, n_w):
    """The model puts n_w crests along the central fibre (Eq. 6, 7); on the refined
    paper-size face the cut along each frontalis sees exactly them.
    """
    face = wv_face
    sheets = [m.name for m in face.muscles if m.type_name == "sheet"]
    for name in sheets:
        face = face.with_muscle(face.muscle(name).replace(n_wrinkles=n_w))
    state = face.evaluate("surprise", refine=True)
    assert [muscle_metrics(state, name)["crests"] for name in sheets] == [n_w] * len(sheets)


def test_the_fibre_cut_runs_along_the_muscle(wv_face):
    """A linear muscle's cut runs along its axis m_A m_I across its wrinkling region
    (lambda_w R to R), in the plane of the axis and the skin normal.
    """
    state = wv_face.evaluate("frown", refine=True)
    m = wv_face.muscle("corrugator_L")
    line = fibre_section(state, "corrugator_L")
    axis = np.subtract(m.insertion, m.attachment)
    axis /= np.linalg.norm(axis)
    along = (line.points - np.asarray(m.attachment)) @ axis
    assert along.min() < 0.2 * m.radius and along.max() > 0.9 * m.radius
    assert np.ptp(along) > 0.8 * line.length  # along the axis, not across it
    flat = np.linalg.svd(line.points - line.points.mean(axis=0), compute_uv=False)
    assert flat[2] < 1e-9 * flat[0]  # one plane
    assert line.values.max() > 0 and (np.diff(line.s) > 0).all()


def test_a_neutral_face_has_no_wrinkle_metrics(small_face):
    m = frame_metrics(small_face.evaluate("neutral"))
    assert m["active_muscles"] == 0 and m["crests"] == 0 and m["W_range"] == 0.0
    assert math.isnan(m["crests_match"]) and math.isnan(m["eps_mean"])
    assert m["crossings_added"] == 0 and m["folds_intersect"] is False


def _two_squares():
    """Two unit squares (two triangles each) 1 apart in z, one above the other."""
    sq = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    points = np.vstack([sq, sq + [0.0, 0.0, 1.0]])
    tris = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])
    return TriangleSurface(points, tris)


def test_folds_that_cross_are_counted_against_rest():
    skin = _two_squares()
    moved = skin.points.copy()
    moved[6] = [0.8, 0.6, -1.0]  # a corner of the upper square pushed through the lower one
    frame = SimpleNamespace(face=SimpleNamespace(skin=skin), activations={},
                            W=np.zeros(8), points=moved, rest_points=skin.points)
    m = frame_metrics(frame)
    assert m["crossings_rest"] == 0 and m["crossings"] >= 1
    assert m["crossings_added"] == m["crossings"] and m["folds_intersect"] is True
    again = frame_metrics(frame, rest_pairs=np.array([[0, 2], [0, 3], [1, 2], [1, 3]]))
    assert again["crossings_rest"] == 4 and again["crossings_added"] == 0
