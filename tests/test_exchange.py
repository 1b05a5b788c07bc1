"""Exchange formats: the ramp as a ParaView time series and as numbered OBJ/PLY files, and
the expressions as glTF morph targets, each read back by another library.
"""

import json
import struct
from pathlib import Path

import meshio
import numpy as np
import pytest
import pyvista as pv

import wrinkle_vis as wv
from wrinkle_vis.cli import main
from wrinkle_vis.plotting import to_polydata
from wrinkle_vis.plotting.exchange import numbered_path, read_glb


@pytest.fixture(scope="module")
def face():
    return wv.datasets.load_face()


def _read_step(reader, k: int) -> pv.PolyData:
    reader.set_active_time_point(k)
    mesh = reader.read()
    return mesh[0] if isinstance(mesh, pv.MultiBlock) else mesh


def _frames_in(folder):
    """The files in ``folder``'s one version folder (``v<pid>-<hex>``)."""
    (version,) = folder.iterdir()
    assert version.is_dir() and version.name.startswith("v")
    return sorted(p.name for p in version.iterdir())


# ---------------------------------------------------------------------- ParaView series
def test_pvd_opens_in_pyvista_with_every_field_on_every_step(tmp_path, face, capsys):
    out = tmp_path / "ramp.pvd"
    assert main(["export", "--sequence", "-e", "fear", "--fps", "4", "-o", str(out),
                 "--skin-model", "geometric"]) == 0  # each frame evaluated on its own
    assert "wrote" in capsys.readouterr().out
    expression = face.expressions["fear"]
    times = np.arange(13) / 4  # 3 s of onset, hold and release at 4 fps, both ends
    reader = pv.get_reader(str(out))
    assert reader.number_time_points == 13
    np.testing.assert_allclose(reader.time_values, times, rtol=0, atol=1e-12)
    assert _frames_in(tmp_path / "ramp") == [f"ramp_{i:04d}.vtp" for i in range(13)]
    for k, t in enumerate(times):
        mesh = _read_step(reader, k)
        state = face.evaluate(expression.at(t), skin="geometric")
        expected = to_polydata(state)
        assert set(mesh.point_data) == set(expected.point_data)
        np.testing.assert_array_equal(mesh.points, state.points)
        for name in expected.point_data:  # exactly: VTK XML keeps float64
            np.testing.assert_array_equal(mesh.point_data[name], expected.point_data[name],
                                          err_msg=f"{name} at t = {t}")
        assert mesh.field_data["TimeValue"][0] == t
    assert np.abs(_read_step(reader, 6)["W"]).max() > 0  # the hold has wrinkles


def test_pvd_replaces_its_frame_folder_whole(tmp_path):
    out = tmp_path / "s.pvd"
    quick = ["--skin-model", "geometric"]  # the files' work: any skin, the quicker one
    assert main(["export", "--sequence", "--fps", "4", "-o", str(out), *quick]) == 0
    assert len(_frames_in(tmp_path / "s")) == 13
    assert main(["export", "--sequence", "--fps", "1", "-o", str(out), *quick]) == 0
    assert _frames_in(tmp_path / "s") == [f"s_{i:04d}.vtp" for i in range(4)]  # old gone
    assert pv.get_reader(str(out)).number_time_points == 4
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s", "s.pvd"]  # nothing left over


def test_pvd_refuses_a_frame_folder_with_other_files_before_any_work(tmp_path, capsys,
                                                                     monkeypatch):
    import wrinkle_vis.datasets

    (tmp_path / "s").mkdir()
    (tmp_path / "s" / "notes.txt").write_text("mine")
    monkeypatch.setattr(wrinkle_vis.datasets, "load_face", None)  # never reached
    assert main(["export", "--sequence", "-o", str(tmp_path / "s.pvd")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "holds other files (notes.txt)" in err
    assert (tmp_path / "s" / "notes.txt").read_text() == "mine"


def test_sequences_are_bounded_like_animations(tmp_path, capsys):
    good = json.loads(wv.datasets.BUILTIN_LAYOUT.read_text())
    good["expressions"]["surprise"]["hold_s"] = 100_000
    (tmp_path / "long.json").write_text(json.dumps(good))
    assert main(["export", "--sequence", "--layout", str(tmp_path / "long.json"),
                 "-o", str(tmp_path / "x.pvd")]) == 2
    assert "more than 10,000; shorten the expression's hold_s" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["long.json"]


@pytest.mark.parametrize(("argv", "message"), [
    (["export", "-o", "x.pvd"], ".pvd is written as a sequence of the expression's ramp; "
                                "add --sequence"),
    (["export", "--sequence", "-o", "x.vtp"], "--output must end in .pvd, .obj or .ply"),
    (["export", "--fps", "3", "-o", "x.vtp"], "--fps is the frame rate of --sequence"),
    (["export", "--sequence", "--fps", "500", "-o", "x.pvd"], "--fps 500 is outside 1..120"),
    (["export", "--intensity", "0.5", "-o", "x.glb"], "a .glb holds each expression at full "
                                                      "intensity"),
    (["export", "-e", "yawn", "-o", "x.glb"], "unknown expression 'yawn'"),
])
def test_exchange_errors_are_one_line(argv, message, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and message in err, err
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------- OBJ and PLY
def test_numbered_paths():
    assert numbered_path("a/f_####.obj", 7, 10).name == "f_0007.obj"
    assert numbered_path("f_##.ply", 3, 200).name == "f_003.ply"  # widened to fit
    assert numbered_path("take#2_###.obj", 5, 10).name == "take#2_005.obj"  # the last run
    assert numbered_path("walk.obj", 12, 13).name == "walk_0012.obj"
    assert numbered_path("a/f_####.obj", 7, 10) == Path("a/f/f_0007.obj")  # in f/
    assert numbered_path("####.ply", 1, 2) == Path("frames/0001.ply")


@pytest.mark.parametrize("suffix", [".obj", ".ply"])
def test_numbered_sequence_counts_and_round_trips(tmp_path, face, suffix):
    (tmp_path / "f_notes.txt").write_text("mine")
    (tmp_path / "f_0001.obj").write_text("beside the pattern: not ours")
    pattern = tmp_path / f"f_####{suffix}"
    assert main(["export", "--sequence", "-e", "frown", "--fps", "2", "-o",
                 str(pattern), "--skin-model", "geometric"]) == 0
    frames = sorted((tmp_path / "f").iterdir())  # in a folder of their own
    assert [p.name for p in frames] == [f"f_{i:04d}{suffix}" for i in range(7)]
    state = face.evaluate(face.expressions["frown"].at(1.5),  # frame 3 at 2 fps
                          skin="geometric")
    if suffix == ".obj":
        mesh = pv.read(frames[3])
        np.testing.assert_allclose(mesh.points, state.points, rtol=1e-9, atol=1e-9)
        np.testing.assert_array_equal(mesh.faces.reshape(-1, 4)[:, 1:], face.skin.triangles)
        np.testing.assert_allclose(mesh["Normals"], state.normals, atol=1e-6)
    else:  # every field, as doubles
        back = meshio.read(frames[3])
        expected = to_polydata(state)
        np.testing.assert_array_equal(back.points, state.points)
        np.testing.assert_array_equal(back.cells_dict["triangle"], face.skin.triangles)
        for name in ("W", "corrugator_L__eps", "corrugator_R__W", "frontalis_major_L__lambda"):
            np.testing.assert_array_equal(back.point_data[name], expected[name])
        np.testing.assert_array_equal(back.point_data["deformation_y"],
                                      expected["deformation"][:, 1])
    # a shorter sequence of the same name replaces the folder whole
    assert main(["export", "--sequence", "-e", "frown", "--fps", "1", "-o",
                 str(pattern)]) == 0
    assert sorted(p.name for p in (tmp_path / "f").iterdir()) == \
        [f"f_{i:04d}{suffix}" for i in range(4)]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f", "f_0001.obj", "f_notes.txt"]
    assert (tmp_path / "f_0001.obj").read_text() == "beside the pattern: not ours"


def test_numbered_sequence_refuses_a_frame_folder_with_other_files(tmp_path, capsys):
    (tmp_path / "f").mkdir()
    (tmp_path / "f" / "notes.txt").write_text("mine")
    assert main(["export", "--sequence", "-o", str(tmp_path / "f_####.ply")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "holds other files (notes.txt)" in err
    assert (tmp_path / "f" / "notes.txt").read_text() == "mine"


# ---------------------------------------------------------------------- glTF
_COMPONENTS = {5126: np.float32, 5125: np.uint32, 5123: np.uint16}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3}


def _array(gltf, blob: bytes, index: int) -> np.ndarray:
    acc = gltf.accessors[index]
    view = gltf.bufferViews[acc.bufferView]
    dtype = _COMPONENTS[acc.componentType]
    data = np.frombuffer(blob, dtype, count=acc.count * _WIDTH[acc.type],
                         offset=view.byteOffset + (acc.byteOffset or 0))
    return data.reshape(acc.count, _WIDTH[acc.type])


def test_glb_has_one_morph_target_per_expression(tmp_path, face, capsys):
    pygltflib = pytest.importorskip("pygltflib")
    out = tmp_path / "face.glb"
    assert main(["export", "-o", str(out)]) == 0
    assert f"{len(face.expressions)} morph targets" in capsys.readouterr().out
    gltf = pygltflib.GLTF2().load(str(out))
    blob = gltf.binary_blob()
    mesh = gltf.meshes[0]
    (primitive,) = mesh.primitives
    names = list(face.expressions)
    assert mesh.extras["targetNames"] == names and len(primitive.targets) == len(names)
    assert mesh.weights == [0.0] * len(names)
    base = _array(gltf, blob, primitive.attributes.POSITION)
    assert base.dtype == np.float32 and base.shape == (face.skin.n_points, 3)
    np.testing.assert_array_equal(
        _array(gltf, blob, primitive.indices).reshape(-1, 3), face.skin.triangles)
    normals = _array(gltf, blob, primitive.attributes.NORMAL)
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1, atol=1e-6)
    # millimetres to metres, y up: a face about 23 cm tall
    assert 0.15 < np.ptp(base[:, 1]) < 0.35
    for name, target in zip(names, primitive.targets, strict=True):
        expected = face.evaluate(name).points * 1e-3
        moved = base.astype(np.float64) + _array(gltf, blob, target["POSITION"])
        tol = 2 * np.finfo(np.float32).eps * np.abs(expected).max()
        np.testing.assert_allclose(moved, expected, rtol=0, atol=tol, err_msg=name)
    surprise = _array(gltf, blob, primitive.targets[names.index("surprise")]["POSITION"])
    assert np.abs(surprise).max() > 1e-4  # the brows rise by millimetres
    assert not _array(gltf, blob, primitive.targets[names.index("neutral")]["POSITION"]).any()


def test_glb_structure_is_valid(tmp_path, face):
    out = tmp_path / "face.glb"
    assert main(["export", "-o", str(out), "--unit", "m"]) == 0
    data = out.read_bytes()
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    assert (magic, version, length) == (b"glTF", 2, len(data)) and length % 4 == 0
    n_json, kind = struct.unpack_from("<I4s", data, 12)
    assert kind == b"JSON" and n_json % 4 == 0
    gltf = json.loads(data[20:20 + n_json])
    n_bin, kind = struct.unpack_from("<I4s", data, 20 + n_json)
    assert kind == b"BIN\0" and n_bin % 4 == 0 and 28 + n_json + n_bin == len(data)
    blob = data[28 + n_json:]
    assert gltf["asset"]["version"] == "2.0" and gltf["buffers"] == [{"byteLength": n_bin}]
    for view in gltf["bufferViews"]:
        assert view["byteOffset"] % 4 == 0
        assert view["byteOffset"] + view["byteLength"] <= n_bin
        assert view["target"] in (34962, 34963)
    sizes = {5126: 4, 5125: 4, 5123: 2}
    primitive = gltf["meshes"][0]["primitives"][0]
    positions = [primitive["attributes"]["POSITION"]] + [t["POSITION"]
                                                          for t in primitive["targets"]]
    for i, acc in enumerate(gltf["accessors"]):
        view = gltf["bufferViews"][acc["bufferView"]]
        assert acc["count"] * sizes[acc["componentType"]] * _WIDTH[acc["type"]] <= \
            view["byteLength"]
        if i in positions:  # glTF requires min and max on POSITION, exactly the data's
            values = np.frombuffer(blob, np.float32, count=3 * acc["count"],
                                   offset=view["byteOffset"]).reshape(-1, 3)
            assert acc["min"] == values.min(axis=0).tolist()
            assert acc["max"] == values.max(axis=0).tolist()
    assert gltf["extras"]["metres_per_source_unit"] == 1.0  # --unit m: not scaled
    base = np.frombuffer(blob, np.float32, count=3 * face.skin.n_points).reshape(-1, 3)
    np.testing.assert_allclose(base, face.skin.points, rtol=1e-6)
    assert read_glb(out)[0] == gltf  # the writer's own reader agrees


def test_glb_of_one_expression(tmp_path):
    out = tmp_path / "frown.glb"
    assert main(["export", "-e", "frown", "-o", str(out)]) == 0
    gltf, _ = read_glb(out)
    assert gltf["meshes"][0]["extras"]["targetNames"] == ["frown"]


def test_glb_of_a_skin_with_uvs_has_texcoord_0(tmp_path, capsys):
    """The built-in head has UVs: the .glb carries them as TEXCOORD_0 (v down, as glTF),
    one vertex per side of a seam, so the maps `bake` writes fit it.
    """
    pygltflib = pytest.importorskip("pygltflib")
    from wrinkle_vis.datasets.lee_perry_smith import lee_perry_smith_uvs

    out = tmp_path / "head.glb"
    assert main(["export", "--face", "lee_perry_smith", "-e", "surprise", "-o",
                 str(out)]) == 0
    assert "vertices with UVs" in capsys.readouterr().out
    head = wv.datasets.load_face("lee_perry_smith")
    corner_uvs = lee_perry_smith_uvs()
    gltf = pygltflib.GLTF2().load(str(out))
    blob = gltf.binary_blob()
    (primitive,) = gltf.meshes[0].primitives
    assert primitive.attributes.TEXCOORD_0 is not None
    uv = _array(gltf, blob, primitive.attributes.TEXCOORD_0)
    pos = _array(gltf, blob, primitive.attributes.POSITION)
    tris = _array(gltf, blob, primitive.indices).reshape(-1, 3)
    assert len(uv) == len(pos) > head.skin.n_points  # seams split
    assert len(tris) == head.skin.n_triangles
    # every corner: the position of its skin vertex and its UV, v flipped
    np.testing.assert_allclose(pos[tris], head.skin.points[head.skin.triangles] * 1e-3,
                               rtol=1e-6, atol=1e-9)
    want = np.stack([corner_uvs[..., 0], 1.0 - corner_uvs[..., 1]], axis=-1)
    np.testing.assert_allclose(uv[tris], want, atol=1e-7)
    moved = pos + _array(gltf, blob, primitive.targets[0]["POSITION"])
    np.testing.assert_allclose(moved[tris], head.evaluate("surprise").points[
        head.skin.triangles] * 1e-3, rtol=0, atol=1e-6)
