import numpy as np
import pytest

import wrinkle_vis as wv


@pytest.fixture(scope="module")
def face():
    return wv.datasets.load_face()


def test_builtin_face_is_a_clean_paper_sized_skin(face):
    assert 4000 <= face.skin.n_triangles <= 5000
    rep = face.skin.report()
    assert rep.n_components == 1 and len(rep.non_manifold_edges) == 0
    assert len(rep.degenerate_triangles) == 0 and rep.consistently_oriented
    # outward: normals on the forehead look forwards (+z)
    n = face.skin.vertex_normals()
    fore = (np.abs(face.skin.points[:, 0]) < 20) & (np.abs(face.skin.points[:, 1] - 50) < 10)
    assert fore.any() and np.all(n[fore, 2] > 0.5)


def test_builtin_face_is_deterministic_and_cached(face):
    again = wv.datasets.load_face()
    np.testing.assert_array_equal(again.skin.points, face.skin.points)
    np.testing.assert_array_equal(again.skin.triangles, face.skin.triangles)


def test_builtin_face_has_paired_muscles_for_the_paper_expressions(face):
    for ex in ("surprise", "frown", "fear"):
        for m in face.expressions[ex].activations:
            face.muscle(m)
    names = set(face.muscle_names)
    assert all(n[:-2] + "_R" in names for n in names if n.endswith("_L"))


@pytest.mark.parametrize("expression", ["surprise", "frown", "fear"])
def test_paper_expressions_wrinkle_the_upper_face_only(face, expression):
    state = face.evaluate(expression)
    wrinkled = face.skin.points[state.W != 0]
    assert len(wrinkled) > 0
    assert wrinkled[:, 1].min() > 0.0  # above the eyes' centre line: brows and forehead


def test_bad_resolution(face):
    with pytest.raises(ValueError, match="n_triangles"):
        wv.datasets.load_face(10)
