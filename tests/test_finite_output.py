"""Nothing absurd or non-finite is written as valid (issue 33, H7).

A furrow depth factor beyond the face's size is refused where the face is made; and, should
a frame still come out non-finite (here: the bounds switched off and k0 = 1e300, which gives
NaN vertex normals), every writer refuses it in one line and leaves no file.
"""

import json

import numpy as np
import pytest
import pyvista as pv

import wrinkle_vis as wv
from wrinkle_vis.cli import main
from wrinkle_vis.plotting.finite import NonFiniteError, require_finite
from wrinkle_vis.plotting.writers import save_mesh


@pytest.fixture
def overflowing(monkeypatch, wv_face):
    """The built-in face with corrugator_L at k0 = 1e300, the bounds switched off."""
    import wrinkle_vis.core.face as face_module
    import wrinkle_vis.core.muscle as muscle_module

    monkeypatch.setattr(muscle_module, "MAX_COORDINATE", np.inf)
    monkeypatch.setattr(face_module, "_check_scale", lambda *args: None)
    m = wv_face.muscle("corrugator_L")
    face = wv_face.with_muscle(m.replace(k0=1e300))
    face.fold_guard = False  # the guard would bound this W; the writers' check is tested
    with np.errstate(all="ignore"):
        state = face.evaluate("frown")
        assert not np.isfinite(state.normals).all()  # the finding: NaN normals
    return face, state


def _refused(call, target) -> None:
    with pytest.raises(NonFiniteError) as info, np.errstate(all="ignore"):
        call()
    message = str(info.value)
    assert "\n" not in message and "non-finite" in message and "k0" in message
    assert not target.exists()


@pytest.mark.parametrize("suffix", [".vtp", ".vtk", ".ply", ".vtm"])
def test_save_mesh_refuses_non_finite_data(overflowing, tmp_path, suffix):
    _, state = overflowing
    mesh = state.to_polydata()
    mesh.point_data["Normals"] = np.asarray(state.normals)
    data = pv.MultiBlock({"skin": mesh}) if suffix == ".vtm" else mesh
    target = tmp_path / f"x{suffix}"
    _refused(lambda: save_mesh(data, target), target)


@pytest.mark.parametrize("name", ["r.pvd", "f_####.obj", "f_####.ply"])
def test_save_sequence_refuses_a_non_finite_frame(overflowing, tmp_path, name):
    from wrinkle_vis.plotting.exchange import numbered_path, save_sequence

    _, state = overflowing
    target = tmp_path / name
    first = numbered_path(target, 0, 2) if "#" in name else target
    _refused(lambda: save_sequence([state, state], [0.0, 1.0], target), first)
    assert [p.name for p in tmp_path.iterdir()] == []  # no frame, no hidden folder


def test_gltf_bake_and_render_refuse_non_finite_frames(overflowing, tmp_path):
    from wrinkle_vis.plotting.bake import bake_maps, save_bake
    from wrinkle_vis.plotting.exchange import save_gltf

    face, state = overflowing
    _refused(lambda: save_gltf(face, tmp_path / "x.glb", ["frown"]), tmp_path / "x.glb")
    uvs = np.zeros((face.skin.n_triangles, 3, 2))
    _refused(lambda: save_bake(bake_maps(state, uvs, (16, 16)), tmp_path / "maps"),
             tmp_path / "maps")
    _refused(lambda: wv.plotting.render_field(face, "frown", filename=tmp_path / "x.png"),
             tmp_path / "x.png")


def test_require_finite_allows_undefined_fields_but_no_infinity(wv_face):
    mesh = wv_face.evaluate("frown").to_polydata()
    assert np.isnan(mesh.point_data["corrugator_L.W"] if "corrugator_L.W" in mesh.point_data
                    else mesh.point_data["corrugator_L__W"]).any()  # NaN: "undefined"
    require_finite("x.vtp", mesh)
    mesh.point_data["W"][3] = np.nan  # the total is defined everywhere
    with pytest.raises(NonFiniteError, match=r"1 non-finite value\(s\) \(NaN or inf\) in "
                                             r"the point array 'W'"):
        require_finite("x.vtp", mesh)
    mesh.point_data["W"][3] = 0.0
    name = next(k for k in mesh.point_data if k.startswith("corrugator_L") and
                k.endswith("W"))
    mesh.point_data[name][5] = np.inf
    with pytest.raises(NonFiniteError, match=r"1 non-finite value\(s\) \(NaN or inf\) in "
                                             r"the point array 'corr"):
        require_finite("x.vtp", mesh)


def test_a_furrow_deeper_than_the_face_is_refused(wv_face):
    m = wv_face.muscle("corrugator_L")
    size = float(np.linalg.norm(np.ptp(wv_face.skin.points, axis=0)))
    wv_face.with_muscle(m.replace(k0=0.5 * size))  # absurd but within the face: allowed
    for param, value in (("k0", 2 * size), ("k0", 1e12)):
        with pytest.raises(ValueError, match=f"'corrugator_L': {param} = .* larger than the "
                                             "whole face"):
            wv_face.with_muscle(m.replace(**{param: value}))


def test_the_cli_refuses_k0_1e12_in_one_line(tmp_path, capsys):
    data = wv.datasets.builtin_layout().to_dict()
    for m in data["muscles"]:
        if m["name"] == "corrugator_L":
            m["k0"] = 1e12
    (tmp_path / "k0.json").write_text(json.dumps(data))
    assert main(["export", "--layout", str(tmp_path / "k0.json"), "-e", "frown", "-o",
                 str(tmp_path / "x.vtp")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "corrugator_L" in err and "k0 = 1e+12" in err
    assert not (tmp_path / "x.vtp").exists()
