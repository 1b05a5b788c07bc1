"""Timeline playback with refinement: the drawn meshes are updated in place on the same
triangles and replaced on others (a real window under Xvfb; fixtures: conftest.py), and
the Qt-free decisions behind it.
"""

from itertools import pairwise

import numpy as np
import pytest
from conftest import skin_mesh

from wrinkle_vis.app.session import TIMELINE_STEPS, playback_position
from wrinkle_vis.app.views import ghost_skin, redraw_kind
from wrinkle_vis.core.mesh import TriangleSurface

pytestmark = pytest.mark.usefixtures("no_leaked_plotters")


# ---------------------------------------------------------------------- Qt-free
def test_redraw_kind():
    tri = np.array([[0, 1, 2], [0, 2, 3]])
    assert redraw_kind(None, None, "k", (4, tri)) == "scene"  # nothing drawn
    assert redraw_kind("k", (4, tri), "other", (4, tri)) == "scene"  # another field...
    assert redraw_kind("k", (4, tri), "k", (4, tri)) == "points"  # the very array
    assert redraw_kind("k", (4, tri), "k", (4, tri.copy())) == "points"  # equal arrays
    assert redraw_kind("k", (4, tri), "k", (5, tri.copy())) == "mesh"  # a vertex more
    assert redraw_kind("k", (4, tri), "k", (4, tri[:, ::-1].copy())) == "mesh"
    assert redraw_kind("k", (4, tri), "k", (4, tri[:1])) == "mesh"  # fewer triangles


def test_ghost_skin_keeps_the_unrefined_triangles_of_a_refined_frame(wv_face):
    state = wv_face.evaluate("frown", refine=True)
    skin = wv_face.skin
    assert state.n_points > skin.n_points
    points, triangles, normals = ghost_skin(state, skin)
    assert triangles is skin.triangles
    np.testing.assert_array_equal(points, state.points[:skin.n_points])
    np.testing.assert_array_equal(normals, state.normals[:skin.n_points])
    plain = wv_face.evaluate("frown")
    points, triangles, normals = ghost_skin(plain, skin)  # unrefined: its own skin
    assert points is plain.points and triangles is plain.triangles
    other = TriangleSurface(skin.points[::-1].copy(), skin.triangles)  # not a prefix
    points, triangles, _ = ghost_skin(state, other)
    assert triangles is state.triangles and len(points) == state.n_points


def test_playback_position_plays_in_real_time_and_wraps_round():
    assert playback_position(0, 0.0, 3.0) == 0
    assert playback_position(0, 1.5, 3.0) == TIMELINE_STEPS // 2
    assert playback_position(10, 0.04, 3.0) == 14  # 40 ms: 4 steps of 10 ms
    assert playback_position(300, 0.01, 3.0) == 0  # past the end: from the start
    assert playback_position(0, 3.0 + 0.5, 3.0) == (TIMELINE_STEPS + 50) % (TIMELINE_STEPS + 1)
    assert playback_position(7, 12.0, 0.0) == 7  # no duration: stays


# ---------------------------------------------------------------------- the window
def _pair(face, same: bool):
    """An expression and two neighbouring intensities (percent) whose refined frames have
    the same triangles (``same``) or other ones, found with the core.
    """
    for name in ("frown", "surprise", "fear"):
        later = face.evaluate(name, 1.0, refine=True)
        for percent in range(99, 59, -1):
            state = face.evaluate(name, percent / 100, refine=True)
            equal = state.triangles.shape == later.triangles.shape and np.array_equal(
                state.triangles, later.triangles)
            if equal == same and not np.array_equal(state.points, later.points):
                return name, percent + 1, percent
            later = state
    raise AssertionError(f"no two refined frames with {'the same' if same else 'other'} "
                         "triangles")


def _drawn(window):
    """What the skin view and the muscles view draw: actors, mappers, datasets."""
    skin = window.skin_view.actors["skin"]
    ghost = window.muscle_view.actors["skin"]
    return {"actor": skin, "mapper": skin.mapper, "dataset": skin.mapper.dataset,
            "points": np.array(skin.mapper.dataset.points), "ghost actor": ghost,
            "ghost dataset": ghost.mapper.dataset}


def _assert_shows(window, expected):
    """The skin view draws ``expected`` (points, triangles, normals, W); the muscles view
    its skin (:func:`ghost_skin`).
    """
    mesh = skin_mesh(window)
    np.testing.assert_allclose(mesh.points, expected.points, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(mesh.regular_faces, expected.triangles)
    np.testing.assert_allclose(mesh.point_data["Normals"], expected.normals, atol=1e-6)
    np.testing.assert_allclose(mesh.point_data["W"], expected.W, rtol=0, atol=1e-9)
    ghost = window.muscle_view.actors["skin"].mapper.dataset
    points, triangles, normals = ghost_skin(expected, window.session.face.skin)
    np.testing.assert_allclose(ghost.points, points, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(ghost.regular_faces, triangles)
    np.testing.assert_allclose(ghost.point_data["Normals"], normals, atol=1e-6)


def test_a_refined_frame_on_the_same_triangles_is_written_in_place(window, wv_face):
    name, a, b = _pair(wv_face, same=True)
    window.expression_box.setCurrentText(name)
    window.intensity_slider.setValue(a)
    window.refine_box.setChecked(True)
    before = _drawn(window)
    window.intensity_slider.setValue(b)
    after = _drawn(window)
    assert window.views.last_redraw == "points"
    for key in ("actor", "mapper", "dataset", "ghost actor", "ghost dataset"):
        assert after[key] is before[key], key
    assert not np.array_equal(after["points"], before["points"])  # new points, same arrays
    _assert_shows(window, wv_face.evaluate(name, b / 100, refine=True))


def test_a_refined_frame_on_other_triangles_gets_a_new_mesh_under_the_same_actor(
        window, wv_face):
    name, a, b = _pair(wv_face, same=False)
    window.expression_box.setCurrentText(name)
    window.intensity_slider.setValue(a)
    window.refine_box.setChecked(True)
    before = _drawn(window)
    bar = window.views._bar
    window.intensity_slider.setValue(b)
    after = _drawn(window)
    assert window.views.last_redraw == "mesh"
    assert after["actor"] is before["actor"] and after["mapper"] is before["mapper"]
    assert after["dataset"] is not before["dataset"]
    assert window.views._bar is bar  # the scalar bar and its lookup table are kept
    assert after["ghost actor"] is before["ghost actor"]
    assert after["ghost dataset"] is before["ghost dataset"]  # unrefined triangles: kept
    _assert_shows(window, wv_face.evaluate(name, b / 100, refine=True))
    window.refine_box.setChecked(False)  # refinement off: the unrefined skin, in place...
    assert window.views.last_redraw == "mesh"
    _assert_shows(window, wv_face.evaluate(name, b / 100))
    kept = _drawn(window)
    window.intensity_slider.setValue(a)  # ...and written in place from then on
    assert window.views.last_redraw == "points" and _drawn(window)["dataset"] is \
        kept["dataset"]
    _assert_shows(window, wv_face.evaluate(name, a / 100))


@pytest.mark.slow
def test_play_with_refinement_draws_each_frame_refined(window, wv_face, qtbot):
    """The Play button with refinement on: each drawn frame is the refined frame of its
    time, written in place when its triangles are the last frame's, else a new mesh
    under the same actor. On the geometric skin, each frame evaluated on its own (the
    physical skin's Play is the simulation: test_app_physical.py).
    """
    window.skin_box.setCurrentText("geometric")
    window.refine_box.setChecked(True)
    window.time_slider.setValue(0)
    frames = []
    refresh = window.refresh

    def recording(*args, **kwargs):
        refresh(*args, **kwargs)
        s = window.session
        frames.append((s.activations(), _drawn(window), window.views.last_redraw,
                       np.array(skin_mesh(window).regular_faces)))

    window.refresh = recording
    window.play_button.setChecked(True)
    qtbot.waitUntil(lambda: len(frames) >= 5, timeout=60000)
    window.play_button.setChecked(False)
    del window.refresh
    frames = frames[:5]
    assert max(max(acts.values()) for acts, *_ in frames) > 0  # it played the onset
    for (_, before, _, tri_before), (acts, after, kind, tri) in pairwise(frames):
        expected = wv_face.evaluate(acts, refine=True, skin="geometric")
        np.testing.assert_allclose(after["points"], expected.points, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(tri, expected.triangles)
        assert after["actor"] is before["actor"] and after["mapper"] is before["mapper"]
        same = tri.shape == tri_before.shape and np.array_equal(tri, tri_before)
        assert kind == ("points" if same else "mesh")
        assert (after["dataset"] is before["dataset"]) == same
