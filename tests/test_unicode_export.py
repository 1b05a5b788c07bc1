"""Muscle names in any language export to every mesh format (issue 33, M8)."""

import meshio
import numpy as np
import pytest
import pyvista as pv

from wrinkle_vis.plotting.writers import save_mesh

NAME = "corrügatör_L_皱眉肌"


@pytest.fixture(scope="module")
def state(wv_face):
    face = wv_face.with_muscle(wv_face.muscle("corrugator_L").replace(name=NAME),
                               replacing="corrugator_L")
    return face.evaluate("frown")


@pytest.mark.parametrize("suffix", [".vtp", ".vtk", ".vtm"])
def test_unicode_array_names_survive_vtk_formats(state, tmp_path, suffix):
    mesh = state.to_polydata()
    data = pv.MultiBlock({"skin": mesh}) if suffix == ".vtm" else mesh
    save_mesh(data, tmp_path / f"x{suffix}")
    back = pv.read(tmp_path / f"x{suffix}")
    back = back[0] if suffix == ".vtm" else back
    names = [k for k in back.point_data if k.startswith(NAME)]
    assert names and set(names) == {k for k in mesh.point_data if k.startswith(NAME)}
    key = names[0]
    np.testing.assert_array_equal(back.point_data[key], mesh.point_data[key])


def test_unicode_array_names_become_ascii_ply_properties(state, tmp_path):
    from wrinkle_vis.plotting.writers import ply_name

    mesh = state.to_polydata()
    save_mesh(mesh, tmp_path / "x.ply")
    back = meshio.read(tmp_path / "x.ply")
    key = next(k for k in mesh.point_data if k.startswith(NAME) and k.endswith("W"))
    assert ply_name(key).isascii() and ply_name(key) in back.point_data
    np.testing.assert_array_equal(back.point_data[ply_name(key)], mesh.point_data[key])
    assert ply_name("corrügatör L.W") == "corr_u00fcgat_u00f6r_L.W"
