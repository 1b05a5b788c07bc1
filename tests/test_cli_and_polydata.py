import numpy as np
from meshes import grid

import wrinkle_vis as wv
from wrinkle_vis.cli import main
from wrinkle_vis.plotting import field_array_name, to_polydata


def test_summary_prints_the_fields_of_an_expression(capsys):
    assert main(["summary", "--expression", "frown", "--intensity", "0.5"]) == 0
    out = capsys.readouterr().out
    assert "== frown (intensity 0.5" in out and "corrugator_L=0.50" in out
    assert "eps [" in out and "W total" in out


def test_summary_rejects_unknown_expressions(capsys):
    assert main(["summary", "--expression", "laughing"]) == 2
    assert "unknown expression 'laughing'" in capsys.readouterr().err


def test_summary_rejects_bad_intensity(capsys):
    import pytest

    with pytest.raises(SystemExit):
        main(["summary", "--intensity", "3"])
    assert "outside [0, 1]" in capsys.readouterr().err


def test_to_polydata_carries_every_field():
    lin = wv.LinearMuscle("lin", (-25, 0, -3), (5, 0, 1), radius=40, max_angle_deg=30)
    face = wv.FaceModel(grid(21, 21, 80.0, bump=5.0), None, [lin])
    state = face.evaluate({"lin": 1.0})
    mesh = state.to_polydata()
    assert mesh.n_points == face.skin.n_points and mesh.n_cells == face.skin.n_triangles
    np.testing.assert_array_equal(mesh.points, state.points)
    np.testing.assert_array_equal(mesh["W"], state.W)
    for f in wv.FIELD_NAMES:
        np.testing.assert_array_equal(mesh[field_array_name(f, "lin")], state.fields["lin"][f])
    assert "lin__lambda" in to_polydata(state).point_data
