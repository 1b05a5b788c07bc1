"""The same request gives the same mesh, and a saved layout rebuilds its face exactly."""

import dataclasses
import json

import numpy as np
import pytest
from conftest import assert_same_face
from meshes import grid

import wrinkle_vis as wv
from wrinkle_vis.app.session import Session
from wrinkle_vis.cli import main
from wrinkle_vis.datasets.face import split_longest_edges


@pytest.mark.parametrize("n", [4498, 4496, 4493, 4500, 1001])
def test_the_builtin_skin_has_exactly_the_requested_triangles(n):
    face = wv.datasets.load_face(n)
    assert face.skin.n_triangles == n  # pyacvd alone gave 4496, 4493, 4492, 4498 for the first four
    rep = face.skin.report()
    assert rep.n_components == 1 and rep.consistently_oriented
    assert len(rep.degenerate_triangles) == 0
    assert_same_face(wv.datasets.load_face(face.skin.n_triangles), face)


def test_a_saved_builtin_face_reopens_bit_for_bit(tmp_path):
    """The app saves through its session and reopens with the face's triangle count."""
    face = wv.datasets.load_face(4498)
    path = Session(face).save(tmp_path / "face.json")
    again = wv.datasets.load_face(face.skin.n_triangles, layout=path)  # as the app does
    assert_same_face(again, face)
    assert_same_face(again, face, "frown")


def test_a_layout_records_the_request_that_rebuilds_its_mesh(tmp_path, capsys):
    face = wv.datasets.load_face(4498)
    layout = dataclasses.replace(Session(face).layout(), n_triangles=4498)
    wv.save_layout(layout, tmp_path / "face.json")
    assert json.loads((tmp_path / "face.json").read_text())["n_triangles"] == 4498
    assert wv.load_layout(tmp_path / "face.json") == layout
    assert_same_face(wv.datasets.load_face(layout=tmp_path / "face.json"), face)
    # the CLI rebuilds it too, unless --triangles says otherwise
    assert main(["summary", "-e", "neutral", "--layout", str(tmp_path / "face.json")]) == 0
    assert "4498 skin triangles" in capsys.readouterr().out


@pytest.mark.parametrize("value", [0, -5, 4500.5, "4500", True])
def test_a_bad_recorded_request_is_a_layout_error(tmp_path, value):
    data = wv.Layout().to_dict()
    data["n_triangles"] = value
    (tmp_path / "bad.json").write_text(json.dumps(data))
    with pytest.raises(wv.LayoutError, match=r"\$\.n_triangles: expected a positive whole"):
        wv.load_layout(tmp_path / "bad.json")


@pytest.mark.parametrize("extra", [1, 2, 7, 40])
def test_split_longest_edges_reaches_the_count_and_keeps_the_orientation(extra):
    g = grid(9, 9, 40.0, bump=4.0)
    out = split_longest_edges(g, g.n_triangles + extra)
    assert out.n_triangles == g.n_triangles + extra
    rep = out.report()
    assert rep.consistently_oriented and len(rep.degenerate_triangles) == 0
    assert len(rep.non_manifold_edges) == 0 and rep.n_components == 1
    np.testing.assert_array_equal(out.points[:g.n_points], g.points)  # old vertices kept
    assert np.isclose(out.triangle_areas().sum(), g.triangle_areas().sum())  # same surface
    normals = out.face_normals()
    assert np.all(normals[:, 2] > 0)  # still facing +z


def test_split_longest_edges_refuses_what_it_cannot_do():
    g = grid(5, 5)
    with pytest.raises(ValueError, match="more than"):
        split_longest_edges(g, g.n_triangles - 1)
