"""Hostile and damaged mesh files: refused in one line naming the file, before VTK reads
them (issue 33: H1 crashes, M7 VTK noise, M12 garbage, L1 non-regular files).

The cases that used to kill the process inside VTK run in a child process with a 4 GiB
address-space limit, so a regression fails the test instead of killing pytest.
"""

from __future__ import annotations

import json
import os
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wrinkle_vis.core import MeshError
from wrinkle_vis.core.files import input_problem
from wrinkle_vis.datasets import read_surface
from wrinkle_vis.datasets.meshfile import check_mesh_file, obj_index_ranges

TRI = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\n"
PLY_HEAD = ("ply\nformat {fmt} 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\n"
            "property float z\nelement face {nf}\nproperty list uchar int vertex_indices\n"
            "end_header\n")
VERTS = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)


def _binary_ply(faces: bytes, nv: int = 3, nf: int = 1) -> bytes:
    return PLY_HEAD.format(fmt="binary_little_endian", nv=nv, nf=nf).encode() + VERTS + faces


#: Files that killed the process inside VTK (SIGSEGV or abort) before the checks, and a
#: word the one-line refusal must hold.
CRASHERS = {
    # the 193-byte PLY of the report: 10^12 vertices claimed
    "bomb.ply": (PLY_HEAD.format(fmt="binary_little_endian", nv=10**12, nf=10**12).encode(),
                 "1,000,000,000,000 vertex"),
    "ascii_2e9.ply": (PLY_HEAD.format(fmt="ascii", nv=2 * 10**9, nf=1).encode()
                      + b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "2,000,000,000 vertex"),
    "vertex_out_of_range.ply": (_binary_ply(struct.pack("<B3i", 3, 0, 1, 2 * 10**9)),
                                "vertex 2000000000"),
    "list_past_the_end.ply": (_binary_ply(struct.pack("<B3i", 200, 0, 1, 2)), "200 entries"),
    "ascii_out_of_range.ply": (PLY_HEAD.format(fmt="ascii", nv=3, nf=1).encode()
                               + b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2000000000\n", "2000000000"),
    "vt_out_of_range.obj": ((TRI + "f 1/1/1 2/999999/1 3/3/1\n").encode(), "vt index 999999"),
    "v_out_of_range.obj": ((TRI + "f 1/1/1 2/2/1 99999999/3/1\n").encode(), "v index"),
    "vn_out_of_range.obj": ((TRI + "f 1//1 2//1 3//99999999\n").encode(), "vn index"),
    "huge.vtp": (b'<?xml version="1.0"?>\n<VTKFile type="PolyData" version="0.1"><PolyData>'
                 b'<Piece NumberOfPoints="1000000000000" NumberOfPolys="1"><Points>'
                 b'<DataArray type="Float32" NumberOfComponents="3" format="ascii">0 0 0'
                 b'</DataArray></Points></Piece></PolyData></VTKFile>\n', "points"),
    "cell_out_of_range.vtk": (b"# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\n"
                              b"POINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 1 4\n"
                              b"3 0 1 99999999\n", "point 99999999"),
}

CHILD = """
import json, resource, sys
resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))
from wrinkle_vis.datasets import read_surface
for path in sys.argv[1:]:
    try:
        s = read_surface(path)
        print(json.dumps([path, "read", s.n_points]), flush=True)
    except Exception as exc:
        print(json.dumps([path, type(exc).__name__, str(exc)]), flush=True)
"""


def test_files_that_crashed_vtk_are_refused_in_one_line_naming_the_file(tmp_path):
    paths = []
    for name, (data, _) in CRASHERS.items():
        (tmp_path / name).write_bytes(data)
        paths.append(str(tmp_path / name))
    run = subprocess.run([sys.executable, "-c", CHILD, *paths], capture_output=True,
                         text=True, timeout=120)
    assert run.returncode == 0, f"the reader died ({run.returncode}) after:\n{run.stdout}"
    assert run.stderr == ""  # nothing from VTK
    results = {Path(p).name: (kind, msg) for p, kind, msg in map(json.loads,
                                                                   run.stdout.splitlines())}
    for name, (_, word) in CRASHERS.items():
        kind, msg = results[name]
        assert kind == "MeshError" and name in msg and word in msg, (name, kind, msg)
        assert "\n" not in msg


def test_a_file_of_zeros_is_refused_after_its_first_block(tmp_path):
    """A sparse 4 GiB file of NUL bytes named .obj (8.3 GB of memory before): refused
    without reading it."""
    path = tmp_path / "zeros.obj"
    with path.open("wb") as f:
        f.truncate(4 << 30)
    with pytest.raises(MeshError, match="NUL bytes"):
        check_mesh_file(path)
    late = tmp_path / "late.obj"
    late.write_bytes(TRI.encode() * 4000 + b"\0" * 100 + TRI.encode())  # past 64 KiB
    with pytest.raises(MeshError, match="NUL bytes"):
        obj_index_ranges(late)
    long_line = tmp_path / "long.obj"
    long_line.write_bytes(b"v 0 0 0\n" + b"1" * (3 << 20))
    with pytest.raises(MeshError, match="longer than 1 MiB"):
        obj_index_ranges(long_line, chunk=1 << 16)


@pytest.mark.parametrize("text, word", [
    (TRI + "f -1 -2 -3\n", "relative (negative) v index"),
    (TRI + "f 1/-1 2/-2 3/-3\n", "relative (negative) vt index"),
    (TRI + "f 0 1 2\n", "v index 0"),
    (TRI + "   f 1 2 999\n", "v index 999"),  # indented lines are seen too
    (TRI + "f 1/1 2/2 3/4\n", "vt index 4"),
    (TRI + "l 1 5\n", "v index 5"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\n", "vt index 1"),  # no vt lines at all
])
def test_obj_indices_are_checked_against_their_counts(tmp_path, text, word):
    path = tmp_path / "bad.obj"
    path.write_text(text)
    with pytest.raises(MeshError, match=word.replace("(", r"\(").replace(")", r"\)")):
        check_mesh_file(path)


@st.composite
def obj_files(draw):
    """Random OBJ text: v/vt/vn lines and faces with random index forms, and the expected
    counts and ranges."""
    lines, counts = [], {"v": 0, "vt": 0, "vn": 0}
    lo, hi = [np.inf] * 3, [0.0] * 3
    for _ in range(draw(st.integers(1, 30))):
        kind = draw(st.sampled_from(["v", "vt", "vn", "f", "f", "#"]))
        if kind in counts:
            counts[kind] += 1
            lines.append(f"{kind} 1.5 -2e3 0")
        elif kind == "#":
            lines.append("# f 99999 comment 7")
        else:
            form = draw(st.sampled_from(["v", "v/t", "v//n", "v/t/n"]))
            corners = []
            for _ in range(draw(st.integers(1, 5))):
                idx = [draw(st.integers(-50, 10**9)) for _ in range(3)]
                slots = {"v": [0], "v/t": [0, 1], "v//n": [0, 2], "v/t/n": [0, 1, 2]}[form]
                for s in slots:
                    lo[s], hi[s] = min(lo[s], idx[s]), max(hi[s], idx[s])
                corners.append(form.replace("v", str(idx[0]), 1).replace("t", str(idx[1]))
                               .replace("n", str(idx[2])))
            lines.append("f " + " ".join(corners))
    return "\n".join(lines) + draw(st.sampled_from(["", "\n", "\r\n"])), counts, lo, hi


@settings(max_examples=60, deadline=None)
@given(obj_files(), st.sampled_from([7, 64, 1 << 22]))
def test_obj_scan_matches_a_line_by_line_reading(tmp_path_factory, drawn, chunk):
    text, counts, lo, hi = drawn
    path = tmp_path_factory.mktemp("obj") / "x.obj"
    path.write_text(text)
    got = obj_index_ranges(path, chunk=chunk)
    assert {k: got[k] for k in counts} == counts
    np.testing.assert_array_equal(got["max"], np.maximum(hi, 0))
    np.testing.assert_array_equal(got["min"], lo)


def test_good_files_still_read(tmp_path):
    """Triangles with vt/vn, binary PLY, and ASCII/binary PLY with a quad (lists of
    different lengths, checked item by item)."""
    obj = tmp_path / "good.obj"
    obj.write_text(TRI + "f 1/1/1 2/2/1 3/3/1\nf 2/2/1 4/2/1 3/3/1\n")
    assert read_surface(obj).n_triangles == 2
    obj.write_bytes(obj.read_bytes() + b"\0")  # a NUL at the end, as the Lee Perry-Smith OBJ
    assert read_surface(obj).n_triangles == 2
    ply = tmp_path / "good.ply"
    ply.write_bytes(_binary_ply(struct.pack("<B3i", 3, 0, 1, 2)))
    assert read_surface(ply).n_triangles == 1
    four = struct.pack("<12f", 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0)
    head = PLY_HEAD.replace("vertex {nv}", "vertex 4")
    mixed = tmp_path / "mixed.ply"
    mixed.write_bytes(head.format(fmt="binary_little_endian", nv=4, nf=2).encode() + four
                      + struct.pack("<B3i", 3, 0, 1, 2) + struct.pack("<B4i", 4, 0, 1, 2, 3))
    assert read_surface(mixed).n_triangles == 3
    text = tmp_path / "mixed_ascii.ply"
    text.write_text(head.format(fmt="ascii", nv=4, nf=2)
                    + "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n4 0 1 2 3\n")
    assert read_surface(text).n_triangles == 3
    bad = tmp_path / "mixed_bad.ply"
    bad.write_text(head.format(fmt="ascii", nv=4, nf=2)
                   + "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n4 0 1 2 4\n")
    with pytest.raises(MeshError, match="vertex 4, outside 0..3"):
        check_mesh_file(bad)


@pytest.mark.parametrize("suffix", [".obj", ".ply", ".stl", ".vtp", ".vtk"])
def test_unreadable_files_give_one_line_and_nothing_from_vtk(tmp_path, capfd, suffix):
    """M7: random bytes (and a PNG named .vtp) used to print 10-27 lines of VTK errors."""
    rng = np.random.default_rng(len(suffix))
    for name, data in (("random", rng.integers(1, 256, 3000, dtype=np.uint8).tobytes()),
                       ("png", b"\x89PNG\r\n\x1a\n" + bytes(range(1, 256)) * 8)):
        path = tmp_path / f"{name}{suffix}"
        path.write_bytes(data)
        with pytest.raises(MeshError) as info:
            read_surface(path)
        assert str(path) in str(info.value) and "\n" not in str(info.value)
    out, err = capfd.readouterr()
    assert (out, err) == ("", "")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes here")
def test_non_regular_files_are_named_for_what_they_are(tmp_path):
    """L1: a FIFO, a folder, /dev/zero and a symbolic link loop were 'missing files'."""
    fifo = tmp_path / "pipe.obj"
    os.mkfifo(fifo)
    (tmp_path / "folder.obj").mkdir()
    os.symlink(tmp_path / "b.obj", tmp_path / "a.obj")
    os.symlink(tmp_path / "a.obj", tmp_path / "b.obj")
    os.symlink(tmp_path / "nowhere.obj", tmp_path / "dangling.obj")
    cases = {fifo: "named pipe", tmp_path / "folder.obj": "folder",
             Path("/dev/zero"): "character device", tmp_path / "a.obj": "link loop",
             tmp_path / "dangling.obj": "link to a missing file"}
    for path, word in cases.items():
        assert word in input_problem(path)
        with pytest.raises(MeshError, match=word):
            read_surface(path)
    with pytest.raises(FileNotFoundError, match="no mesh file"):
        read_surface(tmp_path / "missing.obj")
    assert input_problem(tmp_path / "missing.obj") == "no such file"


def test_cli_names_a_pipe_given_as_skin_or_layout(tmp_path, capsys):
    from wrinkle_vis.cli import main

    fifo = tmp_path / "pipe.ply"
    os.mkfifo(fifo)
    assert main(["summary", "--skin", str(fifo), "--landmarks", str(fifo)]) == 2
    err = capsys.readouterr().err
    assert "named pipe" in err and err.count("\n") == 1
    with pytest.raises(SystemExit):
        main(["summary", "--layout", str(fifo)])
    assert "named pipe" in capsys.readouterr().err


@pytest.mark.parametrize("vt, word", [
    ("vt nan 0\nvt 1 0\nvt 0 1\n", "not finite"),
    ("vt 0.5 0.5\nvt 0.5 0.5\nvt 0.5 0.5\n", "have no area"),
    ("vt 0 0\nvt 0.5 0.5\nvt 1 1\n", "have no area"),  # in a line
])
def test_uvs_that_cannot_be_baked_are_refused(tmp_path, vt, word):
    """M13: NaN UVs gave an IndexError traceback; all-equal UVs baked constant maps."""
    from wrinkle_vis import TriangleSurface
    from wrinkle_vis.plotting.bake import UVError, read_obj_uvs

    path = tmp_path / "uv.obj"
    path.write_text("v 1 0 0\nv 0 1 0\nv 0 0 1\n" + vt + "f 1/1 2/2 3/3\n")
    skin = TriangleSurface(np.eye(3), [[0, 1, 2]])
    with pytest.raises(UVError, match=word) as info:
        read_obj_uvs(path, skin)
    assert str(path) in str(info.value)


def test_bake_maps_refuses_nan_uvs_and_uvs_smaller_than_a_texel():
    from meshes import grid

    from wrinkle_vis import FaceModel
    from wrinkle_vis.core import paper_expressions
    from wrinkle_vis.plotting.bake import UVError, bake_maps

    skin = grid(5, 5)
    face = FaceModel(skin, grid(3, 3), (), {"neutral": paper_expressions()["neutral"]})
    state = face.evaluate("neutral")
    uv = (skin.points[skin.triangles][..., :2] + 30.0) / 60.0  # the square onto [0, 1]^2
    assert bake_maps(state, uv, (16, 16)).images  # the good UVs bake
    nan = uv.copy()
    nan[3, 1, 0] = np.nan
    with pytest.raises(UVError, match="1 of 32 triangles .* not finite"):
        bake_maps(state, nan, (16, 16))
    with pytest.raises(UVError, match="cover 0.25 texels of the 16 x 16 map"):
        bake_maps(state, uv / 32.0, (16, 16))


@pytest.mark.parametrize("scale", [4e29 / 60.0, 4e-31 / 60.0])
def test_a_face_no_unit_makes_a_head_is_refused(scale):
    """L6: faces 4e29 or 4e-31 units tall "read as mm"."""
    import warnings

    from meshes import grid

    from wrinkle_vis.core.units import UnitWarning
    from wrinkle_vis.datasets import load_face
    from wrinkle_vis.datasets.face import face_unit_of

    skin = grid(5, 5, 60.0 * scale)
    with pytest.raises(ValueError, match="a head in no unit"):
        load_face(skin=skin)
    with pytest.warns(UnitWarning, match="a head in no unit"):
        assert face_unit_of(skin, "mm") == "mm"  # a unit given: said, not refused
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert face_unit_of(grid(5, 5, 200.0), "mm") == "mm"  # a face 20 cm across
        assert face_unit_of(grid(5, 5, 2.7), "mm") == "mm"  # odd, but a head in cm


def test_cli_announces_a_large_scan_with_an_estimate(tmp_path, capsys, monkeypatch):
    """M12: a 4.5 M-triangle scan printed nothing for 15 minutes. (The thresholds are
    lowered so that a 4,500-triangle scan counts as large.)"""
    import wrinkle_vis.cli as cli
    from wrinkle_vis.datasets import load_face
    from wrinkle_vis.plotting import to_surface_polydata

    face = load_face()
    scan = tmp_path / "scan.ply"
    to_surface_polydata(face.skin).save(scan)
    marks = tmp_path / "marks.json"
    marks.write_text(json.dumps({k: list(v) for k, v in face.landmarks.items()}))
    monkeypatch.setattr(cli, "LARGE_SKIN_BYTES", 1)
    monkeypatch.setattr(cli, "LARGE_SKIN_TRIANGLES", 1000)
    assert cli.main(["summary", "--skin", str(scan), "--landmarks", str(marks), "--unit",
                     "mm", "-e", "surprise"]) == 0
    err = capsys.readouterr().err.splitlines()
    assert err[0] == f"wrinkle-vis summary: reading {scan} (0 MiB)..."
    assert err[1].startswith(f"wrinkle-vis summary: note: {scan} has "
                             f"{face.skin.n_triangles:,} triangles (read in ")
    assert "the first frame take about" in err[1] and len(err) == 2
    assert cli._estimate_s(2_000_000) > 2 * cli._estimate_s(1_000_000)  # grows faster than n


@pytest.mark.parametrize("suffix", [".vtp", ".vtm"])
def test_a_write_that_does_not_read_back_is_one_line_without_vtk_noise(tmp_path, capfd,
                                                                      monkeypatch, suffix):
    """M7 (X06/X07): VTK's XML reader printed its errors before "does not read back"."""
    import pyvista as pv

    from wrinkle_vis.core.files import WriteError
    from wrinkle_vis.plotting import writers

    monkeypatch.setattr(writers, "_xml_bytes", lambda mesh: b"<VTKFile broken")
    mesh = pv.Sphere()
    with pytest.raises(WriteError, match="read back"):
        writers.save_mesh(mesh if suffix == ".vtp" else pv.MultiBlock({"a": mesh}),
                          tmp_path / f"x{suffix}")
    assert capfd.readouterr() == ("", "")


@pytest.mark.parametrize("last", ["3 0 1 2", "3 0 1 4", "3 -1 1 2", "3 0 1 99999999999999999"])
@pytest.mark.parametrize("fast", [True, False])
def test_ascii_ply_indices_are_checked_with_and_without_the_fast_path(tmp_path, monkeypatch,
                                                                      last, fast):
    from wrinkle_vis.datasets import meshfile

    if not fast:
        monkeypatch.setattr(meshfile, "_ascii_triangles", lambda *a: False)
    path = tmp_path / "t.ply"
    path.write_text(PLY_HEAD.replace("vertex {nv}", "vertex 4").format(fmt="ascii", nv=4, nf=2)
                    + "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 3\n" + last + "\n")
    if last == "3 0 1 2":
        check_mesh_file(path)
    else:
        with pytest.raises(MeshError, match="outside 0..3"):
            check_mesh_file(path)


def test_bake_checks_the_obj_before_parsing_its_uvs(tmp_path):
    """A sparse 4 GiB file of zeros named .obj: the bake's own OBJ parser read it as one
    4 GiB line; now it is refused after its first block."""
    from wrinkle_vis.plotting.bake import _parse_obj

    path = tmp_path / "zeros.obj"
    with path.open("wb") as f:
        f.truncate(4 << 30)
    with pytest.raises(MeshError, match="NUL bytes"):
        _parse_obj(path)
    bad = tmp_path / "bad.obj"
    bad.write_text(TRI + "f 1/1 2/9 3/3\n")
    with pytest.raises(MeshError, match="vt index 9"):
        _parse_obj(bad)
