"""The skin's mesh exports as outside tools read them: normals, array names that are
identifiers, the unit in the file, clean muscle blocks, and .vtu, .obj and .stl, read back
with VTK's own XML readers and with meshio (which reads no PolyData, so not .vtp or a
legacy .vtk of PolyData: .vtu is the format for it).
"""

import meshio
import numpy as np
import pytest
import pyvista as pv
from meshes import grid

import wrinkle_vis as wv
from wrinkle_vis.cli import main
from wrinkle_vis.plotting import to_multiblock, to_polydata
from wrinkle_vis.plotting.writers import save_mesh


@pytest.fixture(scope="module")
def state():
    lin = wv.LinearMuscle("lin", (-25, 0, -3), (5, 0, 1), radius=40, max_angle_deg=30)
    face = wv.FaceModel(grid(21, 21, 80.0, bump=5.0), None, [lin])
    return face.evaluate({"lin": 1.0})


def _vtk_read(path):
    from vtkmodules.vtkIOLegacy import vtkPolyDataReader
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader, vtkXMLUnstructuredGridReader

    reader = {".vtp": vtkXMLPolyDataReader, ".vtu": vtkXMLUnstructuredGridReader,
              ".vtk": vtkPolyDataReader}[path.suffix]()
    reader.SetFileName(str(path))
    reader.Update()
    return reader.GetOutput()


@pytest.mark.parametrize("suffix", [".vtp", ".vtu", ".vtk"])
def test_vtk_files_carry_normals_identifier_names_and_the_unit(state, suffix, tmp_path):
    path = tmp_path / f"skin{suffix}"
    save_mesh(to_polydata(state), path)
    data = _vtk_read(path)
    pd = data.GetPointData()
    assert data.GetNumberOfPoints() == state.n_points
    normals = pd.GetNormals()  # the active normals attribute: viewers shade smoothly
    assert normals is not None
    np.testing.assert_allclose(pv.convert_array(normals), state.normals, atol=1e-12)
    names = [pd.GetArrayName(i) for i in range(pd.GetNumberOfArrays())]
    assert "lin__W" in names and "lin__lambda" in names
    assert all(name.isidentifier() for name in names), names
    fd = data.GetFieldData()
    assert fd.GetArray("metres_per_unit").GetValue(0) == 0.001
    if suffix != ".vtu":  # string arrays too (not in .vtu, for meshio)
        assert fd.GetAbstractArray("unit").GetValue(0) == "mm"
        shown = [fd.GetAbstractArray("display_names").GetValue(i)
                 for i in range(fd.GetAbstractArray("display_names").GetNumberOfValues())]
        assert "W = W (mm), total" in shown and "lin__lambda = lambda, lin" in shown


def test_meshio_reads_the_vtu_obj_and_stl(state, tmp_path):
    mesh = to_polydata(state)
    tris = state.face.skin.triangles
    save_mesh(mesh, tmp_path / "skin.vtu")
    back = meshio.read(tmp_path / "skin.vtu")
    np.testing.assert_array_equal(back.points, state.points)
    np.testing.assert_array_equal(back.cells_dict["triangle"], tris)
    np.testing.assert_array_equal(back.point_data["lin__W"], state.fields["lin"]["W"])
    np.testing.assert_array_equal(back.point_data["Normals"], mesh["Normals"])
    assert float(np.ravel(back.field_data["metres_per_unit"])[0]) == 0.001

    save_mesh(mesh, tmp_path / "skin.obj")
    back = meshio.read(tmp_path / "skin.obj")
    np.testing.assert_allclose(back.points, state.points, rtol=1e-9)
    np.testing.assert_array_equal(back.cells_dict["triangle"], tris)
    assert (tmp_path / "skin.obj").read_text().startswith("# written by wrinkle-vis; "
                                                          "lengths in mm\n")
    obj = pv.read(tmp_path / "skin.obj")  # VTK's OBJ reader: the vertex normals
    np.testing.assert_allclose(obj["Normals"], state.normals, atol=1e-6)

    save_mesh(mesh, tmp_path / "skin.stl")
    back = meshio.read(tmp_path / "skin.stl")
    corners = back.points[back.cells_dict["triangle"]]
    np.testing.assert_allclose(corners, state.points[tris].astype(np.float32), rtol=1e-6)
    assert (tmp_path / "skin.stl").read_bytes()[:80].rstrip() == b"wrinkle-vis; lengths in mm"


def test_muscle_blocks_carry_only_their_normals_and_activation(wv_face, tmp_path):
    save_mesh(to_multiblock(wv_face.evaluate("frown")), tmp_path / "frown.vtm")
    muscles = pv.read(tmp_path / "frown.vtm")["muscles"]
    assert len(muscles) == len(wv_face.muscles)
    for name in muscles.keys():
        block = muscles[name]
        assert set(block.point_data) == {"Normals", "activation"}, name
        assert block.GetPointData().GetNormals() is not None
    skull = pv.read(tmp_path / "frown.vtm")["skull"]
    assert skull.GetPointData().GetNormals() is not None


@pytest.mark.parametrize("suffix", [".obj", ".stl", ".vtu"])
def test_export_writes_one_mesh_as_obj_stl_and_vtu(suffix, tmp_path, capsys):
    out = tmp_path / f"frown{suffix}"
    assert main(["export", "-e", "frown", "-o", str(out)]) == 0
    assert "wrote" in capsys.readouterr().out
    assert pv.read(out).n_cells == wv.datasets.load_face().skin.n_triangles


def test_taper_flag_tapers_every_muscle(wv_face, tmp_path, capsys):
    """--taper turns the taper option on for every muscle: the exported W is the tapered
    face's, and differs from the paper's at the ends of the wrinkling regions.
    """
    import dataclasses

    out = tmp_path / "tapered.vtu"
    assert main(["export", "--taper", "-e", "surprise", "-o", str(out)]) == 0
    tapered = wv_face
    for m in wv_face.muscles:
        tapered = tapered.with_muscle(dataclasses.replace(m, taper=True))
    want = tapered.evaluate("surprise").W
    got = meshio.read(out).point_data["W"]
    np.testing.assert_array_equal(got, want)
    assert np.abs(want - wv_face.evaluate("surprise").W).max() > 0.05  # the seam is gone
    capsys.readouterr()
    with pytest.raises(SystemExit):
        main(["export", "--help"])
    assert "--taper" in capsys.readouterr().out
