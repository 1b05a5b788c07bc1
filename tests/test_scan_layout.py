"""A layout that names its mesh file and landmarks is a whole face: it reopens bit for bit."""

import dataclasses
import json
import shutil
from pathlib import Path

import pytest
from conftest import assert_same_face

import wrinkle_vis as wv
from wrinkle_vis.datasets import read_landmarks, scan_layout

REAL = Path(__file__).resolve().parents[2] / "shared" / "realmeshes"
HEAD = REAL / "lee_perry_smith_head.obj"
EXAMPLE = Path(wv.datasets.__file__).with_name("examples") / "lee_perry_smith.json"

needs_scans = pytest.mark.skipif(not HEAD.exists(), reason="../shared/realmeshes is not here")


@needs_scans
def test_a_scan_layout_names_its_mesh_and_reopens_bit_for_bit(tmp_path):
    scans = tmp_path / "scans"
    scans.mkdir()
    shutil.copy(HEAD, scans / "head.obj")
    marks = wv.load_layout(EXAMPLE).landmarks
    path = tmp_path / "layouts" / "head.json"
    path.parent.mkdir()
    layout = scan_layout(scans / "head.obj", marks, layout_path=path, unit="m")
    assert layout.skin == "../scans/head.obj" and layout.unit == "m"
    builtin = wv.load_layout(wv.datasets.BUILTIN_LAYOUT)
    assert layout.landmarks == marks and len(layout.muscles) == len(builtin.muscles)
    wv.save_layout(layout, path)
    saved = json.loads(path.read_text())
    assert saved["skin"] == "../scans/head.obj" and saved["landmarks"]["nasion"]
    first = wv.datasets.load_face(layout=path)
    again = wv.datasets.load_face(layout=path)
    assert_same_face(first, again)
    # the same face as the scan with the landmarks given directly
    direct = wv.datasets.load_face(skin=scans / "head.obj", landmarks=marks, unit="m")
    assert_same_face(first, direct)
    # the folder moves with the layout: paths are relative
    shutil.move(tmp_path / "layouts", tmp_path / "moved_layouts")
    shutil.move(scans, tmp_path / "scans_too")
    moved = tmp_path / "moved_layouts" / "head.json"
    data = json.loads(moved.read_text())
    data["skin"] = "../scans_too/head.obj"
    moved.write_text(json.dumps(data))
    assert_same_face(first, wv.datasets.load_face(layout=moved))


def test_unit_and_face_keys_round_trip_and_are_checked(tmp_path):
    layout = wv.Layout(name="x", unit="cm", face="lee_perry_smith")
    path = tmp_path / "x.json"
    wv.save_layout(layout, path)
    assert wv.load_layout(path) == layout
    data = json.loads(path.read_text())
    data["unit"] = "furlong"
    path.write_text(json.dumps(data))
    with pytest.raises(wv.LayoutError, match=r"\$\.unit: expected a length unit"):
        wv.load_layout(path)
    # a layout without them writes neither key (older files stay as they were)
    assert "unit" not in wv.Layout().to_dict() and "face" not in wv.Layout().to_dict()


def test_landmarks_files(tmp_path):
    marks = wv.datasets.builtin_landmarks()
    plain = tmp_path / "marks.json"
    plain.write_text(json.dumps({k: list(v) for k, v in marks.items()}))
    assert read_landmarks(plain) == marks
    lay = tmp_path / "layout.json"
    wv.save_layout(wv.load_layout(wv.datasets.BUILTIN_LAYOUT), lay)
    assert read_landmarks(lay) == marks
    bad = tmp_path / "bad.json"
    bad.write_text('{"nasion": [0, 1]}')
    with pytest.raises(ValueError, match=r"bad.json: landmark 'nasion': expected \[x, y, z\]"):
        read_landmarks(bad)
    few = tmp_path / "few.json"
    few.write_text('{"nasion": [0, 1, 2], "elbow": [1, 2, 3]}')
    with pytest.raises(ValueError, match="needs at least 4 of the landmarks"):
        read_landmarks(few)
    with pytest.raises(FileNotFoundError, match="no landmarks file"):
        read_landmarks(tmp_path / "none.json")


def test_a_layout_for_another_unit_is_refused_on_the_builtin_skin():
    """The shipped example (metres, skin null) on the millimetre face: a clear error."""
    with pytest.raises(ValueError, match="made for a face in another unit"):
        wv.datasets.load_face(layout=EXAMPLE)


def _write_obj(path: Path, surface) -> None:
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in surface.points.tolist()]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in surface.triangles.tolist()]
    path.write_text("\n".join(lines) + "\n")


def test_a_layout_object_reads_its_meshes_relative_to_base(tmp_path, monkeypatch, wv_face):
    """``base`` says where a ``Layout`` object's skin and skull files are (an object has no
    file of its own): one rule in ``load_face`` instead of one per caller.
    """
    folder = tmp_path / "face"
    folder.mkdir()
    _write_obj(folder / "skin.obj", wv_face.skin)
    _write_obj(folder / "skull.obj", wv_face.skull)
    layout = dataclasses.replace(wv.load_layout(wv.datasets.BUILTIN_LAYOUT), skin="skin.obj",
                                 skull="skull.obj", unit="mm")
    monkeypatch.chdir(tmp_path)  # not the folder of the meshes
    face = wv.datasets.load_face(layout=layout, base=folder)
    direct = wv.datasets.load_face(layout=layout, skin=folder / "skin.obj",
                                   skull=folder / "skull.obj")
    assert_same_face(face, direct)
    assert face.skin.n_triangles == wv_face.skin.n_triangles
