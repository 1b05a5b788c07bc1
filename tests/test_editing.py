"""Editing muscles without Qt: mirror, names, moved points, faces with muscles renamed or
deleted, and the session's edits (the app wraps each in an undo command).
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from meshes import grid

import wrinkle_vis as wv
from wrinkle_vis.app.session import Session
from wrinkle_vis.core.editing import (
    mirror_name,
    mirrored,
    reflect,
    symmetry_plane,
    unique_name,
    with_point,
)
from wrinkle_vis.core.mesh import barycentric_points, closest_points, surface_coordinates

coords = st.floats(-100, 100, allow_nan=False)
points = st.tuples(coords, coords, coords)


@given(points, points, points.filter(lambda n: np.linalg.norm(n) > 1e-3))
def test_reflect_is_an_involution_that_keeps_the_plane(x, p, n):
    x, p, n = map(np.asarray, (x, p, n))
    y = reflect(x, p, n)
    assert np.allclose(reflect(y, p, n), x, atol=1e-9)
    u = n / np.linalg.norm(n)
    assert np.isclose((y - p) @ u, -((x - p) @ u), atol=1e-9)  # signed distance flips
    assert np.allclose(y - ((y - p) @ u) * u, x - ((x - p) @ u) * u, atol=1e-9)


def test_symmetry_plane_from_landmark_pairs():
    lm = {"eye_L": (12.0, 5.0, 1.0), "eye_R": (2.0, 5.0, 1.0), "nose": (7.0, 0.0, 9.0)}
    point, normal = symmetry_plane(lm)
    assert np.allclose(normal, [1, 0, 0]) and np.isclose(point[0], 7.0)
    point, normal = symmetry_plane({})
    assert np.allclose(point, 0) and np.allclose(normal, [1, 0, 0])


def test_the_builtin_face_is_symmetric_about_x_0(wv_face):
    point, normal = wv_face.symmetry_plane()
    assert abs(point[0]) < 0.5 and normal[0] > 0.999


@pytest.mark.parametrize(("name", "twin"), [("a_L", "a_R"), ("a_R", "a_L"), ("left", "right"),
                                            ("x_l", "x_r"), ("solo", "solo_mirrored")])
def test_mirror_name(name, twin):
    assert mirror_name(name) == twin


def test_unique_name():
    assert unique_name("m", []) == "m"
    assert unique_name("m", ["m"]) == "m_2"
    assert unique_name("m_2", ["m", "m_2", "m_3"]) == "m_4"


def test_mirrored_sheet_swaps_line_ends_so_its_frame_is_a_mirror_image(wv_face):
    m = wv_face.muscle("frontalis_major_L")
    twin = mirrored(m)
    assert twin.name == "frontalis_major_R"
    f, s, n = m.frame
    tf, ts, tn = twin.frame
    flip = np.array([-1.0, 1.0, 1.0])
    # the reflection flips handedness; swapping the ends flips s back, so that the normal
    # axis n = f x s is the mirror image of the original's (the depth bound keeps its side)
    assert np.allclose(tf, f * flip) and np.allclose(ts, -s * flip)
    assert np.allclose(tn, n * flip)
    assert twin.length_value == pytest.approx(m.length_value)
    assert mirrored(twin, name=m.name) == m


def test_with_point_moves_one_point_and_validates(wv_face):
    m = wv_face.muscle("zygomaticus_major_L")
    moved = with_point(m, "insertion", None, np.add(m.insertion, [1.0, 0, 0]))
    assert np.allclose(moved.insertion, np.add(m.insertion, [1.0, 0, 0]))
    assert moved.attachment == m.attachment
    with pytest.raises(wv.MuscleParameterError, match="zygomaticus_major_L"):
        with_point(m, "insertion", None, m.attachment)  # zero length: refused, says why
    sheet = wv_face.muscle("frontalis_inner_L")
    moved = with_point(sheet, "insertion_line", 1, (0.0, 40.0, 100.0))
    assert moved.insertion_line[1] == (0.0, 40.0, 100.0)
    assert moved.insertion_line[0] == sheet.insertion_line[0]
    with pytest.raises(KeyError, match="attachment_line, insertion_line"):
        with_point(sheet, "center", None, (0, 0, 0))


@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(st.floats(-0.45, 0.45), st.floats(-0.45, 0.45),
                          st.floats(-0.5, 0.5)), min_size=1, max_size=5))
def test_surface_coordinates_carry_points_between_moved_copies(queries):
    flat = grid(8, 8, size=1.0)
    bent = flat.with_points(flat.points + np.c_[0 * flat.points[:, :2],
                                                np.sin(3 * flat.points[:, 0])])
    q = np.asarray(queries)
    tri, bary = surface_coordinates(flat, q)
    assert np.allclose(bary.sum(axis=1), 1) and (bary > -1e-9).all()
    on_flat = barycentric_points(flat, tri, bary)
    assert np.allclose(on_flat, closest_points(flat, q))
    assert np.allclose(on_flat[:, :2], q[:, :2]) and np.allclose(on_flat[:, 2], 0)
    on_bent = barycentric_points(flat, tri, bary, points=bent.points)
    back_tri, back_bary = surface_coordinates(bent, on_bent)
    assert np.allclose(barycentric_points(flat, back_tri, back_bary), on_flat, atol=1e-9)


def test_renaming_a_muscle_renames_it_in_the_expressions(wv_face):
    face = wv_face.with_muscle(wv_face.muscle("corrugator_L").replace(name="corr_left"),
                               "corrugator_L")
    assert face.muscle_names.index("corr_left") == wv_face.muscle_names.index("corrugator_L")
    assert "corr_left" in face.expressions["frown"].activations
    assert "corrugator_L" not in face.expressions["frown"].activations
    assert np.array_equal(face.evaluate("frown").W, wv_face.evaluate("frown").W)
    with pytest.raises(ValueError, match="exists already"):
        wv_face.with_muscle(wv_face.muscle("corrugator_L").replace(name="corrugator_R"),
                            "corrugator_L")


def test_deleting_a_muscle_drops_it_from_the_expressions(wv_face):
    face = wv_face.without_muscle("corrugator_L")
    assert "corrugator_L" not in face.muscle_names
    assert "corrugator_L" not in face.expressions["frown"].activations
    face.evaluate("frown")  # still evaluates
    assert wv_face.muscle("corrugator_L")  # the original is untouched


def test_mirror_of_each_left_muscle_matches_its_builtin_right_twin(wv_face):
    session = Session(wv_face.without_muscle("zygomaticus_major_R"))
    for name in [n for n in wv_face.muscle_names if n.endswith("_L")]:
        face, twin = session.mirrored(name)
        assert twin == name[:-2] + "_R"
        got, want = face.muscle(twin), wv_face.muscle(twin)
        for param in want.point_parameters:
            # the meshes are symmetric only up to their remeshing: within an edge length
            assert np.abs(np.subtract(getattr(got, param), getattr(want, param))).max() < 2.0
        for key in ("k0", "alpha", "n_wrinkles", "lambda_w"):
            assert getattr(got, key) == getattr(want, key)
    face, twin = session.mirrored("zygomaticus_major_L")  # the twin was missing: added
    assert face.expressions["smile"].activations[twin] == \
        face.expressions["smile"].activations["zygomaticus_major_L"]
    got, want = face.evaluate("smile"), wv_face.evaluate("smile")
    moved = np.abs(want.deformed_points - wv_face.skin.points).max()  # about 9 mm
    assert np.abs(got.deformed_points - want.deformed_points).max() < 0.02 * moved
    assert abs(np.count_nonzero(got.W) - np.count_nonzero(want.W)) <= 0.1 * np.count_nonzero(
        want.W)


def test_mirroring_a_pair_swaps_its_sides_as_mirror_images(wv_face):
    from wrinkle_vis.core.editing import with_point

    left = wv_face.muscle("zygomaticus_major_L")
    moved = with_point(left, "insertion", None, np.add(left.insertion, (4.0, 3.0, 0.0)))
    session = Session(wv_face.with_muscle(moved))  # an asymmetric pair
    assert session.twin_of("zygomaticus_major_L") == "zygomaticus_major_R"
    face, twin = session.mirrored_pair("zygomaticus_major_L")
    assert twin == "zygomaticus_major_R"
    old, new = session.face, face
    flip = np.array([-1.0, 1.0, 1.0])
    for a, b in (("zygomaticus_major_L", "zygomaticus_major_R"),
                 ("zygomaticus_major_R", "zygomaticus_major_L")):
        for param in ("insertion", "attachment"):
            # each side is the other's mirror image, snapped: within an edge length
            got, want = getattr(new.muscle(a), param), flip * getattr(old.muscle(b), param)
            assert np.abs(got - want).max() < 2.0
    # the moved insertion went to the right side
    assert np.abs(new.muscle(twin).insertion - flip * moved.insertion).max() < 2.0
    assert np.abs(np.subtract(new.muscle(twin).insertion, old.muscle(twin).insertion)).max() > 3.0
    assert new.expressions == old.expressions  # each keeps its activations
    assert new.muscle_names == old.muscle_names
    lone = Session(wv_face.without_muscle("zygomaticus_major_R"))
    assert lone.twin_of("zygomaticus_major_L") is None
    with pytest.raises(ValueError, match="no twin 'zygomaticus_major_R'.*Ctrl\\+M"):
        lone.mirrored_pair("zygomaticus_major_L")


def test_session_edits_change_nothing_until_shown(wv_face):
    session = Session(wv_face)
    face, copy = session.duplicated("corrugator_L")
    assert copy == "corrugator_L_copy" and session.face is wv_face
    assert face.muscle(copy).replace(name="corrugator_L") == wv_face.muscle("corrugator_L")
    with pytest.raises(ValueError, match="exists already"):
        session.renamed("corrugator_L", "corrugator_R")
    with pytest.raises(ValueError, match="empty"):
        session.renamed("corrugator_L", "  ")
    session.set_field("W", "corrugator_L")
    session.set_face(session.deleted("corrugator_L"))
    assert session.muscle is None and "corrugator_L" not in session.face.muscle_names


@pytest.mark.parametrize("type_name", ["linear", "sheet", "ring"])
def test_added_muscles_start_valid_on_their_surfaces(wv_face, type_name):
    at = wv_face.skin.points[np.argmax(wv_face.skin.points[:, 2])]
    face, name = Session(wv_face).added(type_name, at)
    m = face.muscle(name)
    assert m.type_name == type_name and name == f"{type_name}_1"
    from wrinkle_vis.widgets import widget_factory

    for h in widget_factory(type(m)).handles(m):
        surface = wv_face.skin if h.layer == "skin" else wv_face.skull
        p = h.value(m)
        assert np.linalg.norm(closest_points(surface, p[None])[0] - p) < 1e-6
    face.evaluate({name: 1.0})


def test_types_without_create_cannot_be_added_and_say_why(wv_face):
    from dataclasses import dataclass

    from wrinkle_vis.core.registry import _REGISTRY

    @dataclass(frozen=True)
    class Bare(wv.Muscle):  # no create(): creating is the type's, in core
        pass

    @dataclass(frozen=True)
    class Sub(wv.LinearMuscle):  # inherits the linear type's create(), whatever its widget
        widget = "wrinkle_vis.widgets.placement:GenericWidget"

    wv.register_muscle_type(Bare, name="bare_for_test")
    wv.register_muscle_type(Sub, name="sub_for_test")
    try:
        with pytest.raises(NotImplementedError, match="cannot create a new muscle; load one"):
            Session(wv_face).added("bare_for_test", (0, 0, 100))
        face, name = Session(wv_face).added("sub_for_test", (20.0, -40.0, 100.0))
        made = face.muscle(name)
        assert type(made) is Sub and name == "sub_for_test_1"
        # the attachment on the skull, the insertion on the skin, as the type declares
        for param, surface in (("attachment", wv_face.skull), ("insertion", wv_face.skin)):
            p = np.asarray(getattr(made, param))
            assert np.linalg.norm(closest_points(surface, p[None])[0] - p) < 1e-9
    finally:
        _REGISTRY.pop("bare_for_test")
        _REGISTRY.pop("sub_for_test")


def test_many_edits_keep_the_per_muscle_cache_bounded(wv_face):
    face = wv_face
    m = face.muscle("corrugator_L")
    for k in range(150):  # a long drag: a new version of the muscle each move
        face = face.with_muscle(with_point(m, "insertion", None,
                                           np.add(m.insertion, [0.01 * k, 0, 0])))
        face.evaluate({"corrugator_L": 1.0})
    assert len(face._muscle_data) <= 4 * len(face.muscles) + 64 + 1
